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
``s`` of the literature curve, the smooth part's coefficients and the hysteresis' change
over the range (:class:`SmoothPassive`), each rest hold's own offset within the hysteresis
band, and a rotation correction ``delta r_p`` per posture beside the first``)``. ``A``, ``B``
and ``C`` have flat priors; every other coefficient has the Gaussian prior of ``[passive]``
(the joint's prior file, :class:`PassiveBasis`) or of the smooth part, and each posture's
rotation the Gaussian of its ``gravity_rotation_sd`` relative to the first posture's
(``"free"``: flat; a rotation a rigid sweep measured: its SD). The passive and hysteresis
coefficients are nuisance parameters and are **integrated out analytically**: with a
Gaussian prior and a model linear in them, the posterior of ``(A, B)`` given the data is, at
each point of the smooth part's hyperprior grid, Gaussian with the covariance of the
regression; the grid's points are weighted by their evidence and the mixture's mean and
covariance kept. That is exact up to two approximations named here — the rotation enters through its
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

import dataclasses
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from inertiafit.errors import InputError
from inertiafit.io.manifest import PassivePrior, Posture
from inertiafit.passive import literature_curve
from inertiafit.processing.gravity import (
    GravityFit,
    TorqueNoise,
    moving_part,
    pooled_noise,
    steady_angle,
    sweep_noise,
)
from inertiafit.stats import integrated_autocorrelation_time, inverse_variance_mean, shared_error

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
    "SmoothPassive",
    "StaticCurve",
    "StaticRecord",
    "TrialCheck",
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
#: The smooth part of the passive curve (:class:`SmoothPassive`): its amplitude's grid (N m)
#: and its length-scale's (deg), each point equally likely before the data (log-uniform
#: hyperpriors: a hundredth of a N m, nothing the data could see, to 10 N m, more than a
#: relaxed elbow's whole passive moment and a fifth of the knee's at full extension; a stop's
#: e-folding width to beyond the whole range).
SMOOTH_AMPLITUDES = (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
SMOOTH_LENGTHS_DEG = (8.0, 14.0, 25.0, 45.0, 80.0)
#: The basis' domain is this many times the swept half range (the Hilbert-space
#: approximation's boundary factor: the curve is free over the sweeps and a margin beyond).
SMOOTH_BOUNDARY = 2.0
#: The direction-dependent moment's change over the range (``h(theta_j) sgn(omega)``): a
#: Gaussian process of the same basis, its amplitude the hysteresis prior's SD and this
#: length-scale (deg), fixed (a relaxed ankle's sweeps differ by 2.0-3.1 N m over 30 deg:
#: slow changes, which sweeps both ways measure).
HYSTERESIS_LENGTH_DEG = 20.0
#: Basis functions at least and at most (Riutort-Mayol et al. 2023's rule in between).
SMOOTH_FUNCTIONS = (8, 40)
#: Posterior weight on the grid's largest amplitude beyond which a study is told the passive
#: curve needed all the freedom the prior allows.
SMOOTH_EDGE_WEIGHT = 0.5
#: The fit's check of a trial (:class:`TrialCheck`): a sweep's residual smoothed over its
#: angles by Legendre polynomials of degrees 2 to this (0 and 1, a trial's own offset and a
#: drift linear in time, are not the static model's to explain)...
CHECK_DEGREE = 8
#: ... is structure the model left when its RMS exceeds this (N m) ...
CHECK_TOLERANCE = 0.05
#: ... and this many times what the trial's white noise leaves in the same projection; a
#: rest hold's mean residual likewise against its standard error.
CHECK_RATIO = 5.0
#: The smallest prior variance of a smooth coefficient (its spectral density underflows at
#: long length-scales): far below anything the data could move.
_VARIANCE_FLOOR = 1e-16
#: The smallest noise variance of a trial's block mean (N^2 m^2): a thousandth of a N m,
#: ten times below a dynamometer's torque resolution, so exact (simulated) sweeps keep the
#: regression well conditioned beside the smooth part's widest priors.
_NOISE_FLOOR = 1e-6
#: Gauss-Newton iterations of the rotations and the noise weights, at most.
_ITERATIONS = 30
#: Convergence of the rotations (rad) and of the weights (relative).
_TOLERANCE = 1e-10


@dataclass(frozen=True)
class PostureGeometry:
    """A posture's gravity: rotation ``r`` (rad), its prior SD (rad; ``inf`` free), tilt (rad).

    ``measured_sd`` (rad): the rotation relative to the reference posture was measured (by
    a rigid condition swept in both) to this SD, which then replaces the declared SDs.
    """

    name: str
    rotation: float = 0.0
    rotation_sd: float = math.radians(2.0)
    tilt: float = 0.0
    measured_sd: float | None = None

    def relative_sd(self, reference: PostureGeometry) -> float:
        """The prior SD (rad) of this posture's rotation relative to ``reference``."""
        if self.measured_sd is not None:
            return self.measured_sd
        return math.hypot(reference.rotation_sd, self.rotation_sd)


@dataclass(frozen=True)
class PassiveBasis:
    """The passive curve's columns and their Gaussian priors (``(mean, sd)`` each).

    Angles in rad: ``zero`` is the joint angle at the device's 0, ``range_low`` and
    ``range_high`` the joint angles of the end stops, ``width`` their e-folding width.
    ``damping`` is the viscous damping's prior, shown beside the fast trials' estimate (which
    the data decide: the two windows of every fast trial). ``smooth``: the curve has a
    smooth part shaped by the data besides these columns (:class:`SmoothPassive`; the
    manifest's ``[passive] curve = "smooth"``, the default), or these columns alone
    (``"fixed"``, the model before issue 32, kept to compare with).
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
    smooth: bool = True

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
class SmoothPassive:
    """The passive curve's smooth part: a Gaussian process in the joint angle, as a basis.

    ``f(theta_j) = sum_m beta_m phi_m(theta_j)`` with ``phi_m`` the Laplacian's
    eigenfunctions on ``[centre - L, centre + L]`` (``L`` = :data:`SMOOTH_BOUNDARY` times the
    swept half range), ``sqrt(1/L) sin(m pi (theta_j - centre + L) / (2 L))``, and
    ``beta_m ~ N(0, S(m pi / (2 L)))``, ``S`` the spectral density of a squared-exponential
    kernel of amplitude ``a`` and length-scale ``l``: ``a^2 sqrt(2 pi) l exp(-(l w)^2 / 2)``
    (the Hilbert-space approximation of Solin & Sarkka 2020, Stat Comput 30:419; the number
    of functions by Riutort-Mayol et al. 2023, Stat Comput 33:17). Linear in ``beta``: the
    fit stays a Gaussian regression for every ``(a, l)``, and the grid :attr:`grid` is
    integrated over by the evidence of each point (:func:`fit_statics`).

    ``centre`` and ``half_range`` are joint angles (rad); ``lengths`` in rad, ``amplitudes``
    in N m. The hysteresis' change over the range, ``h(theta_j) = h + sum_m eta_m phi_m``,
    takes the first :attr:`hysteresis_functions` of the same functions with fixed
    hyperparameters (:meth:`hysteresis_variances`).
    """

    centre: float
    half_range: float
    functions: int
    amplitudes: tuple[float, ...] = SMOOTH_AMPLITUDES
    lengths: tuple[float, ...] = tuple(math.radians(v) for v in SMOOTH_LENGTHS_DEG)

    @classmethod
    def over(cls, low: float, high: float) -> SmoothPassive:
        """The smooth part over joint angles ``low`` to ``high`` (rad), the swept range."""
        half = max(0.5 * (high - low), math.radians(1.0))
        need = math.ceil(1.75 * SMOOTH_BOUNDARY * half / math.radians(min(SMOOTH_LENGTHS_DEG)))
        lo, hi = SMOOTH_FUNCTIONS
        return cls(0.5 * (low + high), half, int(min(max(need, lo), hi)))

    @property
    def half_width(self) -> float:
        """``L`` (rad), the basis' half domain."""
        return SMOOTH_BOUNDARY * self.half_range

    @property
    def names(self) -> tuple[str, ...]:
        """The coefficients ``smooth:1`` ... ``smooth:M``."""
        return tuple(f"smooth:{m}" for m in range(1, self.functions + 1))

    @property
    def grid(self) -> list[tuple[float, float]]:
        """Every ``(amplitude, length)`` of the hyperprior, equally likely a priori."""
        return [(a, ell) for a in self.amplitudes for ell in self.lengths]

    @property
    def hysteresis_functions(self) -> int:
        """How many functions the hysteresis' change takes (for its length-scale)."""
        need = math.ceil(
            1.75 * SMOOTH_BOUNDARY * self.half_range / math.radians(HYSTERESIS_LENGTH_DEG)
        )
        return int(min(max(need, 2), self.functions))

    @property
    def hysteresis_names(self) -> tuple[str, ...]:
        """The coefficients ``hysteresis_shape:1`` ... of the hysteresis' change."""
        return tuple(f"hysteresis_shape:{m}" for m in range(1, self.hysteresis_functions + 1))

    def hysteresis_design(self, theta_j: NDArray) -> NDArray:
        """``[1, phi_1, ..., phi_K]`` at joint angles ``theta_j``: ``h(theta_j)``'s columns.

        In the order of ``("hysteresis", *hysteresis_names)``; a matrix, one row per angle.
        """
        theta_j = np.atleast_1d(np.asarray(theta_j, dtype=np.float64))
        shapes = self.columns(theta_j)[: self.hysteresis_functions]
        return np.column_stack([np.ones_like(theta_j), *shapes])

    def hysteresis_variances(self, sd: float) -> NDArray:
        """Prior variances of the hysteresis' change: amplitude ``sd`` (N m)."""
        var = self.variances(sd, math.radians(HYSTERESIS_LENGTH_DEG))
        return var[: self.hysteresis_functions]

    def columns(self, theta_j: NDArray) -> list[NDArray]:
        """``phi_m`` at joint angles ``theta_j`` (rad); 0 beyond the domain."""
        ell = self.half_width
        t = np.clip(np.asarray(theta_j, dtype=np.float64) - self.centre + ell, 0.0, 2 * ell)
        scale = 1.0 / math.sqrt(ell)
        return [scale * np.sin(m * math.pi * t / (2 * ell)) for m in range(1, self.functions + 1)]

    def variances(self, amplitude: float, length: float) -> NDArray:
        """The prior variances of ``beta`` at one grid point."""
        w = np.arange(1, self.functions + 1) * math.pi / (2 * self.half_width)
        return amplitude**2 * math.sqrt(2 * math.pi) * length * np.exp(-0.5 * (length * w) ** 2)

    def prior_variance(self) -> NDArray:
        """The prior variances of ``beta`` over the whole grid (the hyperprior's mixture)."""
        return np.mean([self.variances(a, ell) for a, ell in self.grid], axis=0)


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


def _moving(theta: NDArray) -> slice:
    """A sweep's moving part, found on its angle's running median.

    :func:`~inertiafit.processing.gravity.moving_part` on the raw angle starts at the first
    sample whose noise passes its threshold: a real angle channel's noise (a fifth of a
    degree, and a filter's glitch at the first sample) kept the holds before and after a
    sweep in it, and counted them as moving.
    """
    return moving_part(steady_angle(theta))


def _prepare(record: StaticRecord) -> _Prepared:
    theta, y = np.asarray(record.angle, float), np.asarray(record.torque, float)
    direction = 0
    if record.kind != "rest":
        part = _moving(theta)
        theta, y = theta[part], y[part]
        direction = 1 if theta[-1] >= theta[0] else -1
    size = max(1, math.ceil(theta.size / MAX_BLOCKS))
    return _Prepared(record, _blocks(theta, size), _blocks(y, size), direction)


@dataclass(frozen=True)
class TrialCheck:
    """A quasi-static or rest trial against the fitted static model (a predictive check).

    ``structure`` (N m): the RMS of what the model left that varies smoothly with the angle
    (a sweep: the residual's Legendre components of degrees 2 to :data:`CHECK_DEGREE`; a
    rest hold: its mean residual); ``noise`` (N m): what the trial's own noise leaves in the
    same statistic (white noise from the residual's sample-to-sample differences; a hold's
    SE with its autocorrelation time). ``flagged`` when ``structure`` exceeds both
    :data:`CHECK_TOLERANCE` and :data:`CHECK_RATIO` times ``noise``.
    """

    source: str
    kind: str
    structure: float
    noise: float

    @property
    def flagged(self) -> bool:
        """Whether the model leaves structure in this trial beyond its noise."""
        return self.structure > max(CHECK_TOLERANCE, CHECK_RATIO * self.noise)

    @property
    def flag(self) -> str:
        """The trial's flag (``trials.csv``), empty when it passes."""
        if not self.flagged:
            return ""
        what = "its mean" if self.kind == "rest" else "a smooth residual over its angles"
        return (
            f"static model misfit: {what} of {self.structure:.3f} N m (noise "
            f"{self.noise:.3f} N m) left by the fit of gravity and the passive curve"
        )


def _check(
    prep: _Prepared, resid: NDArray, *, offset: float = 0.0, band: float = 0.0
) -> TrialCheck:
    """:class:`TrialCheck` of one trial from its block residuals.

    A rest hold's ``offset`` (its own, fitted) is put back, and only what lies beyond the
    hysteresis ``band`` (N m) it may hold at rest counts.
    """
    record = prep.record
    n = resid.size
    if record.kind == "rest" or n <= CHECK_DEGREE + 2:
        tau = integrated_autocorrelation_time(resid) if n > 8 else 1.0
        sd = float(np.std(resid))
        beyond = max(abs(float(np.mean(resid)) + offset) - abs(band), 0.0)
        return TrialCheck(record.source, record.kind, beyond, sd * math.sqrt(tau / n))
    span = prep.theta.max() - prep.theta.min()
    t = 2.0 * (prep.theta - prep.theta.min()) / span - 1.0 if span > 0 else np.zeros(n)
    basis = np.polynomial.legendre.legvander(t, CHECK_DEGREE)
    fitted = basis @ np.linalg.lstsq(basis, resid, rcond=None)[0]
    low = basis[:, :2] @ np.linalg.lstsq(basis[:, :2], resid, rcond=None)[0]
    structure = math.sqrt(float(np.mean((fitted - low) ** 2)))
    white = math.sqrt(float(np.mean(np.diff(resid) ** 2)) / 2.0)
    return TrialCheck(
        record.source, record.kind, structure, white * math.sqrt((CHECK_DEGREE - 1) / n)
    )


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
    smooth : SmoothPassive or None
        The passive curve's smooth part (``None``: the fixed-shape curve of the prior file
        alone, ``[passive] curve = "fixed"``).
    regression : _Regression or None
        The weighted data's normal equations and the prior, to refit under other priors
        (:meth:`prior_leverage`).
    hyper_weights : ndarray or None
        The posterior weight of each point of :attr:`SmoothPassive.grid`.
    checks : dict of str to TrialCheck
        Each quasi-static and rest trial against the fitted model, by file.
    fit_points : pandas.DataFrame or None
        Each trial beside the fitted model (:data:`FIT_POINT_COLUMNS`): a sweep at up to
        :data:`FIT_POINTS` angles (means of consecutive samples), a rest hold as one point
        against the midline, with the band ``+-h`` a joint at rest may hold within.
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
    smooth: SmoothPassive | None = None
    regression: _Regression | None = None
    hyper_weights: NDArray | None = None
    checks: dict[str, TrialCheck] = field(default_factory=dict)
    fit_points: pd.DataFrame | None = None

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
            self.smooth,
        )
        if velocity is not None:
            v = np.asarray(velocity, dtype=np.float64)
            moving = np.where(np.abs(v) > REST_SPEED, np.sign(v), 0.0)
            cols[self.index("hysteresis")] = moving
            if self.smooth is not None:
                shapes = self.smooth.hysteresis_design(self.basis.zero + np.asarray(angle, float))
                for name, col in zip(self.smooth.hysteresis_names, shapes.T[1:], strict=True):
                    cols[self.index(name)] = moving * col
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
        full = float(grad @ self.covariance @ grad)
        if not full > 0:
            return 1.0
        if self.regression is not None:  # refitted: the parametric SDs and the amplitudes x2
            reg = self.regression
            prec = reg.prior_prec.copy()
            prec[idx] /= 4.0
            refit = dataclasses.replace(reg, prior_prec=prec, scale=4.0 * reg.scale)
            _, cov, _ = refit.solve()
            return math.sqrt(float(grad @ cov @ grad) / full)
        sds = np.array([sd for _, sd in self.basis.priors])
        wider = self.precision.copy()
        wider[idx, idx] -= 0.75 / sds**2  # prior precision 1/sd^2 -> 1/(2 sd)^2
        return math.sqrt(float(grad @ np.linalg.solve(wider, grad)) / full)

    def pinned_by(self, condition: str) -> str:
        """What tells a living condition's ``M_g`` apart from the passive curve.

        ``"passive prior"`` with one posture and a smooth passive curve (a smooth curve can
        take any share of a sinusoid over one sweep: no data tell them apart), or when its SE
        would grow by more than :data:`LEVERAGE_PRIOR` with the passive prior's SDs (and the
        smooth part's amplitudes) doubled; else the data that do — ``"a second posture"``,
        ``"the horizontal plane"`` or, with one posture, ``"the shape of the sweep"`` — with
        ``" and the passive prior"`` while the growth exceeds :data:`LEVERAGE_DATA`.
        """
        if not self.gravity_identified:
            return "passive prior"
        leverage = self.prior_leverage(condition)
        if leverage > LEVERAGE_PRIOR:
            return "passive prior"
        with_gravity = self._with_gravity
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
        length = math.hypot(a, b)
        g_m = self.moment_gradient(condition)
        g_p = np.zeros(len(self.names))
        g_p[ia], g_p[ib] = -b / length**2, a / length**2
        cov = self.covariance
        # |(A, B)| overshoots M_g by the scatter across its direction (E|gamma|^2 = M_g^2 +
        # both variances): that part is taken out, the part along it is the Gaussian kept.
        # Negligible where M_g is sharp (sub-permille at two postures), it matters with one
        # posture and a smooth passive curve, where the SE is a good part of M_g.
        across = float(g_p @ cov @ g_p) * length**2
        moment = math.sqrt(max(length**2 - across, 0.0))
        keep = [ia, ib] + ([ic] if ic is not None else [])
        c = float(self.coefficients[ic]) if ic is not None else 0.0
        c_se = math.sqrt(float(cov[ic, ic])) if ic is not None else math.nan
        coefficients = np.array([a, b, c])
        sub = np.full((3, 3), 0.0)
        sub[: len(keep), : len(keep)] = cov[np.ix_(keep, keep)]
        if self.gravity_identified:
            flag = (
                "living body: M_g from the joint fit of gravity and the passive curve over "
                f"{len(self.postures)} posture(s), decided by "
                f"{self.pinned_by(condition)} (its SE grows "
                f"{self.prior_leverage(condition):.2f}x when the passive prior's SDs double)"
            )
        else:
            flag = (
                "living body: M_g not measured — one posture cannot tell gravity from a "
                "passive curve of any smooth shape, so the bodies' priors decide it (the "
                "joint fit's value is the passive prior's guess); a second posture >= 30 deg "
                "away or a horizontal-plane condition measures it"
            )
        flags = (flag,)
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
        coefficient: the mean inertia moves by ``J delta``, ``M_g`` by ``g_m delta``. Where
        the data do not measure ``M_g`` (:attr:`gravity_identified`) no ``M_g`` enters the
        posterior to couple to: the coupling is 0 and the SD the whole error's.
        """
        jac = np.mean(np.atleast_2d(sensitivities), axis=0)
        if not self.gravity_identified:
            return shared_error(jac, self.covariance, np.zeros(len(self.names)))
        return shared_error(jac, self.covariance, self.moment_gradient(condition))

    @property
    def gravity_identified(self) -> bool:
        """Whether the data tell the living conditions' ``M_g`` from the passive curve.

        False with a smooth passive curve and one posture, all with gravity: over one range
        of angles a smooth curve can take any share of the gravity's sinusoid, so such an
        ``M_g`` comes from the passive curve's prior alone and does not enter the posterior
        (the bodies' priors decide it). A second posture or a horizontal-plane one tells them
        apart; the fixed curve (``curve = "fixed"``) does, by its assumed shape.
        """
        if self.smooth is None:
            return True
        return not (len(self._with_gravity) == len(self.postures) == 1)

    @property
    def _with_gravity(self) -> list[PostureGeometry]:
        """The postures whose axis is not vertical: gravity acts in them."""
        return [p for p in self.postures.values() if abs(math.cos(p.tilt)) > 1e-6]

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

    def hyperparameters(self) -> dict[str, tuple[float, float, float, float]]:
        """The smooth part's amplitude (N m) and length-scale (deg) after the data.

        ``{"smooth_amplitude": (mean, sd, lower, upper), "smooth_length": ...}``: the
        posterior over the grid (:attr:`hyper_weights`), lower and upper the grid points
        holding its central 95 %; empty without a smooth part.
        """
        if self.smooth is None or self.hyper_weights is None:
            return {}
        grid = np.array(self.smooth.grid)
        out = {}
        for k, name in enumerate(("smooth_amplitude", "smooth_length")):
            values = grid[:, k] if k == 0 else np.degrees(grid[:, k])
            order = np.argsort(values, kind="stable")
            v, w = values[order], self.hyper_weights[order]
            cdf = np.cumsum(w)
            mean = float(w @ v)
            sd = math.sqrt(max(float(w @ (v - mean) ** 2), 0.0))
            lower = float(v[int(np.searchsorted(cdf, 0.025))])
            upper = float(v[min(int(np.searchsorted(cdf, 0.975)), v.size - 1)])
            out[name] = (mean, sd, lower, upper)
        return out

    def at_amplitude_edge(self) -> float:
        """The posterior weight on the grid's largest amplitude (0 without a smooth part)."""
        if self.smooth is None or self.hyper_weights is None:
            return 0.0
        top = max(self.smooth.amplitudes)
        grid = zip(self.smooth.grid, self.hyper_weights, strict=True)
        return float(sum(w for (a, _), w in grid if a == top))

    def value(self, name: str) -> tuple[float, float]:
        """A coefficient's mean and SD."""
        i = self.index(name)
        return float(self.coefficients[i]), math.sqrt(float(self.covariance[i, i]))

    @property
    def passive_names(self) -> tuple[str, ...]:
        """The coefficients of the elastic curve ``P``: the prior file's, then the smooth part's."""
        return (*self.basis.names, *(self.smooth.names if self.smooth is not None else ()))

    def passive_columns(self, theta: NDArray) -> NDArray:
        """The columns of :attr:`passive_names` at device angles ``theta`` (rad), a matrix."""
        theta = np.asarray(theta, dtype=np.float64)
        cols = self.basis.columns(theta)
        if self.smooth is not None:
            cols = [*cols, *self.smooth.columns(self.basis.zero + theta)]
        return np.column_stack(cols)

    def hold_prediction(
        self, theta: NDArray, condition: str, posture: str
    ) -> tuple[NDArray, NDArray]:
        """What a quiet hold at device angles ``theta`` (rad) would read: ``(mean, sd)``, N m.

        The static curve's midline there (gravity, the passive curve and the condition's
        offset; no hysteresis) with its error, and the band a joint at rest holds any
        moment within: ``+-h(theta_j)``, uniform, so a variance ``h^2 / 3`` more.
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=np.float64))
        mean, sd = self.midline(theta, condition, posture)
        band = _hysteresis_at(self.names, self.coefficients, self.smooth, self.basis.zero + theta)
        return mean, np.sqrt(sd**2 + band**2 / 3.0)

    def midline(self, theta: NDArray, condition: str, posture: str) -> tuple[NDArray, NDArray]:
        """The static curve's midline at device angles ``theta`` (rad) and its SD, N m.

        Gravity, the passive curve and the condition's offset in ``posture``, no hysteresis:
        what the dynamometer reads midway between the sweep directions.
        """
        x = _matrix(self.columns(theta, condition, posture, 0), theta)
        var = np.einsum("ij,jk,ik->i", x, self.covariance, x)
        return x @ self.coefficients, np.sqrt(var)

    def passive_curve(self, step_deg: float = 2.0) -> pd.DataFrame:
        """The passive elastic moment over the swept range, relative to its middle.

        Columns ``joint_angle`` (deg), ``device_angle`` (deg), ``median``, ``lower``,
        ``upper`` (N m, the 95 % band), ``prior_lower``, ``prior_upper`` (the passive
        prior's 95 % band, also relative to the middle), ``hysteresis``,
        ``hysteresis_lower``, ``hysteresis_upper`` (N m: the direction-dependent moment
        ``h(theta_j)`` and its 95 % band), ``gravity:<condition>``: each
        living condition's gravity moment ``M_g sin(theta + phi)`` in the first posture,
        relative to its middle too, to set the two side by side; and ``static:<key>``,
        ``static_lower:<key>``, ``static_upper:<key>`` for each condition and posture
        (``<condition>@<posture>``, or the condition in a study without postures): the static
        moment a quiet hold reads there (the midline between the sweep directions: gravity,
        the passive curve and the offset together), absolute, with its 95 % band. One posture
        measures this sum, whatever it leaves of its split.
        """
        lo, hi = self.angle_range
        theta = np.radians(np.arange(math.degrees(lo), math.degrees(hi) + 1e-9, step_deg))
        mid = 0.5 * (lo + hi)
        cols = self.passive_columns(theta) - self.passive_columns(np.array([mid]))
        idx = [self.index(n) for n in self.passive_names]
        mean = cols @ self.coefficients[idx]
        sd = np.sqrt(np.einsum("ij,jk,ik->i", cols, self.covariance[np.ix_(idx, idx)], cols))
        prior_mean_all = np.array([m for m, _ in self.basis.priors])
        prior_var = np.array([s for _, s in self.basis.priors]) ** 2
        if self.smooth is not None:
            prior_mean_all = np.r_[prior_mean_all, np.zeros(self.smooth.functions)]
            prior_var = np.r_[prior_var, self.smooth.prior_variance()]
        prior_sd = np.sqrt((cols**2) @ prior_var)
        prior_mean = cols @ prior_mean_all
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
        # the direction-dependent moment h(theta_j): the constant and its change over the range
        hidx, hcols = _hysteresis_columns(self.names, self.smooth, self.basis.zero + theta)
        h_mean = hcols @ self.coefficients[hidx]
        h_sd = np.sqrt(np.einsum("ij,jk,ik->i", hcols, self.covariance[np.ix_(hidx, hidx)], hcols))
        table["hysteresis"] = h_mean
        table["hysteresis_lower"] = h_mean - z * h_sd
        table["hysteresis_upper"] = h_mean + z * h_sd
        for cond in self.conditions:  # the gravity moment beside it, on the same footing
            a = self.coefficients[self.index(f"A:{cond}")]
            b = self.coefficients[self.index(f"B:{cond}")]
            curve = a * np.sin(theta) + b * np.cos(theta)
            table[f"gravity:{cond}"] = curve - (a * math.sin(mid) + b * math.cos(mid))
        for cond, posture in self.setups:  # what the dynamometer reads, measured in any design
            static, static_sd = self.midline(theta, cond, posture)
            key = f"{cond}@{posture}" if posture else cond
            table[f"static:{key}"] = static
            table[f"static_lower:{key}"] = static - z * static_sd
            table[f"static_upper:{key}"] = static + z * static_sd
        return table[_curve_order(table.columns)]

    @property
    def setups(self) -> list[tuple[str, str]]:
        """Each ``(condition, posture)`` whose quasi-static or rest trials were fitted."""
        out = []
        for name in self.names:
            kind, _, rest = name.partition(":")
            if kind == "C":
                cond, _, posture = rest.rpartition(":")
                out.append((cond, posture))
        return out


def _columns(
    names: Sequence[str],
    theta: NDArray,
    condition: str,
    posture: PostureGeometry,
    direction: int,
    basis: PassiveBasis,
    coefficients: NDArray,
    smooth: SmoothPassive | None = None,
    hold: str = "",
) -> list[NDArray | float]:
    """The design: one entry per coefficient, an array or a constant.

    ``hold``: a rest trial's own offset coefficient (``hold:<n>``), 1 in its own trial.
    """
    tilt = math.cos(posture.tilt)
    angle = theta + posture.rotation
    passive = dict(zip(basis.names, basis.columns(theta), strict=True))
    if smooth is not None:
        theta_j = basis.zero + theta
        functions = smooth.columns(theta_j)
        passive |= dict(zip(smooth.names, functions, strict=True))
        shapes = functions[: smooth.hysteresis_functions]
        for name, col in zip(smooth.hysteresis_names, shapes, strict=True):
            passive[name] = direction * col
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
        elif kind == "hold":
            out.append(1.0 if name == hold else 0.0)
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
        smooth=prior.curve == "smooth",
    )


def posture_geometry(posture: Posture) -> PostureGeometry:
    """A ``[postures.<name>]`` table's gravity in radians."""
    return PostureGeometry(
        posture.name,
        math.radians(posture.gravity_rotation),
        math.radians(posture.gravity_rotation_sd),
        math.radians(posture.axis_tilt),
    )


#: Points per sweep in :attr:`LivingStatics.fit_points` (and the report's figure of the fit).
FIT_POINTS = 60
#: Columns of :attr:`LivingStatics.fit_points` (``static_fit.csv``): the trial (``source``,
#: ``kind``, ``condition``, ``posture``, ``direction`` +1/-1, 0 for a hold), where
#: (``joint_angle``, ``device_angle``, deg), what it read (``measured``, N m), what the fit
#: says (``fitted``, a hold's midline, and its SD ``fitted_sd``), ``residual`` and the band a
#: hold may sit within (``allowed``, ``|h|``; 0 for a sweep).
FIT_POINT_COLUMNS = (
    "source",
    "kind",
    "condition",
    "posture",
    "direction",
    "joint_angle",
    "device_angle",
    "measured",
    "fitted",
    "fitted_sd",
    "residual",
    "allowed",
)


def _fit_points(
    prepared: Sequence[_Prepared],
    designs: Sequence[NDArray],
    ys: Sequence[NDArray],
    coef: NDArray,
    covariance: NDArray,
    names: Sequence[str],
    holds: Mapping[int, str],
    basis: PassiveBasis,
    smooth: SmoothPassive | None,
) -> pd.DataFrame:
    """:attr:`LivingStatics.fit_points` of the fitted trials."""
    rows = []
    for k, prep in enumerate(prepared):
        x, y, theta = designs[k], ys[k], prep.theta
        size = theta.size if k in holds else max(1, math.ceil(theta.size / FIT_POINTS))
        starts = np.arange(0, theta.size, size)
        counts = np.diff(np.r_[starts, theta.size])[:, None]
        xb = np.add.reduceat(x, starts, axis=0) / counts
        yb, tb = _blocks(y, size), _blocks(theta, size)
        fitted = xb @ coef
        allowed = np.zeros_like(fitted)
        if k in holds:
            fitted -= coef[names.index(holds[k])]
            xb[:, names.index(holds[k])] = 0.0
            allowed = np.abs(_hysteresis_at(names, coef, smooth, basis.zero + tb))
        sd = np.sqrt(np.einsum("ij,jk,ik->i", xb, covariance, xb))
        r = prep.record
        for i in range(tb.size):
            rows.append(
                (
                    r.source,
                    r.kind,
                    r.condition,
                    r.posture,
                    prep.direction,
                    math.degrees(basis.zero + tb[i]),
                    math.degrees(tb[i]),
                    float(yb[i]),
                    float(fitted[i]),
                    float(sd[i]),
                    float(yb[i] - fitted[i]),
                    float(allowed[i]),
                )
            )
    return pd.DataFrame(rows, columns=list(FIT_POINT_COLUMNS))


def _matrix(columns: Sequence[NDArray | float], theta: NDArray) -> NDArray:
    """The design matrix of :func:`_columns`' entries at ``theta`` (constants broadcast)."""
    return np.column_stack([np.broadcast_to(c, theta.shape) for c in columns])


def _layout(
    conditions: Sequence[str],
    pairs: Sequence[str],
    used: Sequence[str],
    basis: PassiveBasis,
    smooth: SmoothPassive | None,
    holds: Sequence[str] = (),
) -> tuple[tuple[str, ...], NDArray, NDArray]:
    """The coefficients' names, prior means and prior precisions (0: flat or per grid point).

    ``holds`` names the rest trials' own offsets (their priors are set by the caller:
    :func:`_hold_sd`).
    """
    names = (
        *[f"{k}:{c}" for c in conditions for k in ("A", "B")],
        *[f"C:{pc}" for pc in pairs],
        "hysteresis",
        *(smooth.hysteresis_names if smooth is not None else ()),
        *basis.names,
        *(smooth.names if smooth is not None else ()),
        *holds,
        *[f"rotation:{p}" for p in used[1:]],
    )
    prior_mean = np.zeros(len(names))
    prior_prec = np.zeros(len(names))
    known = [("hysteresis", basis.hysteresis), *zip(basis.names, basis.priors, strict=True)]
    if smooth is not None:  # the hysteresis' change over the range: as large as it
        variances = smooth.hysteresis_variances(basis.hysteresis[1])
        sds = np.sqrt(np.maximum(variances, _VARIANCE_FLOOR))
        known += [
            (n, (0.0, float(sd))) for n, sd in zip(smooth.hysteresis_names, sds, strict=True)
        ]
    for name, (mean, sd) in known:
        prior_mean[names.index(name)] = mean
        prior_prec[names.index(name)] = 1.0 / sd**2
    return names, prior_mean, prior_prec


def _hysteresis_columns(
    names: Sequence[str], smooth: SmoothPassive | None, theta_j: NDArray
) -> tuple[list[int], NDArray]:
    """``h(theta_j)``'s coefficients (their indices in ``names``) and columns (a matrix)."""
    theta_j = np.atleast_1d(np.asarray(theta_j, dtype=np.float64))
    if smooth is None:
        return [names.index("hysteresis")], np.ones((theta_j.size, 1))
    index = [names.index(n) for n in ("hysteresis", *smooth.hysteresis_names)]
    return index, smooth.hysteresis_design(theta_j)


def _hysteresis_at(
    names: Sequence[str], coef: NDArray, smooth: SmoothPassive | None, theta_j: ArrayLike
) -> NDArray:
    """``h(theta_j)`` (N m) under coefficients ``coef``: the constant and its change."""
    index, columns = _hysteresis_columns(names, smooth, np.asarray(theta_j, dtype=np.float64))
    return columns @ coef[index]


def _hold_sd(hysteresis: float, basis: PassiveBasis) -> float:
    """The prior SD of a rest hold's own offset.

    A joint at rest holds any moment within its hysteresis band ``+-h`` (as a friction at
    rest holds any torque within its band): the hold's offset from the curve's midline is
    uniform there, taken as a normal of the same variance, ``h / sqrt(3)``, with ``h`` the
    fitted hysteresis or, while it is smaller, its prior's SD.
    """
    return max(abs(hysteresis), basis.hysteresis[1]) / math.sqrt(3.0)


@dataclass(frozen=True)
class _Regression:
    """A weighted linear regression with a Gaussian prior, its smooth part a grid mixture.

    ``gram``, ``rhs``, ``yy``: ``X' W X``, ``X' W y``, ``y' W y`` of the data; ``prior_mean``
    and ``prior_prec`` (diagonal; 0 flat) of every coefficient but the smooth ones, whose
    variances are ``scale`` times ``variances[g]`` at grid point ``g``. ``expected``: the
    evidence averaged over the noise (a design: ``y`` is its noise-free model).
    """

    gram: NDArray
    rhs: NDArray
    yy: float
    prior_mean: NDArray
    prior_prec: NDArray
    smooth_index: NDArray
    variances: tuple[NDArray, ...] = ()
    scale: float = 1.0
    expected: bool = False

    def solve(self) -> tuple[NDArray, NDArray, NDArray]:
        """``(mean, covariance, weights)``: the posterior averaged over the grid.

        Each grid point's posterior is Gaussian; its weight is its evidence (the hyperprior
        is uniform over the grid). The mixture's mean and covariance (the law of total
        covariance) are returned, with the weights.

        Raises
        ------
        numpy.linalg.LinAlgError
            If the data leave a flat coefficient undetermined.
        """
        n = self.prior_mean.size
        # every grid point at once: a stack of (n, n) systems, batched by NumPy and SciPy
        count = max(len(self.variances), 1)
        prec = np.tile(self.prior_prec, (count, 1))
        log_prior = np.zeros(count)
        if self.variances:
            v = np.maximum(self.scale * np.array(self.variances), _VARIANCE_FLOOR)
            prec[:, self.smooth_index] = 1.0 / v
            log_prior = -0.5 * np.sum(np.log(v), axis=1)
        rhs = self.rhs + prec * self.prior_mean
        # scaled to a unit diagonal first: the data's and the priors' precisions differ
        # by many orders of magnitude (exact sweeps, the smallest smooth variances)
        diag = np.diag(self.gram) + prec
        if not np.all(diag > 0):
            raise np.linalg.LinAlgError("singular")
        d = 1.0 / np.sqrt(diag)
        outer = d[:, :, None] * d[:, None, :]
        scaled = (self.gram + prec[:, :, None] * np.eye(n)) * outer
        try:
            lower = np.linalg.cholesky(scaled)
        except np.linalg.LinAlgError:
            raise np.linalg.LinAlgError("singular") from None
        covs = outer * np.linalg.inv(scaled)
        # the means by a solve, not the inverse: yy - mean'rhs below cancels to 1e-4 of yy
        means = d * np.linalg.solve(scaled, (d * rhs)[:, :, None])[:, :, 0]
        logdet = 2.0 * np.sum(np.log(np.diagonal(lower, axis1=1, axis2=2)), axis=1)
        logdet -= 2.0 * np.sum(np.log(d), axis=1)
        quad = (
            self.yy
            + np.sum(self.prior_mean * prec * self.prior_mean, axis=1)
            - np.sum(means * rhs, axis=1)
        )
        logs_arr = -0.5 * quad + log_prior - 0.5 * logdet
        if self.expected:
            logs_arr += 0.5 * np.einsum("gij,ij->g", covs, self.gram)
        weights = np.exp(logs_arr - logs_arr.max())
        weights /= weights.sum()
        mean = weights @ means
        dev = means - mean
        cov = np.einsum("g,gij->ij", weights, covs) + (dev.T * weights) @ dev
        return mean, 0.5 * (cov + cov.T), weights


def _smooth_part(basis: PassiveBasis, low: float, high: float) -> SmoothPassive | None:
    """The smooth part over device angles ``low`` to ``high`` (rad); ``None`` for a fixed curve."""
    if not basis.smooth:
        return None
    return SmoothPassive.over(basis.zero + low, basis.zero + high)


def _smooth_prior(
    smooth: SmoothPassive | None, names: Sequence[str]
) -> tuple[NDArray, tuple[NDArray, ...]]:
    """The smooth coefficients' indices and their prior variances at each grid point."""
    if smooth is None:
        return np.zeros(0, dtype=int), ()
    index = np.array([names.index(n) for n in smooth.names])
    return index, tuple(smooth.variances(a, ell) for a, ell in smooth.grid)


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

    The fit is linear-Gaussian in its coefficients, so at each point of the smooth part's
    grid its covariance does not depend on the data's values: it is computed here from the
    design alone — ``sweeps`` quasi-static sweeps per posture over ``sweep`` (rad,
    alternating up and down), ``rest_trials`` quiet holds per posture spread over the sweep,
    at the noise that gives one rigid sweep's ``M_g`` the SE ``rigid_se`` (N m;
    ``NoiseLevels.gravity_se``), for a condition of gravity moment ``moment`` (N m) and
    ``phase`` (rad). The grid points are weighted by their evidence averaged over the noise,
    for a joint whose curve is the passive prior's mean (the smooth part 0): the prediction
    for a joint that follows its prior file; one that does not widens ``M_g`` with one
    posture. The rotations enter at their priors' SDs.

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
    smooth = _smooth_part(basis, sweep[0], sweep[1])
    order = [p.name for p in postures]
    pairs = [f"{condition}:{p}" for p in order]
    held = {(p, i): f"hold:{p}:{i}" for p in order for i in range(rest_trials)}
    names, prior_mean, prior_prec = _layout(
        (condition,), pairs, order, basis, smooth, tuple(held.values())
    )
    for name in held.values():
        prior_prec[names.index(name)] = 1.0 / _hold_sd(basis.hysteresis[0], basis) ** 2
    coef = prior_mean.copy()
    coef[names.index(f"A:{condition}")] = moment * math.cos(phase)
    coef[names.index(f"B:{condition}")] = moment * math.sin(phase)
    ref = postures[0]
    for posture in postures[1:]:
        i = names.index(f"rotation:{posture.name}")
        sd = posture.relative_sd(ref)
        prior_prec[i] = 1.0 / sd**2 if math.isfinite(sd) else 0.0
    holds = theta[np.linspace(0, blocks - 1, rest_trials + 2).astype(int)[1:-1]]
    gram = np.zeros((len(names), len(names)))
    for posture in postures:
        for k in range(sweeps):
            direction = 1 if k % 2 == 0 else -1
            cols = _columns(names, theta, condition, posture, direction, basis, coef, smooth)
            x = _matrix(cols, theta)
            gram += (x.T @ x) / per_block
        for i, angle in enumerate(holds):
            at = np.array([angle])
            name = held[posture.name, i]
            cols = _columns(names, at, condition, posture, 0, basis, coef, smooth, name)
            x = _matrix(cols, at)
            gram += (x.T @ x) / (per_second / rest_seconds)
    index, variances = _smooth_prior(smooth, names)
    # noise-free data at the nominal values: y = X coef, so X'Wy = gram coef
    regression = _Regression(
        gram=gram,
        rhs=gram @ coef,
        yy=float(coef @ gram @ coef),
        prior_mean=prior_mean,
        prior_prec=prior_prec,
        smooth_index=index,
        variances=variances,
        expected=True,
    )
    _, covariance, weights = regression.solve()
    return LivingStatics(
        names=names,
        coefficients=coef,
        covariance=covariance,
        precision=np.linalg.inv(covariance),
        postures={p.name: p for p in postures},
        basis=basis,
        conditions=(condition,),
        angle_range=(float(sweep[0]), float(sweep[1])),
        smooth=smooth,
        regression=regression,
        hyper_weights=weights if smooth is not None else None,
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
        The passive columns and priors; with :attr:`PassiveBasis.smooth`, a smooth part
        (:class:`SmoothPassive`) over the swept joint angles too.
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
    swept = np.concatenate([p.theta for p in prepared if p.record.kind != "rest"])
    smooth = _smooth_part(basis, swept.min(), swept.max())
    holds = {k: f"hold:{k}" for k, p in enumerate(prepared) if p.record.kind == "rest"}
    names, prior_mean, prior_prec = _layout(
        conditions, pairs, used, basis, smooth, tuple(holds.values())
    )
    index, variances = _smooth_prior(smooth, names)
    n_coef = len(names)
    ref = postures[reference]
    geometry = {p: postures[p] for p in order}
    shift = dict.fromkeys(used[1:], 0.0)  # the rotation fitted, beyond its nominal value
    rot_sd = {p: postures[p].relative_sd(ref) for p in used[1:]}
    coef = np.zeros(n_coef)
    coef[names.index(f"A:{conditions[0]}")] = 1.0  # only for the first rotation column
    weights = np.ones(len(prepared))
    stacked_y = [p.y for p in prepared]
    for iteration in range(_ITERATIONS):
        mean0, prec0 = prior_mean.copy(), prior_prec.copy()
        for p in used[1:]:
            i = names.index(f"rotation:{p}")
            if iteration == 0:
                mean0[i], prec0[i] = 0.0, 1.0  # the first pass: no A, B to rotate yet
            elif math.isfinite(rot_sd[p]):
                mean0[i], prec0[i] = -shift[p], 1.0 / rot_sd[p] ** 2  # on the whole shift
            else:
                mean0[i], prec0[i] = 0.0, 0.0
        for k, name in holds.items():  # within the hysteresis band the fit has so far
            band = _hysteresis_at(names, coef, smooth, basis.zero + prepared[k].theta.mean())
            prec0[names.index(name)] = 1.0 / _hold_sd(float(band[0]), basis) ** 2
        gram = np.zeros((n_coef, n_coef))
        rhs = np.zeros(n_coef)
        yy = 0.0
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
                smooth,
                holds.get(k, ""),
            )
            x = _matrix(cols, prep.theta)
            designs.append(x)
            gram += weights[k] * (x.T @ x)
            rhs += weights[k] * (x.T @ stacked_y[k])
            yy += weights[k] * float(stacked_y[k] @ stacked_y[k])
        regression = _Regression(gram, rhs, yy, mean0, prec0, index, variances)
        try:
            new, covariance, hyper = regression.solve()
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
            new_weights[k] = 1.0 / max(var * tau, _NOISE_FLOOR)
            rms[prep.record.source] = float(np.sqrt(np.mean(resid**2)))
        step = 0.0
        for p in used[1:]:
            i = names.index(f"rotation:{p}")
            step = max(step, abs(float(new[i])))
            shift[p] += float(new[i])
            geometry[p] = dataclasses.replace(
                postures[p], rotation=postures[p].rotation + shift[p]
            )
            new[i] = 0.0
        converged = step < _TOLERANCE and np.allclose(weights, new_weights, rtol=1e-6)
        coef, weights = new, new_weights
        if converged and iteration >= 2:
            break
    checks = {
        prep.record.source: _check(
            prep,
            stacked_y[k] - designs[k] @ coef,
            offset=float(coef[names.index(holds[k])]) if k in holds else 0.0,
            band=float(_hysteresis_at(names, coef, smooth, basis.zero + prep.theta.mean())[0]),
        )
        for k, prep in enumerate(prepared)
    }
    points = _fit_points(
        prepared, designs, stacked_y, coef, covariance, names, holds, basis, smooth
    )
    noise = {
        c: _condition_noise(
            [p for p in prepared if p.record.condition == c], names, geometry, basis, coef, smooth
        )
        for c in conditions
    }
    return LivingStatics(
        names=names,
        coefficients=coef,
        covariance=covariance,
        precision=np.linalg.inv(covariance),
        postures=geometry,
        basis=basis,
        conditions=conditions,
        residual_rms=rms,
        angle_range=(float(swept.min()), float(swept.max())),
        converged=bool(converged),
        noise={c: v for c, v in noise.items() if v is not None},
        smooth=smooth,
        regression=regression,
        hyper_weights=hyper if smooth is not None else None,
        fit_points=points,
        checks=checks,
    )


def _condition_noise(
    prepared: Sequence[_Prepared],
    names: tuple[str, ...],
    geometry: Mapping[str, PostureGeometry],
    basis: PassiveBasis,
    coef: NDArray,
    smooth: SmoothPassive | None = None,
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
        part = _moving(theta)
        theta, y = theta[part], np.asarray(record.torque, float)[part]
        cols = _columns(
            names,
            theta,
            record.condition,
            geometry[record.posture],
            prep.direction,
            basis,
            coef,
            smooth,
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
    "smooth_amplitude": "N m",
    "smooth_length": "deg",
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
    "hysteresis",
    "hysteresis_lower",
    "hysteresis_upper",
)


def living_tables_from_dict(stored: Mapping[str, Mapping[str, list]]) -> dict[str, pd.DataFrame]:
    """:func:`living_tables` back from their JSON form (``posterior.nc``'s ``inputs``).

    JSON keeps no column order: the tables get theirs back (the curve's ``gravity:``
    columns after the others).
    """
    return {name: _in_order(name, pd.DataFrame(dict(c))) for name, c in stored.items()}


def _in_order(name: str, frame: pd.DataFrame) -> pd.DataFrame:
    """A stored table with the columns in the order :func:`living_tables` wrote them."""
    if name == "passive_curve":
        return frame[_curve_order(frame.columns)]
    first = {"passive_parameters": PARAMETER_COLUMNS, "static_fit": FIT_POINT_COLUMNS}[name]
    return frame[[c for c in first if c in frame]]


#: The living joint's group in ``posterior.nc`` and its children: the three tables of
#: :func:`living_tables` (each a dimension ``row``, a variable per column) and the joint
#: fit itself (``fit``: :func:`statics_dataset`).
LIVING_GROUP = "living"
_TABLE_GROUPS = {
    "passive_parameters": "parameters",
    "passive_curve": "curve",
    "static_fit": "static_fit",
}


def statics_dataset(statics: LivingStatics) -> xr.Dataset:
    """The joint fit as a Dataset: what :func:`living_tables` summarises, whole.

    Dimensions ``coefficient`` (:attr:`LivingStatics.names`; ``coefficient_`` its copy for
    the covariance), ``trial`` (the quasi-static and rest trials checked) and ``grid`` (the
    smooth part's hyperparameter grid). Variables: ``mean`` and ``covariance`` of the
    coefficients (N m, or N m per unit of their column); each trial's check, ``structure``,
    ``noise`` (N m), ``flagged``, ``kind``; each posture's fitted ``rotation`` (deg; dim
    ``posture``); and with a smooth part, the grid's ``amplitude`` (N m), ``length`` (deg)
    and posterior ``weight``. Attributes: the swept device angles (deg) and whether the fit
    settled and measured the living ``M_g``; the passive columns' geometry in rad (``joint``,
    ``joint_angle_at_zero``, ``stop_range``, ``stop_width``, ``angle_range``).
    """
    names = list(statics.names)
    checks = list(statics.checks.values())
    data: dict[str, Any] = {
        "mean": ("coefficient", statics.coefficients, {"long_name": "coefficient's mean"}),
        "covariance": (("coefficient", "coefficient_"), statics.covariance),
        "structure": ("trial", [c.structure for c in checks], {"units": "N m"}),
        "noise": ("trial", [c.noise for c in checks], {"units": "N m"}),
        "flagged": ("trial", [int(c.flagged) for c in checks]),
        "kind": ("trial", [c.kind for c in checks]),
        "rotation": (
            "posture",
            [math.degrees(p.rotation) for p in statics.postures.values()],
            {"units": "deg"},
        ),
    }
    coords: dict[str, Any] = {
        "coefficient": names,
        "coefficient_": names,
        "trial": [c.source for c in checks],
        "posture": list(statics.postures),
    }
    if statics.smooth is not None and statics.hyper_weights is not None:
        grid = np.array(statics.smooth.grid, dtype=np.float64).reshape(-1, 2)
        data["amplitude"] = ("grid", grid[:, 0], {"units": "N m"})
        data["length"] = ("grid", np.degrees(grid[:, 1]), {"units": "deg"})
        data["weight"] = ("grid", np.asarray(statics.hyper_weights, dtype=np.float64))
    lo, hi = statics.angle_range
    attrs = {
        "angle_range_deg": [math.degrees(lo), math.degrees(hi)],
        "converged": int(statics.converged),
        "gravity_identified": int(statics.gravity_identified),
        "curve": "smooth" if statics.smooth is not None else "fixed",
        # the passive columns' geometry (rad), to evaluate the curve again (report.living_joint)
        "joint": statics.basis.joint,
        "joint_angle_at_zero": statics.basis.zero,
        "stop_range": [statics.basis.range_low, statics.basis.range_high],
        "stop_width": statics.basis.width,
        "angle_range": [lo, hi],
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def living_datatree(tables: Mapping[str, pd.DataFrame], statics: LivingStatics) -> xr.DataTree:
    """The living joint's group of ``posterior.nc``: its tables and its fit.

    ``xarray.open_datatree`` (and ArviZ, which reads the same tree) opens it as
    ``tree["living"]``, with children ``parameters``, ``curve``, ``static_fit`` (a dimension
    ``row``; :func:`living_tables_from_tree` gives the tables back) and ``fit``
    (:func:`statics_dataset`).
    """
    children = {
        group: xr.Dataset.from_dataframe(tables[name].reset_index(drop=True).rename_axis("row"))
        for name, group in _TABLE_GROUPS.items()
        if name in tables
    }
    children["fit"] = statics_dataset(statics)
    return xr.DataTree.from_dict({f"/{k}": v for k, v in children.items()}, name=LIVING_GROUP)


def living_tables_from_tree(tree: xr.DataTree) -> dict[str, pd.DataFrame]:
    """:func:`living_tables` back from a ``posterior.nc`` tree (empty for a rigid study).

    Reads the ``living`` group (:func:`living_datatree`); a file written before it existed
    keeps its tables as JSON in the root attribute ``inputs`` (:func:`living_tables_from_dict`).
    """
    if LIVING_GROUP not in tree.children:
        inputs = json.loads(tree.attrs.get("inputs", "{}") or "{}")
        return living_tables_from_dict(inputs.get("living", {}))
    group = tree[LIVING_GROUP]
    return {
        name: _in_order(name, group[child].to_dataset().to_dataframe().reset_index(drop=True))
        for name, child in _TABLE_GROUPS.items()
        if child in group.children
    }


def _curve_order(columns: Iterable[str]) -> list[str]:
    """``passive.csv``'s column order, the same however its columns were stored.

    :data:`CURVE_COLUMNS`, the ``gravity:`` columns, then each condition and posture's
    ``static:``, ``static_lower:``, ``static_upper:`` (keys sorted).
    """
    columns = list(columns)
    rank = {"gravity": 0, "static": 1, "static_lower": 2, "static_upper": 3}

    def place(column: str) -> tuple:
        prefix, _, key = column.partition(":")
        return (0, "", 0) if prefix == "gravity" else (1, key, rank[prefix])

    extra = sorted((c for c in columns if c not in CURVE_COLUMNS), key=lambda c: (place(c), c))
    return [c for c in CURVE_COLUMNS if c in columns] + extra


def living_tables(
    statics: LivingStatics, damping: tuple[float, float] | None, *, body: str = ""
) -> dict[str, pd.DataFrame]:
    """The living joint's outputs: ``passive_parameters``, ``passive_curve``, ``static_fit``.

    ``passive_parameters``: one row per parameter of the joint — the passive coefficients,
    the hysteresis, the viscous damping ``b`` (the fast trials'; without them its prior,
    ``pinned_by`` saying so), each posture's fitted
    rotation, and each living condition's ``M_g`` with what decided it (``pinned_by``) and
    how much its SE grows when the passive prior's SDs double
    (:meth:`LivingStatics.prior_leverage`) — columns ``parameter``, ``unit``, ``mean``,
    ``sd``, ``lower``, ``upper`` (95 %), ``prior_mean``, ``prior_sd``, ``pinned_by``,
    ``prior_leverage``, and ``body``, the living body. ``passive_curve``:
    :meth:`LivingStatics.passive_curve`. ``static_fit``: :attr:`LivingStatics.fit_points`.
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
    if statics.smooth is not None:
        for name, (mean, sd, lower, upper) in statics.hyperparameters().items():
            add(name, _UNITS[name], mean, sd)
            rows[-1] |= {"lower": lower, "upper": upper}
    if damping is not None:
        add("damping", "N m s/rad", damping[0], damping[1], statics.basis.damping, "data")
    else:  # a slow sweep's b*omega (0.01 N m at 5 deg/s) is within its hysteresis
        add(
            "damping",
            "N m s/rad",
            *statics.basis.damping,
            statics.basis.damping,
            "prior (no fast trials of the living body)",
        )
    measured = {p for _, p in statics.setups}
    for name, posture in statics.postures.items():
        if not name or name not in measured:  # no [postures], or one without living trials
            continue
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
    tables = {
        "passive_parameters": pd.DataFrame(rows, columns=list(PARAMETER_COLUMNS)),
        "passive_curve": statics.passive_curve(),
    }
    if statics.fit_points is not None:
        tables["static_fit"] = statics.fit_points
    return tables
