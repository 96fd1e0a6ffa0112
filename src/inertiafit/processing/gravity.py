"""Gravity model of a condition from its quasi-static trial.

A quasi-static move (1 deg/s) has no inertial torque worth the name, so its torque is the
gravity model ``tau = M_g sin(theta + phi) + c``. Written as ``A sin(theta) + B cos(theta) + C``
it is linear in ``(A, B, C)``; least squares over the move gives ``M_g = sqrt(A^2 + B^2)`` and
``phi = atan2(B, A)``. Fitting both sin and cos over a range replaces the one-angle weighing
that can be off by tens of N m (``docs/processing.md``).

The fit (:func:`gravity_regression`):

- uses the *move*: the samples at rest before and after it (within :data:`REST_ANGLE` of the
  first and last angle) are left out; at rest a friction can hold any torque in its band, so
  a direction-dependent (Coulomb) friction would otherwise tilt the fit;
- allows for a friction that builds up over the first degrees of the move,
  ``D exp(-s / s_f)`` (``s`` the angle travelled): a hysteresis reaches its steady value,
  which ``C`` then holds, only after the shaft has travelled a few degrees, and that build-up
  left out shifts ``M_g`` by about 0.25 N m per N m deg of it on a 0-90 deg sweep. The fit
  averages the models without a build-up and with one over each angle of
  :data:`FRICTION_ANGLES` (steps of ``sqrt(2)``), weighted by their evidence (Bayes factors
  of ``D`` against a Normal prior of SD :data:`FRICTION_PRIOR_SD`; prior probability
  :data:`FRICTION_PRIOR_NONE` of none, the angle uniform): the spread between the models is
  part of the covariance. Without a friction this costs about 6 % on the SE of ``M_g``;
- gives the covariance of ``(A, B, C)`` from a model of the residual noise: white noise plus
  a drift (a stationary first-order autoregression, correlation time ``tau_d``), fitted by
  restricted maximum likelihood (REML) to the residuals summed over :data:`NOISE_BATCHES`
  batches, in the discrete-cosine domain where the drift's covariance is nearly diagonal, on
  the lowest :data:`NOISE_BAND` of the frequencies (where the regressors' variance is decided;
  a drift of several time scales is then followed where it matters). REML accounts for the
  part of the drift the fit absorbs; the covariance is the sandwich
  ``(X'X)^-1 X' Sigma X (X'X)^-1`` with the fitted ``Sigma``, so regressors that change within
  the drift's correlation time are handled;
- widens that covariance for the noise model's own uncertainty: a drift of correlation time
  ``tau_d`` is worth only about ``T / (4 tau_d)`` independent pieces of evidence over a sweep
  of duration ``T``, so the estimated variance ``v`` of each of ``M_g``, ``phi``, ``c`` is
  uncertain; the delta method on the REML information gives ``var(log v)``, and the
  covariance is multiplied by ``1 + var(log v)`` (the largest of the three), since
  ``E[1 / v_hat] = (1 + var(log v_hat)) / v``: then ``error^2 / SE^2`` has mean one.
  ``se_dof`` is ``nu`` with ``trigamma(nu / 2) = var(log v)`` (a ``chi2_nu`` variance);
  below :data:`MIN_SE_DOF` a flag says the SE is itself uncertain.

``docs/processing.md`` shows the method against the spread of 200 simulated trials per
setting (``benchmarks/gravity_se.py``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy import fft, ndimage, optimize, signal, special

from inertiafit.errors import InputError
from inertiafit.processing.filtering import sampling_rate, source_of

__all__ = [
    "FRICTION_ANGLES",
    "FRICTION_FLAG",
    "FRICTION_PRIOR_NONE",
    "FRICTION_PRIOR_SD",
    "MAX_QUASI_STATIC_SPEED",
    "MIN_RANGE",
    "MIN_SAMPLES",
    "MIN_SE_DOF",
    "NOISE_BAND",
    "NOISE_BATCHES",
    "REFUSE_RANGE",
    "REFUSE_SPEED",
    "REST_ANGLE",
    "STEADY_SAMPLES",
    "TRIAL_NOISE_BATCHES",
    "GravityFit",
    "GravityRegression",
    "TorqueNoise",
    "fit_gravity",
    "fit_gravity_arrays",
    "gravity_regression",
    "moving_part",
    "pooled_noise",
    "steady_angle",
    "sweep_noise",
    "white_level",
]

#: Median speed (deg/s) above which a quasi-static trial is flagged as not quasi-static.
MAX_QUASI_STATIC_SPEED = 5.0
#: 95th-percentile speed (deg/s) above which a "quasi-static" trial is refused: it is a fast
#: trial (its torque holds inertial moments and its median may still be low, at rest).
REFUSE_SPEED = 60.0
#: Angle range (deg) below which sin and cos are poorly separated (flag) ...
MIN_RANGE = 30.0
#: ... and below which they cannot be separated at all (error).
REFUSE_RANGE = 2.0
#: Fewest samples of a quasi-static fit.
MIN_SAMPLES = 20
#: Number of batches the residuals are summed over for the noise model's likelihood.
NOISE_BATCHES = 500
#: The noise model is fitted to the lowest frequencies of the batch sums only, this fraction
#: of them (at least 64): the regressors' variance depends on the lowest, and a drift with
#: several time scales is then followed where it matters.
NOISE_BAND = 0.25
#: Samples within this angle (deg) of the first and of the last angle are at rest: left out.
REST_ANGLE = 0.25
#: Range (deg) of the angles over which the friction builds up in the models averaged over
#: (ratio sqrt(2)); the upper end is at most a tenth of the sweep (a slower build-up is not
#: told apart from the gravity curve).
FRICTION_ANGLES = (0.25, 8.0)
#: Prior standard deviation (N m) of a friction's amplitude, and prior probability of none.
FRICTION_PRIOR_SD = 0.5
FRICTION_PRIOR_NONE = 0.8
#: A friction build-up more probable than this is flagged.
FRICTION_FLAG = 0.99
#: Standard errors resting on fewer degrees of freedom than this are flagged.
MIN_SE_DOF = 8.0
#: Batches of the noise model a fast trial's drift is fitted over (:func:`_drift_given_white`).
TRIAL_NOISE_BATCHES = 5000
#: The covariance is widened by at most this factor (for the noise model's uncertainty).
_MAX_WIDEN = 3.0


@dataclass(frozen=True)
class TorqueNoise:
    """A torque channel's noise: white noise plus a drift (a stationary AR(1) process).

    Attributes
    ----------
    white_sd : float
        Standard deviation of the white noise per sample (N m).
    drift_sd : float
        Standard deviation of the drift (N m); 0 for none.
    drift_time : float
        The drift's correlation time (s): its autocorrelation is ``exp(-lag / drift_time)``.
    """

    white_sd: float = 0.0
    drift_sd: float = 0.0
    drift_time: float = 0.0


@dataclass(frozen=True)
class GravityFit:
    """Gravity model of one condition: ``tau = M_g sin(theta + phi) + c``.

    Attributes
    ----------
    gravity_moment : float
        ``M_g`` (N m), the largest gravitational moment.
    gravity_moment_se : float
        Its standard error (N m), ``sqrt(g_m' covariance g_m)``, ``g_m = (A, B, 0) / M_g``.
    gravity_phase : float
        ``phi`` (rad), from the device's angle zero to the gravity vertical.
    gravity_phase_se : float
        Its standard error (rad), from ``covariance`` likewise.
    offset : float
        ``c`` (N m), the constant torque offset (with a friction, its value once the friction
        has built up in the direction of the sweep).
    offset_se : float
        Its standard error (N m).
    residual_rms : float
        Root mean square of the residuals (N m).
    n : int
        Samples in the fit (the move, without the rest before and after it).
    n_effective : float
        What the fit of ``M_g`` is worth in independent samples: ``n`` times its OLS variance
        (as if the residuals were white) over its honest variance; ``n / tau_int`` of the
        residuals when the regressors change slowly against the noise's correlation time.
    angle_range : float
        Range of the angle covered (rad).
    median_speed : float
        Median absolute velocity (rad/s).
    source : str
        The trial's file.
    flags : tuple of str
        Problems worth a look, one line each (a study lists them as ``"file: flag"``).
    coefficients : ndarray[3]
        ``(A, B, C)`` of ``A sin(theta) + B cos(theta) + C``; ``A = M_g cos(phi)``,
        ``B = M_g sin(phi)``, ``C = c``. Default: from ``M_g``, ``phi`` and ``c``.
    covariance : ndarray[3, 3]
        Covariance of the error of ``(A, B, C)``, widened for the uncertainty of the noise
        model so that a Gaussian with it has the error's variance. Default: from the three
        standard errors, as if their errors were independent.
    se_dof : float
        Degrees of freedom of the standard errors (``inf`` when exact): the noise model's
        evidence. The covariance already holds the widening for it (about
        ``1 + 2 / se_dof``); do not put a Student-t on top.
    noise : TorqueNoise or None
        The noise model of the residuals (white plus drift, the drift's time in seconds),
        fitted by REML; the condition's fast trials take their drift from it. ``None`` when
        not fitted (a model given by hand).
    """

    gravity_moment: float
    gravity_moment_se: float
    gravity_phase: float
    gravity_phase_se: float
    offset: float
    offset_se: float
    residual_rms: float
    n: int
    n_effective: float
    angle_range: float
    median_speed: float
    source: str = ""
    flags: tuple[str, ...] = ()
    coefficients: NDArray = field(default_factory=lambda: np.empty(0), compare=False, repr=False)
    covariance: NDArray = field(default_factory=lambda: np.empty(0), compare=False, repr=False)
    se_dof: float = math.inf
    noise: TorqueNoise | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        moment, phase = self.gravity_moment, self.gravity_phase
        cos, sin = math.cos(phase), math.sin(phase)
        if np.size(self.coefficients) == 0:
            object.__setattr__(
                self, "coefficients", np.array([moment * cos, moment * sin, self.offset])
            )
        if np.size(self.covariance) == 0:
            # d(A, B, C) / d(M_g, phi, c), with the three errors independent
            jac = np.array([[cos, -moment * sin, 0.0], [sin, moment * cos, 0.0], [0, 0, 1.0]])
            ses = np.array([self.gravity_moment_se, self.gravity_phase_se, self.offset_se])
            object.__setattr__(self, "covariance", (jac * ses**2) @ jac.T)

    def torque(self, angle: ArrayLike) -> NDArray:
        """Gravity-model torque ``M_g sin(theta + phi) + c`` (N m) at ``angle`` (rad)."""
        theta = np.asarray(angle, dtype=np.float64)
        return self.gravity_moment * np.sin(theta + self.gravity_phase) + self.offset


#: Second differences of white noise have variance 6 sigma^2; the MAD of a Normal is 0.6745 SD.
_SECOND_DIFFERENCE_SD = math.sqrt(6.0) * 0.6744897501960817


def white_level(x: ArrayLike) -> float:
    """Standard deviation of a channel's white noise, from its second differences (robust).

    A smooth signal (the gravity curve, the motion's torque, a drift slower than a few
    samples) has next to no second difference, white noise ``6 sigma^2`` of variance; the
    corners of a fast trial's ramps (a step of the torque, a kink of the velocity) touch a
    handful of samples, which the median absolute deviation ignores.
    """
    d2 = np.diff(np.asarray(x, dtype=np.float64), 2)
    if d2.size < 3:
        return 0.0
    return float(np.median(np.abs(d2 - np.median(d2)))) / _SECOND_DIFFERENCE_SD


# --- the noise model: white noise + AR(1) drift, REML on batch sums --------------------------


def _ar1_batches(length: int, tau: float) -> tuple[float, float, float]:
    """A unit-variance AR(1) of correlation time ``tau`` samples, summed over batches.

    Returns ``(v0, c1, q)``: the variance of a batch sum of ``length`` samples, the covariance
    of neighbouring sums, and the factor per batch by which further covariances decay
    (covariance at ``k >= 1`` batches: ``c1 q^(k-1)``).
    """
    log_rho = -1.0 / tau
    one_minus = -math.expm1(log_rho)
    rho = math.exp(log_rho)
    one_minus_l = -math.expm1(length * log_rho)
    v0 = length * (1 + rho) / one_minus - 2 * rho * one_minus_l / one_minus**2
    c1 = rho * one_minus_l**2 / one_minus**2
    return v0, c1, math.exp(length * log_rho)


def _drift_spectrum(cosw: NDArray, length: int, tau: float) -> NDArray:
    """Spectral density of the batch sums of a unit AR(1) at frequencies ``arccos(cosw)``."""
    v0, c1, q = _ar1_batches(length, tau)
    return v0 + 2 * c1 * (cosw - q) / (1 - 2 * q * cosw + q * q)


class _Reml:
    """REML of ``white + drift`` on batch sums, diagonal in the discrete-cosine basis.

    Parameters are ``log`` of the white variance per sample, of the drift's variance and of
    its correlation time (samples). The DCT-II nearly diagonalises an AR(1) covariance (it is
    its limiting eigenbasis), so the likelihood is a sum over frequencies (a Whittle
    likelihood without the wrap-around of the Fourier one); the regressors (smooth, so in the
    lowest frequencies) are projected out exactly (REML).
    """

    def __init__(self, sums: NDArray, design: NDArray, length: int) -> None:
        batches, self.p = design.shape
        self.batches = min(batches, max(int(NOISE_BAND * batches), 64))
        self.means = design
        self.length = length
        self.st = fft.dct(sums, norm="ortho")[: self.batches]
        self.xt = fft.dct(design, axis=0, norm="ortho")[: self.batches]
        self.cosw = np.cos(np.pi * np.arange(self.batches) / batches)

    def spectrum(self, theta: NDArray, grad: bool = False) -> tuple[NDArray, NDArray | None]:
        white, drift, tau = np.exp(theta)
        shape = _drift_spectrum(self.cosw, self.length, tau)
        lam = white * self.length + drift * shape
        if not grad:
            return lam, None
        h = 1e-4
        d_tau = (
            _drift_spectrum(self.cosw, self.length, tau * math.exp(h))
            - _drift_spectrum(self.cosw, self.length, tau * math.exp(-h))
        ) / (2 * h)
        grads = np.stack(
            [np.full(self.batches, white * self.length), drift * shape, drift * d_tau]
        )
        return lam, grads

    def loglik(self, theta: NDArray, need: bool = False) -> tuple[float, NDArray, NDArray]:
        lam, grads = self.spectrum(theta, grad=need)
        weight = 1.0 / lam
        xw = self.xt * weight[:, None]
        gram = self.xt.T @ xw
        inv = np.linalg.inv(gram)
        r = self.st - self.xt @ (inv @ (xw.T @ self.st))
        ll = -0.5 * (
            float(np.sum(np.log(lam))) + np.linalg.slogdet(gram)[1] + float(r @ (weight * r))
        )
        if not need:
            return ll, np.empty(0), np.empty(0)
        assert grads is not None
        keep = 1.0 - np.einsum("ij,jk,ik->i", self.xt, inv, self.xt) * weight
        rel = grads * weight
        score = 0.5 * rel @ (r * r * weight - keep)
        info = 0.5 * (rel * keep) @ rel.T
        return ll, score, info


def _fit_noise(
    residuals: NDArray, design: NDArray, batches: int
) -> tuple[NDArray, _Reml, NDArray, int, float]:
    """Fit the noise model to the residuals; ``(theta, reml, info, length, used)``.

    ``theta`` is the REML estimate, ``info`` its expected information, ``length`` the batch
    length and ``used`` the fraction of the samples in whole batches.
    """
    n, p = design.shape
    length = max(n // batches, 1)
    batches = n // length
    used = batches * length
    sums = residuals[:used].reshape(batches, length).sum(axis=1)
    means = _design_means(design, length, batches)
    reml = _Reml(sums, means, length)
    lower = np.array([-np.inf, -np.inf, math.log(length / 20.0)])
    upper = np.array([np.inf, np.inf, math.log(10.0 * n)])
    # Start from moments: half the batch-sum variance white, half drift; the correlation time
    # from the batch sums' lag-one correlation.
    var = float(sums @ sums) / max(batches - p, 1)
    if var <= 0:
        var = 1e-30
    r1 = float(sums[1:] @ sums[:-1]) / max(float(sums @ sums), 1e-300)
    tau = -length / math.log(min(max(r1, 0.05), 0.995))
    theta = np.array(
        [
            math.log(0.5 * var / length),
            math.log(0.5 * var / _ar1_batches(length, tau)[0]),
            math.log(tau),
        ]
    )
    theta = np.clip(theta, lower, upper)
    ll, score, info = reml.loglik(theta, need=True)
    # Fisher scoring with step halving. When the drift's correlation time is below a batch,
    # white noise and drift are alike in the batch sums and the likelihood has a flat ridge
    # along which nothing that matters changes: stop when the likelihood stops rising.
    for _ in range(50):
        step = np.clip(np.linalg.solve(info + 1e-9 * np.eye(3), score), -3.0, 3.0)
        t = 1.0
        while True:
            new = np.clip(theta + t * step, lower, upper)
            ll_new = reml.loglik(new)[0]
            if ll_new >= ll or t < 0.1:
                break
            t *= 0.5
        if not ll_new > ll:
            break
        gain = ll_new - ll
        theta = new
        ll, score, info = reml.loglik(theta, need=True)
        if gain < 1e-6:
            break
    # a variance component at its floor leaves the information singular: keep it invertible
    info = info + 1e-9 * np.trace(info) * np.eye(3)
    return theta, reml, info, length, used / n


# --- the regression ---------------------------------------------------------------------------


@dataclass(frozen=True)
class GravityRegression:
    """The least-squares gravity model of one quasi-static trial (:func:`gravity_regression`).

    Attributes
    ----------
    coefficients : ndarray[3]
        ``(A, B, C)`` of ``A sin(theta) + B cos(theta) + C`` (N m).
    covariance : ndarray[3, 3]
        Covariance of their error, widened for the noise model's uncertainty.
    residuals : ndarray
        ``torque - model`` on the samples fitted (N m).
    fitted : slice
        The samples fitted: the move, without the rest before and after it.
    n_effective : float
        ``n`` times the OLS variance of ``M_g`` over its honest variance (at most ``n``).
    se_dof : float
        Degrees of freedom of the standard errors (the noise model's evidence).
    white_sd, drift_sd : float
        The noise model: white noise per sample and the drift's standard deviation (N m).
    drift_time : float
        The drift's correlation time (samples).
    friction : float
        Amplitude (N m) of the friction build-up in the direction of the sweep, averaged over
        the models (``0`` for the model without one; ``C`` holds its steady value).
    friction_angle : float
        Angle (rad) over which it builds up (``1/e`` of it left) in the likeliest model with
        one (``0`` when none was tried).
    friction_se : float
        Standard deviation of ``friction`` over the models.
    friction_probability : float
        Posterior probability of a build-up.
    trial_noise : (float, float, float)
        The noise a fast trial of the condition sees: the sweep's white level
        (:func:`white_level`, N m) and the drift fitted with it held
        (:func:`_drift_given_white`): its standard deviation (N m) and correlation time
        (samples).
    """

    coefficients: NDArray
    covariance: NDArray
    residuals: NDArray
    fitted: slice
    n_effective: float
    se_dof: float
    white_sd: float
    drift_sd: float
    drift_time: float
    friction: float = 0.0
    friction_angle: float = 0.0
    friction_se: float = 0.0
    friction_probability: float = 0.0
    trial_noise: tuple[float, float, float] = (0.0, 0.0, 0.0)


#: Samples of an angle's running median (:func:`steady_angle`): about 50 ms at 1 kHz.
STEADY_SAMPLES = 51


def steady_angle(theta: NDArray) -> NDArray:
    """The angle's running median (:data:`STEADY_SAMPLES`, fewer in a short trial).

    What a trial's angle does, with a noisy channel's sample-to-sample jitter and an odd
    glitch (a filter's first sample) left aside: where a sweep starts and ends, whether a
    hold holds still.
    """
    theta = np.asarray(theta, dtype=np.float64)
    size = min(STEADY_SAMPLES, max(1, (theta.size // 10) | 1))
    return ndimage.median_filter(theta, size=size, mode="mirror")


def moving_part(theta: NDArray) -> slice:
    """The samples of the move, without the rest before and after it.

    From the first sample beyond ``REST_ANGLE`` of the first angle to the last beyond it of
    the last angle; the whole trial when that leaves too few.
    """
    rest = math.radians(REST_ANGLE)
    left = np.abs(theta - theta[0]) > rest
    arrived = np.abs(theta - theta[-1]) > rest
    start = int(np.argmax(left))
    stop = theta.size - int(np.argmax(arrived[::-1]))
    if not (left.any() and arrived.any()) or stop - start < MIN_SAMPLES:
        return slice(0, theta.size)
    return slice(start, stop)


def _travelled(theta: NDArray) -> NDArray:
    """Angle travelled away from the first sample in the sweep's direction (never decreasing)."""
    direction = 1.0 if theta[-1] >= theta[0] else -1.0
    return np.maximum.accumulate(np.maximum(direction * (theta - theta[0]), 0.0))


def _dof_of_log_variance(var_log: float) -> float:
    """Degrees of freedom of a variance estimate whose log has variance ``var_log``.

    For ``chi2_nu / nu`` that variance is ``trigamma(nu / 2)`` (about ``2 / nu``).
    """
    if not math.isfinite(var_log) or var_log >= 1e6:
        return 1e-3
    if var_log <= 1e-8:
        return math.inf
    return float(
        optimize.brentq(lambda nu: float(special.polygamma(1, nu / 2)) - var_log, 1e-3, 1e12)
    )


def _drift_given_white(residuals: NDArray, design: NDArray, white: float) -> tuple[float, float]:
    """The drift a fast trial sees: ``(sd, correlation time in samples)``, white held fixed.

    The sweep's own noise model (:func:`_fit_noise`) looks at frequencies below about 1 Hz,
    where a drift of a few tenths of a second is as flat as white noise and only their sum
    is decided: enough for the sweep's coefficients, not for a fast trial's window of a
    tenth of a second, which sees white noise and a slow drift very differently. So the
    drift is fitted again, by the same REML on batch sums, over :data:`TRIAL_NOISE_BATCHES`
    batches (frequencies up to several Hz at 1 kHz over a 90 s sweep), with the white
    variance held at the sample-to-sample noise's (:func:`white_level`).
    """
    n = residuals.size
    if not white > 0 or n < 4 * 64:
        return 0.0, 0.0
    length = max(n // TRIAL_NOISE_BATCHES, 2)
    batches = n // length
    sums = residuals[: batches * length].reshape(batches, length).sum(axis=1)
    reml = _Reml(sums, _design_means(design, length, batches), length)
    lower = np.array([math.log(1e-12 * white), 0.0])
    upper = np.array([math.log(1e6 * white), math.log(10.0 * n)])
    fixed = math.log(white)

    def negative(x: NDArray) -> float:
        return -reml.loglik(np.array([fixed, *np.clip(x, lower, upper)]))[0]

    # two starts, a small fast drift and a large slow one (on 14 simulated sweeps, default
    # noise, a drift of 0.1 N m over 1 s and none, one start found the same optimum)
    starts = [
        np.array([math.log(k * white), math.log(t * length)]) for k, t in ((1e-3, 1), (0.1, 30))
    ]
    best = min(
        (
            optimize.minimize(
                negative, np.clip(x0, lower, upper), method="Nelder-Mead", options={"xatol": 1e-3}
            )
            for x0 in starts
        ),
        key=lambda r: r.fun,
    )
    drift, tau = np.exp(np.clip(best.x, lower, upper))
    return math.sqrt(float(drift)), float(tau)


#: Singular values of a sweep's design below this share of the largest are collinear columns
#: (:func:`sweep_noise`): found from the Gram matrix, whose eigenvalues are their squares, the
#: round-off leaves exact collinearity near 1e-8 of the largest singular value.
SPAN_TOLERANCE = 1e-7


def sweep_noise(
    torque: ArrayLike, model: ArrayLike, design: ArrayLike, rate: float
) -> TorqueNoise:
    """A sweep's torque noise as a fast trial sees it: white level and drift (seconds).

    ``torque`` is the sweep's (its move), ``model`` the fitted model there and ``design``
    its columns (what the fit absorbed, projected out by the REML): the white level from the
    torque's second differences (:func:`white_level`), the drift by :func:`_drift_given_white`.
    """
    y = np.asarray(torque, dtype=np.float64)
    white = white_level(y)
    # an orthonormal basis of what the design spans (a living sweep's constant and
    # hysteresis columns are one and the same there): the REML projects out the span. From
    # the eigenvectors of the p x p Gram matrix, x V / sqrt(lambda): a fifth of the time of
    # an SVD of the n x p design (90 000 samples of a sweep, 40 columns: 0.04 s, not 0.2),
    # orthonormal to 1e-13; directions below SPAN_TOLERANCE of the largest singular value
    # (exactly collinear columns give 1e-8) are dropped.
    x = np.asarray(design, dtype=np.float64)
    if x.shape[1]:
        lam, vectors = np.linalg.eigh(x.T @ x)
        keep = lam > SPAN_TOLERANCE**2 * lam.max()
        x = x @ (vectors[:, keep] / np.sqrt(lam[keep]))
    sd, tau = _drift_given_white(y - np.asarray(model, dtype=np.float64), x, white**2)
    return TorqueNoise(white, sd, tau / rate)


def pooled_noise(models: Sequence[TorqueNoise | None]) -> TorqueNoise | None:
    """Several sweeps' noise models as one: mean white and drift variances, mean time."""
    known = [m for m in models if m is not None]
    if not known:
        return None
    return TorqueNoise(
        math.sqrt(float(np.mean([m.white_sd**2 for m in known]))),
        math.sqrt(float(np.mean([m.drift_sd**2 for m in known]))),
        float(np.mean([m.drift_time for m in known])),
    )


def _design_means(design: NDArray, length: int, batches: int) -> NDArray:
    """Means of the design's columns over batches of ``length`` samples, ``(batches, p)``."""
    cols = np.asfortranarray(design[: batches * length]).T  # (p, n), rows contiguous
    return cols.reshape(design.shape[1], batches, length).mean(axis=2).T


def _batch_means(column: NDArray, stop: int, length: int, batches: int) -> NDArray:
    """Means over batches of ``length`` samples of a column that is zero from ``stop`` on."""
    out = np.zeros(batches)
    whole = min(stop, batches * length) // length
    if whole:
        out[:whole] = column[: whole * length].reshape(whole, length).mean(axis=1)
    if whole < batches and whole * length < stop:
        out[whole] = column[whole * length : stop].sum() / length
    return out


def _drift_times(means: NDArray, theta: NDArray, length: int) -> NDArray:
    """``Sigma_d @ means`` for the drift part of the noise model (batch sums, by filters)."""
    _, drift, tau = np.exp(theta)
    v0, c1, q = _ar1_batches(length, tau)
    forward = signal.lfilter([0.0, 1.0], [1.0, -q], means, axis=0)
    backward = signal.lfilter([0.0, 1.0], [1.0, -q], means[::-1], axis=0)[::-1]
    return drift * (v0 * means + c1 * (forward + backward))


def _friction_grid(span: float) -> NDArray:
    """The build-up angles (rad) of the friction models averaged over.

    :data:`FRICTION_ANGLES` in steps of ``sqrt(2)``, the upper end at most a tenth of the sweep
    (none if that is below the lower end).
    """
    lower, upper = (math.radians(a) for a in FRICTION_ANGLES)
    upper = min(upper, 0.1 * span)
    if upper < lower:
        return np.empty(0)
    steps = math.floor(2 * math.log2(upper / lower) + 1e-9) + 1
    return lower * np.sqrt(2.0) ** np.arange(steps)


@functools.cache
def _blas_threads() -> object:
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def _one_blas_thread[**P, R](func: Callable[P, R]) -> Callable[P, R]:
    """Run ``func`` with one BLAS thread.

    The regression's products over a whole sweep (90 000 samples) are long enough for
    OpenBLAS to split them over threads, and when the other cores are busy the threads'
    hand-over costs a hundred times the arithmetic (8 ms for one dot product of 90 000
    numbers on 2 loaded cores, 25 us on one thread). One thread also makes the fit's last
    digits independent of how many cores the machine has.
    """

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with _blas_threads().limit(limits=1, user_api="blas"):  # type: ignore[attr-defined]
            return func(*args, **kwargs)

    return wrapper


@_one_blas_thread
def gravity_regression(
    angle: ArrayLike,
    torque: ArrayLike,
    *,
    source: str = "",
    friction: bool = True,
    trial_noise: bool = True,
) -> GravityRegression:
    """Least squares of ``torque = A sin(angle) + B cos(angle) + C`` with an honest covariance.

    The method is in the module docstring: the move without its rests, the models with and
    without a friction build-up ``D exp(-s / s_f)`` averaged (``friction=False``: only the
    one without), and the covariance from a REML-fitted white-plus-drift model of the
    residuals, widened for that model's own uncertainty.

    Parameters
    ----------
    angle : array_like[nsamples]
        Angle (rad).
    torque : array_like[nsamples]
        Torque (N m).
    source : str
        File named in errors.
    friction : bool
        Allow for a friction build-up (on sweeps of at least ten times
        ``FRICTION_ANGLES[0]``).
    trial_noise : bool
        Also fit the noise a fast trial sees (:attr:`GravityRegression.trial_noise`, about half
        the fit's time); ``False`` leaves it ``(0, 0, 0)`` and every other field the same.

    Returns
    -------
    GravityRegression

    Raises
    ------
    InputError
        If there are fewer than :data:`MIN_SAMPLES` samples or the angle range is below
        :data:`REFUSE_RANGE` degrees.
    """
    theta_all = np.asarray(angle, dtype=np.float64)
    y_all = np.asarray(torque, dtype=np.float64)
    where = f"{source}: " if source else ""
    if theta_all.size < MIN_SAMPLES:
        raise InputError(
            f"{where}trial too short: {theta_all.size} samples; a quasi-static fit needs at "
            f"least {MIN_SAMPLES}"
        )
    span = float(np.ptp(theta_all))
    if span < math.radians(REFUSE_RANGE):
        raise InputError(
            f"{where}angle: covers only {math.degrees(span):.3g} deg; a quasi-static trial must "
            f"sweep a range (>= {MIN_RANGE:g} deg) to separate M_g, phi and the offset"
        )
    fitted = moving_part(theta_all)
    theta, y = theta_all[fitted], y_all[fitted]
    n = theta.size
    x3 = np.empty((n, 3), order="F")  # columns contiguous: batch means, slices
    np.sin(theta, out=x3[:, 0])
    np.cos(theta, out=x3[:, 1])
    x3[:, 2] = 1.0
    gram3 = x3.T @ x3
    rhs3 = x3.T @ y
    yy = float(y @ y)
    angles = _friction_grid(span) if friction else np.empty(0)
    direction = 1.0 if theta_all[-1] >= theta_all[0] else -1.0
    travelled = _travelled(theta_all)[fitted] if angles.size else np.empty(0)

    # Model 0: no friction; model k: a build-up over angles[k-1]. Each is least squares.
    models = [(np.linalg.solve(gram3, rhs3), gram3, np.empty(0), 0)]
    for angle_k in angles:
        stop = int(np.searchsorted(travelled, 12.0 * angle_k, side="right"))  # exp(-12)~6e-6
        column = np.exp(-travelled[:stop] / angle_k)
        gram = np.empty((4, 4))
        gram[:3, :3] = gram3
        gram[:3, 3] = gram[3, :3] = x3[:stop].T @ column
        gram[3, 3] = column @ column
        rhs = np.append(rhs3, column @ y[:stop])
        models.append((np.linalg.solve(gram, rhs), gram, column, stop))
    rss = [yy - float(c @ (g @ c)) for c, g, _, _ in models]
    best = int(np.argmin(rss))
    coef_best, _, column_best, stop_best = models[best]
    residuals = y - x3 @ coef_best[:3]
    if best:
        residuals[:stop_best] -= coef_best[3] * column_best
    design = x3
    if best:
        design = np.zeros((n, 4), order="F")
        design[:, :3] = x3
        design[:stop_best, 3] = column_best
    theta_noise, reml, info, length, used = _fit_noise(residuals, design, NOISE_BATCHES)
    white = float(np.exp(theta_noise[0]))
    if trial_noise:
        trial_white = white_level(y)
        trial_drift = _drift_given_white(residuals, design, trial_white**2)
    else:
        trial_white, trial_drift = 0.0, (0.0, 0.0)

    # The covariance of each model's coefficients under the noise model: the drift part from
    # the batch means, the white part exact (a steep build-up column changes within a batch).
    batches = n // length
    means3 = reml.means[:, :3]
    drift3 = _drift_times(means3, theta_noise, length)
    meat3 = means3.T @ drift3 / used + white * gram3
    estimates, covariances, log_weight = [], [], []
    for k, (coef, gram, column, stop) in enumerate(models):
        bread = np.linalg.inv(gram)
        if k == 0:
            meat = meat3
        else:
            means_r = _batch_means(column, stop, length, batches)
            meat = np.empty((4, 4))
            meat[:3, :3] = meat3
            meat[:3, 3] = meat[3, :3] = means_r @ drift3 / used + white * gram[:3, 3]
            meat[3, 3] = means_r @ _drift_times(means_r, theta_noise, length) / used
            meat[3, 3] += white * gram[3, 3]
        cov = bread @ meat @ bread
        estimates.append(coef)
        covariances.append(cov)
        if k == 0:
            log_weight.append(math.log(FRICTION_PRIOR_NONE))
        else:
            # Bayes factor of a friction of prior SD s against none, given this model's D
            v, s2 = cov[3, 3], FRICTION_PRIOR_SD**2
            log_weight.append(
                math.log((1 - FRICTION_PRIOR_NONE) * angles[k - 1] / angles.sum())
                + 0.5 * math.log(v / (v + s2))
                + 0.5 * coef[3] ** 2 / v * s2 / (s2 + v)
            )
    weights = np.exp(np.array(log_weight) - max(log_weight))
    weights /= weights.sum()
    # Model average: the mixture's mean and covariance (the spread between the models' (A, B,
    # C) is part of the error: which build-up angle, if any, is not known).
    stacked = np.array([e[:3] for e in estimates])
    coef3 = weights @ stacked
    spread = stacked - coef3
    cov3 = sum(w * c[:3, :3] for w, c in zip(weights, covariances, strict=True))
    cov3 = cov3 + (spread.T * weights) @ spread
    amplitudes = np.array([0.0] + [-direction * float(e[3]) for e in estimates[1:]])
    amp_vars = np.array([0.0] + [float(c[3, 3]) for c in covariances[1:]])
    friction_value = float(weights @ amplitudes)
    friction_se = math.sqrt(float(weights @ (amp_vars + (amplitudes - friction_value) ** 2)))
    likeliest = int(np.argmax(weights[1:])) + 1 if angles.size else 0

    # Degrees of freedom of the SEs of M_g, phi and c: 2 / var(log variance), by the delta
    # method from the REML information (the design's variance, DCT-diagonal, differentiated).
    lam, grads = reml.spectrum(theta_noise, grad=True)
    assert grads is not None
    a, b = float(coef3[0]), float(coef3[1])
    moment = math.hypot(a, b) or 1.0
    directions = np.array(
        [[a / moment, b / moment, 0.0], [-b / moment**2, a / moment**2, 0.0], [0.0, 0.0, 1.0]]
    )
    ways = directions @ np.linalg.inv(design.T @ design)[:3, :]
    projected = reml.xt @ ways.T  # (batches, 3): each quantity's weights, DCT domain
    variances = np.einsum("jq,j,jq->q", projected, lam, projected)
    d_log = np.einsum("jq,kj,jq->kq", projected, grads, projected) / variances
    var_log = np.einsum("kq,kl,lq->q", d_log, np.linalg.inv(info), d_log)
    var_max = float(np.max(var_log))
    dof = _dof_of_log_variance(var_max)
    # E[1 / v_hat] = (1 + var(log v_hat)) / v to first order: widening by that makes the
    # mean of error^2 / SE^2 one (a Student-t's nu / (nu - 2), to the same order).
    widen = 1.0 + min(var_max, _MAX_WIDEN - 1.0) if math.isfinite(var_max) else _MAX_WIDEN
    _, drift, tau = np.exp(theta_noise)
    cov3 = cov3 * widen
    # What the fit of M_g is worth in independent samples: the OLS variance (white residuals)
    # over the honest one, times n (n / tau_int when the regressors change slowly).
    ols = float(residuals @ residuals) / max(n - design.shape[1], 1) * np.linalg.inv(gram3)
    g_m = directions[0]
    n_effective = n * float(g_m @ ols @ g_m) / max(float(g_m @ cov3 @ g_m), 1e-300)
    return GravityRegression(
        coefficients=np.asarray(coef3, dtype=np.float64),
        covariance=cov3,
        residuals=residuals,
        fitted=fitted,
        n_effective=min(n_effective, float(n)),
        se_dof=dof,
        white_sd=math.sqrt(white),
        drift_sd=math.sqrt(drift),
        drift_time=float(tau),
        friction=friction_value,
        friction_se=friction_se,
        friction_angle=float(angles[likeliest - 1]) if likeliest else 0.0,
        friction_probability=float(1.0 - weights[0]),
        trial_noise=(trial_white, *trial_drift),
    )


def fit_gravity_arrays(
    angle: ArrayLike, torque: ArrayLike, *, source: str = ""
) -> tuple[NDArray, NDArray, NDArray, float]:
    """Least squares of ``torque = a sin(angle) + b cos(angle) + c`` (numpy core).

    :func:`gravity_regression` with its main results (without the fast trials' noise model,
    which they do not include).

    Parameters
    ----------
    angle : array_like[nsamples]
        Angle (rad).
    torque : array_like[nsamples]
        Torque (N m).
    source : str
        File named in errors.

    Returns
    -------
    coef : ndarray[3]
        ``(a, b, c)``.
    cov : ndarray[3, 3]
        Their covariance (:attr:`GravityRegression.covariance`).
    residuals : ndarray
        ``torque - model`` on the samples fitted (the move).
    n_effective : float
        ``n / tau_int``.

    Raises
    ------
    InputError
        If there are fewer than :data:`MIN_SAMPLES` samples or the angle range is below
        :data:`REFUSE_RANGE` degrees.
    """
    fit = gravity_regression(angle, torque, source=source, trial_noise=False)
    return fit.coefficients, fit.covariance, fit.residuals, fit.n_effective


def fit_gravity(
    trial: xr.Dataset,
    *,
    max_speed_deg_s: float = MAX_QUASI_STATIC_SPEED,
    min_range_deg: float = MIN_RANGE,
    torque_sign: int = 1,
) -> GravityFit:
    """Fit the gravity model of a condition to its quasi-static trial.

    The raw torque is fitted (no low-pass filter): the model is smooth and linear in its
    coefficients, so noise averages out without filtering, and filtering would only add
    autocorrelation. The method (:func:`gravity_regression`) is in the module docstring.

    Parameters
    ----------
    trial : xarray.Dataset
        A quasi-static Trial (``angle`` rad, ``velocity`` rad/s, ``torque`` N m).
    max_speed_deg_s : float
        Median ``|velocity|`` (deg/s) above which the trial is flagged as not quasi-static.
    min_range_deg : float
        Angle range (deg) below which the trial is flagged: sin and cos are poorly separated.
    torque_sign : {1, -1}
        Multiplies the torque (a device reporting the opposite sign).

    Returns
    -------
    GravityFit
        ``M_g``, ``phi``, ``c`` with honest standard errors, the coefficients and their
        covariance, and flags (not quasi-static, small angle range, a drift that leaves the
        standard errors uncertain, a friction that builds up at the start of the sweep).

    Raises
    ------
    InputError
        If the trial is too short, sweeps less than :data:`REFUSE_RANGE` degrees, moves faster
        than :data:`REFUSE_SPEED` deg/s (95th percentile; a fast trial marked quasi-static), or
        ``torque_sign`` is not +-1.
    """
    source = source_of(trial)
    if torque_sign not in (1, -1):
        raise InputError(f"{source}: torque_sign: expected +1 or -1, got {torque_sign!r}")
    angle = trial["angle"].values
    torque = torque_sign * trial["torque"].values
    speeds = np.abs(trial["velocity"].values)
    speed, fast = (float(v) for v in np.percentile(speeds, [50, 95]))
    speed_deg = math.degrees(speed)
    fast = math.degrees(fast)
    if fast > REFUSE_SPEED:
        raise InputError(
            f"{source}: velocity: 5 % of the samples move faster than {fast:.3g} deg/s; a "
            "quasi-static trial moves at about 1 deg/s (is this a fast trial? set "
            'kind = "fast" in the manifest)'
        )
    reg = gravity_regression(angle, torque, source=source)
    a, b, c = (float(v) for v in reg.coefficients)
    cov = reg.covariance
    moment = math.hypot(a, b)
    phase = math.atan2(b, a)
    # Delta method: gradients of hypot(a, b) and atan2(b, a) with respect to (a, b).
    g_m = np.array([a / moment, b / moment, 0.0])
    g_p = np.array([-b / moment**2, a / moment**2, 0.0])
    span = float(np.ptp(angle))

    flags = []
    if speed_deg > max_speed_deg_s:
        flags.append(
            f"not quasi-static: median speed {speed_deg:.3g} deg/s > {max_speed_deg_s:g} deg/s"
        )
    if math.degrees(span) < min_range_deg:
        flags.append(
            f"small angle range: {math.degrees(span):.3g} deg < {min_range_deg:g} deg "
            "(M_g, phi and offset poorly separated)"
        )
    # residuals at rounding level (a noise-free recording): no noise to describe
    noisy = float(np.std(reg.residuals)) > 1e-9 * max(1.0, float(np.max(np.abs(torque))))
    if noisy and reg.se_dof < MIN_SE_DOF:
        rate = sampling_rate(trial)
        flags.append(
            f"drifting residuals: correlation time {reg.drift_time / rate:.3g} s over a "
            f"{reg.residuals.size / rate:.3g} s move leaves the standard errors themselves "
            f"uncertain (about {reg.se_dof:.2g} degrees of freedom; widened for it)"
        )
    if noisy and reg.friction_probability > FRICTION_FLAG:
        flags.append(
            f"friction builds up at the start of the sweep: {reg.friction:.3g} ± "
            f"{reg.friction_se:.2g} N m over about {math.degrees(reg.friction_angle):.2g} deg "
            "(fitted; the offset holds its steady value, and fast trials carry the same "
            "build-up early in their ramp)"
        )
    return GravityFit(
        gravity_moment=moment,
        gravity_moment_se=float(math.sqrt(g_m @ cov @ g_m)),
        gravity_phase=phase,
        gravity_phase_se=float(math.sqrt(g_p @ cov @ g_p)),
        offset=c,
        offset_se=float(math.sqrt(cov[2, 2])),
        residual_rms=float(np.sqrt(np.mean(reg.residuals**2))),
        n=int(reg.residuals.size),
        n_effective=float(reg.n_effective),
        angle_range=span,
        median_speed=speed,
        source=source,
        flags=tuple(flags),
        coefficients=reg.coefficients.copy(),
        covariance=cov.copy(),
        se_dof=reg.se_dof,
        noise=TorqueNoise(
            reg.trial_noise[0] if noisy else 0.0,
            reg.trial_noise[1] if noisy else 0.0,
            reg.trial_noise[2] / sampling_rate(trial),
        ),
    )
