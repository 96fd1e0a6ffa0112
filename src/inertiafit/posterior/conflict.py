"""Prior-data conflict: whether each body's prior allows what its data measure.

One rotation axis measures per body ``I`` and ``M_g`` (and a weighing ``m``, a balance point
``x``); the prior places the body on the curve those leave. When the data lie where the prior
puts almost no mass — a de Leva forearm of a 72 kg subject mounted with a body twice as heavy —
the posterior is a compromise that neither believes: ``m`` lands several prior SDs out, and the
prior's share (:mod:`inertiafit.posterior.pins`) leaves 0-1 because narrowing the prior now
moves the posterior instead of narrowing it. This module says so.

The check
---------
For every body and every quantity the data measure of it, the *prior predictive* of the
data's own estimate: the prior's ``(m, x, rho)`` pushed through the physics (``I = m (rho^2 +
x^2)``, ``M_g = m g x``), times the torque gain's prior when there is one, plus the estimate's
own error. Its two-sided tail probability at the estimate,

    p = 2 min(P(Y <= y), P(Y >= y)),

is uniform on (0, 1) when the data come from a body the prior could have drawn; a quantity
with ``p <`` :data:`CONFLICT_TAIL` is in conflict.

*The data's own estimate* of a body's ``I`` (or ``M_g``) is the least-variance combination
``sum_c w_c y_c`` of the plain conditions' evidence (no body moved along the lever; known added
masses subtracted) whose expectation is the body's own value: condition A for the attachment,
B - A for the segment mounted on it. A body the conditions measure only together with another
(no condition without it) is checked through the conditions that hold it, named by their
bodies (``attachment+forearm``). A condition whose body is moved along the lever is left out
(its totals depend on ``m`` itself). A weighed mass and a balance point are checked against the
prior of ``m`` and ``x`` directly.

*The estimate's error* is each condition's evidence as the likelihood states it: a Student-t of
its scale and degrees of freedom, plus its shared Gaussian error, plus (an inertia) the
coupling times its gravity moment's error. The tail probability is the average over
:data:`N_PREDICTIVE` prior draws of the error's CDF (exact for a Gaussian error part; with only
Student-t terms the widest is integrated exactly and the others drawn). The draws are
quasi-random (scrambled Sobol points through each parameter's inverse CDF, a fixed seed; each
body its own dimensions), so the check is the same for every sampler seed: it reads the prior
and the evidence, never the posterior draws. Against quadrature over a box prior its tail
probabilities are within 0.1 % of their value between 0.005 and 0.05
(``tests/test_conflict.py``).

For repeated trials with unknown noise the Student-t is the likelihood, not exactly the
predictive of a sample mean with its own SD; where the prior is much wider than the SE (every
case of interest) the difference does not show (``tests/test_conflict.py`` measures the rate
of false alarms on studies simulated from the prior).
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from inertiafit.formatting import mean_sd, tail_probability
from inertiafit.measured import MEASURED_QUANTITIES
from inertiafit.physics import PARAMETERS, UNITS

__all__ = [
    "CONFLICT_TAIL",
    "N_PREDICTIVE",
    "Check",
    "ConditionData",
    "check_body",
    "condition_bodies",
    "conflict_lines",
    "predictive_tail",
    "prior_data_checks",
    "prior_draws",
]

#: Two-sided prior-predictive tail probability below which a quantity is in conflict.
CONFLICT_TAIL = 0.01
#: Prior draws behind each tail probability (quasi-random; fixed seed).
N_PREDICTIVE = 2**17
_SEED = 20_240_607
#: Short names of the quantities in the warning.
_SHORT = {"inertia": "I", "gravity_moment": "M_g", "mass": "m", "com_distance": "x"}


@dataclass(frozen=True)
class ConditionData:
    """One condition's evidence on one observable, as the check reads it.

    ``bodies`` are the mounted bodies (their values add), ``center``, ``scale``, ``df`` the
    evidence's Student-t (``df = inf``: Gaussian), ``extra_sd`` its Gaussian error besides
    (shared error; for an inertia, the coupling times its gravity moment's error) and
    ``added`` the known added masses' contribution (kg m^2 or N m).
    """

    label: str
    bodies: tuple[str, ...]
    center: float
    scale: float
    df: float
    extra_sd: float = 0.0
    added: float = 0.0

    @property
    def variance(self) -> float:
        """The error's variance (a Student-t of 2 or fewer degrees of freedom: 3 scales^2)."""
        factor = 1.0 if math.isinf(self.df) else self.df / (self.df - 2) if self.df > 2 else 3.0
        return self.scale**2 * factor + self.extra_sd**2


@dataclass(frozen=True)
class Check:
    """One quantity of one body against its prior predictive.

    ``body`` is the body (or the bodies joined by ``+`` when only their sum is measured),
    ``quantity`` ``inertia``, ``gravity_moment``, ``mass`` or ``com_distance``, ``source``
    ``data`` or the direct measurement's words; ``estimate`` and ``se`` the data's own
    estimate and its SE; ``prior_low``, ``prior_median``, ``prior_high`` the prior's central
    95 % of the quantity; ``lower_tail`` ``P(Y <= estimate)`` and ``p`` the two-sided tail
    probability.
    """

    body: str
    quantity: str
    source: str
    estimate: float
    se: float
    prior_low: float
    prior_median: float
    prior_high: float
    lower_tail: float
    p: float

    @property
    def conflict(self) -> bool:
        """Whether the tail probability is below :data:`CONFLICT_TAIL`."""
        return bool(self.p < CONFLICT_TAIL)

    def line(self) -> str:
        """The one-line warning (names the body and the quantity)."""
        symbol = _SHORT[self.quantity]
        unit = UNITS[self.quantity]
        side = "above" if self.lower_tail > 0.5 else "below"
        what = "the data give" if self.source == "data" else f"its {self.source} gives"
        return (
            f"prior-data conflict: {self.body} {symbol}: {what} "
            f"{mean_sd(self.estimate, self.se)} {unit}, {side} what its prior allows (95 % of "
            "the prior within "
            f"{self.prior_low:.4g}-{self.prior_high:.4g}; prior-predictive tail probability "
            f"{tail_probability(self.p)} < {CONFLICT_TAIL:g}); m, x and rho then rest on a prior the "
            "data contradict: check the prior (body mass, segment, units) and the data"
        )


# -- the prior pushed through the physics ---------------------------------------------------
#: Dimensions of the quasi-random points: three per body (its first :data:`_BODIES`), the
#: torque gain, then the Student-t terms drawn in :func:`predictive_tail`.
_BODIES = 4
_GAIN_DIM = 3 * _BODIES
_DIMS = _GAIN_DIM + 9


@functools.lru_cache(maxsize=4)
def _uniforms(n: int) -> np.ndarray:
    """``(n, _DIMS)`` points in (0, 1): scrambled Sobol (``n`` a power of 2), fixed seed."""
    if n >= 2 and n & (n - 1) == 0:
        from scipy.stats import qmc

        u = qmc.Sobol(_DIMS, scramble=True, seed=_SEED).random_base2(int(math.log2(n)))
    else:
        u = np.random.default_rng(_SEED).uniform(size=(n, _DIMS))
    u = np.clip(u, 1e-12, 1 - 1e-12)
    u.setflags(write=False)
    return u


def _column(n: int, dim: int) -> np.ndarray:
    """One dimension of :func:`_uniforms`; past its dimensions, independent pseudo-random."""
    if dim < _DIMS:
        return _uniforms(n)[:, dim]
    return np.random.default_rng([_SEED, dim]).uniform(1e-12, 1 - 1e-12, size=n)


@functools.lru_cache(maxsize=16)
def _student(n: int, dim: int, df: float) -> np.ndarray:
    """Student-t quantiles of one dimension of :func:`_uniforms` (cached: they are fixed)."""
    from scipy import special

    out = special.stdtrit(df, _column(n, dim))
    out.setflags(write=False)
    return out


_CDF_STEPS = 2**16


@functools.lru_cache(maxsize=16)
def _student_cdf(df: float) -> np.ndarray:
    """A Student-t's CDF on a uniform grid of ``arctan(z)`` over (-pi/2, pi/2)."""
    from scipy import special

    grid = np.linspace(-math.pi / 2, math.pi / 2, _CDF_STEPS + 1)
    with np.errstate(over="ignore"):
        table = special.stdtr(df, np.tan(grid))
    table[0], table[-1] = 0.0, 1.0
    table.setflags(write=False)
    return table


def _student_cdf_at(df: float, z: np.ndarray) -> np.ndarray:
    """The Student-t CDF at ``z``, linear in ``arctan(z)`` between the table's points.

    Exact to 1e-9, and far faster than ``scipy.special.stdtr`` on every draw.
    """
    table = _student_cdf(df)
    u = (np.arctan(z) + math.pi / 2) * (_CDF_STEPS / math.pi)
    k = np.clip(u.astype(np.int64), 0, _CDF_STEPS - 1)
    frac = u - k
    return table[k] + frac * (table[k + 1] - table[k])


def _spec_key(spec: Mapping[str, Any]) -> tuple:
    return tuple(
        (bool(spec[p]["log"]), bool(spec[p]["gaussian"]), *(float(spec[p][k]) for k in (
            "center", "scale", "lower", "upper")))
        for p in PARAMETERS
    )  # fmt: skip


@functools.lru_cache(maxsize=8)
def _draws_cached(key: tuple, n: int, stream: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from scipy import special

    out = []
    for k, (log, gaussian, center, scale, lower, upper) in enumerate(key):
        dim = 3 * stream + k if stream < _BODIES else _DIMS + 3 * stream + k
        u = _column(n, dim)
        if gaussian:
            a, b = special.ndtr((lower - center) / scale), special.ndtr((upper - center) / scale)
            v = center + scale * special.ndtri(a + u * (b - a))
        else:
            v = lower + u * (upper - lower)
        v = np.exp(v) if log else v
        v.setflags(write=False)
        out.append(v)
    return out[0], out[1], out[2]


def prior_draws(
    spec: Mapping[str, Mapping[str, Any]],
    gravity: float,
    n: int = N_PREDICTIVE,
    *,
    stream: int = 0,
) -> dict[str, np.ndarray]:
    """``n`` quasi-random draws of a body's prior and its ``I`` and ``M_g`` (fixed seed).

    ``spec`` is the body's prior as :func:`inertiafit.posterior.pins.prior_specs` reads it;
    ``stream`` numbers the body: bodies of other streams are drawn independently (a sum of
    bodies needs that), the same stream and prior give the same draws.
    """
    m, x, rho = _draws_cached(_spec_key(spec), n, stream)
    return {
        "mass": m,
        "com_distance": x,
        "radius_of_gyration": rho,
        "inertia": m * (rho * rho + x * x),
        "gravity_moment": m * gravity * x,
    }


def _gain_draws(sd: float, n: int) -> np.ndarray | None:
    if not sd > 0:
        return None
    from scipy import special

    return np.exp(sd * special.ndtri(_column(n, _GAIN_DIM)))


# -- the tail probability -------------------------------------------------------------------
def predictive_tail(
    mu: np.ndarray,
    estimate: float,
    terms: Sequence[tuple[float, float]],
    gaussian_sd: float,
) -> float:
    """``P(mu + E <= estimate)`` averaged over the draws ``mu``.

    ``E`` is ``sum_j s_j T_j`` (``terms`` = ``(s_j, df_j)``, ``T_j`` Student-t, Gaussian for
    ``df = inf``) plus an independent Gaussian of SD ``gaussian_sd``. The Gaussian part (all
    Gaussian terms together) is integrated exactly; without one, the widest Student-t is, and
    the other terms are drawn (quasi-random, fixed seed).
    """
    from scipy import special

    n = mu.size
    gauss = gaussian_sd**2 + sum(s * s for s, df in terms if math.isinf(df))
    student = [(abs(s), df) for s, df in terms if not math.isinf(df) and s != 0]
    exact: tuple[float, float] | None = None
    if gauss <= 0 and student:
        widest = max(range(len(student)), key=lambda j: student[j][0])
        exact = student.pop(widest)
    shift = np.zeros(n)
    for j, (s, df) in enumerate(student):
        shift = shift + s * _student(n, _GAIN_DIM + 1 + j, df)
    z = estimate - mu - shift
    if gauss > 0:
        cdf = special.ndtr(z / math.sqrt(gauss))
    elif exact is not None:
        cdf = _student_cdf_at(exact[1], z / exact[0])
    else:  # no error at all: the prior's own CDF
        cdf = (z >= 0).astype(float)
    return float(np.mean(cdf))


def _result(body, quantity, source, truth, estimate, se, lower) -> Check:
    lo, med, hi = (float(v) for v in np.quantile(truth, [0.025, 0.5, 0.975]))
    p = min(1.0, 2 * min(lower, 1 - lower))
    return Check(body, quantity, source, estimate, se, lo, med, hi, lower, p)


def _contrast(
    rows: Sequence[ConditionData], bodies: Sequence[str], body: str
) -> np.ndarray | None:
    """Least-variance weights ``w`` with ``sum_c w_c (bodies of c) = body``; None if none."""
    if not rows or body not in bodies:
        return None
    a = np.array([[1.0 if b in r.bodies else 0.0 for b in bodies] for r in rows])
    v = np.array([max(r.variance, 1e-300) for r in rows])
    target = np.array([1.0 if b == body else 0.0 for b in bodies])
    if not a[:, bodies.index(body)].any():
        return None
    scaled = a / v[:, None]
    w = scaled @ np.linalg.pinv(a.T @ scaled) @ target
    if not np.allclose(a.T @ w, target, atol=1e-8):
        return None
    return np.where(np.abs(w) < 1e-12, 0.0, w)


def check_body(
    body: str,
    quantity: str,
    rows: Sequence[ConditionData],
    draws: Mapping[str, Mapping[str, np.ndarray]],
    *,
    gain_sd: float = 0.0,
) -> Check | None:
    """The check of ``body``'s ``quantity`` from the plain conditions ``rows`` (None: unmeasured).

    ``draws`` holds every body's prior draws (:func:`prior_draws`).
    """
    bodies = list(draws)
    w = _contrast(rows, bodies, body)
    if w is None:
        return None
    used = [(wc, r) for wc, r in zip(w, rows, strict=True) if wc != 0]
    estimate = sum(wc * (r.center - r.added) for wc, r in used)
    se = math.sqrt(sum(wc * wc * r.variance for wc, r in used))
    truth = np.asarray(draws[body][quantity])
    gain = _gain_draws(gain_sd, truth.size)
    added = sum(wc * r.added for wc, r in used)
    mu = truth + added if gain is None else gain * (truth + added)
    lower = predictive_tail(
        mu,
        estimate + added,
        [(wc * r.scale, r.df) for wc, r in used],
        math.sqrt(sum((wc * r.extra_sd) ** 2 for wc, r in used)),
    )
    return _result(body, quantity, "data", truth, estimate, se, lower)


def _sum_check(
    quantity: str,
    row: ConditionData,
    draws: Mapping[str, Mapping[str, np.ndarray]],
    gain_sd: float,
) -> Check:
    """A condition's total against the summed priors of its bodies."""
    truth = sum(np.asarray(draws[b][quantity]) for b in row.bodies)
    assert isinstance(truth, np.ndarray)
    gain = _gain_draws(gain_sd, truth.size)
    mu = truth + row.added if gain is None else gain * (truth + row.added)
    lower = predictive_tail(mu, row.center, [(row.scale, row.df)], row.extra_sd)
    se = math.sqrt(row.variance)
    return _result(
        "+".join(row.bodies), quantity, "data", truth, row.center - row.added, se, lower
    )


def _measured_check(
    body: str, quantity: str, label: str, value: float, sd: float, truth: np.ndarray
) -> Check:
    lower = predictive_tail(truth, value, [], sd)
    return _result(body, quantity, label, truth, value, sd, lower)


# -- from a tree -----------------------------------------------------------------------------
def condition_bodies(tree: xr.DataTree) -> dict[str, list[str]]:
    """Each condition label's mounted bodies.

    From the root attribute ``inputs``' ``conditions`` (a study); without it, a posterior of
    one body mounts it in every condition, and otherwise a label's ``+``-joined names that
    are bodies are its bodies (a model built by hand).
    """
    try:
        held = json.loads(tree.attrs.get("inputs", "{}") or "{}").get("conditions")
    except (TypeError, ValueError, AttributeError):
        held = None
    bodies = [str(b) for b in np.asarray(tree["posterior"]["body"]).tolist()]
    labels: list[str] = []
    if "constant_data" in tree.children and "condition" in tree["constant_data"].coords:
        labels = [str(v) for v in np.asarray(tree["constant_data"]["condition"]).tolist()]
    if "observed_data" in tree.children:
        obs = tree["observed_data"].to_dataset()
        for c in obs.coords:
            if str(c).endswith("_condition"):
                labels += [str(v) for v in np.asarray(obs[c].values).tolist()]
    labels = list(dict.fromkeys(labels))
    if isinstance(held, dict):
        out = {str(k): [str(b) for b in v] for k, v in held.items()}
        return {**{c: [b for b in c.split("+") if b in bodies] for c in labels}, **out}
    if len(bodies) == 1:
        return {c: list(bodies) for c in labels}
    return {c: [b for b in c.split("+") if b in bodies] for c in labels}


def _rows(tree: xr.DataTree, quantity: str) -> list[ConditionData]:
    """The plain conditions' evidence on ``quantity`` (``inertia`` or ``gravity_moment``)."""
    cd = tree["constant_data"].to_dataset()
    if f"{quantity}_center" not in cd or "condition" not in cd.coords:
        return []
    held = condition_bodies(tree)
    labels = [str(v) for v in np.asarray(cd["condition"].values).tolist()]
    g = float(cd["gravity"]) if "gravity" in cd else 9.81

    def col(name: str, default: float = 0.0) -> np.ndarray:
        if name not in cd:
            return np.full(len(labels), default)
        return np.asarray(cd[name].values, float)

    center, scale, df = col(f"{quantity}_center", math.nan), col(f"{quantity}_scale"), col(
        f"{quantity}_df", math.inf)  # fmt: skip
    shared = col(f"{quantity}_shared_sd")
    offset = col("offset")
    coupling = col("coupling")
    mg_scale, mg_shared = col("gravity_moment_scale", math.nan), col("gravity_moment_shared_sd")
    mg_df = col("gravity_moment_df", math.inf)
    added = col("added_inertia") if quantity == "inertia" else g * col("added_first_moment")
    rows = []
    for k, label in enumerate(labels):
        if not (math.isfinite(center[k]) and scale[k] > 0) or not held.get(label):
            continue
        if math.isfinite(offset[k]) and offset[k] != 0:  # a moved body: its totals read m
            continue
        extra = shared[k] ** 2
        if quantity == "inertia" and coupling[k] and math.isfinite(mg_scale[k]):
            mg_var = ConditionData("", (), 0.0, mg_scale[k], mg_df[k], mg_shared[k]).variance
            extra += coupling[k] ** 2 * mg_var
        rows.append(
            ConditionData(
                label,
                tuple(held[label]),
                float(center[k]),
                float(scale[k]),
                float(df[k]),
                math.sqrt(extra),
                float(added[k]) if math.isfinite(added[k]) else 0.0,
            )
        )
    return rows


def prior_data_checks(tree: xr.DataTree) -> list[Check]:
    """Every body's measured quantities against their prior predictive (module docstring).

    In order: per quantity (``inertia``, ``gravity_moment``) each body the data measure on
    its own, then the sums of bodies measured only together; then weighed masses and balance
    points.
    """
    from inertiafit.posterior.pins import prior_specs

    if "constant_data" not in tree.children:
        return []
    cd = tree["constant_data"].to_dataset()
    g = float(cd["gravity"]) if "gravity" in cd else 9.81
    gain_sd = float(cd["torque_gain_sd"]) if "torque_gain_sd" in cd else 0.0
    specs = prior_specs(tree)
    draws = {b: prior_draws(s, g, stream=k) for k, (b, s) in enumerate(specs.items())}
    out: list[Check] = []
    for quantity in ("inertia", "gravity_moment"):
        rows = _rows(tree, quantity)
        alone = set()
        for body in draws:
            found = check_body(body, quantity, rows, draws, gain_sd=gain_sd)
            if found is not None:
                out.append(found)
                alone.add(body)
        seen = set()
        for row in rows:  # bodies measured only together with others
            if row.bodies in seen or set(row.bodies) <= alone:
                continue
            seen.add(row.bodies)
            out.append(_sum_check(quantity, row, draws, gain_sd))
    for key, q in MEASURED_QUANTITIES.items():
        name, sd_name = q.constant_vars
        if name not in cd or key not in PARAMETERS:
            continue
        for body in draws:
            value = float(cd[name].sel(body=body))
            sd = float(cd[sd_name].sel(body=body))
            if math.isfinite(value) and math.isfinite(sd):
                out.append(_measured_check(body, key, q.label, value, sd, draws[body][key]))
    return out


def conflict_lines(tree: xr.DataTree) -> list[str]:
    """One warning line per quantity in conflict (:meth:`Check.line`)."""
    return [c.line() for c in prior_data_checks(tree) if c.conflict]
