"""One comparison table for every result, study or fit.

The posterior beside the prior, ideal bodies, the paper's estimator and published values.
:func:`comparison_table` builds it (a row per body and reported quantity). A study's
``comparison.csv`` shows the columns :data:`STUDY_COLUMNS` (the paper's Tables 2 and 3 with the
posterior beside them); a body fitted from numbers shows :data:`FIT_COLUMNS` (its prior's
nominal values and the published reference in the prior file). :func:`paper_baselines` applies
the paper's estimator to a study's trials as the paper does, for the table's ``baseline``
column (``inertiafit run`` and ``inertiafit report`` both call it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import pandas as pd

from inertiafit import physics
from inertiafit.baseline import BaselineResult, paper_baseline
from inertiafit.errors import InputError
from inertiafit.inference.priors import Prior
from inertiafit.physics import REPORTED, UNITS
from inertiafit.posterior import Posterior
from inertiafit.processing.study import condition_gravity, usable_trials

__all__ = [
    "COLUMNS",
    "FIT_COLUMNS",
    "STUDY_COLUMNS",
    "comparison_table",
    "paper_baselines",
    "prior_values",
]

#: Every column of :func:`comparison_table`.
COLUMNS = [
    "body",
    "parameter",
    "unit",
    "prior_nominal",
    "ideal",
    "reference",
    "posterior_median",
    "hdi_lower",
    "hdi_upper",
    "baseline",
    "posterior_vs_ideal",
    "baseline_vs_ideal",
    "ideal_in_hdi",
    "sd_ratio",
    "identified_by",
]
#: ``comparison.csv`` of a study (from trial files).
STUDY_COLUMNS = [
    "body",
    "parameter",
    "unit",
    "ideal",
    "posterior_median",
    "hdi_lower",
    "hdi_upper",
    "baseline",
    "posterior_vs_ideal",
    "baseline_vs_ideal",
    "ideal_in_hdi",
    "sd_ratio",
    "identified_by",
]
#: ``comparison.csv`` of one body fitted from numbers.
FIT_COLUMNS = [
    "parameter",
    "unit",
    "prior_nominal",
    "posterior_median",
    "hdi_lower",
    "hdi_upper",
    "baseline",
    "reference",
]


def prior_values(prior: Prior, gravity: float) -> tuple[dict[str, float], dict[str, float]]:
    """A prior's nominal values and published reference, with ``I`` and ``M_g`` derived."""
    n = prior.nominal
    nominal = dict(n)
    nominal["inertia"] = float(
        physics.inertia(n["mass"], n["radius_of_gyration"], n["com_distance"])
    )
    nominal["gravity_moment"] = float(
        physics.gravity_moment(n["mass"], n["com_distance"], gravity)
    )
    ref = {k: v for k, v in prior.reference.items() if k in REPORTED}
    if "gravity_moment" not in ref and {"mass", "com_distance"} <= set(ref):
        ref["gravity_moment"] = float(
            physics.gravity_moment(ref["mass"], ref["com_distance"], gravity)
        )
    return nominal, ref


def comparison_table(
    posterior: Posterior,
    priors: Mapping[str, Prior],
    *,
    hdi_prob: float,
    gravity: float,
    ideals: Mapping[str, Mapping[str, float]] | None = None,
    baselines: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """Per body and quantity: prior, ideal, reference, posterior, baseline, who identifies it.

    Parameters
    ----------
    posterior : Posterior
        The fit.
    priors : mapping of str to Prior
        Each body's prior (its nominal values and published reference).
    hdi_prob : float
        Probability of the posterior's highest-density interval.
    gravity : float
        m/s^2, for the nominal and reference ``M_g``.
    ideals : mapping, optional
        Ideal (textbook) values per body (SI units).
    baselines : mapping, optional
        The paper's estimator per body (:class:`~inertiafit.baseline.BaselineResult`).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COLUMNS`; relative differences are ``(value - ideal) / ideal``.
    """
    s = posterior.summary(hdi_prob).set_index(["body", "parameter"])
    ident = posterior.identification().set_index(["body", "parameter"])
    ideals = ideals or {}
    baselines = baselines or {}
    rows = []
    for body in posterior.bodies:
        nominal, ref = prior_values(priors[body], gravity)
        ideal = ideals.get(body, {})
        base = baselines[body].estimate if body in baselines else {}
        for p in REPORTED:
            med = float(s.loc[(body, p), "median"])
            lo, hi = float(s.loc[(body, p), "hdi_lower"]), float(s.loc[(body, p), "hdi_upper"])
            iv = float(ideal.get(p, math.nan))
            bv = float(base.get(p, math.nan))
            has_ideal = not math.isnan(iv)
            rows.append(
                {
                    "body": body,
                    "parameter": p,
                    "unit": UNITS[p],
                    "prior_nominal": nominal[p],
                    "ideal": iv,
                    "reference": ref.get(p, math.nan),
                    "posterior_median": med,
                    "hdi_lower": lo,
                    "hdi_upper": hi,
                    "baseline": bv,
                    "posterior_vs_ideal": (med - iv) / iv if has_ideal else math.nan,
                    "baseline_vs_ideal": (bv - iv) / iv if has_ideal else math.nan,
                    "ideal_in_hdi": (lo <= iv <= hi) if has_ideal else None,
                    "sd_ratio": float(ident.loc[(body, p), "sd_ratio"]),
                    "identified_by": ident.loc[(body, p), "identified_by"],
                }
            )
    return pd.DataFrame(rows, columns=COLUMNS)


def paper_baselines(
    trials: pd.DataFrame,
    conditions: Mapping[str, tuple[str, ...]],
    priors: Mapping[str, Prior],
    *,
    gravity: float,
    notes: list[str] | None = None,
) -> dict[str, BaselineResult]:
    """The paper's estimator per body, as the paper applies it.

    A body measured alone gets the multi-start fit of its condition's mean ``I`` and ``M_g``;
    a body added to another condition gets the fit of the differences of the condition means
    (Son et al., section 3.2: ``I_w = mean(I_b) - mean(I_a)``). Bodies measured neither way
    have no baseline; a baseline that cannot be computed is a line in ``notes``. Skipped trials
    (``status`` ``"skipped"``) are left out.
    """
    trials = usable_trials(trials)
    grav = condition_gravity(trials)
    means = {}
    for label, bodies in conditions.items():
        fast = trials[(trials["condition"] == label) & (trials["kind"] == "fast")]
        if len(fast) and label in grav:
            means[frozenset(bodies)] = (float(fast["inertia"].mean()), grav[label])
    out = {}
    for name, prior in priors.items():
        target = means.get(frozenset([name]))
        if target is None:
            for key, (i_b, g_b) in means.items():
                rest = key - {name}
                if name in key and rest in means:
                    i_a, g_a = means[rest]
                    target = (i_b - i_a, g_b - g_a)
                    break
        if target is None or target[0] <= 0 or target[1] <= 0:
            continue
        try:
            out[name] = paper_baseline(
                inertia=target[0],
                gravity_moment=target[1],
                nominal=prior.nominal,
                lower=prior.lower,
                upper=prior.upper,
                gravity=gravity,
            )
        except InputError as exc:
            if notes is not None:
                notes.append(f"baseline of '{name}' not computed: {exc}")
    return out
