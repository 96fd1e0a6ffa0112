"""The paper's estimator: multi-start bounded least squares and a "feasible region" mean.

Son et al. (Section 2.2, Eq. (4), Fig. 2) estimate a body's mass ``m``, CoM distance ``x`` and
radius of gyration ``rho`` from its inertia about the joint ``I`` and gravitational moment
``M_g`` by minimising::

    (m x − M_g / g)² + (m rho² + m x² − I)²   subject to   0.5 p0 <= p <= 1.5 p0

with MATLAB's ``fmincon`` from the starts ``p0 (1 + k/100)``, ``k = −50..50``, and reporting the
mean of the solutions over the range of starts "in which solutions showed no considerable
variations". :func:`paper_baseline` reproduces that with :func:`scipy.optimize.minimize` so the
answer can be set beside the posterior.

Two equations, three unknowns: every point of the curve ``m x = M_g/g``, ``m (rho² + x²) = I``
inside the box has objective exactly zero, so each start returns wherever the optimiser stops on
that curve, and the feasible-region mean is a property of the optimiser and the starts, not of
the data. ``docs/baseline.md`` shows how much it moves.

Arrays of parameters are ordered ``(mass, com_distance, radius_of_gyration)`` throughout, as
:data:`inertiafit.physics.PARAMETERS`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import Bounds, minimize

from inertiafit import physics
from inertiafit._checks import check_positive
from inertiafit.errors import InputError
from inertiafit.physics import PARAMETERS, UNITS

__all__ = [
    "BOUND_MARGIN",
    "DEFAULT_METHOD",
    "METHODS",
    "BaselineResult",
    "curve_mass_intervals",
    "feasible_region",
    "identification_curve",
    "paper_baseline",
]

#: Methods of :func:`scipy.optimize.minimize` that take bounds and that this module has tuned.
#: ``trust-constr`` is an interior-point (barrier) method like fmincon's default algorithm.
METHODS = ("trust-constr", "SLSQP", "L-BFGS-B")
#: The default optimiser. SLSQP, started from the paper's 101 scaled nominals, reproduces its
#: Table 2 attachment answer (2.80 kg, 0.270 m, 0.065 m against the printed 2.81, 0.269, 0.065)
#: and takes ~0.1 s; trust-constr (the closest analogue of fmincon's default interior-point)
#: stops mid-curve at 3.21 kg and takes ~3-4 s (docs/baseline.md).
DEFAULT_METHOD = "SLSQP"

#: A start component on or outside a bound is moved this fraction of the box width inside it.
#: MATLAB's fmincon interior-point algorithm (``HonorBounds``, its default) also moves such
#: components strictly inside; doing the same for every method gives them identical starts.
BOUND_MARGIN = 1e-3

# Stopping rules tight enough that every returned point satisfies both equations to
# objective < 1e-14 on the paper's cases (the defaults stop at ~1e-11). trust-constr keeps its
# 3-by-3 matrices dense: with SciPy 1.18 its default (sparse, for the bounds' Jacobian) spent
# most of each iteration building sparse matrices, 2.2x the time for the same points (the
# attachment's 101 solutions within 1.2e-7, the disk's within 1.3e-15, every feasible region
# the same).
_OPTIONS = {
    "trust-constr": {
        "gtol": 1e-10,
        "xtol": 1e-12,
        "barrier_tol": 1e-10,
        "maxiter": 1000,
        "sparse_jacobian": False,
    },
    "SLSQP": {"ftol": 1e-20, "maxiter": 1000},
    "L-BFGS-B": {"ftol": 1e-20, "gtol": 1e-12, "maxiter": 5000},
}


# --- input checking ---------------------------------------------------------------------------


def _triple(value: Any, name: str) -> NDArray[np.float64]:
    """``(mass, com_distance, radius_of_gyration)`` from a mapping by name or a length-3 array."""
    if isinstance(value, Mapping):
        missing = [p for p in PARAMETERS if p not in value]
        if missing:
            raise InputError(f"{name}: expected keys {', '.join(PARAMETERS)}; missing {missing}")
        value = [value[p] for p in PARAMETERS]
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(
            f"{name}: expected 3 numbers (mass, com_distance, radius_of_gyration), got {value!r}"
        ) from None
    if arr.shape != (3,):
        raise InputError(
            f"{name}: expected shape (3,) in the order (mass, com_distance, radius_of_gyration),"
            f" got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers, got {arr.tolist()}")
    return arr


def _method(method: object) -> str:
    for known in METHODS:
        if isinstance(method, str) and method.lower() == known.lower():
            return known
    raise InputError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")


def _ks(ks: ArrayLike) -> NDArray[np.float64]:
    try:
        arr = np.asarray(list(ks) if isinstance(ks, range) else ks, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"ks: expected start offsets in percent, got {ks!r}") from None
    if arr.ndim not in (1, 2) or arr.shape[0] == 0 or (arr.ndim == 2 and arr.shape[1] != 3):
        raise InputError(
            f"ks: expected shape (n,) or (n, 3) with n >= 1 (percent), got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)) or np.any(arr <= -100):
        raise InputError("ks: expected finite offsets above -100 % (a start must be positive)")
    return arr


# --- the identification curve -----------------------------------------------------------------


def _intersect(intervals, lo: float, hi: float) -> list[tuple[float, float]]:
    out = [(float(max(a, lo)), float(min(b, hi))) for a, b in intervals]
    return [(a, b) for a, b in out if a <= b]


def curve_mass_intervals(
    *,
    inertia: float,
    gravity_moment: float,
    lower: ArrayLike | Mapping[str, float],
    upper: ArrayLike | Mapping[str, float],
    gravity: float = physics.GRAVITY,
) -> list[tuple[float, float]]:
    """Masses (kg) at which the identification curve lies inside the box.

    On the curve ``x = a / m`` and ``rho² = I / m − a² / m²`` with ``a = M_g / g``, so each
    bound on ``x`` or ``rho`` is a bound on ``m`` (the ``rho`` bounds are quadratic in ``m``).

    Parameters
    ----------
    inertia : float
        ``I`` about the joint (kg m^2).
    gravity_moment : float
        ``M_g = m g x`` (N m).
    lower, upper : array_like of shape (3,) or mapping
        The box, ``(mass, com_distance, radius_of_gyration)`` (kg, m, m).
    gravity : float, optional
        ``g`` (m/s^2).

    Returns
    -------
    list of (float, float)
        Disjoint closed mass intervals, increasing; empty when the curve misses the box. The
        curve needs ``m >= (M_g/g)² / I`` (``rho² >= 0``).
    """
    lo, hi = _triple(lower, "lower"), _triple(upper, "upper")
    a, b = gravity_moment / gravity, inertia
    m_lo, x_lo, r_lo = lo
    m_hi, x_hi, r_hi = hi
    intervals = _intersect([(m_lo, m_hi)], a / x_hi, a / x_lo if x_lo > 0 else math.inf)
    # rho >= r_lo  <=>  r_lo² m² − I m + a² <= 0  (for r_lo = 0: m >= a²/I)
    if r_lo > 0:
        disc = b * b - 4.0 * r_lo**2 * a * a
        if disc < 0:
            return []
        root = math.sqrt(disc)
        intervals = _intersect(intervals, (b - root) / (2 * r_lo**2), (b + root) / (2 * r_lo**2))
    else:
        intervals = _intersect(intervals, a * a / b, math.inf)
    # rho <= r_hi  <=>  r_hi² m² − I m + a² >= 0: m outside the roots, if there are two
    disc = b * b - 4.0 * r_hi**2 * a * a
    if disc > 0:
        root = math.sqrt(disc)
        first, second = (b - root) / (2 * r_hi**2), (b + root) / (2 * r_hi**2)
        intervals = _intersect(intervals, -math.inf, first) + _intersect(
            intervals, second, math.inf
        )
        intervals.sort()
    return intervals


def identification_curve(
    *,
    inertia: float,
    gravity_moment: float,
    lower: ArrayLike | Mapping[str, float],
    upper: ArrayLike | Mapping[str, float],
    gravity: float = physics.GRAVITY,
    num: int = 201,
) -> NDArray[np.float64]:
    """Points of the curve ``m x = M_g/g``, ``m (rho² + x²) = I`` inside the box.

    Parameters
    ----------
    inertia, gravity_moment, lower, upper, gravity
        As :func:`curve_mass_intervals`.
    num : int, optional
        Points per mass interval, evenly spaced in mass, end points included.

    Returns
    -------
    ndarray of shape (n, 3)
        ``(mass, com_distance, radius_of_gyration)`` (kg, m, m); ``n = 0`` when the curve
        misses the box.
    """
    a = gravity_moment / gravity
    masses = [
        np.linspace(m0, m1, num)
        for m0, m1 in curve_mass_intervals(
            inertia=inertia,
            gravity_moment=gravity_moment,
            lower=lower,
            upper=upper,
            gravity=gravity,
        )
    ]
    m = np.concatenate(masses) if masses else np.empty(0)
    x, rho = physics.curve_at_mass(a, inertia, m)
    return np.column_stack([m, x, rho])


# --- the feasible-region rule -----------------------------------------------------------------


def feasible_region(
    solutions: ArrayLike,
    scale: ArrayLike,
    *,
    tolerance: float = 0.01,
    ks: ArrayLike | None = None,
    valid: ArrayLike | None = None,
) -> slice:
    """Find the paper's "feasible region": the starts over which the solution stays put.

    The rule: consecutive starts ``i`` and ``i + 1`` are *linked* when both are valid and every
    parameter's solution changes by at most ``tolerance * scale`` between them. The feasible
    region is the longest run of linked starts (a run of ``L`` starts has ``L − 1`` links; a
    single valid start is a run of length 1). Ties go to the run nearest ``k = 0`` (smallest
    ``|k|`` over the run, Euclidean norm for per-parameter ``ks``), then to the earlier run.
    The rule only looks at step-to-step changes, so a slow drift that stays below the tolerance
    at every step counts as "no considerable variation", as a reading of Fig. 2 would.

    Parameters
    ----------
    solutions : array_like of shape (n, 3)
        Solution per start, in start order.
    scale : array_like of shape (3,)
        Per-parameter scale of the tolerance, the nominal values in :func:`paper_baseline`.
    tolerance : float, optional
        Largest change between neighbouring starts, as a fraction of ``scale`` (1 %).
    ks : array_like of shape (n,) or (n, 3), optional
        Start offsets, for the tie rule; default ``0..n-1`` centred on the middle start.
    valid : array_like of bool, shape (n,), optional
        Starts that may belong to a run (converged, no warning); default all.

    Returns
    -------
    slice
        ``slice(start, stop)`` into the starts; empty (``slice(0, 0)``) when no start is valid.
    """
    sol = np.asarray(solutions, dtype=float)
    n = sol.shape[0]
    ok = np.ones(n, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    if ks is None:
        dist = np.abs(np.arange(n) - (n - 1) / 2.0)
    else:
        k = np.asarray(ks, dtype=float)
        dist = np.abs(k) if k.ndim == 1 else np.linalg.norm(k, axis=1)
    atol = tolerance * np.abs(np.asarray(scale, dtype=float))
    linked = np.all(np.abs(np.diff(sol, axis=0)) <= atol, axis=1) & ok[:-1] & ok[1:]

    best: tuple[int, float, int] | None = None  # (-length, distance to k=0, start)
    i = 0
    while i < n:
        if not ok[i]:
            i += 1
            continue
        j = i
        while j < n - 1 and linked[j]:
            j += 1
        key = (-(j - i + 1), float(dist[i : j + 1].min()), i)
        if best is None or key < best:
            best = key
        i = j + 1
    if best is None:
        return slice(0, 0)
    return slice(best[2], best[2] - best[0])


# --- the estimator ----------------------------------------------------------------------------


def _objective(first_moment: float, inertia: float):
    """Eq. (4) with its gradient and Hessian, parameters ``(m, x, rho)``."""
    a, b = first_moment, inertia

    def fun(p):
        m, x, r = p
        r1 = m * x - a
        r2 = m * (r * r + x * x) - b
        return r1 * r1 + r2 * r2

    def jac(p):
        m, x, r = p
        r1 = m * x - a
        r2 = m * (r * r + x * x) - b
        return np.array(
            [2 * r1 * x + 2 * r2 * (r * r + x * x), 2 * r1 * m + 4 * r2 * m * x, 4 * r2 * m * r]
        )

    def hess(p):
        m, x, r = p
        r1 = m * x - a
        r2 = m * (r * r + x * x) - b
        j1 = np.array([x, m, 0.0])
        j2 = np.array([r * r + x * x, 2 * m * x, 2 * m * r])
        h1 = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
        h2 = np.array([[0.0, 2 * x, 2 * r], [2 * x, 2 * m, 0.0], [2 * r, 0.0, 2 * m]])
        return 2 * (np.outer(j1, j1) + np.outer(j2, j2)) + 2 * r1 * h1 + 2 * r2 * h2

    return fun, jac, hess


@dataclass(frozen=True, eq=False)
class BaselineResult:
    """The paper's estimate for one body, with everything behind it.

    Attributes
    ----------
    method : str
        The :func:`scipy.optimize.minimize` method used.
    starts : ndarray of shape (n,) or (n, 3)
        Start offsets ``k`` (percent): start ``= nominal * (1 + k/100)``.
    initial : ndarray of shape (n, 3)
        Start points actually used, after moving components on or outside a bound inside.
    solutions : ndarray of shape (n, 3)
        Solution per start, ``(mass, com_distance, radius_of_gyration)`` (kg, m, m).
    objective : ndarray of shape (n,)
        Eq. (4) at each solution (kg² m² and kg² m⁴ summed, as the paper writes it).
    success : ndarray of bool, shape (n,)
        The optimiser reported success and raised no warning.
    feasible : slice
        The feasible region, a slice into the starts (:func:`feasible_region`).
    mass, com_distance, radius_of_gyration : float
        Mean of the solutions over the feasible region (kg, m, m); NaN if it is empty.
    inertia : float
        ``m (rho² + x²)`` of that mean (kg m^2); differs from the observed ``I`` by the
        curvature of the curve over the region.
    gravity_moment : float
        ``m g x`` of that mean (N m).
    observed_inertia, observed_gravity_moment, gravity : float
        The inputs ``I`` (kg m^2), ``M_g`` (N m), ``g`` (m/s^2).
    nominal, lower, upper : ndarray of shape (3,)
        Nominal values (centre of the starts) and the box.
    tolerance : float
        Step tolerance of the feasible-region rule, as a fraction of ``nominal``.
    messages : tuple of str
        Optimiser messages and warnings of the starts that did not succeed, ``"k=...: ..."``.
    """

    method: str
    starts: NDArray[np.float64]
    initial: NDArray[np.float64]
    solutions: NDArray[np.float64]
    objective: NDArray[np.float64]
    success: NDArray[np.bool_]
    feasible: slice
    mass: float
    com_distance: float
    radius_of_gyration: float
    inertia: float
    gravity_moment: float
    observed_inertia: float
    observed_gravity_moment: float
    gravity: float
    nominal: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    tolerance: float
    messages: tuple[str, ...] = ()

    @property
    def feasible_mask(self) -> NDArray[np.bool_]:
        """Boolean mask of shape ``(n,)``, true for the starts in the feasible region."""
        mask = np.zeros(len(self.starts), dtype=bool)
        mask[self.feasible] = True
        return mask

    @property
    def run_length(self) -> int:
        """Number of starts in the feasible region."""
        return self.feasible.stop - self.feasible.start

    @property
    def estimate(self) -> dict[str, float]:
        """The feasible-region mean and derived quantities by name (SI units)."""
        return {
            "mass": self.mass,
            "com_distance": self.com_distance,
            "radius_of_gyration": self.radius_of_gyration,
            "inertia": self.inertia,
            "gravity_moment": self.gravity_moment,
        }

    def to_dict(self) -> dict[str, Any]:
        """Plain Python types only (lists, floats, str), ready for JSON."""
        region = self.starts[self.feasible]
        return {
            "method": self.method,
            **self.estimate,
            "observed_inertia": self.observed_inertia,
            "observed_gravity_moment": self.observed_gravity_moment,
            "gravity": self.gravity,
            "nominal": dict(zip(PARAMETERS, self.nominal.tolist(), strict=True)),
            "lower": dict(zip(PARAMETERS, self.lower.tolist(), strict=True)),
            "upper": dict(zip(PARAMETERS, self.upper.tolist(), strict=True)),
            "tolerance": self.tolerance,
            "feasible_start": self.feasible.start,
            "feasible_stop": self.feasible.stop,
            "feasible_k": [region[0].tolist(), region[-1].tolist()] if len(region) else [],
            "run_length": self.run_length,
            "starts": self.starts.tolist(),
            "initial": self.initial.tolist(),
            "solutions": self.solutions.tolist(),
            "objective": self.objective.tolist(),
            "success": self.success.tolist(),
            "messages": list(self.messages),
        }

    def __str__(self) -> str:
        n = len(self.starts)
        if self.starts.ndim == 1:
            span = f"k = {self.starts[0]:g}..{self.starts[-1]:g} %"
        else:
            span = "per-parameter k"
        if self.run_length:
            first, last = self.starts[self.feasible][[0, -1]]
            region = (
                f"k = {first:g}..{last:g} %"
                if self.starts.ndim == 1
                else f"starts {self.feasible.start}..{self.feasible.stop - 1}"
            )
        else:
            region = "empty"
        lines = [
            f"Paper baseline (Son et al., Eq. (4)), method {self.method}, {n} starts, {span}",
            (
                f"  data: I = {self.observed_inertia:.6g} kg m^2, "
                f"M_g = {self.observed_gravity_moment:.6g} N m, g = {self.gravity:g} m/s^2"
            ),
            (
                f"  feasible region: {region} ({self.run_length} starts, step tolerance "
                f"{100 * self.tolerance:g} % of nominal)"
            ),
            f"  {'parameter':<26}{'nominal':>10}{'lower':>10}{'upper':>10}{'baseline':>11}",
        ]
        for i, name in enumerate(PARAMETERS):
            label = f"{name} [{UNITS[name]}]"
            lines.append(
                f"  {label:<26}{self.nominal[i]:>10.4g}{self.lower[i]:>10.4g}"
                f"{self.upper[i]:>10.4g}{getattr(self, name):>11.5g}"
            )
        for name in physics.DERIVED:
            label = f"{name} [{UNITS[name]}]"
            lines.append(f"  {label:<56}{getattr(self, name):>11.5g}")
        lines.append(
            f"  largest objective over starts: {np.max(self.objective):.2g}; "
            f"{int(np.sum(~self.success))} of {n} starts flagged"
        )
        lines.append(
            "  (one point of a curve of exact solutions: the optimiser, not the data, picks it)"
        )
        return "\n".join(lines)


def paper_baseline(
    *,
    inertia: float,
    gravity_moment: float,
    nominal: ArrayLike | Mapping[str, float],
    lower: ArrayLike | Mapping[str, float] | None = None,
    upper: ArrayLike | Mapping[str, float] | None = None,
    gravity: float = physics.GRAVITY,
    method: str = DEFAULT_METHOD,
    ks: ArrayLike = range(-50, 51),
    tolerance: float = 0.01,
) -> BaselineResult:
    """Son et al.'s estimate of ``(m, x, rho)``: Eq. (4) from many starts, feasible-region mean.

    Each start ``nominal * (1 + k/100)`` is minimised with :func:`scipy.optimize.minimize`
    (analytic gradient and, for ``trust-constr``, Hessian) inside the box; the solutions over
    the :func:`feasible_region` are averaged.

    Parameters
    ----------
    inertia : float
        Moment of inertia about the joint ``I`` (kg m^2), > 0.
    gravity_moment : float
        Largest gravitational moment ``M_g = m g x`` (N m), > 0.
    nominal : array_like of shape (3,) or mapping
        Nominal (ideal-model) values ``(mass, com_distance, radius_of_gyration)`` (kg, m, m),
        or a mapping with those keys (e.g. ``Prior.nominal``).
    lower, upper : array_like of shape (3,) or mapping, optional
        The box; default ``0.5 * nominal`` and ``1.5 * nominal`` as in Eq. (4). ``nominal``
        must lie inside it.
    gravity : float, optional
        ``g`` (m/s^2).
    method : {"trust-constr", "SLSQP", "L-BFGS-B"}, optional
        Default :data:`DEFAULT_METHOD` (SLSQP: it reproduces the paper's Table 2);
        ``trust-constr`` is a barrier (interior-point) method like fmincon's default.
    ks : array_like of shape (n,) or (n, 3), optional
        Start offsets in percent, in the order the feasible-region rule walks them. 1-D: all
        three parameters scaled by the same factor (the paper's "±50 % with the increment of
        1 %"); shape ``(n, 3)``: an offset per parameter, e.g. ``np.column_stack([k, 0*k,
        0*k])`` varies only the mass start. A start component on or outside a bound (``k =
        ±50`` with the default box) is moved :data:`BOUND_MARGIN` of the box width inside.
    tolerance : float, optional
        Largest change of each parameter between neighbouring starts inside the feasible
        region, as a fraction of its nominal value (1 %).

    Returns
    -------
    BaselineResult
        Per-start solutions, the feasible region and its mean.

    Raises
    ------
    InputError
        Non-positive ``inertia``, ``gravity_moment`` or ``gravity``; ``nominal``, ``lower`` or
        ``upper`` not three finite numbers; ``lower >= upper``; ``nominal`` outside the box;
        an unknown ``method``; bad ``ks`` or ``tolerance``; or a box that holds no point with
        ``I = m (rho² + x²)`` and ``M_g = m g x``.

    Examples
    --------
    The 3 kg disk of the paper's Table 3:

    >>> res = paper_baseline(inertia=0.594, gravity_moment=2.90 * 9.81 * 0.45,
    ...                      nominal=[2.92, 0.45, 0.035], method="SLSQP")
    >>> round(res.mass, 2)
    2.87
    """
    i_obs = check_positive(inertia, "inertia", "kg m^2")
    mg_obs = check_positive(gravity_moment, "gravity_moment", "N m")
    g = check_positive(gravity, "gravity", "m/s^2")
    p0 = _triple(nominal, "nominal")
    if np.any(p0 <= 0):
        raise InputError(f"nominal: expected positive values, got {p0.tolist()}")
    lo = (1.0 - 0.5) * p0 if lower is None else _triple(lower, "lower")
    hi = (1.0 + 0.5) * p0 if upper is None else _triple(upper, "upper")
    for i, par in enumerate(PARAMETERS):
        if lo[i] < 0:
            raise InputError(f"lower: expected {par} >= 0, got {lo[i]:g}")
        if not lo[i] < hi[i]:
            raise InputError(
                f"lower, upper: expected lower < upper for {par}, got {lo[i]:g} >= {hi[i]:g}"
            )
        if not lo[i] <= p0[i] <= hi[i]:
            raise InputError(
                f"nominal: expected {par} inside [{lo[i]:g}, {hi[i]:g}], got {p0[i]:g}"
            )
    name = _method(method)
    k = _ks(ks)
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        tol = math.nan
    if not (math.isfinite(tol) and tol >= 0):
        raise InputError(f"tolerance: expected a finite fraction >= 0, got {tolerance!r}")
    if not curve_mass_intervals(
        inertia=i_obs, gravity_moment=mg_obs, lower=lo, upper=hi, gravity=g
    ):
        raise InputError(
            f"inertia, gravity_moment: no (mass, com_distance, radius_of_gyration) in the box "
            f"gives I = {i_obs:g} kg m^2 and M_g = {mg_obs:g} N m (mass must be >= "
            f"(M_g/g)^2/I = {physics.minimum_mass(i_obs, mg_obs, g):.4g} kg, "
            f"com_distance <= I g/M_g = {physics.maximum_com_distance(i_obs, mg_obs, g):.4g} m)"
        )

    factor = 1.0 + (k[:, None] if k.ndim == 1 else k) / 100.0
    margin = BOUND_MARGIN * (hi - lo)
    initial = np.clip(p0 * factor, lo + margin, hi - margin)

    fun, jac, hess = _objective(mg_obs / g, i_obs)
    bounds = Bounds(lo, hi)
    extra = {"hess": hess} if name == "trust-constr" else {}
    n = len(initial)
    solutions = np.empty((n, 3))
    objective = np.empty(n)
    success = np.empty(n, dtype=bool)
    messages: list[str] = []
    for i, x0 in enumerate(initial):
        # An optimiser's warning concerns one start: keep it with that start, flag the start
        # (it then cannot join the feasible region) and carry on with the others.
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = minimize(
                fun, x0, jac=jac, bounds=bounds, method=name, options=_OPTIONS[name], **extra
            )
        x = np.clip(res.x, lo, hi)
        solutions[i] = x
        objective[i] = fun(x)
        success[i] = bool(res.success) and not caught and np.isfinite(objective[i])
        if not success[i]:
            label = f"k={k[i]:g}" if k.ndim == 1 else f"start {i}"
            text = "; ".join([str(res.message), *(str(w.message) for w in caught)])
            messages.append(f"{label}: {text}")

    region = feasible_region(solutions, p0, tolerance=tol, ks=k, valid=success)
    if region.stop > region.start:
        m, x, rho = solutions[region].mean(axis=0)
    else:
        m = x = rho = math.nan
    return BaselineResult(
        method=name,
        starts=k,
        initial=initial,
        solutions=solutions,
        objective=objective,
        success=success,
        feasible=region,
        mass=float(m),
        com_distance=float(x),
        radius_of_gyration=float(rho),
        inertia=float(physics.inertia(m, rho, x)),
        gravity_moment=float(physics.gravity_moment(m, x, g)),
        observed_inertia=i_obs,
        observed_gravity_moment=mg_obs,
        gravity=g,
        nominal=p0,
        lower=lo,
        upper=hi,
        tolerance=tol,
        messages=tuple(messages),
    )
