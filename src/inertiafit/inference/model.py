"""The statistical model: bodies with prior boxes, conditions that superpose them, evidence.

Parametrisation
---------------
Rotation about one axis identifies, per body, only the first moment of mass ``a = m x`` (kg m)
and the inertia about the joint ``b = I`` (kg m^2). Write the rest of the body as the angle
``psi = atan(x / rho)`` in ``(0, pi/2)``: with ``R = b/a``, ``x = R sin^2 psi``,
``rho = R sin psi cos psi`` and ``m = a/x``. The uniform prior on the box of ``(m, x, rho)`` is,
in ``(a, b, psi)``, the density ``1/a`` on the image of the box, and for fixed ``(a, b)`` it is
*uniform in psi* on the set ``Psi(a, b)`` of angles that keep all three parameters inside their
bounds — at most two intervals, known in closed form. The likelihood does not involve ``psi``.

So the posterior factorises exactly: ``p(a, b | data) ~ L(a, b) |Psi(a, b)| / a`` is sampled
with emcee (in ``log a, log b``, where it is close to Gaussian and axis-aligned), and ``psi``
is drawn exactly, uniformly from ``Psi(a, b)``, for every kept draw. The data-identified part and
the prior-only part of the problem are separate coordinates.

Priors that are not a box
-------------------------
The Jacobian ``|d(m, x, rho) / d(a, b, psi)|`` is ``1/a`` whatever the prior (from
``|d(m, a, b) / d(m, x, rho)| = 2 m^2 rho`` and ``dm/dpsi = -2 a^2 cos psi / (b sin^3 psi)``).
So a prior density ``p_m(m) p_x(x) p_rho(rho)`` (:meth:`~inertiafit.inference.priors.Prior.
log_density`, zero outside its support box) is, in ``(a, b, psi)``,
``p_m p_x p_rho (a, b, psi) / a`` on the same ``Psi(a, b)``: for fixed ``(a, b)`` the angle has
the density ``p(psi | a, b) ~ p_m p_x p_rho`` along the curve, and ``(a, b)`` the marginal
``(1/a) * integral over Psi(a, b) of p_m p_x p_rho d psi``. Both are computed on one grid of
:data:`N_ANGLE_CELLS` equal cells spanning ``Psi(a, b)`` (its two intervals laid end to end): the
integral by the midpoint rule (:func:`log_identified_prior`), and the angle drawn exactly from
the density that is constant on each cell (inverse CDF, linear within cells;
:func:`draw_angles`). A box (every parameter uniform) keeps the closed forms above.

Systematic errors
-----------------
* A condition's gravity model is subtracted from all its fast trials: its error moves their
  inertia together and correlates with the error of the condition's ``M_g``. Given the gravity
  moment's error ``M_g_obs - M_g``, the inertia's shifts by ``coupling * (M_g_obs - M_g)`` and
  the rest is a Gaussian of SD ``inertia.shared_sd`` (:class:`Condition`).
* A torque gain ``gamma`` (the torque channel's calibration) multiplies every observed ``I``
  and ``M_g`` of a study. With ``torque_gain_sd > 0`` the sampled ``(log a, log b)`` are
  *observed-scale* values, ``gamma`` times the true ones (what the data identify), and
  ``log gamma ~ N(0, torque_gain_sd^2)`` is one more coordinate; the true values are the
  observed ones over ``gamma``, so the box prior is evaluated at ``z - log gamma``.

Extra information
-----------------
Evidence that involves the body's own ``m``, ``x`` or ``rho`` — a weighed mass, a balance-point
centre of mass (``Model(measured=...)``), a second mounting that moves the body ``d`` along
the lever (``Condition(offset_body=, offset=)``: ``a + m d``, ``I + 2 a d + m d^2``) — is a
function of ``psi`` for fixed ``(a, b)`` (every term is a function of ``m = a^2 / (b sin^2 psi)``
and ``x = a / m``). It multiplies the prior along the curve: the angle's conditional density
is the prior times that evidence, still 1-D and drawn exactly, and the marginal of the sampled
coordinates integrates both. Where the evidence is sharp (a scale reads to 0.3 %), the angles
it allows fill a small part of ``Psi(a, b)``, so the grid is cut to the masses each term allows
(all but :data:`~inertiafit.inference.terms.WINDOW_TAIL` of its likelihood) and refined over the narrowest term's core:
:data:`N_EXTRA_CELLS` equal cells over each, merged. A moved body's condition involves the other
bodies it is mounted with, so its evidence is evaluated per row of the sampled coordinates; at
most one body of a condition is moved, so the angles stay conditionally independent. Known
added masses (``Condition(added=)``: their :func:`inertiafit.physics.point_moments`) add known
``a`` and ``I`` to their condition's totals (times the torque gain, like everything the torque
channel sees).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from inertiafit import physics
from inertiafit._checks import check_number, check_positive
from inertiafit.errors import InputError
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior
from inertiafit.inference.terms import (
    TERM_KINDS,
    ConditionEvidence,
    CurvePiece,
    MeasuredEvidence,
    Point,
    Term,
)
from inertiafit.io.manifest import MAX_TORQUE_GAIN_SD
from inertiafit.measured import MEASURED_QUANTITIES
from inertiafit.mounting import Mounting
from inertiafit.physics import GRAVITY, PARAMETERS

__all__ = [
    "MEASURED",
    "N_ANGLE_CELLS",
    "Box",
    "Condition",
    "Model",
    "ObservableRange",
    "angle_density",
    "angles_at",
    "box_meets",
    "draw_angles",
    "feasible_angles",
    "feasible_measure",
    "log_curve_integral",
    "log_identified_prior",
    "observable_ranges",
]

HALF_PI = np.pi / 2

#: Equal cells in the fraction of ``Psi(a, b)`` on which a prior that is not a box is integrated
#: and its angle drawn (module docstring, "Priors that are not a box").
N_ANGLE_CELLS = 128

#: Quantities of a body that can be measured directly (a scale; a balance point): the names of
#: the registry :data:`inertiafit.measured.MEASURED_QUANTITIES`.
MEASURED = tuple(MEASURED_QUANTITIES)

#: Cells of the angle grid of a body whose angle meets evidence: uniform over the window where
#: the evidence allows the body, and as many again over the narrowest term's core.
N_EXTRA_CELLS = 96

#: Edges of :data:`N_EXTRA_CELLS` equal cells of ``[0, 1]``.
_UNIT_EDGES = np.linspace(0.0, 1.0, N_EXTRA_CELLS + 1)
#: Their midpoints and widths, computed once: on a window that needs no refining every row has
#: these cells, scaled.
_UNIT_MIDS = 0.5 * (_UNIT_EDGES[1:] + _UNIT_EDGES[:-1])
_UNIT_WIDTHS = np.diff(_UNIT_EDGES)
#: The few distinct values among those widths, and which one each cell has: the log of a row's
#: cell widths is taken on these (the same numbers, fewer logarithms).
_UNIT_WIDTH_VALUES, _UNIT_WIDTH_INDEX = np.unique(_UNIT_WIDTHS, return_inverse=True)

#: Rows of ``(a, b)`` handled at once on the angle grid (bounds the memory of one call).
_ROWS_PER_BLOCK = 512

#: Largest size of a sampled coordinate (``log a``, ``log b``, ``log gain``) with any density:
#: e^50 = 5e21 is far beyond any body's ``a`` (kg m) or ``b`` (kg m^2), and any torque gain, on
#: either side, and within it the model's exponentials, squares and ratios stay finite. The
#: Student-t proposal of a condition with two fast trials (one degree of freedom, a Cauchy)
#: reaches 2e4, whose ``exp`` overflowed with a RuntimeWarning.
_MAX_COORDINATE = 50.0


class _Cells:
    """The cells of one block of angle grids: their edges, made only when asked.

    ``fractions`` are the edges as fractions of each row's window (``None``: the equal cells
    :data:`_UNIT_EDGES`), ``scale`` the window's length (a column); :attr:`angles` are the
    window's two intervals ``(lo1, len1, lo2)`` (rows).
    """

    __slots__ = ("angles", "fractions", "log_width_values", "scale")

    def __init__(self, fractions, scale, log_width_values=None) -> None:
        self.fractions = fractions
        self.scale = scale
        self.log_width_values = log_width_values
        self.angles: tuple = ()

    def edges(self):
        """``(edges, lo1, len1, lo2)``: cell edges in radians into the window, and its intervals."""
        base = _UNIT_EDGES if self.fractions is None else self.fractions
        return (base * self.scale, *self.angles)

    def widths(self, log_w):
        """``exp(log_w)``, the cells' widths (over the few distinct ones of the equal cells)."""
        if self.log_width_values is None:
            return np.exp(log_w)
        return np.exp(self.log_width_values)[:, _UNIT_WIDTH_INDEX]


class Box(Protocol):
    """Prior bounds: a :class:`Prior`, or several bodies' bounds as arrays."""

    @property
    def lower(self) -> Mapping[str, Any]:
        """Lower bounds of ``mass``, ``com_distance``, ``radius_of_gyration``."""
        ...

    @property
    def upper(self) -> Mapping[str, Any]:
        """Upper bounds, same keys."""
        ...


def feasible_angles(first_moment, inertia, prior: Box):
    """Intervals of ``psi`` that keep ``(m, x, rho)`` inside the prior box.

    Parameters
    ----------
    first_moment, inertia : array_like
        ``a = m x`` (kg m) and ``b = I`` (kg m^2), broadcast together.
    prior : Prior
        The box.

    Returns
    -------
    lo1, hi1, lo2, hi2 : ndarray
        Two intervals ``[lo, hi]`` in rad (an empty one has ``hi <= lo``); their union is
        ``Psi(a, b)``.
    """
    a = np.asarray(first_moment, dtype=float)
    b = np.asarray(inertia, dtype=float)
    scalar = a.ndim == 0 and b.ndim == 0
    with np.errstate(invalid="ignore", divide="ignore"):
        out = _feasible_angles(a.reshape(1) if scalar else a, b.reshape(1) if scalar else b, prior)
    if scalar and out.shape[1:] == (1,):  # scalars in, scalars out
        return out[0, 0], out[1, 0], out[2, 0], out[3, 0]
    return out[0], out[1], out[2], out[3]


def _feasible_angles(a: np.ndarray, b: np.ndarray, prior: Box) -> np.ndarray:
    """:func:`feasible_angles` as one array ``(4, ...)`` of ``lo1, hi1, lo2, hi2``.

    ``a``, ``b`` are float arrays of at least one dimension; the caller sets NumPy's error
    state (0/0 and x/0 are expected where a row is off the support). Fewer, larger NumPy calls
    than one per bound: the sampler calls this on a few rows at a time, where each call's
    overhead is the cost.
    """
    r = b / a  # x = r sin^2(psi), rho = (r / 2) sin(2 psi)
    lo, up = prior.lower, prior.upper
    # x and m = a / x bound x; x = r sin^2 psi is increasing in psi.
    x_lo = np.maximum(lo["com_distance"], a / up["mass"])
    x_hi = np.minimum(up["com_distance"], a / lo["mass"])
    shape = r.shape
    if not x_lo.shape == shape == x_hi.shape:
        shape = np.broadcast_shapes(x_lo.shape, x_hi.shape, shape)
    # sin^2 psi at x_lo and x_hi, sin(2 psi) at rho_lo and rho_hi, clipped to [0, 1]
    sines = np.empty((4, *shape))
    sines[0] = x_lo
    sines[1] = x_hi
    sines[2] = 2 * lo["radius_of_gyration"]
    sines[3] = 2 * up["radius_of_gyration"]
    sines /= r
    never = sines[2] > 1  # rho can never reach its lower bound
    np.maximum(sines, 0.0, out=sines)
    np.minimum(sines, 1.0, out=sines)
    np.sqrt(sines[:2], out=sines[:2])
    np.arcsin(sines, out=sines)
    a0, a1 = sines[0], sines[1]
    # rho >= rho_lo: sin(2 psi) >= 2 rho_lo / r, an interval symmetric about pi/4.
    b0 = 0.5 * sines[2]
    b1 = HALF_PI - b0
    np.copyto(b1, -1.0, where=never)
    # rho <= rho_hi: psi <= c or psi >= pi/2 - c.
    c = 0.5 * sines[3]
    out = np.empty((4, *shape))
    start, hi1, lo2, end = out
    np.maximum(a0, b0, out=start)
    np.minimum(a1, b1, out=end)
    np.copyto(end, -1.0, where=x_lo >= np.minimum(x_hi, r))  # x has no room
    np.minimum(end, c, out=hi1)
    np.maximum(start, HALF_PI - c, out=lo2)
    return out


def feasible_measure(first_moment, inertia, prior: Box):
    """Length of ``Psi(a, b)`` in rad: the prior mass of the curve through ``(a, b)``, times a."""
    lo1, hi1, lo2, hi2 = feasible_angles(first_moment, inertia, prior)
    return np.maximum(hi1 - lo1, 0.0) + np.maximum(hi2 - lo2, 0.0)


def _reaches(obs: Observation, low: float, high: float) -> bool:
    """Whether ``[low, high]`` meets the values an observation allows (all but 1e-4 of them)."""
    half = obs.quantile_halfwidth()
    return obs.center + half >= low and obs.center - half <= high


@dataclass(frozen=True)
class ObservableRange:
    """The values of one observable that a prior box allows, and how a miss is explained.

    ``low`` and ``high`` in ``unit``; ``symbol`` (``I``, ``M_g``), ``trials`` (the kind of
    trials that give it) and ``causes`` (the slips that put it outside) for messages.
    """

    low: float
    high: float
    symbol: str
    unit: str
    trials: str
    causes: str


def observable_ranges(priors: Sequence[Prior], gravity: float) -> dict[str, ObservableRange]:
    """The ``I`` and ``M_g`` that bodies mounted together can give under their priors.

    Each body's range runs from its box's lower corner to its upper corner (``M_g`` from
    ``g m x``, ``I`` from ``m (rho^2 + x^2)``); bodies mounted in line add up. Keys
    ``"inertia"`` and ``"gravity_moment"``.
    """
    lo_g = sum(gravity * p.lower["mass"] * p.lower["com_distance"] for p in priors)
    up_g = sum(gravity * p.upper["mass"] * p.upper["com_distance"] for p in priors)
    lo_i = sum(
        p.lower["mass"] * (p.lower["radius_of_gyration"] ** 2 + p.lower["com_distance"] ** 2)
        for p in priors
    )
    up_i = sum(
        p.upper["mass"] * (p.upper["radius_of_gyration"] ** 2 + p.upper["com_distance"] ** 2)
        for p in priors
    )
    return {
        "gravity_moment": ObservableRange(
            lo_g,
            up_g,
            "M_g",
            "N m",
            "quasi-static trials",
            "a flat, clipped or wrongly scaled torque, too short a sweep",
        ),
        "inertia": ObservableRange(
            lo_i,
            up_i,
            "I",
            "kg m^2",
            "fast trials",
            "a wrongly scaled torque or velocity, a wrong window",
        ),
    }


def _check_data_in_box(cond: Condition, prior: Prior, gravity: float) -> None:
    """A condition's ``M_g`` or ``I`` that no point of its body's box reaches is a data problem.

    Each observable is held alone against the range the box allows
    (:func:`observable_ranges`), widened by the likelihood's 1e-4 quantiles. A flat or wrongly
    scaled quasi-static torque, or fast trials of another body, are then said as what they
    are; the prior's bounds are blamed only when each value alone fits.
    """
    ranges = observable_ranges([prior], gravity)
    observed = {"gravity_moment": cond.gravity_moment, "inertia": cond.inertia}
    for key, r in ranges.items():
        obs = observed[key]
        if obs is None or _reaches(obs, r.low, r.high):
            continue
        raise InputError(
            f"condition '{cond.label}': its {r.trials} give {r.symbol} = {obs.center:.4g} "
            f"± {obs.scale:.2g} {r.unit}, outside the {r.low:.4g} to {r.high:.4g} {r.unit} that "
            f"the prior '{prior.name}' of body '{cond.bodies[0]}' allows: check those trials "
            f"({r.causes}?) before the prior"
        )


def box_meets(
    first_moment: tuple[float, float], inertia: tuple[float, float], prior: Box, n: int = 4097
) -> bool:
    """Whether some ``(m, x, rho)`` of the prior box has ``a = m x`` and ``I`` in the ranges.

    For a fixed mass the box reaches ``a`` in ``[m x_lo, m x_up]`` and, at each such ``a``, every
    ``I = m rho^2 + a^2/m`` for ``rho`` in its bounds; both terms grow with their variable, so
    the inertias reachable within the ``a`` range form one interval with closed-form ends. The
    mass is then scanned on ``n`` points of its bounds, so a feasible region is missed only if
    its masses span less than ``1/(n - 1)`` of the box: a thin curve through a wide range of
    ``(a, I)`` (a Student-t of two trials spans orders of magnitude) is found wherever it is.
    """
    lo, up = prior.lower, prior.upper
    m = np.linspace(max(lo["mass"], 1e-12 * up["mass"]), up["mass"], n)
    a_lo = np.maximum(first_moment[0], m * lo["com_distance"])
    a_up = np.minimum(first_moment[1], m * up["com_distance"])
    i_lo = m * lo["radius_of_gyration"] ** 2 + a_lo**2 / m
    i_up = m * up["radius_of_gyration"] ** 2 + a_up**2 / m
    return bool(np.any((a_lo <= a_up) & (i_lo <= inertia[1]) & (i_up >= inertia[0])))


def angles_at(first_moment, inertia, prior: Box, fraction):
    """The angle ``fraction`` (in ``[0, 1)``) of the way through ``Psi(a, b)``.

    ``fraction`` broadcasts against ``(a, b)``; uniform fractions give uniform angles.
    """
    lo1, hi1, lo2, hi2 = feasible_angles(first_moment, inertia, prior)
    len1 = np.maximum(hi1 - lo1, 0.0)
    len2 = np.maximum(hi2 - lo2, 0.0)
    u = np.asarray(fraction) * (len1 + len2)
    return np.where(u < len1, lo1 + u, lo2 + (u - len1))


@functools.lru_cache(maxsize=8)
def _unit_midpoints(n: int) -> np.ndarray:
    """Midpoints of ``n`` equal cells of ``[0, 1]`` (read-only)."""
    mids = (np.arange(n) + 0.5) / n
    mids.flags.writeable = False
    return mids


def _curve_log_density(a, b, prior: Prior, n: int):
    """``log p_m p_x p_rho`` at the midpoints of ``n`` equal cells of ``Psi(a, b)``.

    ``a``, ``b`` are 1-D; returns ``(log density (rows, n), |Psi| (rows,))``. The cells are
    those of :func:`angles_at` (the two intervals laid end to end). The caller sets NumPy's
    error state.
    """
    feasible = _feasible_angles(a, b, prior)
    lens = feasible[1::2] - feasible[0::2]
    np.maximum(lens, 0.0, out=lens)
    lo1, lo2 = feasible[0], feasible[2]
    len1 = lens[0]
    measure = len1 + lens[1]
    ok = measure > 0
    all_ok = ok.all()
    u = _unit_midpoints(n)[None, :] * measure[:, None]
    _, _, log_f = _prior_on_curve(a, b, u, lo1, len1, lo2, ok, all_ok, prior)
    return (log_f if all_ok else np.where(ok[:, None], log_f, -np.inf)), measure


def _prior_on_curve(a, b, u, lo1, len1, lo2, ok, all_ok, prior: Prior):
    """``(m, x, log p_m p_x p_rho)`` at the angles ``u`` radians into ``Psi(a, b)``.

    ``u`` has a row per ``(a, b)``; ``lo1, len1, lo2`` are the two intervals of ``Psi`` laid end
    to end, ``ok`` the rows where it is not empty (``all_ok``: every row; the others are
    evaluated at ``a = b = 1`` and left for the caller to mask). The caller sets NumPy's error
    state. rho is computed only where its prior is not uniform.
    """
    psi = u + np.where(u < len1[:, None], lo1[:, None], (lo2 - len1)[:, None])
    if all_ok:
        aa, bb = a[:, None], b[:, None]
    else:
        aa, bb = np.where(ok, a, 1.0)[:, None], np.where(ok, b, 1.0)[:, None]
    mass, x, rho = physics.parameters_from_identified(
        aa, bb, psi, radius=prior.kind("radius_of_gyration") != "uniform"
    )
    return mass, x, prior.log_density(mass, x, rho, check_support=False)


def log_curve_integral(first_moment, inertia, prior: Prior, n: int = N_ANGLE_CELLS):
    """``log`` of the integral of ``p_m p_x p_rho`` over ``Psi(a, b)`` d psi (midpoint rule).

    ``a`` times the prior density of ``(a, b)``; ``-inf`` where ``Psi(a, b)`` is empty. For a
    box this is ``log(|Psi| / V)``, ``V`` the box's volume.
    """
    a, b = np.asarray(first_moment, float), np.asarray(inertia, float)
    if a.shape != b.shape:
        a, b = np.broadcast_arrays(a, b)
    flat_a, flat_b = a.ravel(), b.ravel()
    out = np.empty(flat_a.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(0, len(flat_a), _ROWS_PER_BLOCK):
            sl = slice(i, i + _ROWS_PER_BLOCK)
            log_f, measure = _curve_log_density(flat_a[sl], flat_b[sl], prior, n)
            top = log_f.max(-1)
            finite = np.isfinite(top)
            if finite.all():  # the usual case, in place: the same numbers as below
                log_f -= top[:, None]
                np.exp(log_f, out=log_f)
                out[sl] = top + np.log(log_f.sum(-1) / n) + np.log(measure)
                continue
            safe = np.where(finite, top, 0.0)
            mean = np.log(np.exp(log_f - safe[:, None]).mean(-1))
            out[sl] = np.where(finite, safe + mean + np.log(measure), -np.inf)
    return out.reshape(a.shape)


def log_identified_prior(first_moment, inertia, prior: Box):
    """Log prior density of ``(a, b)`` up to a constant per prior; ``-inf`` off the support.

    ``log(|Psi| / a)`` for a box (closed form), ``log_curve_integral - log a`` otherwise.
    ``prior`` may be a :class:`~inertiafit.inference.priors.Prior` or, for boxes only, bounds
    of several bodies as arrays.
    """
    a = np.asarray(first_moment, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        if getattr(prior, "is_box", True):
            return np.log(feasible_measure(a, inertia, prior)) - np.log(a)
        return log_curve_integral(a, inertia, prior) - np.log(a)  # type: ignore[arg-type]


def angle_density(first_moment: float, inertia: float, prior: Prior, psi, n: int = 4096):
    """Density of ``psi`` given ``(a, b)`` under the prior, at angles ``psi`` (1/rad).

    The exact ``p_m p_x p_rho`` along the curve over its integral (midpoint rule on ``n``
    cells); for a box ``1 / |Psi|`` on ``Psi(a, b)``. For tests and figures.
    """
    psi = np.asarray(psi, float)
    a = np.full(psi.shape, float(first_moment))
    b = np.full(psi.shape, float(inertia))
    lo1, hi1, lo2, hi2 = feasible_angles(a, b, prior)
    inside = ((psi >= lo1) & (psi <= hi1)) | ((psi >= lo2) & (psi <= hi2))
    with np.errstate(divide="ignore", invalid="ignore"):
        log_f = prior.log_density(*physics.parameters_from_identified(a, b, psi))
    log_z = log_curve_integral(float(first_moment), float(inertia), prior, n)
    return np.where(inside, np.exp(log_f - log_z), 0.0)


def draw_angles(first_moment, inertia, prior: Box, rng: np.random.Generator):
    """Draw ``psi`` from its prior given ``(a, b)``, for each pair (arrays of one shape).

    Uniform on ``Psi(a, b)`` for a box; otherwise from the density constant on each of
    :data:`N_ANGLE_CELLS` cells (inverse CDF, linear within cells). One uniform per draw.
    """
    shape = np.broadcast_shapes(np.shape(first_moment), np.shape(inertia))
    if getattr(prior, "is_box", True):
        return angles_at(first_moment, inertia, prior, rng.uniform(size=shape))
    v = rng.uniform(size=shape).ravel()
    a = np.broadcast_to(np.asarray(first_moment, float), shape).ravel()
    b = np.broadcast_to(np.asarray(inertia, float), shape).ravel()
    n = N_ANGLE_CELLS
    fraction = np.empty(v.shape)
    for i in range(0, len(v), _ROWS_PER_BLOCK):
        sl = slice(i, i + _ROWS_PER_BLOCK)
        with np.errstate(divide="ignore", invalid="ignore"):
            log_f, _ = _curve_log_density(a[sl], b[sl], prior, n)  # type: ignore[arg-type]
        top = log_f.max(-1, keepdims=True)
        w = np.exp(log_f - np.where(np.isfinite(top), top, 0.0))
        cdf = np.cumsum(w, -1)
        target = v[sl] * cdf[:, -1]
        cell = np.minimum((cdf <= target[:, None]).sum(-1), n - 1)
        rows = np.arange(len(cell))
        below = np.where(cell > 0, cdf[rows, np.maximum(cell - 1, 0)], 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            within = np.clip((target - below) / w[rows, cell], 0.0, 1.0)
        fraction[sl] = (cell + np.nan_to_num(within, nan=0.5)) / n
    return angles_at(a, b, prior, np.minimum(fraction, 1 - 1e-12)).reshape(shape)


@dataclass(frozen=True, init=False)
class Condition:
    """A set of bodies mounted together and the evidence measured on them.

    What is mounted is a :class:`~inertiafit.mounting.Mounting`:
    ``Condition(bodies, inertia, gravity_moment, label, coupling, offset_body=, offset=,
    added=)`` builds it from its fields; ``Condition(mounting, ...)`` (or
    ``mounting=``) takes one as it is. The mounting's fields (``bodies``, ``offset_body``,
    ``offset``, ``added``) and its added masses' moments (``added_first_moment``,
    ``added_inertia``) read through.

    Attributes
    ----------
    mounting : Mounting
        What is mounted: bodies (their ``I`` and ``M_g`` add up), a body moved along the lever,
        known added masses.
    inertia : Observation or None
        Evidence on the total inertia about the joint (kg m^2).
    gravity_moment : Observation or None
        Evidence on the total gravitational moment (N m).
    label : str
        Defaults to the mounting's :attr:`~inertiafit.mounting.Mounting.label` (the body
        names joined by ``+`` when plain).
    coupling : float
        ``dI/dM_g`` of the shared gravity-model error (kg m^2 per N m): the inertia evidence
        is evaluated at ``I + coupling * (M_g_obs - M_g)``, ``M_g_obs`` the gravity moment's
        centre. 0 when the errors are independent.
    """

    mounting: Mounting
    inertia: Observation | None
    gravity_moment: Observation | None
    label: str
    coupling: float

    def __init__(
        self,
        bodies: Sequence[str] | Mounting | None = None,
        inertia: Observation | None = None,
        gravity_moment: Observation | None = None,
        label: str = "",
        coupling: float = 0.0,
        *,
        offset_body: str = "",
        offset: float = 0.0,
        added: tuple[tuple[float, float, float], ...] = (),
        mounting: Mounting | None = None,
    ) -> None:
        if mounting is None:
            if isinstance(bodies, Mounting):
                mounting = bodies
            else:
                mounting = Mounting(tuple(bodies or ()), offset_body, offset, added)
        elif bodies is not None:
            raise InputError("condition: give the bodies or a mounting, not both")
        object.__setattr__(self, "mounting", mounting)
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(self, "gravity_moment", gravity_moment)
        object.__setattr__(self, "label", label or mounting.label)
        object.__setattr__(self, "coupling", coupling)
        where = f"condition '{self.label}'"
        if not math.isfinite(self.coupling):
            raise InputError(f"{where}: coupling must be finite")
        if self.coupling and self.gravity_moment is None:
            raise InputError(f"{where}: coupling needs a gravity moment")

    @property
    def bodies(self) -> tuple[str, ...]:
        """The mounted bodies."""
        return self.mounting.bodies

    @property
    def offset_body(self) -> str:
        """The body moved along the lever (``""``: none)."""
        return self.mounting.offset_body

    @property
    def offset(self) -> float:
        """How far it is moved (m)."""
        return self.mounting.offset

    @property
    def added_first_moment(self) -> float:
        """``m x`` of the known added masses (kg m)."""
        return self.mounting.added_moments[0]

    @property
    def added_inertia(self) -> float:
        """``I`` of the known added masses about the joint (kg m^2)."""
        return self.mounting.added_moments[1]

    @property
    def has_added(self) -> bool:
        """Whether known masses are mounted with the bodies."""
        return bool(self.mounting.added)

    def inertia_at(self, inertia, gravity_moment):
        """Where the inertia evidence is evaluated for true totals ``I`` and ``M_g`` (arrays)."""
        if not self.coupling:
            return inertia
        assert self.gravity_moment is not None
        return inertia + self.coupling * (self.gravity_moment.center - gravity_moment)


class Model:
    """Joint posterior over every body's ``(m, x, rho)`` given the conditions' evidence.

    Parameters
    ----------
    priors : mapping of str to Prior
        One prior per body (a box or other distributions), in the order bodies are reported.
    conditions : sequence of Condition
        What was measured; every body must appear in at least one condition.
    gravity : float
        Gravitational acceleration (m/s^2).
    torque_gain_sd : float
        SD of the log torque gain (relative SD of the gain; 0: not modelled). See the module
        docstring, "Systematic errors".
    measured : mapping of str to mapping of str to Observation, optional
        Direct measurements of a body's ``mass`` (kg; a scale) or ``com_distance`` (m, from the
        joint axis in the body's own mounting; a balance point), by body name
        (:data:`inertiafit.measured.MEASURED_QUANTITIES`); each becomes a
        :class:`~inertiafit.inference.terms.MeasuredEvidence`. See the module docstring, "Extra
        information".
    terms : sequence of Term, optional
        Further likelihood terms (:mod:`inertiafit.inference.terms`), of any registered kind.

    The model's :attr:`terms` are the extra terms (measurements first) and one
    :class:`~inertiafit.inference.terms.ConditionEvidence` per condition; the joint density,
    the angle grid, :meth:`log_likelihood_terms` and the samplers iterate them.
    """

    def __init__(
        self,
        priors: Mapping[str, Prior],
        conditions: Sequence[Condition],
        *,
        gravity: float = GRAVITY,
        torque_gain_sd: float = 0.0,
        measured: Mapping[str, Mapping[str, Observation]] | None = None,
        terms: Sequence[Term] = (),
    ) -> None:
        self.priors = dict(priors)
        self.bodies = tuple(self.priors)
        self.conditions = tuple(conditions)
        self.gravity = check_positive(gravity, "gravity", "m/s^2")
        torque_gain_sd = check_number(torque_gain_sd, "torque_gain_sd")
        if not (math.isfinite(torque_gain_sd) and 0 <= torque_gain_sd < MAX_TORQUE_GAIN_SD):
            raise InputError(
                f"torque_gain_sd: expected a relative SD in [0, {MAX_TORQUE_GAIN_SD:g}), "
                f"got {torque_gain_sd!r}"
            )
        self.torque_gain_sd = float(torque_gain_sd)
        if not self.conditions:
            raise InputError("model: no conditions (nothing was measured)")
        labels = [c.label for c in self.conditions]
        if len(set(labels)) != len(labels):
            raise InputError(f"model: condition labels repeat: {labels}")
        index = {b: i for i, b in enumerate(self.bodies)}
        self.membership = np.zeros((len(self.conditions), len(self.bodies)))
        for ci, cond in enumerate(self.conditions):
            for body in cond.bodies:
                if body not in index:
                    raise InputError(f"condition '{cond.label}': unknown body '{body}'")
                self.membership[ci, index[body]] = 1.0
        unused = [
            b for b, used in zip(self.bodies, self.membership.any(0), strict=True) if not used
        ]
        if unused:
            raise InputError(f"model: body '{unused[0]}' is in no condition")
        for body in measured or {}:
            if body not in index:
                raise InputError(f"measured: unknown body '{body}'")
        extra: list[Term] = [
            MeasuredEvidence(body, key, obs)
            for body in self.bodies
            for key, obs in (measured or {}).get(body, {}).items()
        ]
        for term in terms:
            unknown = [b for b in term.bodies if b not in index]
            if unknown:
                raise InputError(f"{term.kind} term '{term.label}': unknown body '{unknown[0]}'")
            extra.append(term)
        #: Evidence besides the conditions' (direct measurements first, then ``terms``).
        self.extra_terms: tuple[Term, ...] = tuple(extra)
        #: Every likelihood term: the extra ones, then one per condition (its evidence).
        self.terms: tuple[Term, ...] = (
            *self.extra_terms,
            *(ConditionEvidence(ci, c, self.gravity) for ci, c in enumerate(self.conditions)),
        )
        #: The terms off every angle: functions of the sampled coordinates alone.
        self._direct = tuple(t for t in self.terms if not t.angle_body)
        #: The ``log_likelihood`` variables the terms write, in the registry's order.
        self.variables: tuple[str, ...] = tuple(
            v
            for kind in TERM_KINDS.values()
            for v in kind.VARIABLES
            if any(v in t.variables for t in self.terms)
        )
        #: Conditions whose evidence involves a body's mass (a moved body), by body index.
        self.moved_conditions: dict[int, list[int]] = {}
        for ci, cond in enumerate(self.conditions):
            if cond.offset_body:
                self.moved_conditions.setdefault(index[cond.offset_body], []).append(ci)
        #: The terms on each body's angle, by body.
        self._angle_terms: dict[str, tuple[Term, ...]] = {
            body: tuple(t for t in self.terms if t.angle_body == body) for body in self.bodies
        }
        #: Bodies whose angle ``psi`` meets evidence (module docstring, "Extra information").
        self.curve_bodies = tuple(
            k
            for k, body in enumerate(self.bodies)
            if any(t.angle_body == body for t in self.terms)
        )
        self._added = np.array(
            [[c.added_first_moment, c.added_inertia] for c in self.conditions], dtype=float
        )
        self._has_added = bool(self._added.any())

    @property
    def measured(self) -> dict[str, dict[str, Observation]]:
        """Direct measurements by body and quantity (the ``measured`` argument, as terms)."""
        out: dict[str, dict[str, Observation]] = {}
        for t in self.extra_terms:
            if isinstance(t, MeasuredEvidence):
                out.setdefault(t.body, {})[t.quantity] = t.observation
        return out

    @property
    def has_gain(self) -> bool:
        """Whether the torque gain is a coordinate (``torque_gain_sd > 0``)."""
        return self.torque_gain_sd > 0

    @property
    def ndim(self) -> int:
        """Number of sampled coordinates: ``(log a, log b)`` per body, then ``log gain``."""
        return 2 * len(self.bodies) + int(self.has_gain)

    def split(self, z):
        """Sampled coordinates → observed-scale ``a`` (kg m) and ``b`` (kg m^2), ``(..., K)``.

        Without a torque gain these are the bodies' own values.
        """
        z = np.asarray(z)
        k2 = 2 * len(self.bodies)
        return np.exp(z[..., 0:k2:2]), np.exp(z[..., 1:k2:2])

    def log_gain(self, z):
        """The ``log gain`` coordinate, ``(...,)``; zeros without a torque gain."""
        z = np.asarray(z)
        return z[..., -1] if self.has_gain else np.zeros(np.shape(z)[:-1])

    def true_identified(self, z):
        """The bodies' true ``a`` and ``b``: observed-scale values over the gain."""
        a, b = self.split(z)
        if not self.has_gain:
            return a, b
        inv = np.exp(-self.log_gain(z))[..., None]
        return a * inv, b * inv

    def coordinates(self, first_moment, inertia, gain=None):
        """Sampled coordinates of true ``a``, ``b`` (``(..., K)``) and ``gain`` (``(...,)``)."""
        a = np.asarray(first_moment, float)
        b = np.asarray(inertia, float)
        lead = np.shape(a)[:-1]
        z = np.empty((*lead, self.ndim))
        log_g = np.zeros(lead) if gain is None else np.log(np.asarray(gain, float))
        with np.errstate(divide="ignore", invalid="ignore"):
            z[..., 0 : 2 * len(self.bodies) : 2] = np.log(a) + log_g[..., None]
            z[..., 1 : 2 * len(self.bodies) : 2] = np.log(b) + log_g[..., None]
        if self.has_gain:
            z[..., -1] = log_g
        return z

    @property
    def has_extra(self) -> bool:
        """Whether any evidence involves the angle ``psi`` (a measured or a moved body)."""
        return bool(self.curve_bodies)

    def _totals(self, z):
        """Observed-scale totals of every condition, ``(..., C)`` each, with added masses.

        A moved body enters with its own ``(a, b)`` only; its condition's term
        (:meth:`~inertiafit.inference.terms.ConditionEvidence.lines`) adds the part that
        depends on its mass.
        """
        a, b = self.split(z)
        total_a = a @ self.membership.T
        total_b = b @ self.membership.T
        if self._has_added:
            gain = np.exp(self.log_gain(z))[..., None]
            total_a = total_a + gain * self._added[:, 0]
            total_b = total_b + gain * self._added[:, 1]
        return total_a, total_b

    def _point(self, z, mass=None) -> Point:
        """Rows ``z`` as the terms see them (:class:`~inertiafit.inference.terms.Point`)."""
        total_a, total_b = self._totals(z)
        return Point(self, z, total_a, total_b, mass)

    def log_prior(self, z):
        """Log density of the marginal prior of the sampled coordinates, up to a constant.

        Per body ``log(integral over Psi(a, b) of the prior along the curve) + log b`` (the
        ``1/a`` of the Jacobian and the ``a b`` of the log coordinates cancel).
        """
        a, b = self.true_identified(z)
        out = np.zeros(np.shape(a)[:-1])
        for k, body in enumerate(self.bodies):
            prior = self.priors[body]
            if prior.is_box:
                with np.errstate(divide="ignore"):
                    out = out + np.log(feasible_measure(a[..., k], b[..., k], prior))
            else:  # the integral of the prior along the curve (module docstring)
                out = out + log_curve_integral(a[..., k], b[..., k], prior)
        out = out + np.log(b).sum(-1)
        if self.has_gain:
            out = out - 0.5 * (self.log_gain(z) / self.torque_gain_sd) ** 2
        return out

    def _stacked(self, point: Point, terms: Sequence[Term]) -> dict[str, np.ndarray]:
        """The ``terms``' log-likelihoods at ``point``, per variable ``(..., n_terms)``."""
        cols: dict[str, list[np.ndarray]] = {v: [] for v in self.variables}
        for term in terms:
            for var, value in term.log_likelihood(point).items():
                cols[var].append(value)
        return {v: np.stack(c, -1) for v, c in cols.items() if c}

    def log_likelihood_terms(self, z, mass=None) -> dict[str, np.ndarray]:
        """Pointwise log-likelihood of every piece of evidence, each ``(..., n_obs)``.

        One array per variable of :attr:`variables` (``inertia`` and ``gravity_moment`` along
        the conditions that have them, a measured quantity along the bodies measured;
        :meth:`likelihood_coords`). Evidence that involves a body's mass (a moved body, a
        measured one) needs the bodies' true masses ``mass`` (``(..., K)``, from
        :meth:`parameters`); without them only terms off the angle can be evaluated
        (``mass=None`` with such evidence is an error).
        """
        if mass is None and self.has_extra:
            raise ValueError("log_likelihood_terms: this model's evidence needs the masses")
        point = self._point(z, None if mass is None else np.asarray(mass, float))
        return self._stacked(point, self.terms)

    def likelihood_coords(self) -> dict[str, tuple[str, list[str]]]:
        """Each ``log_likelihood`` variable's dimension and labels (:meth:`log_likelihood_terms`)."""
        out: dict[str, tuple[str, list[str]]] = {}
        for var in self.variables:
            having = [t for t in self.terms if var in t.variables]
            out[var] = (having[0].dims()[var], [t.label for t in having])
        return out

    # -- evidence on the angle ---------------------------------------------------------------
    def _curve_terms(self, z, k: int, a_k, b_k) -> list[CurvePiece]:
        """The terms on body ``k``'s angle for rows ``z`` (2-D or ``None``), true ``a_k``, ``b_k``.

        Each term's :class:`~inertiafit.inference.terms.CurvePiece`: its log-likelihood on a grid
        of masses and CoM distances, the interval of masses outside which it holds less than
        :data:`~inertiafit.inference.terms.WINDOW_TAIL` of its mass, and its core
        (:data:`~inertiafit.inference.terms.CORE_SDS` SDs), all ``(rows,)``.

        The terms get the rows as a :class:`~inertiafit.inference.terms.Point` only when the
        body is moved in some condition; otherwise ``None``, as when the body is evaluated
        alone (:meth:`body_log_curve`): its terms involve that body only.
        """
        body = self.bodies[k]
        point = None if z is None or k not in self.moved_conditions else self._point(z)
        return [t.curve(point, a_k, b_k) for t in self._angle_terms[body]]

    def _curve_grid(self, z, k: int, a, b):
        """Body ``k``'s angle grid for rows ``z``: ``log f``, ``log`` cell width, cell edges.

        ``a``, ``b`` are the body's true values (rows); ``z`` is needed only when the body is
        moved in some condition (its evidence involves the other bodies).

        ``f`` is the prior density along the curve times the evidence on the angle, at the
        midpoints of cells laid over ``Psi(a, b)`` cut to where the evidence allows the body:
        :data:`N_EXTRA_CELLS` equal cells over that window and as many over the narrowest
        term's core, merged. Returns three ``(rows, cells)`` arrays.
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            log_f, log_w, grid, _ = self._angle_grid(z, k, a, b)
            return log_f, log_w, grid.edges()

    def _angle_grid(self, z, k: int, a, b, *, all_rows: bool = True):
        """:meth:`_curve_grid` with the cell edges as a :class:`_Cells` (made when asked).

        The caller sets NumPy's error state. Called on a few rows at a time by the sampler,
        so written for few NumPy calls: per-row quantities in stacked arrays, the cells of a
        window that needs no refining from constants (:data:`_UNIT_MIDS`), the logarithm of
        their widths over their few distinct values. The numbers are those of the plain formulas
        (one NumPy call per quantity), bit for bit.

        With ``all_rows=False`` the grid is computed only on the rows inside the support (the
        others' ``log f`` is ``-inf`` everywhere: nothing to compute), with the same cells as
        when all rows are; returns ``(log_f, log_w, cells, rows)``, ``rows`` the indices of
        the rows computed (``None``: all).
        """
        prior = self.priors[self.bodies[k]]
        terms = self._curve_terms(z, k, a, b)
        m_lo = np.zeros(a.shape)
        m_hi = np.full(a.shape, np.inf)
        core = narrowest = None
        for piece in terms:
            (lo, hi), (clo, chi) = piece.window, piece.core
            m_lo, m_hi = np.maximum(m_lo, lo), np.minimum(m_hi, hi)
            if core is None or (chi - clo < core[1] - core[0]).all():
                core, narrowest = (clo, chi), (lo, hi)
        assert core is not None
        assert narrowest is not None
        # Where the terms' windows do not meet (a state far from the data, where the terms
        # disagree), take the narrowest term's window: the density there is tiny but finite,
        # so a search from such a state can climb toward the posterior.
        apart = m_lo >= m_hi
        if apart.any():
            m_lo = np.where(apart, narrowest[0], m_lo)
            m_hi = np.where(apart, narrowest[1], m_hi)

        # psi of the mass m on the curve through (a, b): sin^2 psi = a^2 / (b m); psi falls as
        # m grows. Rows: window high, window low, core high, core low.
        ends = np.array([m_hi, m_lo, core[1], core[0]], dtype=float)
        np.maximum(ends, 0.0, out=ends)
        np.divide(a * a / b, ends, out=ends)
        np.maximum(ends, 0.0, out=ends)
        np.minimum(ends, 1.0, out=ends)
        np.sqrt(ends, out=ends)
        np.arcsin(ends, out=ends)
        # Psi(a, b) cut to the window: rows lo1, lo2 and hi1, hi2
        feasible = _feasible_angles(a, b, prior)
        los = np.maximum(feasible[0::2], ends[0])
        lens = np.minimum(feasible[1::2], ends[1])
        lens -= los
        np.maximum(lens, 0.0, out=lens)
        lo1, lo2 = los
        len1, len2 = lens
        total = len1 + len2
        ok = (total > 0) & (m_hi > m_lo)
        all_ok = ok.all()
        safe = total if all_ok else np.where(ok, total, 1.0)

        # the core's ends as fractions of the window (both intervals laid end to end)
        core_psi = ends[2:]
        f1 = core_psi - lo1
        np.maximum(f1, 0.0, out=f1)
        np.minimum(f1, len1, out=f1)
        f2 = core_psi - lo2
        np.maximum(f2, 0.0, out=f2)
        np.minimum(f2, len2, out=f2)
        f1 += f2
        f1 /= safe
        f_lo, f_hi = f1
        # unless the core is most of the window: then one grid will do
        refine = not (f_hi - f_lo > 0.5).all()
        if all_rows or all_ok:
            cells = self._grid_values(prior, terms, refine, a, b, ok, safe, lo1, len1, lo2, f1)
            return (*cells, None)
        # Only the rows inside the support. The choices above (one grid or a refined one, the
        # narrowest term) were made over every row, as they are when all rows are computed;
        # the terms' log-likelihoods on the curve are per row, taken again for these rows.
        rows = np.flatnonzero(ok)
        if not rows.size:
            return np.empty((0, 1)), np.empty((0, 1)), None, rows
        terms = self._curve_terms(None if z is None else z[rows], k, a[rows], b[rows])
        cells = self._grid_values(
            prior,
            terms,
            refine,
            a[rows],
            b[rows],
            ok[rows],
            safe[rows],
            lo1[rows],
            len1[rows],
            lo2[rows],
            f1[:, rows],
        )
        return (*cells, rows)

    @staticmethod
    def _grid_values(prior, terms, refine, a, b, ok, safe, lo1, len1, lo2, core_fractions):
        """The cells of :meth:`_angle_grid` and ``log f`` on them, from its per-row quantities.

        ``ok`` marks the rows inside the support (``safe``: the window's length there, 1
        elsewhere); ``core_fractions`` holds the core's ends as fractions of the window.
        Returns ``(log_f, log_w, cells)``.
        """
        all_ok = ok.all()
        f_lo, f_hi = core_fractions
        col = safe[:, None]
        if not refine:
            log_values = np.log(_UNIT_WIDTH_VALUES * col)
            cells = _Cells(None, col, log_values)
            u = _UNIT_MIDS * col
            log_w = log_values[:, _UNIT_WIDTH_INDEX]
            width_ok = bool((log_w > -np.inf).all())
        else:
            base = _UNIT_EDGES
            edges = np.concatenate(
                [
                    np.broadcast_to(base, (len(a), len(base))),
                    f_lo[:, None] + (f_hi - f_lo)[:, None] * base[None, :],
                ],
                axis=1,
            )
            edges.sort(axis=1, kind="stable")  # two sorted runs: merged, the same values
            cells = _Cells(edges, col)
            u = 0.5 * (edges[:, 1:] + edges[:, :-1]) * col
            width = np.diff(edges, axis=1) * col
            log_w = np.log(width)
            width_ok = bool((width > 0).all())
        mass, x, log_f = _prior_on_curve(a, b, u, lo1, len1, lo2, ok, all_ok, prior)
        for piece in terms:
            log_f = log_f + piece.log_likelihood(mass, x)
        if not (all_ok and width_ok):
            log_f = np.where(ok[:, None] & (log_w > -np.inf), log_f, -np.inf)
        cells.angles = (lo1, len1, lo2)
        return log_f, log_w, cells

    @staticmethod
    def _angle_at(u, lo1, len1, lo2):
        """The angle ``u`` radians into the two intervals laid end to end (rows of ``u``)."""
        return np.where(u < len1[:, None], lo1[:, None] + u, (lo2 - len1)[:, None] + u)

    def _log_marginal(self, z):
        """:meth:`log_prior` with the evidence on each angle integrated along with the prior."""
        z = np.atleast_2d(z)
        a, b = self.true_identified(z)
        out = np.zeros(len(z))
        for k, body in enumerate(self.bodies):
            prior = self.priors[body]
            if k in self.curve_bodies:
                out = out + self._log_curve_evidence(z, k, a[:, k], b[:, k])
            elif prior.is_box:
                with np.errstate(divide="ignore"):
                    out = out + np.log(feasible_measure(a[:, k], b[:, k], prior))
            else:
                out = out + log_curve_integral(a[:, k], b[:, k], prior)
        out = out + np.log(b).sum(-1)
        if self.has_gain:
            out = out - 0.5 * (self.log_gain(z) / self.torque_gain_sd) ** 2
        return out

    def _log_curve_evidence(self, z, k: int, a, b):
        """``log`` of the integral over ``psi`` of body ``k``'s prior times its evidence (rows)."""
        out = np.empty(len(a))
        with np.errstate(divide="ignore", invalid="ignore"):
            for i in range(0, len(a), _ROWS_PER_BLOCK):
                sl = slice(i, i + _ROWS_PER_BLOCK)
                log_f, log_w, _, rows = self._angle_grid(
                    None if z is None else z[sl], k, a[sl], b[sl], all_rows=False
                )
                top = log_f.max(-1)
                finite = np.isfinite(top)
                if finite.all():
                    log_f += log_w
                    log_f -= top[:, None]
                    np.exp(log_f, out=log_f)
                    value = top + np.log(log_f.sum(-1))
                else:
                    safe = np.where(finite, top, 0.0)
                    value = np.where(
                        finite,
                        safe + np.log(np.exp(log_f + log_w - safe[:, None]).sum(-1)),
                        -np.inf,
                    )
                if rows is None:
                    out[sl] = value
                else:  # rows outside the support: -inf
                    block = np.full(len(a[sl]), -np.inf)
                    block[rows] = value
                    out[sl] = block
        return out

    def body_log_curve(self, k: int, first_moment, inertia):
        """``log`` integral over ``psi`` of body ``k``'s prior times its own evidence.

        For a body whose angle meets only its own measurements (not moved in any condition):
        :func:`log_identified_prior` plus ``log a`` with the measurements included; for other
        bodies, :func:`log_curve_integral` (or ``log |Psi|`` for a box). True ``a``, ``b``.
        """
        a, b = np.broadcast_arrays(np.asarray(first_moment, float), np.asarray(inertia, float))
        prior = self.priors[self.bodies[k]]
        if k in self.moved_conditions:
            raise ValueError(f"body '{self.bodies[k]}' is moved: its evidence needs every body")
        if k in self.curve_bodies:
            flat = self._log_curve_evidence(None, k, a.ravel(), b.ravel())
            return flat.reshape(a.shape)
        if prior.is_box:
            with np.errstate(divide="ignore"):
                return np.log(feasible_measure(a, b, prior))
        return log_curve_integral(a, b, prior)

    def _draw_curve_angles(self, z, k: int, rng: np.random.Generator):
        """Body ``k``'s angle drawn exactly from its conditional (prior times the evidence)."""
        z = np.asarray(z)
        lead = z.shape[:-1]
        flat = z.reshape(-1, z.shape[-1])
        true_a, true_b = self.true_identified(flat)
        v = rng.uniform(size=len(flat))
        out = np.empty(len(flat))
        for i in range(0, len(flat), _ROWS_PER_BLOCK):
            sl = slice(i, i + _ROWS_PER_BLOCK)
            with np.errstate(divide="ignore", invalid="ignore"):
                log_f, log_w, cells, _ = self._angle_grid(
                    flat[sl], k, true_a[sl, k], true_b[sl, k]
                )
            edges, lo1, len1, lo2 = cells.edges()
            top = log_f.max(-1, keepdims=True)
            dens = np.exp(log_f - np.where(np.isfinite(top), top, 0.0))
            w = dens * cells.widths(log_w)
            cdf = np.cumsum(w, -1)
            target = v[sl] * cdf[:, -1]
            cell = np.minimum((cdf <= target[:, None]).sum(-1), w.shape[1] - 1)
            rows = np.arange(len(cell))
            below = np.where(cell > 0, cdf[rows, np.maximum(cell - 1, 0)], 0.0)
            with np.errstate(invalid="ignore", divide="ignore"):
                within = np.clip((target - below) / w[rows, cell], 0.0, 1.0)
            within = np.nan_to_num(within, nan=0.5)
            u = edges[rows, cell] + within * (edges[rows, cell + 1] - edges[rows, cell])
            out[sl] = self._angle_at(u[:, None], lo1, len1, lo2)[:, 0]
        return out.reshape(lead)

    def measured_bodies(self, key: str) -> list[str]:
        """Bodies with a measured ``key`` (``mass`` or ``com_distance``), in model order."""
        return [b for b in self.bodies if key in self.measured.get(b, {})]

    def log_prob(self, z):
        """Log posterior density of the sampled coordinates up to a constant (rows).

        The evidence that involves ``psi`` (measured and moved bodies) is integrated over it
        together with the prior (module docstring, "Extra information"). A row with a
        coordinate beyond ``_MAX_COORDINATE`` (or not a number) has none: ``-inf``, quietly.
        """
        z = np.atleast_2d(z)
        inside = np.all(np.abs(z) <= _MAX_COORDINATE, axis=-1)  # a NaN is not inside
        if not inside.all():  # no density out there (_MAX_COORDINATE), and nothing computed
            out = np.full(z.shape[:-1], -np.inf)
            if inside.any():
                out[inside] = self.log_prob(z[inside])
            return out
        lp = self.log_prior(z) if not self.has_extra else self._log_marginal(z)
        ok = np.isfinite(lp)
        if ok.all():  # the sampler's usual case: no rows to leave out
            return self._plus_direct(lp, self._point(z))
        out = np.full(lp.shape, -np.inf)
        if ok.any():
            out[ok] = self._plus_direct(lp[ok], self._point(z[ok]))
        return out

    def _plus_direct(self, total, point: Point):
        """``total`` plus the terms off every angle at ``point``, summed per variable in turn.

        The sums of :meth:`_stacked`'s columns, without stacking a variable of one column.
        """
        cols: dict[str, list[np.ndarray]] = {v: [] for v in self.variables}
        for term in self._direct:
            for var, value in term.log_likelihood(point).items():
                cols[var].append(value)
        for c in cols.values():
            if len(c) == 1:
                total = total + c[0]
            elif c:
                total = total + np.stack(c, -1).sum(-1)
        return total

    def parameters(self, z, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Complete sampled coordinates with exact angle draws → physical parameters.

        Returns a dict with ``mass``, ``com_distance``, ``radius_of_gyration``, ``inertia`` and
        ``gravity_moment``, each of shape ``(..., K)``, and with a torque gain ``torque_gain``
        of shape ``(...,)``.
        """
        a, b = self.true_identified(z)
        psi = np.empty_like(a)
        for k, body in enumerate(self.bodies):
            if k in self.curve_bodies:
                psi[..., k] = self._draw_curve_angles(z, k, rng)
            else:
                psi[..., k] = draw_angles(a[..., k], b[..., k], self.priors[body], rng)
        mass, x, rho = physics.parameters_from_identified(a, b, psi)
        out = {
            "mass": mass,
            "com_distance": x,
            "radius_of_gyration": rho,
            "inertia": b,
            "gravity_moment": self.gravity * a,
        }
        if self.has_gain:
            out["torque_gain"] = np.exp(self.log_gain(z))
        return out

    def prior_draws(self, size: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Draws from the prior, same layout as :meth:`parameters` with ``(size, K)``."""
        cols: dict[str, list] = {p: [] for p in (*PARAMETERS, "inertia", "gravity_moment")}
        for body in self.bodies:
            d = self.priors[body].sample(size, rng)
            for p in PARAMETERS:
                cols[p].append(d[p])
            m, x, rho = d["mass"], d["com_distance"], d["radius_of_gyration"]
            cols["inertia"].append(physics.inertia(m, rho, x))
            cols["gravity_moment"].append(physics.gravity_moment(m, x, self.gravity))
        out = {k: np.stack(v, -1) for k, v in cols.items()}
        if self.has_gain:
            out["torque_gain"] = np.exp(self.torque_gain_sd * rng.standard_normal(size))
        return out

    def check_feasible(self) -> None:
        """Fail early, and say why, when no point of a body's box can explain its evidence.

        Only single-body conditions with both observables are checked in closed form: the
        bound ``m >= (M_g/g)^2 / I`` and its twins for ``x`` and ``rho``, over the region
        where the likelihood holds all but 1e-4 of its mass.
        """
        self._check_measured_in_boxes()
        for cond in self.conditions:
            if len(cond.bodies) != 1 or not (cond.inertia and cond.gravity_moment):
                continue
            if cond.offset_body or cond.has_added:  # its totals are not the body's own
                continue
            prior = self.priors[cond.bodies[0]]
            _check_data_in_box(cond, prior, self.gravity)
            g0 = cond.gravity_moment.center
            a0 = g0 / self.gravity
            b0 = cond.inertia.center
            da = cond.gravity_moment.quantile_halfwidth() / self.gravity
            db = cond.inertia.quantile_halfwidth()
            if self.has_gain:  # the true values are the observed ones over a gain near 1
                da += 5 * self.torque_gain_sd * a0
            db += (
                5 * self.torque_gain_sd * cond.inertia.center
                + abs(cond.coupling) * da * self.gravity
            )
            a_range = (max(a0 - da, 1e-9 * a0), a0 + da)
            b_range = (max(b0 - db, 1e-9 * b0), b0 + db)
            if box_meets(a_range, b_range, prior):
                continue
            m_min = a0 * a0 / b0
            x_max = b0 / a0
            where = f"prior '{prior.name}'"
            if prior.upper["mass"] < m_min:
                why = (
                    f"mass upper bound {prior.upper['mass']:.4g} kg is below "
                    f"(M_g/g)^2/I = {m_min:.4g} kg"
                )
            elif prior.lower["com_distance"] > x_max:
                why = (
                    f"com_distance lower bound {prior.lower['com_distance']:.4g} m is above "
                    f"I g/M_g = {x_max:.4g} m"
                )
            elif prior.lower["radius_of_gyration"] > x_max / 2:
                why = (
                    f"radius_of_gyration lower bound {prior.lower['radius_of_gyration']:.4g} m "
                    f"is above I g/(2 M_g) = {x_max / 2:.4g} m"
                )
            else:
                why = (
                    f"no (m, x, rho) in the box gives M_g = {g0:.4g} N m and "
                    f"I = {b0:.4g} kg m^2 ((M_g/g)^2/I = {m_min:.4g} kg)"
                )
            raise InputError(
                f"{where}: the prior box contains no solution for condition '{cond.label}': {why}"
            )

    def _check_measured_in_boxes(self) -> None:
        """A weighed mass or balance point that its body's prior box cannot hold is a data slip.

        Said as such (with the unit slip it looks like), not as a density that no draw from the
        boxes can make finite.
        """
        for body, readings in self.measured.items():
            prior = self.priors[body]
            for key, obs in readings.items():
                quantity = MEASURED_QUANTITIES[key]
                lo, hi = prior.lower[key], prior.upper[key]
                if _reaches(obs, lo, hi):
                    continue
                ratio = obs.center / (lo if obs.center < lo else hi)
                slip = {1000.0: "grams entered as kg?", 100.0: "cm entered as m?"}
                hint = next(
                    (f" ({text})" for f, text in slip.items() if 0.3 * f < ratio < 3 * f), ""
                )
                raise InputError(
                    f"body '{body}': the {quantity.label} {obs.center:.4g} {quantity.unit} lies "
                    f"outside what its prior '{prior.name}' allows ({lo:.4g} to {hi:.4g} "
                    f"{quantity.unit}){hint}; check the reading and its unit, then the prior"
                )
