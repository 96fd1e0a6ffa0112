"""A body's inertial parameters carried into the joint moment of a motion, with their spread.

For a segment turning about its joint the inverse-dynamics moment is the rigid-body part of
the dynamometer's equation (:func:`inertiafit.physics.joint_moment`)::

    M(t) = I alpha(t) + M_g sin(theta(t) + phi),   I = m (rho^2 + x^2),   M_g = m g x

:func:`propagate` evaluates it for every draw of ``(m, x, rho)`` — a posterior's, a prior's
(the ±50 % box, a de Leva prior) or any arrays — along one motion, and returns the draws of
``M(t)``, their median and highest-density band (``arviz_stats.hdi``), and which parameter
the spread is due to (:meth:`Propagation.shares`):

* **by conditioning** on each of ``m``, ``x``, ``rho`` (first-order sensitivity index):
  ``S_p(t) = Var(E[M(t) | p]) / Var(M(t))``, estimated by sorting the draws by ``p`` into
  equal-count bins; the within-bin noise (``mean within-bin variance / draws per bin``) is
  subtracted. Posterior parameters are strongly correlated along the identification curve,
  so these shares overlap and need not sum to 1: each says how much of the spread would go
  if that parameter alone were known;
* **exactly, by the identified pair**: ``M`` is linear in ``I`` and ``M_g``, so
  ``Var M = alpha^2 Var I + s^2 Var M_g + 2 alpha s Cov(I, M_g)`` with ``s = sin(theta +
  phi)``; the three terms over ``Var M`` sum to 1.

**A living body** (a posterior whose body is a study's ``living = true`` one) adds what its
joint does on its own, the rest of the dynamometer's equation
(:mod:`inertiafit.report.living_joint`)::

    M(t) = I alpha + M_g sin(theta + phi) + P(theta) + b omega + h(theta) sgn(omega)

``P`` the passive elastic moment (0 at the middle of the swept range, as ``passive.csv``),
``b`` the viscous damping, ``h`` the hysteresis, each draw's joint drawn given that draw's
gravity moment; ``theta`` is the dynamometer's angle. The parts are in
:attr:`Propagation.parts`, and the exact split gains the joint's variance
(``share_joint``) and its covariance with ``I`` and ``M_g`` (``share_joint_covariance``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from inertiafit._checks import check_finite, check_probability, check_seed, check_whole
from inertiafit.errors import InputError
from inertiafit.inference.priors import Prior
from inertiafit.io.readers import read_trial
from inertiafit.physics import GRAVITY, PARAMETERS, gravity_moment, inertia, joint_moment
from inertiafit.posterior import Posterior, open_posterior
from inertiafit.processing.filtering import derivative
from inertiafit.report.export.phase import data_phase
from inertiafit.report.living_joint import condition_moments, living_joint

__all__ = ["DEFAULT_DRAWS", "JOINT_SHARE_COLUMNS", "SHARE_COLUMNS", "Propagation", "propagate"]

#: Draws taken from a prior, and at most from a posterior.
DEFAULT_DRAWS = 4000
#: Columns of :meth:`Propagation.shares`.
SHARE_COLUMNS = [
    "share_mass",
    "share_com_distance",
    "share_radius_of_gyration",
    "share_inertia",
    "share_gravity_moment",
    "share_covariance",
]
#: More columns of :meth:`Propagation.shares` for a living body's joint.
JOINT_SHARE_COLUMNS = ["share_joint", "share_joint_covariance"]


@dataclass(frozen=True)
class Propagation:
    """Draws of a joint moment along a motion, and their summaries.

    Attributes
    ----------
    time, angle, acceleration : ndarray
        The motion: s, rad, rad/s^2 (``n`` samples).
    moments : ndarray
        ``(draws, n)``: ``M(t)`` of each parameter draw (N m).
    parameters : dict of str to ndarray
        The draws of ``mass``, ``com_distance``, ``radius_of_gyration`` (``draws``).
    inertia, gravity_moment : ndarray
        The draws of ``I`` (kg m^2) and ``M_g`` (N m).
    phase : float
        ``phi`` (rad).
    hdi_prob : float
    label : str
        Where the draws come from (body and posterior, or the prior).
    parts : dict of str to ndarray
        A living body's joint, ``(draws, n)`` each (N m): ``passive`` (``P(theta)``),
        ``damping`` (``b omega``), ``hysteresis`` (``h(theta) sgn(omega)``); empty for a
        rigid body. ``moments`` includes them.
    velocity : ndarray or None
        ``omega`` (rad/s) where the joint needed it.
    """

    time: NDArray
    angle: NDArray
    acceleration: NDArray
    moments: NDArray
    parameters: dict[str, NDArray]
    inertia: NDArray
    gravity_moment: NDArray
    phase: float
    hdi_prob: float
    label: str
    parts: dict[str, NDArray] = field(default_factory=dict)
    velocity: NDArray | None = None
    _cache: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def median(self) -> NDArray:
        """Median moment at each sample (N m)."""
        return np.median(self.moments, axis=0)

    @property
    def hdi(self) -> NDArray:
        """``(n, 2)``: the highest-density interval of ``hdi_prob`` at each sample (N m)."""
        if "hdi" not in self._cache:
            from arviz_stats import hdi

            self._cache["hdi"] = np.asarray(hdi(self.moments, prob=self.hdi_prob, axis=0))
        return self._cache["hdi"]

    def shares(self, bins: int | None = None) -> pd.DataFrame:
        """Share of the moment's variance due to each parameter, at each sample.

        ``share_<p>`` for ``m``, ``x``, ``rho`` by conditioning (see the module notes; with
        ``bins`` equal-count bins, default ``sqrt(draws) / 2`` between 5 and 50), and the
        exact split by ``I``, ``M_g`` and their covariance (and, for a living body, the
        joint's variance and its covariance with them, :data:`JOINT_SHARE_COLUMNS`). Where
        the moment does not vary (a single draw) every share is NaN.
        """
        m = self.moments
        n = m.shape[0]
        k = bins if bins is not None else int(np.clip(np.sqrt(n) / 2, 5, 50))
        k = check_whole(k, "bins", minimum=2)
        var = m.var(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            out: dict[str, NDArray] = {}
            for p in PARAMETERS:
                order = np.argsort(self.parameters[p], kind="stable")
                groups = np.array_split(order, min(k, n))
                means = np.array([m[g].mean(axis=0) for g in groups])
                sizes = np.array([len(g) for g in groups], dtype=float)[:, None]
                within = np.array([m[g].var(axis=0) for g in groups])
                between = (sizes * (means - m.mean(axis=0)) ** 2).sum(axis=0) / n
                noise = (sizes * within).sum(axis=0) / n / sizes.mean()
                out[f"share_{p}"] = np.clip(between - noise, 0.0, None) / var
            a = self.acceleration
            s = np.sin(self.angle + self.phase)
            cov = np.cov(self.inertia, self.gravity_moment, ddof=0)
            out["share_inertia"] = a * a * cov[0, 0] / var
            out["share_gravity_moment"] = s * s * cov[1, 1] / var
            out["share_covariance"] = 2 * a * s * cov[0, 1] / var
            columns = SHARE_COLUMNS
            if self.parts:
                joint: NDArray = np.sum(list(self.parts.values()), axis=0)
                centred = joint - joint.mean(axis=0)
                with_i = ((self.inertia - self.inertia.mean())[:, None] * centred).mean(axis=0)
                with_g = (
                    (self.gravity_moment - self.gravity_moment.mean())[:, None] * centred
                ).mean(axis=0)
                out["share_joint"] = joint.var(axis=0) / var
                out["share_joint_covariance"] = 2 * (a * with_i + s * with_g) / var
                columns = [*SHARE_COLUMNS, *JOINT_SHARE_COLUMNS]
        bad = ~(var > 0)
        frame = pd.DataFrame(out, columns=columns)
        frame.loc[bad, :] = np.nan
        return frame

    def table(self) -> pd.DataFrame:
        """A row per sample: motion, ``median``, ``hdi_lower``, ``hdi_upper``, ``sd``, shares."""
        band = self.hdi
        return pd.concat(
            [
                pd.DataFrame(
                    {
                        "time": self.time,
                        "angle": self.angle,
                        "acceleration": self.acceleration,
                        "median": self.median,
                        "hdi_lower": band[:, 0],
                        "hdi_upper": band[:, 1],
                        "sd": self.moments.std(axis=0, ddof=1)
                        if len(self.moments) > 1
                        else np.nan,
                    }
                ),
                self.shares(),
            ],
            axis=1,
        )

    def peak(self) -> pd.Series:
        """The table's row where the median moment is largest in magnitude.

        With the band's relative half-width ``relative_width`` (half the HDI over the
        median's magnitude).
        """
        table = self.table()
        row = table.iloc[int(np.argmax(np.abs(table["median"].to_numpy())))].copy()
        row["relative_width"] = (row["hdi_upper"] - row["hdi_lower"]) / 2 / abs(row["median"])
        return row


#: A motion whose time step exceeds this (s) is refused: 10 Hz, below any motion capture's
#: rate; a time in ms read as s gives steps of a second.
MAX_STEP = 0.1
#: Time steps that differ from their median by more than this fraction are uneven: the
#: spectral derivative assumes one step (time stamps rounded to 1 ms at 120 Hz are 20 % off).
STEP_TOLERANCE = 0.01
#: Largest angular travel (rad) of a motion: a turn; more is an angle in degrees.
MAX_TRAVEL = 2 * np.pi
#: Largest angular acceleration (rad/s^2) a limb reaches: a pitcher's shoulder about 1e4.
MAX_ACCELERATION = 5e4
#: Most moment values one propagation holds (draws x samples): 1.6 GB.
MAX_VALUES = 2e8


def _floats(value: Any, what: str) -> NDArray:
    """``value`` as float64 numbers, or a one-line error naming ``what``."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"motion: {what}: expected numbers, got {value!r:.60}") from None


def _check_motion(time: NDArray, angle: NDArray, acc: NDArray, *, derived: bool) -> None:
    """Refuse a motion whose numbers cannot mean what propagate takes (issue 36).

    Angles beyond a turn of travel (degrees read as radians), time steps beyond
    :data:`MAX_STEP` (milliseconds read as seconds), uneven steps where the acceleration is
    derived (the spectral derivative assumes one step), and accelerations beyond any limb's.
    """
    travel = float(np.ptp(angle))
    if travel > MAX_TRAVEL:
        raise InputError(
            f"motion: angle: travels {travel:.4g} rad ({np.degrees(travel):.4g} deg), more than "
            "a turn; give the angle in rad (are these degrees?)"
        )
    steps = np.diff(time)
    median = float(np.median(steps))
    if median > MAX_STEP:
        raise InputError(
            f"motion: time: a step of {median:.4g} s ({1 / median:.3g} Hz); give the time in s "
            "(is it in ms?)"
        )
    spread = float(np.max(np.abs(steps - median))) / median
    if derived and spread > STEP_TOLERANCE:
        raise InputError(
            f"motion: time: steps from {steps.min():.4g} to {steps.max():.4g} s (up to "
            f"{100 * spread:.0f} % off their median, rounded time stamps?); the acceleration "
            "is derived for one even step: resample the motion to an even step or give its "
            "acceleration"
        )
    peak = float(np.max(np.abs(acc)))
    if peak > MAX_ACCELERATION:
        raise InputError(
            f"motion: acceleration reaches {peak:.4g} rad/s^2, beyond any limb's "
            f"({MAX_ACCELERATION:g}); check the units of time, angle and acceleration"
        )


def _velocity(time: NDArray, angle: NDArray) -> NDArray:
    """The angle's derivative, for a motion on one even step (the spectral derivative's)."""
    steps = np.diff(time)
    median = float(np.median(steps))
    if float(np.max(np.abs(steps - median))) / median > STEP_TOLERANCE:
        raise InputError(
            "motion: time: uneven steps; a living joint's damping needs the velocity: give "
            "'velocity' (rad/s) or resample the motion to an even step"
        )
    return derivative(angle, time)


def _motion(
    motion: Any, reader: Mapping[str, Any] | None
) -> tuple[NDArray, NDArray, NDArray, NDArray | None]:
    """``(time, angle, acceleration, velocity)`` of a motion: arrays, a Trial or a trial file.

    ``velocity`` is the Trial's or the mapping's ``velocity``, else ``None``.
    """
    if isinstance(motion, str | Path):
        motion = read_trial(motion, **dict(reader or {}))
    if isinstance(motion, xr.Dataset):
        if not {"angle", "velocity"} <= set(motion.data_vars):
            raise InputError("motion: a Trial needs 'angle' and 'velocity' (rad, rad/s)")
        time = np.asarray(motion["time"].values, dtype=float)
        angle = np.asarray(motion["angle"].values, dtype=float)
        omega = np.asarray(motion["velocity"].values, dtype=float)
        return time, angle, derivative(omega, time), omega
    if isinstance(motion, Mapping):
        missing = [k for k in ("time", "angle") if k not in motion]
        if missing:
            raise InputError(f"motion: '{missing[0]}' is missing (time in s, angle in rad)")
        time = _floats(motion["time"], "time")
        angle = _floats(motion["angle"], "angle")
        acceleration = motion.get("acceleration")
        given = motion.get("velocity")
    elif isinstance(motion, tuple) and len(motion) in (2, 3):
        time, angle = _floats(motion[0], "time"), _floats(motion[1], "angle")
        acceleration = motion[2] if len(motion) == 3 else None
        given = None
    else:
        raise InputError(
            "motion: expected (time, angle) arrays (s, rad), a mapping with 'time' and "
            f"'angle', a Trial or a trial file, got {type(motion).__name__}"
        )
    if time.ndim != 1 or time.shape != angle.shape or time.size < 4:
        raise InputError("motion: time and angle must be 1-D arrays of the same length (>= 4)")
    if not (np.all(np.isfinite(time)) and np.all(np.isfinite(angle))):
        raise InputError("motion: time and angle must be finite")
    if not np.all(np.diff(time) > 0):
        raise InputError("motion: time must increase strictly")
    if acceleration is None:
        acc = derivative(derivative(angle, time), time)
    else:
        acc = _floats(acceleration, "acceleration")
        if acc.shape != time.shape or not np.all(np.isfinite(acc)):
            raise InputError("motion: 'acceleration' must be finite, one value per time")
    velocity = None
    if given is not None:
        velocity = _floats(given, "velocity")
        if velocity.shape != time.shape or not np.all(np.isfinite(velocity)):
            raise InputError("motion: 'velocity' must be finite, one value per time")
    _check_motion(time, angle, acc, derived=acceleration is None)
    return time, angle, acc, velocity


@dataclass(frozen=True)
class _Source:
    """Where the draws come from: the draws, ``g`` (or None), a label, a posterior's joint."""

    values: dict[str, NDArray]
    gravity: float | None
    label: str
    posterior: Posterior | None = None
    body: str = ""
    index: NDArray | None = None  # the posterior's flat draws taken


def _draws(source: Any, body: str | None, draws: int | None, rng: np.random.Generator) -> _Source:
    """The parameter draws of ``source``, its gravity (or None) and a label."""
    if isinstance(source, str | Path):
        path = Path(source)
        source = open_posterior(path / "posterior.nc" if path.is_dir() else path)
    if isinstance(source, Prior):
        size = draws or DEFAULT_DRAWS
        return _Source(source.sample(size, rng), None, f"prior {source.name}")
    if isinstance(source, Posterior):
        bodies = source.bodies
        if body is None:
            if len(bodies) != 1:
                raise InputError(f"body: the posterior has bodies {', '.join(bodies)}; name one")
            body = bodies[0]
        if body not in bodies:
            raise InputError(f"body: no body '{body}' in the posterior ({', '.join(bodies)})")
        values = {p: source.draws(body, p).reshape(-1) for p in PARAMETERS}
        gravity = float(source.tree["constant_data"]["gravity"])
        label = f"posterior of {body}"
    elif isinstance(source, Mapping):
        missing = [p for p in PARAMETERS if p not in source]
        if missing:
            raise InputError(f"posterior: '{missing[0]}' is missing from the draws given")
        given = []
        for p in PARAMETERS:
            try:
                given.append(np.asarray(source[p], dtype=float))
            except (TypeError, ValueError):
                raise InputError(
                    f"posterior: {p}: expected numbers, got {source[p]!r:.60}"
                ) from None
        try:
            arrays = np.broadcast_arrays(*given)
        except ValueError:
            raise InputError(
                "posterior: the draws of mass, com_distance, radius_of_gyration differ in length"
            ) from None
        values = {p: a.reshape(-1).copy() for p, a in zip(PARAMETERS, arrays, strict=True)}
        for p in ("mass", "radius_of_gyration"):
            bad = ~(np.isfinite(values[p]) & (values[p] > 0))
            if bad.any():
                raise InputError(
                    f"posterior: {p}: every draw must be a positive number, got "
                    f"{float(values[p][bad][0])!r} ({int(bad.sum())} of {bad.size})"
                )
        if not np.all(np.isfinite(values["com_distance"])):
            raise InputError("posterior: com_distance: every draw must be a finite number")
        gravity, label = None, "draws given"
    else:
        raise InputError(
            "posterior: expected a Posterior, a posterior.nc or results folder, a Prior or a "
            f"mapping of draws, got {type(source).__name__}"
        )
    n = values["mass"].size
    index = np.arange(n)
    if draws is not None and draws < n:
        index = np.sort(rng.choice(n, size=draws, replace=False))
        values = {p: v[index] for p, v in values.items()}
    if isinstance(source, Posterior):
        return _Source(values, gravity, label, source, str(body), index)
    return _Source(values, gravity, label)


def propagate(
    posterior: Posterior | Prior | Mapping[str, ArrayLike] | str | Path,
    motion: Any,
    *,
    body: str | None = None,
    phase: float | str = 0.0,
    gravity: float | None = None,
    hdi_prob: float = 0.95,
    draws: int | None = None,
    seed: int = 0,
    reader: Mapping[str, Any] | None = None,
    joint: bool = True,
) -> Propagation:
    """The joint moment of a motion for every draw of a body's ``(m, x, rho)``.

    Parameters
    ----------
    posterior : Posterior, Prior, mapping or path
        A :class:`~inertiafit.Posterior` (or its ``posterior.nc``, or a results folder), a
        :class:`~inertiafit.Prior` (``draws`` independent draws of it: the ±50 % box, a de Leva
        prior), or arrays ``mass``, ``com_distance``, ``radius_of_gyration`` (SI units).
    motion : tuple, mapping, Trial or path
        ``(time, angle)`` or ``(time, angle, acceleration)`` arrays (s, rad, rad/s^2), a
        mapping with those keys (and optionally ``velocity``, rad/s), a Trial
        (:func:`~inertiafit.read_trial`) or a trial file (read with ``reader``'s options).
        Without an acceleration it is the angle's second derivative (spectral,
        :func:`inertiafit.processing.filtering.derivative`): give smooth angles, or a Trial,
        whose velocity is differentiated once.
    body : str, optional
        The body of a posterior with several.
    phase : float or "data"
        ``phi`` (rad): ``theta + phi`` is the angle from hanging (the gravity vertical);
        ``"data"``: the phase the study behind a posterior measured
        (:func:`~inertiafit.report.export.data_phase`).
    gravity : float, optional
        m/s^2; default the posterior's, or 9.81.
    hdi_prob : float
        Probability of the band.
    draws : int, optional
        Draws used: from a prior (default 4000), or at most this many of a posterior's.
    seed : int
        Seeds the prior's draws, the choice among a posterior's and a living joint's draws.
    reader : mapping, optional
        Options of :func:`~inertiafit.read_trial` for a trial file (``format``, ``columns``,
        ``units``).
    joint : bool
        Add a living body's joint (passive moment, damping, hysteresis; the module notes)
        when the posterior carries one (default); ``False``: the rigid-body moment only.

    Returns
    -------
    Propagation
    """
    check_probability(hdi_prob, "hdi_prob")
    check_seed(seed)
    if draws is not None:
        draws = check_whole(draws, "draws")
    time, angle, acceleration, velocity = _motion(motion, reader)
    rng = np.random.default_rng(seed)
    source = _draws(posterior, body, draws, rng)
    if isinstance(phase, str) and phase == "data":
        if source.posterior is None:
            raise InputError("phase: 'data' needs a posterior (a results folder or posterior.nc)")
        phase = data_phase(source.posterior)[0]
    phase = check_finite(phase, "phase", "rad")
    values = source.values
    g = gravity if gravity is not None else (source.gravity or GRAVITY)
    g = check_finite(g, "gravity", "m/s^2")
    m, x, rho = (values[p] for p in PARAMETERS)
    if m.size * time.size > MAX_VALUES:
        raise InputError(
            f"motion: {time.size} samples x {m.size} draws is {m.size * time.size:.3g} moments "
            f"({8 * m.size * time.size / 2**30:.3g} GiB), more than one propagation holds "
            f"({MAX_VALUES:.0e}); pass draws= fewer or resample the motion"
        )
    i_joint = inertia(m, rho, x)
    m_g = gravity_moment(m, x, g)
    moments = joint_moment(i_joint[:, None], m_g[:, None], angle[None, :], acceleration[None, :],
                           phase)  # fmt: skip
    parts: dict[str, NDArray] = {}
    living = (
        living_joint(source.posterior, source.body)
        if joint and source.posterior is not None
        else None
    )
    if living is not None:
        if velocity is None:
            velocity = _velocity(time, angle)
        size = m.size
        given = condition_moments(source.posterior, living, source.index)  # type: ignore[arg-type]
        coefficients = living.draws(rng, size, given)
        damping = living.damping_draws(rng, size)
        parts = {
            "passive": living.passive(angle, coefficients),
            "damping": damping[:, None] * velocity[None, :],
            "hysteresis": living.hysteresis(angle, coefficients) * np.sign(velocity)[None, :],
        }
        moments = moments + np.sum(list(parts.values()), axis=0)
        source = dataclasses.replace(source, label=f"{source.label} with its joint")
    return Propagation(
        time=time,
        angle=angle,
        acceleration=acceleration,
        moments=moments,
        parameters=values,
        inertia=i_joint,
        gravity_moment=m_g,
        phase=phase,
        hdi_prob=hdi_prob,
        label=source.label,
        parts=parts,
        velocity=velocity if parts else None,
    )
