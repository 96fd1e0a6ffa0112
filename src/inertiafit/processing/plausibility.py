"""Plausibility of a processed fast trial: slips that give a wrong inertia without an error.

Each check compares a setting or a channel with what the trial itself shows, and answers with a
flag (one line, kept in ``trials.csv`` and the warnings) where the data may still be right, or
an ``InputError`` naming the trial where the number cannot be:

- a nominal ``speed`` that the trial's constant-speed plateau misses by more than
  :data:`SPEED_TOLERANCE` (a wrong ``speed``, or a velocity channel in other units: 1.4 x too
  large gave an inertia 29 % low) — a flag;
- a manual ``window`` over which the speed hardly changes (a stretch of constant speed holds no
  acceleration to weigh the inertia by; 2 x too large was seen) — an error below
  :data:`WINDOW_SPEED_CHANGE_MIN`, a flag below the detector's own
  :data:`~inertiafit.processing.window.MIN_SPEED_CHANGE`;
- a fixed ``lag`` longer than the acceleration window (``0.5`` for ``0.005`` s gave -13 %) — an
  error; outside the study's ``lag_bounds`` — a flag;
- a torque that over the constant-speed stretch runs against the condition's gravity model (the
  quasi-static trial signed opposite to the fast ones: +10 to +23 %) — a flag;
- a gravity model that alone moves the inertia by more than :data:`GRAVITY_SHARE_MAX` of it (a
  quasi-static sweep of 2.5 deg) — an error naming the quasi-static trial and its sweep.

And, over a condition's trials (before sampling):

- a quasi-static trial that sweeps less than its fit needs: shorter than
  :data:`~inertiafit.processing.gravity.MIN_RANGE` with ``M_g`` not told from zero (``M_g ±
  2 SE`` reaches it; a living ankle's 1518 ± 3428 N m) — an error naming it
  (:func:`check_quasi_static_sweep`);
- quasi-static trials of one condition whose ``M_g`` differ by more than
  :data:`GRAVITY_SCATTER_MAX` standard errors — an error naming each
  (:func:`gravity_scatter_message`);
- negative inertias: the torque sign is advised only where the data support it — every fast
  trial of the condition negative, or this trial's ``torque_sign`` other than that of its
  positive siblings; otherwise following it would mix signs within the condition, and the
  message says so (:func:`inertia_sign_checks`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from inertiafit.errors import InputError
from inertiafit.processing.filtering import source_of
from inertiafit.processing.gravity import MIN_RANGE, GravityFit, steady_angle
from inertiafit.processing.inertia import NEGATIVE_SE, InertiaEstimate, torque_sign_hint
from inertiafit.processing.window import MIN_SPEED_CHANGE, plateau_speed

__all__ = [
    "GRAVITY_SCATTER_MAX",
    "GRAVITY_SHARE_MAX",
    "REST_TRAVEL",
    "SCALE_RANGE",
    "SIGN_CORRELATION",
    "SLOPE_RANGE",
    "SPEED_TOLERANCE",
    "WINDOW_SPEED_CHANGE_MIN",
    "SignVerdict",
    "check_quasi_static_sweep",
    "check_rest_hold",
    "cruise_slope",
    "fast_trial_flags",
    "gravity_scale_flag",
    "gravity_scatter_message",
    "inertia_sign_checks",
]

#: Largest relative difference between the measured plateau speed and the nominal ``speed``.
SPEED_TOLERANCE = 0.2
#: A manual window changing the speed by less than this fraction of the plateau is refused.
WINDOW_SPEED_CHANGE_MIN = 0.1
#: Largest SD of a fast trial's inertia from its condition's gravity model alone, as a share of
#: the inertia; beyond it the quasi-static trial does not determine the model (too short a sweep).
GRAVITY_SHARE_MAX = 0.25
#: Correlation of torque and gravity model over the constant-speed stretch below which the
#: torque is taken to run against the model (consistent trials of the simulator show > 0.9).
SIGN_CORRELATION = -0.5
#: Quasi-static trials of one condition whose ``M_g`` differ by more than this many standard
#: errors (of the difference) are refused: one condition has one ``M_g``.
GRAVITY_SCATTER_MAX = 5.0
#: Slopes of a fast trial's cruise torque on its gravity model (in absolute value) within
#: which the model fits the trial, so that a negative inertia may be a torque sign.
SLOPE_RANGE = (0.5, 2.0)
#: Slopes within which a positive inertia's gravity model is taken to fit its trial (clean
#: simulated trials: 0.91 to 1.12); outside, a flag (a quasi-static torque 2 x too large gave
#: 0.5 and every inertia half its value, silently).
SCALE_RANGE = (0.75, 1.33)


def fast_trial_flags(
    trial: xr.Dataset,
    estimate: InertiaEstimate,
    gravity: GravityFit,
    *,
    speed_deg_s: float | None = None,
    window: Sequence[float] | None = None,
    lag_bounds: Sequence[float] = (-0.02, 0.02),
) -> list[str]:
    """Flags of the slips above for one fast trial; raises ``InputError`` where it cannot be right.

    ``speed_deg_s``, ``window`` are the trial's settings (``None``: not given); ``estimate`` is
    :func:`~inertiafit.processing.inertia.estimate_inertia`'s result on ``trial`` with
    ``gravity``, whose filtered velocity and acceleration it reuses.
    """
    source = source_of(trial)
    time = trial.variables["time"].values
    v = estimate.velocity if estimate.velocity is not None else trial.variables["velocity"].values
    u = np.abs(np.asarray(v, dtype=np.float64))  # speed, whichever way the shaft turns
    plateau = plateau_speed(u) if u.size and np.max(u) > 0 else 0.0
    flags: list[str] = []
    if speed_deg_s and plateau > 0:
        measured = math.degrees(plateau)
        off = measured / float(speed_deg_s) - 1
        if abs(off) > SPEED_TOLERANCE:
            flags.append(
                f"speed: the trial runs at {measured:.4g} deg/s, {off:+.0%} from its nominal "
                f"speed {float(speed_deg_s):g} deg/s (a wrong speed, or a velocity channel in "
                "other units?)"
            )
    duration = estimate.window_end - estimate.window_start
    if window is not None and plateau > 0:
        i0, i1 = np.searchsorted(time, [estimate.window_start, estimate.window_end])
        i1 = min(int(i1), time.size - 1)
        # the speed's range over the window, not its ends' difference: a window over the whole
        # speed-up and slow-down starts and ends at rest, and holds every acceleration
        inside = np.asarray(v[int(i0) : i1 + 1], dtype=np.float64)
        change = float(np.ptp(inside)) / plateau if inside.size else 0.0
        where = f"[{estimate.window_start:.4g}, {estimate.window_end:.4g}] s"
        if change < WINDOW_SPEED_CHANGE_MIN:
            raise InputError(
                f"{source}: window: {where} changes the speed by {change:.0%} of the trial's "
                f"{math.degrees(plateau):.4g} deg/s: a stretch of constant speed has no "
                "acceleration to weigh the inertia by; put the window on the speed-up"
            )
        if change < MIN_SPEED_CHANGE:
            flags.append(
                f"window: the manual window {where} changes the speed by only {change:.0%} "
                f"of the trial's {math.degrees(plateau):.4g} deg/s (the detector asks "
                f"{MIN_SPEED_CHANGE:.0%})"
            )
    if estimate.lag_source == "manifest":
        lag = estimate.lag
        lower, upper = (float(b) for b in lag_bounds)
        if abs(lag) > duration:
            raise InputError(
                f"{source}: lag: {lag:g} s is longer than the trial's acceleration window "
                f"({duration:.3g} s): the torque would be matched to samples outside the "
                f"speed-up; a torque channel lags by milliseconds (lag_bounds {lower:g} to "
                f"{upper:g} s)"
            )
        if not lower <= lag <= upper:
            flags.append(
                f"lag: the fixed lag {lag:g} s is outside lag_bounds {lower:g} to {upper:g} s"
            )
    _check_gravity_share(source, estimate, gravity)
    flags.extend(_sign_flags(trial, estimate, gravity, u, plateau))
    return flags


def _check_gravity_share(source: str, estimate: InertiaEstimate, gravity: GravityFit) -> None:
    """Refuse an inertia that the condition's gravity model leaves undetermined.

    The inertia moves with the subtracted gravity model by ``gravity_sensitivity``; with the
    model's covariance that is an SD of the inertia from the model alone. Beyond
    :data:`GRAVITY_SHARE_MAX` of the inertia (a quasi-static sweep of 2.5 deg gave 3.6 kg m^2
    on 1.3, against 0.0003 on 0.2 for a 90-deg sweep), the error used to be blamed on the fast
    trials' inertia against the prior box.
    """
    s = np.asarray(estimate.gravity_sensitivity, dtype=np.float64)
    cov = np.asarray(gravity.covariance, dtype=np.float64)
    if s.shape != (3,) or cov.shape != (3, 3):
        return
    spread = float(np.sqrt(max(float(s @ cov @ s), 0.0)))
    if not spread > GRAVITY_SHARE_MAX * abs(estimate.inertia):
        return
    raise InputError(
        f"{source}: its condition's gravity model (from {gravity.source}, a sweep of "
        f"{math.degrees(gravity.angle_range):.3g} deg: M_g = {gravity.gravity_moment:.4g} ± "
        f"{gravity.gravity_moment_se:.2g} N m) moves this trial's inertia "
        f"{estimate.inertia:.4g} kg m^2 by ± {spread:.2g}: record the quasi-static trial over "
        f"the fast trials' range ({MIN_RANGE:g} deg or more separates M_g, phi and the offset)"
    )


def _cruise(
    trial: xr.Dataset,
    estimate: InertiaEstimate,
    gravity: GravityFit,
    u: np.ndarray,
    plateau: float,
) -> tuple[np.ndarray, np.ndarray] | None:
    """Torque and gravity model over the cruise (speed ``u`` near ``plateau``, no acceleration).

    ``None`` when the cruise is too short, or sweeps too little of the model to compare.
    """
    if estimate.acceleration is None or plateau <= 0:
        return None
    alpha = np.abs(estimate.acceleration)
    cruise = (u > 0.8 * plateau) & (alpha < 0.2 * float(np.max(alpha)))
    if cruise.sum() < 20:
        return None
    model = gravity.torque(trial.variables["angle"].values[cruise])
    torque = trial.variables["torque"].values[cruise]
    spread = float(np.std(model))
    if spread < 0.1 * abs(gravity.gravity_moment) or float(np.std(torque)) == 0.0:
        return None
    return torque, model


def _sign_flags(
    trial: xr.Dataset,
    estimate: InertiaEstimate,
    gravity: GravityFit,
    u: np.ndarray,
    plateau: float,
) -> list[str]:
    """A flag when the cruise torque (speed ``u`` near ``plateau``) runs against the model."""
    found = _cruise(trial, estimate, gravity, u, plateau)
    if found is None:
        return []  # the cruise sweeps too little of the model to tell its sign
    torque, model = found
    r = float(np.corrcoef(torque, model)[0, 1])
    if not r < SIGN_CORRELATION:
        return []
    flag = (
        f"torque: over the constant-speed stretch it runs against the condition's gravity model "
        f"(correlation {r:.2f}): the quasi-static trial may be signed opposite to this one "
        "(torque_sign of one of them?)"
    )
    return [flag]


def cruise_slope(
    trial: xr.Dataset, estimate: InertiaEstimate, gravity: GravityFit
) -> float | None:
    """How the torque at constant speed follows the condition's gravity model: its slope on it.

    About 1 when the quasi-static and fast trials agree, about -1 when they are signed
    opposite, far from both when the model is wrongly scaled (a quasi-static torque 10 x too
    large gave 0.1). ``None`` when the cruise cannot tell (too short, or the model nearly flat
    over it).
    """
    v = estimate.velocity if estimate.velocity is not None else trial.variables["velocity"].values
    u = np.abs(np.asarray(v, dtype=np.float64))
    plateau = plateau_speed(u) if u.size and np.max(u) > 0 else 0.0
    found = _cruise(trial, estimate, gravity, u, plateau)
    if found is None:
        return None
    torque, model = found
    return float(np.cov(torque, model)[0, 1] / np.var(model, ddof=1))


def gravity_scale_flag(slope: float | None) -> str | None:
    """A flag when a fast trial's cruise torque follows its gravity model with the wrong scale.

    ``slope`` is :func:`cruise_slope`; a positive slope outside :data:`SCALE_RANGE` means the
    model subtracted from the trial's torque is too large or too small for it (a quasi-static
    trial recorded with another gain or unit), which moves its inertia without an error. A
    negative slope is :func:`fast_trial_flags`' sign flag.
    """
    if slope is None or slope <= 0 or SCALE_RANGE[0] <= slope <= SCALE_RANGE[1]:
        return None
    return (
        f"torque: at constant speed it follows the condition's gravity model with a slope of "
        f"{slope:.2g} where 1 is expected: the quasi-static trials and this one disagree in "
        "scale (a torque gain or unit that differs between them?), and the inertia rests on it"
    )


def check_quasi_static_sweep(fit: GravityFit) -> GravityFit:
    """Refuse a quasi-static trial whose sweep is too short to determine ``M_g``.

    A sweep shorter than :data:`~inertiafit.processing.gravity.MIN_RANGE` (flagged by the
    fit) whose ``M_g ± 2 SE`` reaches zero: sin, cos and the offset are not told apart, and the
    ``M_g`` it gives (185 ± 700 N m for a 2.5-deg sweep of a 6.7 N m attachment) would reach
    the evidence. A wide sweep with such an interval is a body nearly balanced on the axis,
    and goes on. Returns ``fit``.
    """
    sweep = math.degrees(fit.angle_range)
    if sweep >= MIN_RANGE or not 2 * fit.gravity_moment_se >= fit.gravity_moment:
        return fit
    raise InputError(
        f"{fit.source}: angle: a quasi-static sweep of {sweep:.3g} deg gives M_g = "
        f"{fit.gravity_moment:.4g} ± {fit.gravity_moment_se:.4g} N m, which it "
        "does not "
        f"determine (the interval reaches 0); record the quasi-static trial over "
        f"{MIN_RANGE:g} deg or more (the fast trials' range)"
    )


#: A rest trial whose angle (its running median, :func:`steady_angle`) travels more than this
#: (deg) is not a quiet hold.
REST_TRAVEL = 2.0


def check_rest_hold(trial: xr.Dataset) -> xr.Dataset:
    """Refuse a rest trial that moves: a quiet hold is one angle (issue 36).

    The hold's moment is read as the static curve at its angle; a sweep or a fast move
    labelled ``kind = "rest"`` was taken as such a hold. Its angle's running median (a noisy
    channel's samples left aside) may travel at most :data:`REST_TRAVEL`. Returns ``trial``.
    """
    steady = steady_angle(trial["angle"].values)
    travel = math.degrees(float(np.ptp(steady))) if steady.size else 0.0
    if travel <= REST_TRAVEL:
        return trial
    raise InputError(
        f"{source_of(trial)}: angle: a rest trial must hold still, but its angle travels {travel:.3g} deg "
        f"({math.degrees(float(steady.min())):.3g} to {math.degrees(float(steady.max())):.3g}); "
        'a slow sweep is kind = "quasi-static", a fast move kind = "fast"'
    )


def gravity_scatter_message(fits: Sequence[GravityFit], condition: str) -> str | None:
    """One line when a condition's quasi-static ``M_g`` disagree far beyond their errors.

    Each fit is compared with the inverse-variance mean of the others; the largest difference
    over its standard error beyond :data:`GRAVITY_SCATTER_MAX` is a line naming every fit
    with its ``M_g ± SE`` (``None`` when they agree, or for one fit). Their inverse-variance
    combination would otherwise be precise and wrong.
    """
    if len(fits) < 2:
        return None
    values = np.array([f.gravity_moment for f in fits], dtype=np.float64)
    ses = np.array([f.gravity_moment_se for f in fits], dtype=np.float64)
    if not np.all(ses > 0):
        return None
    worst = 0.0
    for i in range(len(fits)):
        others = np.arange(len(fits)) != i
        w = 1.0 / ses[others] ** 2
        mean, se_mean = float(np.sum(w * values[others]) / np.sum(w)), float(np.sum(w) ** -0.5)
        worst = max(worst, abs(values[i] - mean) / math.hypot(ses[i], se_mean))
    if not worst > GRAVITY_SCATTER_MAX:
        return None
    listed = ", ".join(
        f"{f.gravity_moment:.4g} ± {f.gravity_moment_se:.2g} N m ({f.source})" for f in fits
    )
    return (
        f"condition '{condition}': its quasi-static trials give M_g = {listed}: {worst:.3g} "
        "standard errors apart, where one condition has one M_g; check for a body moved "
        "between them, a trial of another mounting or a torque zero that drifted, and give "
        "such a trial its own condition (or remove it)"
    )


def _sign_key(sign: int | str) -> float | str:
    return sign if isinstance(sign, str) else float(sign)


@dataclass(frozen=True)
class SignVerdict:
    """What :func:`inertia_sign_checks` says of one fast trial: an error, or a flag."""

    error: str = ""
    flag: str = ""


def inertia_sign_checks(
    trials: Sequence[tuple[int | str, InertiaEstimate, float | None]], condition: str
) -> list[SignVerdict | None]:
    """Judge the negative inertias of one condition's fast trials together.

    Parameters
    ----------
    trials : sequence of (torque_sign, InertiaEstimate, slope)
        Every fast trial of the condition: its manifest ``torque_sign`` (1, -1 or
        ``"motion"``), its estimate (from
        :func:`~inertiafit.processing.inertia.estimate_inertia` with ``refuse_negative=False``)
        and its :func:`cruise_slope` on the condition's gravity model (``None``: unknown).
    condition : str
        The condition's label, for messages.

    Returns
    -------
    list
        Per trial, ``None`` (not negative) or a :class:`SignVerdict`: an ``error`` for an
        inertia below zero by more than ``NEGATIVE_SE`` standard errors, else a ``flag``.

    Notes
    -----
    A torque sign is advised only where the data support it: the cruise torque follows the
    gravity model with a slope near +-1 (:data:`SLOPE_RANGE`; else the gravity model is
    blamed, naming the slope), and following the advice leaves the condition of one sign —
    every fast trial negative (with a slope near +1 the quasi-static trials agree with them, so
    the whole condition is flipped), or this trial's ``torque_sign`` other than that of every
    positive sibling, or this trial's cruise following the gravity model negated while its
    siblings are positive (one file written with the other sign: its own ``torque_sign`` is
    the fix). Otherwise (no cruise to compare) the line says that flipping would mix signs,
    with the siblings' range.
    """
    positive = [(sign, est) for sign, est, _ in trials if est.inertia >= 0]
    out: list[SignVerdict | None] = []
    for sign, est, slope in trials:
        value, se = est.inertia, est.inertia_se
        if value >= 0:
            out.append(None)
            continue
        n = len(trials)
        if slope is not None and not SLOPE_RANGE[0] <= abs(slope) <= SLOPE_RANGE[1]:
            advice = (
                f"its torque at constant speed follows the condition's gravity model with a "
                f"slope of {slope:.2g} where ±1 is expected: the gravity model (its "
                "quasi-static trials' scale, sweep or sign) is wrong, not this torque's sign"
            )
        elif not positive:
            every = (
                f"{'the' if n == 1 else f'all {n}'} fast trial{'' if n == 1 else 's'} of "
                f"condition '{condition}' {'is' if n == 1 else 'are'} negative"
            )
            if slope is not None and slope > 0 and sign != "motion":
                advice = (
                    f"{every} and agree with its quasi-static trials: the whole condition is "
                    f"signed opposite; {torque_sign_hint(sign)}, and for its quasi-static trials"
                )
            else:
                advice = f"{every}: {torque_sign_hint(sign)}"
        elif sign != "motion" and all(_sign_key(s) != _sign_key(sign) for s, _ in positive):
            advice = (
                f"its torque_sign differs from that of the condition's positive fast trials: "
                f"{torque_sign_hint(sign)}"
            )
        elif sign != "motion" and slope is not None and slope < 0:
            advice = (
                f"its torque at constant speed follows the condition's gravity model negated "
                f"(slope {slope:.2g}) where its other fast trials are positive: this file's "
                f"torque is written with the other sign; {torque_sign_hint(sign)}"
            )
        else:
            values = [e.inertia for _, e in positive]
            advice = (
                f"{len(positive)} other fast trial{'' if len(positive) == 1 else 's'} of "
                f"condition '{condition}' give {min(values):.3g} to {max(values):.3g} kg m^2 "
                "with the same torque_sign, so flipping its sign would mix signs within the "
                "condition; check this trial's columns, window and recording"
            )
        if value + NEGATIVE_SE * se < 0:
            message = (
                f"{est.source}: torque: inertia {value:.4g} kg m^2 is negative (the torque "
                f"opposes the acceleration in the window {est.window_start:.4g} to "
                f"{est.window_end:.4g} s); {advice}"
            )
            out.append(SignVerdict(error=message))
        else:
            out.append(
                SignVerdict(flag=f"negative inertia {value:.3g} ± {se:.2g} kg m^2; {advice}")
            )
    return out
