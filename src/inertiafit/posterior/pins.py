"""What pins what: the prior's share of each parameter, correlations, and the sources per body.

One rotation axis identifies per body only ``a = m x`` (from ``M_g``) and ``b = I``; where the
body sits on the curve of constant ``(a, b)`` is decided by the prior unless more information
(a weighed mass, a balance point, a second mounting) pins it. This module measures that from
the draws of a fitted tree.

The prior's share
-----------------
``prior_share = d log(posterior SD) / d log(prior scale)``: how the posterior SD of a quantity
follows when the body's prior is made narrower. It is 1 where the prior alone sets the width,
0 where the data do, and for a Gaussian prior and likelihood it is exactly the prior's fraction
of the posterior precision, ``SD_post^2 / SD_prior^2``.

The derivative is a one-sided finite difference: every parameter's prior is shrunk about its
centre by the factor ``1 - PRIOR_SCALE_STEP`` (a box about the middle of its bounds, bounds and
all; a normal or truncated normal about its mean, with its SD; a lognormal in ``log`` about its
median, with ``sd_log``) and the existing draws are reweighted by the ratio of the shrunk to the
original density: ``exp(-z^2 (1/lambda^2 - 1) / 2)`` for a Gaussian shape, 0 or 1 for a box (a
draw outside the shrunk bounds drops out). Shrinking keeps the weights bounded (at most 1), so
no refit and no Pareto smoothing are needed. The share is ``log(SD_w / SD) / log(lambda)``.

Why not only ``arviz_stats.psense``: power-scaling a uniform prior, ``p^alpha``, leaves it
uniform on the same box, so ``psense`` reports no prior sensitivity for a box even where the
box alone decides a parameter (and for a box the log prior is constant, on which
``arviz_stats`` raises). Shrinking the box is the power-scaling of its width; for a normal prior
it is psense's own mechanism (``p^alpha`` is the normal with SD ``alpha^-1/2``). The psense
values are reported beside it where they mean something: the likelihood's always, the prior's
for priors that are not a box.

Sources
-------
Each ``log_likelihood`` variable says what it is credited as, in the attributes its term kind
wrote (:class:`inertiafit.inference.terms.Source`): ``source`` (the name, e.g. ``data``,
``weighed mass``), ``credits`` (``coordinate``: an entry informs the body its coordinate
names; ``all``: every body), ``pins`` (the parameters it measures directly) and
``moved_source`` (the name an entry is credited as for the body its condition moves:
``constant_data``'s ``offset_body`` at a non-zero ``offset``; a ``second mounting``). A body's
sources are ``data`` (always), then those that measure a parameter directly, then the rest, each
in the order of the variables; :func:`source_terms` sums each one's entries. A variable without
these attributes (a tree written before terms carried them, or built by hand) is read as the
quantity of :data:`~inertiafit.measured.MEASURED_QUANTITIES` it is named after, and otherwise
as the dynamometer's own evidence (:func:`variable_source`). Which of several sources pins a
parameter is read from ``psense`` of each source's log-likelihood terms (sensitivity >=
:data:`PSENSE_THRESHOLD`); ``data`` is always named except for a parameter another source
measures directly (``m`` of a weighed mass, ``x`` of a balance point), since the others follow
from ``m x`` and ``I`` as well. When none stands out all are named together.

The verdict
-----------
Who decides a quantity is said once, by :func:`verdict`, and every output reads it: the
identification table's ``identified_by`` (the body's prior against the rest) and ``pinned_by``
(the same with the sources named and the calibration prior's part), the text, the HTML and the
identification figures' titles. It reads the SD ratio ``r = posterior SD / prior SD`` (the
prior's SD from :func:`inertiafit.posterior.conflict.prior_draws`, exact to 0.3 %): ``data``
below :data:`DATA_DECIDES`, ``prior`` above :data:`PRIOR_DECIDES`, both between — with a band
of half-width ``max(VERDICT_MARGIN, 3 x its Monte Carlo SE)`` about each split inside which the
verdict names both (``data + prior``), which is true on either side of the split. The ratio is
the statistic because its Monte Carlo error is small (about 1 % of it; the SE from batch
means, :func:`batch_se`); the prior's share moves by 0.05-0.1 between seeds, and a verdict read
from it flipped between runs of the same data. The calibration prior's part is read from its
share with the same rule.

A share outside 0-1 beyond its Monte Carlo error (``prior_share_se``) is not noise: above 1,
narrowing the prior narrows the quantity faster than the prior (a box whose edges cut the curve
of constant ``m x`` and ``I``, or a prior the data pull against); below 0, narrowing the prior
widens it. Far outside, with a prior-data conflict (:mod:`inertiafit.posterior.conflict`), the
data contradict the prior and narrowing the prior moves the posterior rather than narrows it.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from inertiafit.formatting import share
from inertiafit.measured import MEASURED_QUANTITIES
from inertiafit.physics import PARAMETERS

__all__ = [
    "BATCHES",
    "DATA_DECIDES",
    "DATA_SOURCE",
    "PRIOR_DECIDES",
    "PRIOR_SCALE_STEP",
    "PSENSE_THRESHOLD",
    "SHARE_NOTE",
    "SHORT",
    "VERDICT_MARGIN",
    "VERDICT_NOTE",
    "batch_se",
    "body_sources",
    "correlation_table",
    "counted_sources",
    "direct_sources",
    "gain_scaling_log_weights",
    "living_bodies",
    "measured_quantities",
    "parameter_spec",
    "pinned_by",
    "pins_line",
    "prior_scaling_log_weights",
    "prior_share",
    "prior_specs",
    "sensitivity",
    "source_terms",
    "variable_source",
    "verdict",
]

#: Relative step by which the prior's scale is shrunk for :func:`prior_share`.
PRIOR_SCALE_STEP = 0.1
#: The splits of :func:`verdict`: at or below ``DATA_DECIDES`` (of the SD ratio, or of the
#: calibration prior's share) the data decide, at or above ``PRIOR_DECIDES`` the prior.
DATA_DECIDES = 0.3
PRIOR_DECIDES = 0.7
#: Least half-width of the band about each split inside which the verdict names both.
VERDICT_MARGIN = 0.05
#: Batches of draws behind the Monte Carlo SEs of :func:`batch_se`.
BATCHES = 8
#: What the verdict is, in one sentence (text, report.html).
VERDICT_NOTE = (
    "'identified by' compares each quantity's posterior SD with its prior's: data below 0.3, "
    "prior above 0.7, data + prior between - and within 0.05 (or 3 Monte Carlo SEs) of either "
    "split, so that runs of the same data with other seeds give the same verdict"
)
#: What the prior share means, and what a value outside 0-1 says (text, report.html).
SHARE_NOTE = (
    "prior share = d log(posterior SD) / d log(prior scale): 1 when the prior alone sets a "
    "quantity's width, 0 when the data do; estimated by reweighting the draws (its Monte Carlo "
    "SE is the column prior_share_se of identification.csv). Beyond that error a share above 1 "
    "means narrowing the prior narrows the quantity faster than the prior (a box whose edges "
    "cut the curve of constant m·x and I, or a prior the data pull against), one below 0 that "
    "it widens it; far outside 0-1 with a prior-data conflict, the data contradict the prior "
    "and narrowing it moves the posterior rather than narrows it - not Monte Carlo noise"
)
#: The dynamometer's own evidence: every body's first source.
DATA_SOURCE = "data"
#: psense sensitivity above which a source counts (Kallioinen et al.'s 0.05).
PSENSE_THRESHOLD = 0.05
#: Short names of the quantities in sentences.
SHORT = {
    "mass": "m",
    "com_distance": "x",
    "radius_of_gyration": "rho",
    "inertia": "I",
    "gravity_moment": "M_g",
}


def parameter_spec(lower: float, upper: float, distribution: Mapping[str, Any]) -> dict:
    """One parameter's prior as a scaling rule (the values of :func:`prior_specs`).

    ``lower``, ``upper`` are its support (SI units), ``distribution`` the prior's entry for it
    (``kind`` and its numbers, as :class:`~inertiafit.inference.priors.Prior` stores it; empty
    for a uniform box).
    """
    kind = distribution.get("kind", "uniform")
    if kind == "lognormal":
        return {
            "log": True,
            "center": math.log(distribution["median"]),
            "scale": float(distribution["sd_log"]),
            "gaussian": True,
            "lower": math.log(lower),
            "upper": math.log(upper),
        }
    if kind in ("normal", "truncated-normal"):
        return {
            "log": False,
            "center": float(distribution["mean"]),
            "scale": float(distribution["sd"]),
            "gaussian": True,
            "lower": lower,
            "upper": upper,
        }
    return {
        "log": False,
        "center": 0.5 * (lower + upper),
        "scale": math.nan,
        "gaussian": False,
        "lower": lower,
        "upper": upper,
    }


def prior_specs(tree: xr.DataTree) -> dict[str, dict[str, dict[str, Any]]]:
    """Each body's prior per parameter, read from the tree, as a scaling rule.

    Returns ``{body: {parameter: spec}}`` with ``spec`` keys ``log`` (bool: scaled in
    ``log``), ``center``, ``scale`` (the SD, ``nan`` for a box), ``gaussian`` (bool),
    ``lower``, ``upper`` (the support, in the scaled coordinate): :func:`parameter_spec`.
    Bodies without a stored ``distribution`` (older trees) are boxes.
    """
    cd = tree["constant_data"]
    try:
        stored = json.loads(tree.attrs.get("priors") or "{}")
    except (TypeError, ValueError):
        stored = {}
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for body in np.asarray(tree["posterior"]["body"]).tolist():
        dist = (stored.get(str(body)) or {}).get("distribution") or {}
        out[str(body)] = {
            p: parameter_spec(
                float(cd["lower"].sel(body=body, parameter=p)),
                float(cd["upper"].sel(body=body, parameter=p)),
                dist.get(p) or {},
            )
            for p in PARAMETERS
        }
    return out


def prior_scaling_log_weights(
    values: Mapping[str, np.ndarray], specs: Mapping[str, Mapping[str, Any]], factor: float
) -> np.ndarray:
    """Log importance weights that turn the posterior into the one under a rescaled prior.

    Every parameter's prior is scaled about its centre by ``factor`` (< 1 shrinks; see the
    module docstring); ``values`` holds the draws of ``mass``, ``com_distance`` and
    ``radius_of_gyration``. ``-inf`` where a draw leaves the scaled support.
    """
    shape = np.shape(values[PARAMETERS[0]])
    out = np.zeros(shape)
    for p in PARAMETERS:
        s = specs[p]
        v = np.asarray(values[p], float)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.log(v) if s["log"] else v
        c = s["center"]
        lo, hi = c + factor * (s["lower"] - c), c + factor * (s["upper"] - c)
        if s["gaussian"]:
            z = (u - c) / s["scale"]
            out = out - 0.5 * z * z * (1 / factor**2 - 1)
        out = np.where((u >= lo) & (u <= hi), out, -np.inf)
    return out


def gain_scaling_log_weights(torque_gain: np.ndarray, sd: float, factor: float) -> np.ndarray:
    """Log weights that shrink the torque gain's prior, ``log gain ~ N(0, sd^2)``, by ``factor``.

    The gain's prior is scaled the way :func:`prior_scaling_log_weights` scales a body's.
    """
    z = np.log(np.asarray(torque_gain, float)) / sd
    return -0.5 * z * z * (1 / factor**2 - 1)


def _weighted_sd(x: np.ndarray, w: np.ndarray) -> float:
    total = w.sum()
    if not total > 0:
        return math.nan
    mean = (w * x).sum() / total
    return math.sqrt(max((w * (x - mean) ** 2).sum() / total, 0.0))


def prior_share(
    draws: Mapping[str, np.ndarray],
    specs: Mapping[str, Mapping[str, Any]] | None,
    step: float = PRIOR_SCALE_STEP,
    *,
    torque_gain: np.ndarray | None = None,
    torque_gain_sd: float = 0.0,
) -> dict[str, float]:
    """``d log(posterior SD) / d log(prior scale)`` of every quantity in ``draws``.

    With ``specs`` the body's prior is scaled (``draws`` must then hold the three parameters
    and may hold more, e.g. ``inertia``, ``gravity_moment``; arrays of one shape). With
    ``specs=None`` and ``torque_gain`` (its draws) the torque gain's prior of SD
    ``torque_gain_sd`` is scaled instead: the calibration prior's share. ``nan`` for a
    quantity without spread.
    """
    factor = 1.0 - step
    if specs is not None:
        log_w = prior_scaling_log_weights(draws, specs, factor).ravel()
    elif torque_gain is not None and torque_gain_sd > 0:
        log_w = gain_scaling_log_weights(torque_gain, torque_gain_sd, factor).ravel()
    else:
        return dict.fromkeys(draws, math.nan)
    top = log_w.max()
    if not np.isfinite(top):
        return dict.fromkeys(draws, math.nan)
    w = np.exp(log_w - top)
    out = {}
    for q, values in draws.items():
        x = np.asarray(values, float).ravel()
        sd = float(x.std())
        sd_w = _weighted_sd(x, w)
        out[q] = math.log(sd_w / sd) / math.log(factor) if sd > 0 and sd_w > 0 else math.nan
    return out


def sensitivity(posterior: xr.Dataset, log_term: xr.DataArray) -> dict[str, float]:
    """``arviz_stats.psense`` of each variable of ``posterior`` to power-scaling ``log_term``.

    ``posterior`` holds one body's quantities ``(chain, draw)``, ``log_term`` a log density
    ``(chain, draw)`` (a likelihood's or a prior's). ``nan`` where psense cannot run (a
    constant term: power-scaling it changes nothing).
    """
    from arviz_stats import psense

    tree = xr.DataTree.from_dict(
        {"posterior": posterior, "log_likelihood": xr.Dataset({"term": log_term})}
    )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = psense(tree, group="likelihood")
    except ValueError:
        return {str(v): math.nan for v in posterior.data_vars}
    return {str(v): float(result[v]) for v in result.data_vars}


def variable_source(arr: xr.DataArray, name: str) -> dict[str, Any]:
    """What the ``log_likelihood`` variable ``name`` is credited as (module docstring).

    ``{"source", "credits", "pins", "moved_source"}`` from its attributes; without them, the
    measured quantity it is named after (on its body dimension) or the dynamometer's data.
    """
    attrs = arr.attrs
    if "source" in attrs:
        return {
            "source": str(attrs["source"]),
            "credits": str(attrs.get("credits", "coordinate")),
            "pins": tuple(str(attrs.get("pins", "")).split()),
            "moved_source": str(attrs.get("moved_source", "")),
        }
    q = MEASURED_QUANTITIES.get(name)
    if q is not None and q.body_dim in arr.dims:
        return {"source": q.label, "credits": "coordinate", "pins": (q.name,), "moved_source": ""}
    return {
        "source": DATA_SOURCE,
        "credits": "all",
        "pins": (),
        "moved_source": "second mounting",
    }


def _credited(
    tree: xr.DataTree, body: str
) -> list[tuple[str, tuple[str, ...], str, xr.DataArray]]:
    """Each part of the ``log_likelihood`` group that informs ``body``.

    ``(source, pins, variable, mask)``: ``mask`` a boolean along the variable's dimension,
    true for its entries credited to ``source``.
    """
    if "log_likelihood" not in tree.children:
        return []
    ll = tree["log_likelihood"].to_dataset()
    moved = set(_mountings(tree, body))
    out: list[tuple[str, tuple[str, ...], str, xr.DataArray]] = []
    for key, arr in ll.data_vars.items():
        name = str(key)
        dims = [str(d) for d in arr.dims if d not in ("chain", "draw")]
        if len(dims) != 1:
            continue
        dim = dims[0]
        labels = _labels(arr, dim)
        src = variable_source(arr, name)
        if src["credits"] == "all":
            is_moved = [bool(src["moved_source"]) and c in moved for c in labels]
            out.append(
                (src["source"], (), name, xr.DataArray([not m for m in is_moved], dims=dim))
            )
            if any(is_moved):
                out.append((src["moved_source"], (), name, xr.DataArray(is_moved, dims=dim)))
        elif body in labels:
            mask = xr.DataArray([c == body for c in labels], dims=dim)
            out.append((src["source"], src["pins"], name, mask))
    return out


def _ordered(found: Sequence[tuple[str, tuple[str, ...]]]) -> dict[str, tuple[str, ...]]:
    """Source names (and what they pin): ``data``, those that pin a parameter, the rest."""
    pins: dict[str, tuple[str, ...]] = {DATA_SOURCE: ()}
    for name, pinned in found:
        pins[name] = tuple(dict.fromkeys((*pins.get(name, ()), *pinned)))
    return {
        name: pins[name] for name in sorted(pins, key=lambda n: (n != DATA_SOURCE, not pins[n]))
    }


def body_sources(tree: xr.DataTree, body: str) -> list[str]:
    """The information sources of ``body``: ``data`` and any extra ones (module docstring)."""
    return list(_ordered([(s, p) for s, p, _, _ in _credited(tree, body)]))


def direct_sources(tree: xr.DataTree, body: str) -> dict[str, tuple[str, ...]]:
    """``body``'s sources that measure parameters directly, with those parameters."""
    found = _ordered([(s, p) for s, p, _, _ in _credited(tree, body)])
    return {s: p for s, p in found.items() if p}


def measured_quantities(tree: xr.DataTree, body: str) -> tuple[str, ...]:
    """Which of ``gravity_moment`` and ``inertia`` the data measure for ``body``.

    A quantity is measured when ``observed_data`` holds at least one value of it from a
    condition that mounts the body (the root attribute ``inputs``' ``conditions``; without
    it, the one body's every condition, or the bodies a ``+`` joins in a label). A study
    without fast trials measures no ``I``; one with a living body in one posture, no ``M_g``.
    """
    if "observed_data" not in tree.children:
        return ()
    held = json.loads(tree.attrs.get("inputs", "{}")).get("conditions")
    obs = tree["observed_data"].to_dataset()
    if held is None:  # fitted from numbers, or a Model built by hand: labels name the bodies
        labels = {
            str(v) for c in obs.coords if str(c).endswith("_condition") for v in obs[c].values
        }
        single = tree["posterior"].sizes.get("body", 1) == 1
        held = {c: [body] if single else c.split("+") for c in labels}
    mounting = {c for c, bodies in held.items() if body in bodies}
    found = []
    for name in ("gravity_moment", "inertia"):
        label = f"{name}_condition"
        if name not in obs or label not in obs.coords:
            continue
        if mounting & {str(v) for v in np.asarray(obs[label].values).tolist()}:
            found.append(name)
    return tuple(found)


def _labels(arr: xr.DataArray, dim: str) -> list[str]:
    return [str(v) for v in np.asarray(arr[dim]).tolist()] if dim in arr.dims else []


def _mountings(tree: xr.DataTree, body: str) -> list[str]:
    """Labels of the conditions that mount ``body`` at a non-zero offset."""
    cd = tree["constant_data"]
    if "offset" not in cd or "offset_body" not in cd:
        return []
    offsets = np.asarray(cd["offset"].values, float)
    owners = [str(v) for v in np.asarray(cd["offset_body"].values).tolist()]
    labels = [str(v) for v in np.asarray(cd["condition"].values).tolist()]
    return [
        c
        for c, d, o in zip(labels, offsets, owners, strict=True)
        if o == body and math.isfinite(d) and d != 0
    ]


def source_terms(tree: xr.DataTree, body: str) -> dict[str, xr.DataArray]:
    """Each source's summed log-likelihood ``(chain, draw)`` for ``body`` (its sources only)."""
    ll = tree["log_likelihood"].to_dataset()
    zero = xr.zeros_like(tree["posterior"].to_dataset()["mass"].isel(body=0, drop=True))
    credited = _credited(tree, body)
    terms = dict.fromkeys(_ordered([(s, p) for s, p, _, _ in credited]), zero)
    for source, _, name, mask in credited:
        terms[source] = terms[source] + ll[name].where(mask, 0.0).sum(str(mask.dims[0]))
    return terms


def counted_sources(
    sources: Sequence[str],
    parameter: str,
    sensitivities: Mapping[str, float],
    direct: Mapping[str, Sequence[str]] | None = None,
) -> list[str]:
    """The sources to name for ``parameter``: those whose psense reaches the threshold.

    ``data`` stays unless a source measures the parameter directly (``direct``: the
    parameters each source measures, :func:`direct_sources`; a weighed mass ``m``, a balance
    point ``x``): every other parameter follows from ``m x`` and ``I`` too. A source without
    a sensitivity counts; when none counts, all are named.
    """
    direct = direct or {}
    measured = any(parameter in direct.get(s, ()) for s in sources)
    counted = [
        s
        for s in sources
        if sensitivities.get(s, 1.0) >= PSENSE_THRESHOLD or (s == DATA_SOURCE and not measured)
    ]
    return counted or list(sources)


def batch_se(statistic, arrays: Sequence[np.ndarray], batches: int = BATCHES) -> Any:
    """Monte Carlo SE of ``statistic(*arrays)`` from batch means along the draws.

    ``arrays`` are ``(chain, draw)`` draws of one fit; each of ``batches`` runs of consecutive
    draws (every chain) gives the statistic once (a number, or an array of them), and the SE
    is their SD over ``sqrt(batches)``: a float, or an array of the statistic's shape.
    ``nan`` with fewer than two draws per batch, and where a batch's value is not finite.
    """
    arrays = [np.asarray(a) for a in arrays]
    size = arrays[0].shape[-1] // batches
    if size < 2:
        shape = np.shape(statistic(*arrays))
        return math.nan if shape == () else np.full(shape, math.nan)
    values = np.asarray(
        [statistic(*(a[..., k * size : (k + 1) * size] for a in arrays)) for k in range(batches)],
        float,
    )
    with np.errstate(invalid="ignore"):
        se = values.std(axis=0, ddof=1) / math.sqrt(batches)
    se = np.where(np.all(np.isfinite(values), axis=0), se, math.nan)
    return float(se) if se.ndim == 0 else se


def verdict(value: float, se: float = 0.0) -> str:
    """Who decides, from a 0 (data) to 1 (prior) scale: ``data``, ``data + prior`` or ``prior``.

    ``value`` is the SD ratio (posterior over prior) or the calibration prior's share, ``se``
    its Monte Carlo SE. ``data`` at or below :data:`DATA_DECIDES` and ``prior`` at or above
    :data:`PRIOR_DECIDES` by more than ``max(VERDICT_MARGIN, 3 se)``; ``data + prior``
    otherwise (module docstring). ``nan``: ``data`` (nothing to say the prior decides).
    """
    if not math.isfinite(value):
        return "data"
    margin = max(VERDICT_MARGIN, 3 * se) if math.isfinite(se) else VERDICT_MARGIN
    if value <= DATA_DECIDES - margin:
        return "data"
    if value >= PRIOR_DECIDES + margin:
        return "prior"
    return "data + prior"


def pinned_by(who: str, sources: Sequence[str], calibration: str = "data") -> str:
    """The verdict with its sources: who pins a quantity.

    ``who`` is the body's prior's :func:`verdict`, ``calibration`` the torque-gain prior's
    (from its share). ``prior`` when the body's prior decides, ``calibration prior`` when the
    gain's does, else the sources that count (``data + weighed mass``) with ``+ prior`` /
    ``+ calibration prior`` where they decide together.
    """
    if who == "prior":
        return "prior"
    if calibration == "prior":
        return "calibration prior"
    named = list(sources) or ["data"]
    if who == "data + prior":
        named.append("prior")
    if calibration == "data + prior":
        named.append("calibration prior")
    return " + ".join(named)


def living_bodies(tree: xr.DataTree) -> set[str]:
    """The living bodies of a study's tree (its ``living`` group's joint parameters' body)."""
    if "living" not in tree.children or "parameters" not in tree["living"].children:
        return set()
    table = tree["living"]["parameters"].to_dataset()
    if "body" not in table:
        return set()
    return {str(b) for b in np.asarray(table["body"].values).tolist() if str(b)}


def _join(names: Sequence[str]) -> str:
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def _share_range(shares: Sequence[float]) -> str:
    lo, hi = share(min(shares)), share(max(shares))
    return lo if lo == hi else f"{lo}-{hi}"


_PRIORS = {
    "prior": ("the prior", "prior_share"),
    "calibration prior": (
        "the torque-gain (calibration) prior",
        "calibration_share",
    ),
}


def pins_line(
    body: str,
    rows: Sequence[Mapping[str, Any]],
    sources: Sequence[str],
    *,
    living: bool = False,
    conflicts: Sequence[str] = (),
    measured: Sequence[str] = (),
) -> str:
    """One sentence per body: which information pins each of its quantities.

    ``rows`` are the body's identification rows (``parameter``, ``pinned_by``, ``prior_share``,
    ``sd_ratio``, optionally ``prior_share_se``, ``calibration_share``) in table order;
    ``sources`` what the body has (:func:`body_sources`); ``living``: a living segment (it can
    be neither weighed nor remounted, and is not told to); ``conflicts``: the short names of
    its quantities in prior-data conflict (:mod:`inertiafit.posterior.conflict`), which
    explain shares outside 0-1; ``measured``: which of ``gravity_moment`` and ``inertia`` the
    data measure (:func:`measured_quantities`; both: the data fix the body's curve).
    """
    curve = {"gravity_moment", "inertia"} <= set(measured)
    groups: dict[str, list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault(str(r["pinned_by"]), []).append(r)
    parts = []
    left: list[str] = []  # parameters the body's prior still (co-)decides
    for who, members in groups.items():
        names = _join([SHORT[str(r["parameter"])] for r in members])
        parts_of = who.split(" + ")
        priors = [c for c in parts_of if c in _PRIORS]
        others = [c for c in parts_of if c not in _PRIORS]
        shares = []
        for c in priors:
            column = _PRIORS[c][1]
            values = [float(r.get(column, math.nan)) for r in members]
            values = [v for v in values if math.isfinite(v)]
            if values:
                label = "prior share" if c == "prior" else "calibration share"
                shares.append(f"{label} {_share_range(values)}")
        if "prior" in priors and conflicts and shares:
            shares[0] += (
                ", read with the prior-data conflict: beyond 0-1 it is the data contradicting "
                "the prior, not Monte Carlo noise"
            )
        share = f" ({'; '.join(shares)})" if shares else ""
        if not priors:
            parts.append(f"{names} pinned by the {who}")
        elif not others:
            parts.append(f"{names} decided by {_PRIORS[priors[0]][0]}{share}")
        else:
            together = _join(["the " + " + ".join(others), *(_PRIORS[c][0] for c in priors)])
            on_curve = (
                curve
                and others == ["data"]
                and priors == ["prior"]
                and all(r["parameter"] in PARAMETERS for r in members)
            )
            where = (
                ": the data fix the curve of m·x and I, the prior where on it" if on_curve else ""
            )
            parts.append(f"{names} by {together} together{share}{where}")
        if "prior" in priors:
            left += [str(r["parameter"]) for r in members if r["parameter"] in PARAMETERS]
    line = f"{body}: " + "; ".join(parts)
    if conflicts:
        line += f"; prior-data conflict in {_join(list(conflicts))}"
    if left and list(sources) == ["data"]:
        if living and any(p in left for p in MEASURED_QUANTITIES):
            line += (
                " - a living segment can be neither weighed nor remounted: only a narrower "
                "prior (medical imaging, or a population of subjects: inertiafit population) "
                "would pin them"
            )
        elif any(p in left for p in MEASURED_QUANTITIES):
            line += (
                " - weigh it, find its balance point or mount it at a second distance from "
                "the axis to pin them"
            )
        else:  # m and x pinned: rho^2 = I/m - x^2 is what remains
            line += (
                " - rho^2 = I/m - x^2 is a small difference of pinned quantities here; only "
                "more precise I, m and x would pin it"
            )
    return line


def correlation_table(tree: xr.DataTree) -> list[dict[str, Any]]:
    """Posterior correlations of ``m``, ``x`` and ``rho`` per body (rows of a table)."""
    post = tree["posterior"]
    rows = []
    for body in np.asarray(post["body"]).tolist():
        cols = [np.asarray(post[p].sel(body=body).values, float).ravel() for p in PARAMETERS]
        with np.errstate(invalid="ignore", divide="ignore"):
            c = np.corrcoef(np.stack(cols))
        rows.append(
            {"body": str(body), "corr_m_x": c[0, 1], "corr_m_rho": c[0, 2], "corr_x_rho": c[1, 2]}
        )
    return rows
