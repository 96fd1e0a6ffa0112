"""The static moment of a living segment: gravity and the joint's passive curve, fitted together.

A living body's joint resists being moved: its passive elastic moment ``P(theta_j)``
(:mod:`inertiafit.passive`) and, while it moves, a hysteresis ``h sgn(omega)`` and a viscous
``b omega``. A quasi-static sweep of a condition that holds the living body, in posture ``p``
(a setup that rotates gravity by ``r_p`` about the axis and tilts the axis by ``t_p``), reads

    tau = cos(t_p) [A sin(theta + r_p) + B cos(theta + r_p)] + C_p + P(theta_j) + H d

with ``M_g = hypot(A, B)``, ``d`` the sweep's direction (+1, -1; 0 for a quiet hold, a rest
trial) and ``H = h + b omega_slow`` (at 1 deg/s, ``b omega`` is a thousandth of ``h``).
On one posture's sweep ``A sin(theta + phi)`` and a passive spring ``k theta_j`` are nearly
the same curve, so gravity and the passive moment are told apart only by the passive prior
there; a second posture rotates the gravity curve and not the passive one (the joint moves
through the same angles), and a horizontal-plane posture (``t_p = 90`` deg) has no gravity
at all.

**The fit** (:func:`fit_statics`) is a Bayesian linear regression over every quasi-static
and rest trial of the study's living conditions at once. The coefficients are
``gamma = (A_c, B_c`` per living condition, ``C_cp`` per condition and posture, ``H``,
the passive coefficients ``k``, ``a_lo``, ``a_hi`` and, for the knee and the ankle, the scale
``s`` of the literature curve, and a rotation correction ``delta r_p`` per posture beside
the first``)``. ``A``, ``B`` and ``C`` have flat priors; every other coefficient has the
Gaussian prior of ``[passive]`` (the joint's prior file, :class:`PassiveBasis`), and each
posture's rotation the Gaussian of its ``gravity_rotation_sd`` relative to the first
posture's (``"free"``: flat). The passive and hysteresis coefficients are nuisance
parameters and are **integrated out analytically**: with a Gaussian prior and a model linear
in them, the posterior of ``(A, B)`` given the data is Gaussian with the covariance of the
regression, exact up to two approximations named here — the rotation enters through its
first-order term (Gauss-Newton, iterated to convergence: a Laplace approximation in
``delta r_p``, tight at the 2 deg of a protractor), and the noise of each trial is Gaussian
with a variance and an autocorrelation time estimated from its residuals (the sandwich of
:mod:`~inertiafit.processing.gravity` in its simplest form: the variance of slowly varying
regressors times ``tau_int``). Sampling the nuisance coefficients with the bodies' would give
the same posterior with seven more dimensions on a ridge; integrating them keeps the
sampler, its exactness and its reference (:mod:`inertiafit.inference.reference`) as they are.

The living condition's ``M_g`` then enters the posterior as every condition's does, a
Gaussian with the SE of ``hypot(A, B)`` (:meth:`LivingStatics.gravity_fit`), and its fast
trials subtract the fitted static curve at their own posture and direction
(:class:`StaticCurve`), the curve's error carried into their inertia through the
sensitivities (:meth:`LivingStatics.inertia_coupling`).

Constants of the passive curve (the spring's relaxed angle) are not identified: the offset
``C_cp`` absorbs them. :meth:`LivingStatics.passive_curve` shows ``P`` relative to its value
at the middle of the swept range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.manifest import PassivePrior, Posture
from inertiafit.passive import literature_curve
from inertiafit.processing.gravity import (
    GravityFit,
    TorqueNoise,
    integrated_autocorrelation_time,
    moving_part,
    pooled_noise,
    sweep_noise,
)
from inertiafit.stats import inverse_variance_mean, shared_error

__all__ = [
    "CURVE_COLUMNS",
    "LEVERAGE_DATA",
    "LEVERAGE_PRIOR",
    "MAX_BLOCKS",
    "PARAMETER_COLUMNS",
    "REST_SPEED",
    "LivingStatics",
    "PassiveBasis",
    "PostureGeometry",
    "StaticCurve",
    "StaticRecord",
    "design_statics",
    "fit_statics",
    "living_tables",
    "living_tables_from_dict",
    "passive_basis",
    "posture_geometry",
]

#: A trial's samples are averaged in consecutive blocks, at most this many per trial (the
#: fit's cost; the curves change by a fraction of a degree within a block).
MAX_BLOCKS = 2000
_Z95 = 1.959963984540054
#: A living condition's ``M_g`` whose SE grows by more than this factor when the passive
#: prior's SDs double is said to be decided by the passive prior (1: data alone; 2: prior alone).
LEVERAGE_PRIOR = 1.5
#: ... and by the data alone below this factor (in between: both).
LEVERAGE_DATA = 1.15
#: Speed (rad/s) below which a fast trial's shaft counts as at rest for the hysteresis
#: (0.5 deg/s: half a quasi-static sweep's speed, far below any fast trial's).
REST_SPEED = math.radians(0.5)
#: Gauss-Newton iterations of the rotations and the noise weights, at most.
_ITERATIONS = 30
#: Convergence of the rotations (rad) and of the weights (relative).
_TOLERANCE = 1e-10


@dataclass(frozen=True)
class PostureGeometry:
    """A posture's gravity: rotation ``r`` (rad), its prior SD (rad; ``inf`` free), tilt (rad)."""

    name: str
    rotation: float = 0.0
    rotation_sd: float = math.radians(2.0)
    tilt: float = 0.0


@dataclass(frozen=True)
class PassiveBasis:
    """The passive curve's columns and their Gaussian priors (``(mean, sd)`` each).

    Angles in rad: ``zero`` is the joint angle at the device's 0, ``range_low`` and
    ``range_high`` the joint angles of the end stops, ``width`` their e-folding width.
    ``damping`` is the viscous damping's prior, shown beside the fast trials' estimate (which
    the data decide: the two windows of every fast trial).
    """

    joint: str
    zero: float
    stiffness: tuple[float, float]
    stop_moment: tuple[float, float]
    width: float
    range_low: float
    range_high: float
    hysteresis: tuple[float, float]
    curve_scale: tuple[float, float] | None = None
    damping: tuple[float, float] = (math.nan, math.nan)

    @property
    def names(self) -> tuple[str, ...]:
        """The passive coefficients, in column order."""
        out = (
            "stiffness",
            "stop_low_narrow",
            "stop_low_wide",
            "stop_high_narrow",
            "stop_high_wide",
        )
        return (*out, "curve_scale") if self.curve_scale is not None else out

    @property
    def priors(self) -> list[tuple[float, float]]:
        """``(mean, sd)`` of each of :attr:`names`.

        Each end stop is two exponentials, ``width / sqrt(2)`` and ``width * sqrt(2)`` wide,
        sharing the stop's prior (half its mean, its SD over ``sqrt(2)`` each): a stop of
        any width in between, which no published number pins, is then within the model.
        """
        mean, sd = self.stop_moment
        half = (0.5 * mean, sd / math.sqrt(2.0))
        out = [self.stiffness, half, half, half, half]
        return [*out, self.curve_scale] if self.curve_scale is not None else out

    def columns(self, theta: NDArray) -> list[NDArray]:
        """The passive columns at device angles ``theta`` (rad)."""
        tj = self.zero + np.asarray(theta, dtype=np.float64)
        narrow, wide = self.width / math.sqrt(2.0), self.width * math.sqrt(2.0)
        out = [
            tj,
            -np.exp((self.range_low - tj) / narrow),
            -np.exp((self.range_low - tj) / wide),
            np.exp((tj - self.range_high) / narrow),
            np.exp((tj - self.range_high) / wide),
        ]
        if self.curve_scale is not None:
            out.append(literature_curve(self.joint, tj))
        return out


@dataclass(frozen=True)
class StaticRecord:
    """One quasi-static or rest trial of a living condition, as the fit needs it."""

    angle: NDArray
    torque: NDArray
    condition: str
    posture: str
    kind: str
    source: str
    rate: float = 0.0  # Hz; 0: unknown (no noise model for the condition's fast trials)


def _blocks(x: NDArray, size: int) -> NDArray:
    """Means of consecutive blocks of ``size`` samples (the last may be shorter)."""
    return np.add.reduceat(x, np.arange(0, x.size, size)) / np.diff(
        np.r_[0 : x.size : size, x.size]
    )


@dataclass(frozen=True)
class _Prepared:
    """A record reduced to block means, with its direction."""

    record: StaticRecord
    theta: NDArray
    y: NDArray
    direction: int


def _prepare(record: StaticRecord) -> _Prepared:
    theta, y = np.asarray(record.angle, float), np.asarray(record.torque, float)
    direction = 0
    if record.kind != "rest":
        part = moving_part(theta)
        theta, y = theta[part], y[part]
        direction = 1 if theta[-1] >= theta[0] else -1
    size = max(1, math.ceil(theta.size / MAX_BLOCKS))
    return _Prepared(record, _blocks(theta, size), _blocks(y, size), direction)


@dataclass(frozen=True)
class StaticCurve:
    """The static moment a fast trial of a living condition subtracts, linear in ``gamma``.

    :func:`~inertiafit.processing.inertia.estimate_inertia` takes it in place of a
    :class:`~inertiafit.processing.gravity.GravityFit`: :meth:`columns` at the trial's angles
    (an array or a constant per coefficient) times :attr:`coefficients`.
    """

    statics: LivingStatics
    condition: str
    posture: str
    direction: int

    @property
    def coefficients(self) -> NDArray:
        """``gamma``, the fitted coefficients."""
        return self.statics.coefficients

    def columns(self, angle: NDArray, velocity: NDArray | None = None) -> list[NDArray | float]:
        """Each coefficient's column at ``angle`` (rad): an array, or a float when constant.

        With the trial's ``velocity`` (rad/s) the hysteresis acts only while the shaft moves,
        ``H sgn(omega)`` (a step at the start and the end of the move, which the low-pass
        filter spreads into the ramps as it does the torque's); without it, ``H`` times the
        move's direction throughout.
        """
        return self.statics.columns(
            angle, self.condition, self.posture, self.direction, velocity=velocity
        )

    @property
    def noise(self) -> TorqueNoise | None:
        """The condition's torque noise model (its sweeps'), if known."""
        return self.statics.noise.get(self.condition)


@dataclass(frozen=True)
class LivingStatics:
    """The joint fit of a study's living conditions (:func:`fit_statics`).

    Attributes
    ----------
    names : tuple of str
        The coefficients: ``A:<condition>``, ``B:<condition>``, ``C:<condition>:<posture>``,
        ``hysteresis``, the passive ones (:attr:`PassiveBasis.names`) and
        ``rotation:<posture>`` for every posture after the first.
    coefficients, covariance : ndarray
        Their posterior mean and covariance (the passive prior included).
    precision : ndarray
        The posterior precision (the inverse of ``covariance``).
    postures : dict of str to PostureGeometry
        With the fitted rotations (rad).
    basis : PassiveBasis
    sources : dict of str to str
        Each condition's trials (file names), for messages.
    residual_rms : dict of str to float
        RMS residual of each trial (N m), by file.
    angle_range : (float, float)
        The device angles (rad) the sweeps covered.
    converged : bool
        Whether the rotations and the noise weights settled within the iterations allowed
        (a study says so when they did not).
    noise : dict of str to TorqueNoise
        Each condition's torque noise (white plus drift), for its fast trials' standard
        errors; set by :func:`~inertiafit.processing.study.process_study` from the
        condition's sweeps (empty: none known).
    """

    names: tuple[str, ...]
    coefficients: NDArray
    covariance: NDArray
    precision: NDArray
    postures: dict[str, PostureGeometry]
    basis: PassiveBasis
    conditions: tuple[str, ...]
    residual_rms: dict[str, float] = field(default_factory=dict)
    angle_range: tuple[float, float] = (0.0, 0.0)
    converged: bool = True
    noise: dict[str, TorqueNoise] = field(default_factory=dict)

    def index(self, name: str) -> int:
        """Position of a coefficient."""
        return self.names.index(name)

    def columns(
        self,
        angle: NDArray,
        condition: str,
        posture: str,
        direction: int,
        *,
        velocity: NDArray | None = None,
    ) -> list[NDArray | float]:
        """The design columns at ``angle`` for a trial of ``condition`` in ``posture``.

        ``velocity`` (rad/s): the hysteresis column is ``sgn(omega)`` (0 at rest, below
        :data:`REST_SPEED`) instead of the constant ``direction``.
        """
        cols = _columns(
            self.names,
            np.asarray(angle, float),
            condition,
            self.postures[posture],
            direction,
            self.basis,
            self.coefficients,
        )
        if velocity is not None:
            v = np.asarray(velocity, dtype=np.float64)
            moving = np.where(np.abs(v) > REST_SPEED, np.sign(v), 0.0)
            cols[self.index("hysteresis")] = moving
        return cols

    def curve(self, condition: str, posture: str, direction: int) -> StaticCurve:
        """What a fast trial of ``condition`` in ``posture`` moving ``direction`` subtracts."""
        return StaticCurve(self, condition, posture, direction)

    def moment_gradient(self, condition: str) -> NDArray:
        """``d M_g / d gamma`` of a condition (``M_g = hypot(A, B)``)."""
        a = self.coefficients[self.index(f"A:{condition}")]
        b = self.coefficients[self.index(f"B:{condition}")]
        moment = math.hypot(a, b)
        grad = np.zeros(len(self.names))
        grad[self.index(f"A:{condition}")] = a / moment
        grad[self.index(f"B:{condition}")] = b / moment
        return grad

    def prior_leverage(self, condition: str) -> float:
        """How much ``M_g``'s SE grows when the passive prior's SDs are doubled (1 to 2).

        Near 2 when the passive prior alone tells gravity from the passive curve; near 1
        when the data do (a second posture, the horizontal plane).
        """
        grad = self.moment_gradient(condition)
        idx = [self.index(n) for n in self.basis.names]
        sds = np.array([sd for _, sd in self.basis.priors])
        wider = self.precision.copy()
        wider[idx, idx] -= 0.75 / sds**2  # prior precision 1/sd^2 -> 1/(2 sd)^2
        full = float(grad @ self.covariance @ grad)
        return math.sqrt(float(grad @ np.linalg.solve(wider, grad)) / full) if full > 0 else 1.0

    def pinned_by(self, condition: str) -> str:
        """What tells a living condition's ``M_g`` apart from the passive curve.

        ``"passive prior"`` when its SE would grow by more than :data:`LEVERAGE_PRIOR` with
        the passive prior's SDs doubled; else the data that do — ``"a second posture"``,
        ``"the horizontal plane"`` or, with one posture, ``"the shape of the sweep"`` — with
        ``" and the passive prior"`` while the growth exceeds :data:`LEVERAGE_DATA`.
        """
        leverage = self.prior_leverage(condition)
        if leverage > LEVERAGE_PRIOR:
            return "passive prior"
        with_gravity = [p for p in self.postures.values() if abs(math.cos(p.tilt)) > 1e-6]
        parts = []
        if len(with_gravity) > 1:
            parts.append("a second posture")
        if len(with_gravity) < len(self.postures):
            parts.append("the horizontal plane")
        source = " and ".join(parts) or "the shape of the sweep"
        return f"{source} and the passive prior" if leverage > LEVERAGE_DATA else source

    def gravity_fit(self, condition: str, *, source: str = "") -> GravityFit:
        """A living condition's ``M_g`` as a :class:`GravityFit` (first posture's frame)."""
        ia, ib = self.index(f"A:{condition}"), self.index(f"B:{condition}")
        offsets = [i for i, n in enumerate(self.names) if n.startswith(f"C:{condition}:")]
        ic = offsets[0] if offsets else None
        a, b = float(self.coefficients[ia]), float(self.coefficients[ib])
        moment = math.hypot(a, b)
        g_m = self.moment_gradient(condition)
        g_p = np.zeros(len(self.names))
        g_p[ia], g_p[ib] = -b / moment**2, a / moment**2
        cov = self.covariance
        keep = [ia, ib] + ([ic] if ic is not None else [])
        c = float(self.coefficients[ic]) if ic is not None else 0.0
        c_se = math.sqrt(float(cov[ic, ic])) if ic is not None else math.nan
        coefficients = np.array([a, b, c])
        sub = np.full((3, 3), 0.0)
        sub[: len(keep), : len(keep)] = cov[np.ix_(keep, keep)]
        flags = (
            (
                "living body: M_g from the joint fit of gravity and the passive curve over "
                f"{len(self.postures)} posture(s), decided by "
                f"{self.pinned_by(condition)} (its SE grows "
                f"{self.prior_leverage(condition):.2f}x when the passive prior's SDs double)"
            ),
        )
        return GravityFit(
            gravity_moment=moment,
            gravity_moment_se=math.sqrt(float(g_m @ cov @ g_m)),
            gravity_phase=math.atan2(b, a),
            gravity_phase_se=math.sqrt(float(g_p @ cov @ g_p)),
            offset=c,
            offset_se=c_se,
            residual_rms=(
                float(np.sqrt(np.mean(np.square(list(self.residual_rms.values())))))
                if self.residual_rms
                else math.nan
            ),
            n=0,
            n_effective=math.nan,
            angle_range=self.angle_range[1] - self.angle_range[0],
            median_speed=math.nan,
            source=source,
            flags=flags,
            coefficients=coefficients,
            covariance=sub,
        )

    def inertia_coupling(self, condition: str, sensitivities: NDArray) -> tuple[float, float]:
        """The static curve's error in a condition's mean inertia: ``(coupling, shared_sd)``.

        As :func:`~inertiafit.inference.evidence.shared_gravity_error`, over every
        coefficient: the mean inertia moves by ``J delta``, ``M_g`` by ``g_m delta``.
        """
        jac = np.mean(np.atleast_2d(sensitivities), axis=0)
        return shared_error(jac, self.covariance, self.moment_gradient(condition))

    def damping(self, values, ses, sensitivities) -> tuple[float, float]:
        """The viscous damping ``b`` over fast trials: ``(mean, sd)``.

        The inverse-variance mean of the trials' estimates; its SD adds the static curve's
        error, which every trial shares (``J_b Sigma J_b'``, ``J_b`` the trials' mean
        sensitivity ``d b / d gamma``) and which the trials' own SEs do not show.
        """
        mean, se = inverse_variance_mean(values, ses)
        weights = 1.0 / np.asarray(ses, float) ** 2
        jac = weights @ np.atleast_2d(np.asarray(sensitivities, float)) / weights.sum()
        return mean, math.sqrt(se**2 + float(jac @ self.covariance @ jac))

    def value(self, name: str) -> tuple[float, float]:
        """A coefficient's mean and SD."""
        i = self.index(name)
        return float(self.coefficients[i]), math.sqrt(float(self.covariance[i, i]))

    def passive_curve(self, step_deg: float = 2.0) -> pd.DataFrame:
        """The passive elastic moment over the swept range, relative to its middle.

        Columns ``joint_angle`` (deg), ``device_angle`` (deg), ``median``, ``lower``,
        ``upper`` (N m, the 95 % band), ``prior_lower``, ``prior_upper`` (the passive
        prior's 95 % band, also relative to the middle) and ``gravity:<condition>``: each
        living condition's gravity moment ``M_g sin(theta + phi)`` in the first posture,
        relative to its middle too, to set the two side by side.
        """
        lo, hi = self.angle_range
        theta = np.radians(np.arange(math.degrees(lo), math.degrees(hi) + 1e-9, step_deg))
        mid = 0.5 * (lo + hi)
        cols = np.column_stack(self.basis.columns(theta)) - np.column_stack(
            self.basis.columns(np.array([mid]))
        )
        idx = [self.index(n) for n in self.basis.names]
        mean = cols @ self.coefficients[idx]
        sd = np.sqrt(np.einsum("ij,jk,ik->i", cols, self.covariance[np.ix_(idx, idx)], cols))
        prior_var = np.array([s for _, s in self.basis.priors]) ** 2
        prior_sd = np.sqrt((cols**2) @ prior_var)
        prior_mean = cols @ np.array([m for m, _ in self.basis.priors])
        z = _Z95
        table = pd.DataFrame(
            {
                "joint_angle": np.degrees(theta + self.basis.zero),
                "device_angle": np.degrees(theta),
                "median": mean,
                "lower": mean - z * sd,
                "upper": mean + z * sd,
                "prior_lower": prior_mean - z * prior_sd,
                "prior_upper": prior_mean + z * prior_sd,
            }
        )
        for cond in self.conditions:  # the gravity moment beside it, on the same footing
            a = self.coefficients[self.index(f"A:{cond}")]
            b = self.coefficients[self.index(f"B:{cond}")]
            curve = a * np.sin(theta) + b * np.cos(theta)
            table[f"gravity:{cond}"] = curve - (a * math.sin(mid) + b * math.cos(mid))
        return table


def _columns(
    names: Sequence[str],
    theta: NDArray,
    condition: str,
    posture: PostureGeometry,
    direction: int,
    basis: PassiveBasis,
    coefficients: NDArray,
) -> list[NDArray | float]:
    """The design: one entry per coefficient, an array or a constant."""
    tilt = math.cos(posture.tilt)
    angle = theta + posture.rotation
    passive = dict(zip(basis.names, basis.columns(theta), strict=True))
    out: list[NDArray | float] = []
    for name in names:
        kind, _, rest = name.partition(":")
        if kind == "A":
            out.append(tilt * np.sin(angle) if rest == condition else 0.0)
        elif kind == "B":
            out.append(tilt * np.cos(angle) if rest == condition else 0.0)
        elif kind == "C":
            out.append(1.0 if rest == f"{condition}:{posture.name}" else 0.0)
        elif kind == "hysteresis":
            out.append(float(direction))
        elif kind == "rotation":
            if rest != posture.name:
                out.append(0.0)
                continue
            a = coefficients[names.index(f"A:{condition}")]
            b = coefficients[names.index(f"B:{condition}")]
            out.append(tilt * (a * np.cos(angle) - b * np.sin(angle)))
        else:
            out.append(passive[name])
    return out


def passive_basis(prior: PassivePrior) -> PassiveBasis:
    """The passive curve's columns and priors from a ``[passive]`` table (angles to rad)."""
    return PassiveBasis(
        joint=prior.joint,
        zero=math.radians(prior.joint_angle_at_zero),
        stiffness=prior.stiffness,
        stop_moment=prior.stop_moment,
        width=math.radians(prior.stop_width),
        range_low=math.radians(prior.range[0]),
        range_high=math.radians(prior.range[1]),
        hysteresis=prior.hysteresis,
        curve_scale=prior.curve_scale,
        damping=prior.damping,
    )


def posture_geometry(posture: Posture) -> PostureGeometry:
    """A ``[postures.<name>]`` table's gravity in radians."""
    return PostureGeometry(
        posture.name,
        math.radians(posture.gravity_rotation),
        math.radians(posture.gravity_rotation_sd),
        math.radians(posture.axis_tilt),
    )


def _matrix(columns: Sequence[NDArray | float], theta: NDArray) -> NDArray:
    """The design matrix of :func:`_columns`' entries at ``theta`` (constants broadcast)."""
    return np.column_stack([np.broadcast_to(c, theta.shape) for c in columns])


def _layout(
    conditions: Sequence[str], pairs: Sequence[str], used: Sequence[str], basis: PassiveBasis
) -> tuple[tuple[str, ...], NDArray, NDArray]:
    """The coefficients' names, prior means and prior precisions (0: flat)."""
    names = (
        *[f"{k}:{c}" for c in conditions for k in ("A", "B")],
        *[f"C:{pc}" for pc in pairs],
        "hysteresis",
        *basis.names,
        *[f"rotation:{p}" for p in used[1:]],
    )
    prior_mean = np.zeros(len(names))
    prior_prec = np.zeros(len(names))
    for name, (mean, sd) in [
        ("hysteresis", basis.hysteresis),
        *zip(basis.names, basis.priors, strict=True),
    ]:
        prior_mean[names.index(name)] = mean
        prior_prec[names.index(name)] = 1.0 / sd**2
    return names, prior_mean, prior_prec


def design_statics(
    moment: float,
    postures: Sequence[PostureGeometry],
    basis: PassiveBasis,
    *,
    rigid_se: float,
    sweeps: int = 2,
    rest_trials: int = 0,
    sweep: tuple[float, float] = (0.0, math.pi / 2),
    sweep_seconds: float = 90.0,
    rest_seconds: float = 5.0,
    phase: float = 0.0,
    condition: str = "living",
) -> LivingStatics:
    """The joint fit a design *would* give, before it is measured (for the planner).

    The fit is linear-Gaussian in its coefficients, so its covariance does not depend on the
    data's values: it is computed here from the design alone — ``sweeps`` quasi-static sweeps
    per posture over ``sweep`` (rad, alternating up and down), ``rest_trials`` quiet holds per
    posture spread over the sweep, at the noise that gives one rigid sweep's ``M_g`` the SE
    ``rigid_se`` (N m; ``NoiseLevels.gravity_se``), for a condition of gravity moment
    ``moment`` (N m) and ``phase`` (rad). The rotations enter at their priors' SDs.

    Returns
    -------
    LivingStatics
        At the nominal values; its :meth:`~LivingStatics.gravity_fit`,
        :meth:`~LivingStatics.pinned_by` and :meth:`~LivingStatics.prior_leverage` are the
        design's predictions.
    """
    blocks = 400
    theta = np.linspace(sweep[0], sweep[1], blocks)
    # the noise: a rigid sweep's M_g variance over the same blocks fixes the per-block variance
    rigid = np.column_stack([np.sin(theta + phase), np.cos(theta + phase), np.ones(blocks)])
    g_m = np.array([1.0, 0.0, 0.0])  # d M_g along the phase direction
    per_block = rigid_se**2 / float(g_m @ np.linalg.inv(rigid.T @ rigid) @ g_m)
    per_second = per_block * sweep_seconds / blocks  # variance x seconds: a mean over T has /T
    order = [p.name for p in postures]
    pairs = [f"{condition}:{p}" for p in order]
    names, _, prior_prec = _layout((condition,), pairs, order, basis)
    coef = np.zeros(len(names))
    coef[names.index(f"A:{condition}")] = moment * math.cos(phase)
    coef[names.index(f"B:{condition}")] = moment * math.sin(phase)
    precision = np.diag(prior_prec)
    ref = postures[0]
    for posture in postures[1:]:
        i = names.index(f"rotation:{posture.name}")
        sd = math.hypot(ref.rotation_sd, posture.rotation_sd)
        precision[i, i] = 1.0 / sd**2 if math.isfinite(sd) else 0.0
    holds = theta[np.linspace(0, blocks - 1, rest_trials + 2).astype(int)[1:-1]]
    for posture in postures:
        for k in range(sweeps):
            direction = 1 if k % 2 == 0 else -1
            cols = _columns(names, theta, condition, posture, direction, basis, coef)
            x = _matrix(cols, theta)
            precision += (x.T @ x) / per_block
        if rest_trials:
            cols = _columns(names, holds, condition, posture, 0, basis, coef)
            x = _matrix(cols, holds)
            precision += (x.T @ x) / (per_second / rest_seconds)
    return LivingStatics(
        names=names,
        coefficients=coef,
        covariance=np.linalg.inv(precision),
        precision=precision,
        postures={p.name: p for p in postures},
        basis=basis,
        conditions=(condition,),
        angle_range=(float(sweep[0]), float(sweep[1])),
    )


def fit_statics(
    records: Sequence[StaticRecord],
    postures: Mapping[str, PostureGeometry],
    basis: PassiveBasis,
    *,
    where: str = "study",
) -> LivingStatics:
    """Fit gravity and the passive curve of the living conditions together.

    Every quasi-static and rest trial at once; the method is in the module docstring.

    Parameters
    ----------
    records : sequence of StaticRecord
        The trials (angle rad, torque N m, signed), each naming its condition and posture.
    postures : mapping of str to PostureGeometry
        Every posture, the first the reference of the rotations (``rotation_sd`` of the
        others is taken relative to it: ``hypot`` of the two).
    basis : PassiveBasis
        The passive columns and priors.
    where : str
        Named in errors (the manifest).

    Raises
    ------
    InputError
        If a living condition has no trial in a posture with gravity (all horizontal), or
        the trials leave ``M_g`` undetermined.
    """
    prepared = [_prepare(r) for r in records]
    conditions = tuple(dict.fromkeys(r.condition for r in records))
    pairs = tuple(dict.fromkeys(f"{r.condition}:{r.posture}" for r in records))
    order = list(postures)
    used = [p for p in order if any(r.posture == p for r in records)]
    reference = used[0]
    names, prior_mean, prior_prec = _layout(conditions, pairs, used, basis)
    for c in conditions:
        if not any(
            r.condition == c
            and r.kind == "quasi-static"
            and abs(math.cos(postures[r.posture].tilt)) > 1e-6
            for r in records
        ):
            raise InputError(
                f"{where}: condition {c}: no quasi-static trial in a posture with gravity "
                "(axis_tilt < 90 deg); M_g cannot be measured"
            )
    n_coef = len(names)
    ref = postures[reference]
    geometry = {p: postures[p] for p in order}
    shift = dict.fromkeys(used[1:], 0.0)  # the rotation fitted, beyond its nominal value
    rot_sd = {p: math.hypot(ref.rotation_sd, postures[p].rotation_sd) for p in used[1:]}
    coef = np.zeros(n_coef)
    coef[names.index(f"A:{conditions[0]}")] = 1.0  # only for the first rotation column
    weights = np.ones(len(prepared))
    stacked_y = [p.y for p in prepared]
    for iteration in range(_ITERATIONS):
        gram = np.diag(prior_prec.copy())
        rhs = prior_prec * prior_mean
        for p in used[1:]:
            i = names.index(f"rotation:{p}")
            if iteration == 0:
                gram[i, i], rhs[i] = 1.0, 0.0  # the first pass: no A, B to rotate yet
            elif math.isfinite(rot_sd[p]):
                gram[i, i] = 1.0 / rot_sd[p] ** 2
                rhs[i] = -shift[p] / rot_sd[p] ** 2  # the prior is on the whole shift
            else:
                gram[i, i], rhs[i] = 0.0, 0.0
        designs = []
        for k, prep in enumerate(prepared):
            cols = _columns(
                names,
                prep.theta,
                prep.record.condition,
                geometry[prep.record.posture],
                prep.direction,
                basis,
                coef,
            )
            x = _matrix(cols, prep.theta)
            designs.append(x)
            gram += weights[k] * (x.T @ x)
            rhs += weights[k] * (x.T @ stacked_y[k])
        try:
            new = np.linalg.solve(gram, rhs)
        except np.linalg.LinAlgError:
            raise InputError(
                f"{where}: the living conditions' quasi-static trials do not determine M_g "
                "(a singular fit); sweep a wider range or add a posture"
            ) from None
        new_weights = np.empty(len(prepared))
        rms = {}
        for k, prep in enumerate(prepared):
            resid = stacked_y[k] - designs[k] @ new
            var = float(resid @ resid) / max(resid.size - 1, 1)
            tau = integrated_autocorrelation_time(resid) if resid.size > 8 else 1.0
            new_weights[k] = 1.0 / max(var * tau, 1e-300)
            rms[prep.record.source] = float(np.sqrt(np.mean(resid**2)))
        step = 0.0
        for p in used[1:]:
            i = names.index(f"rotation:{p}")
            step = max(step, abs(float(new[i])))
            shift[p] += float(new[i])
            geometry[p] = PostureGeometry(
                p, postures[p].rotation + shift[p], postures[p].rotation_sd, postures[p].tilt
            )
            new[i] = 0.0
        converged = step < _TOLERANCE and np.allclose(weights, new_weights, rtol=1e-6)
        coef, weights = new, new_weights
        if converged and iteration >= 2:
            break
    # the final precision at the converged point (rotation columns at the fitted angles)
    precision = gram
    covariance = np.linalg.inv(precision)
    noise = {
        c: _condition_noise(
            [p for p in prepared if p.record.condition == c], names, geometry, basis, coef
        )
        for c in conditions
    }
    angles = np.concatenate([p.theta for p in prepared if p.record.kind != "rest"])
    return LivingStatics(
        names=names,
        coefficients=coef,
        covariance=covariance,
        precision=precision,
        postures=geometry,
        basis=basis,
        conditions=conditions,
        residual_rms=rms,
        angle_range=(float(angles.min()), float(angles.max())),
        converged=bool(converged),
        noise={c: v for c, v in noise.items() if v is not None},
    )


def _condition_noise(
    prepared: Sequence[_Prepared],
    names: tuple[str, ...],
    geometry: Mapping[str, PostureGeometry],
    basis: PassiveBasis,
    coef: NDArray,
) -> TorqueNoise | None:
    """A condition's torque noise from the residuals of its sweeps under the joint fit.

    Each sweep's (:func:`~inertiafit.processing.gravity.sweep_noise`, on its raw samples),
    pooled (:func:`~inertiafit.processing.gravity.pooled_noise`); ``None`` when no sweep
    knows its sampling rate.
    """
    found = []
    for prep in prepared:
        record = prep.record
        if record.kind != "quasi-static" or not record.rate > 0:
            continue
        theta = np.asarray(record.angle, float)
        part = moving_part(theta)
        theta, y = theta[part], np.asarray(record.torque, float)[part]
        cols = _columns(
            names, theta, record.condition, geometry[record.posture], prep.direction, basis, coef
        )
        x = _matrix(cols, theta)
        model = x @ coef
        x = x[:, np.any(x != 0.0, axis=0)]  # what the fit could absorb from this sweep
        found.append(sweep_noise(y, model, x, record.rate))
    return pooled_noise(found)


#: Units of the joint's parameters in :func:`living_tables`.
_UNITS = {
    "stiffness": "N m/rad",
    "stop_low_narrow": "N m",
    "stop_low_wide": "N m",
    "stop_high_narrow": "N m",
    "stop_high_wide": "N m",
    "curve_scale": "1",
    "hysteresis": "N m",
    "damping": "N m s/rad",
    "rotation": "deg",
    "gravity_moment": "N m",
}


#: Columns of ``passive_parameters.csv`` and the first of ``passive.csv``, in order.
PARAMETER_COLUMNS = (
    "body",
    "parameter",
    "unit",
    "mean",
    "sd",
    "lower",
    "upper",
    "prior_mean",
    "prior_sd",
    "pinned_by",
    "prior_leverage",
)
CURVE_COLUMNS = (
    "joint_angle",
    "device_angle",
    "median",
    "lower",
    "upper",
    "prior_lower",
    "prior_upper",
)


def living_tables_from_dict(stored: Mapping[str, Mapping[str, list]]) -> dict[str, pd.DataFrame]:
    """:func:`living_tables` back from their JSON form (``posterior.nc``'s ``inputs``).

    JSON keeps no column order: the tables get theirs back (the curve's ``gravity:``
    columns after the others).
    """
    out = {}
    for name, columns in stored.items():
        frame = pd.DataFrame(dict(columns))
        first = PARAMETER_COLUMNS if name == "passive_parameters" else CURVE_COLUMNS
        order = [c for c in first if c in frame] + sorted(c for c in frame if c not in first)
        out[name] = frame[order]
    return out


def living_tables(
    statics: LivingStatics, damping: tuple[float, float] | None, *, body: str = ""
) -> dict[str, pd.DataFrame]:
    """The living joint's outputs: ``passive_parameters`` and ``passive_curve``.

    ``passive_parameters``: one row per parameter of the joint — the passive coefficients,
    the hysteresis, the viscous damping ``b`` (the fast trials'), each posture's fitted
    rotation, and each living condition's ``M_g`` with what decided it (``pinned_by``) and
    how much its SE grows when the passive prior's SDs double
    (:meth:`LivingStatics.prior_leverage`) — columns ``parameter``, ``unit``, ``mean``,
    ``sd``, ``lower``, ``upper`` (95 %), ``prior_mean``, ``prior_sd``, ``pinned_by``,
    ``prior_leverage``, and ``body``, the living body. ``passive_curve``:
    :meth:`LivingStatics.passive_curve`.
    """
    rows = []

    def add(name, unit, mean, sd, prior=(math.nan, math.nan), pinned="", leverage=math.nan):
        rows.append(
            {
                "parameter": name,
                "unit": unit,
                "mean": mean,
                "sd": sd,
                "lower": mean - _Z95 * sd,
                "upper": mean + _Z95 * sd,
                "prior_mean": prior[0],
                "prior_sd": prior[1],
                "pinned_by": pinned,
                "prior_leverage": leverage,
                "body": body,
            }
        )

    for name, prior in zip(statics.basis.names, statics.basis.priors, strict=True):
        add(name, _UNITS[name], *statics.value(name), prior)
    add("hysteresis", "N m", *statics.value("hysteresis"), statics.basis.hysteresis)
    if damping is not None:
        add("damping", "N m s/rad", damping[0], damping[1], statics.basis.damping, "data")
    for name, posture in statics.postures.items():
        key = f"rotation:{name}"
        sd = statics.value(key)[1] if key in statics.names else 0.0
        add(key, "deg", math.degrees(posture.rotation), math.degrees(sd))
    for cond in statics.conditions:
        fit = statics.gravity_fit(cond)
        add(
            f"gravity_moment:{cond}",
            "N m",
            fit.gravity_moment,
            fit.gravity_moment_se,
            pinned=statics.pinned_by(cond),
            leverage=statics.prior_leverage(cond),
        )
    return {
        "passive_parameters": pd.DataFrame(rows, columns=list(PARAMETER_COLUMNS)),
        "passive_curve": statics.passive_curve(),
    }
