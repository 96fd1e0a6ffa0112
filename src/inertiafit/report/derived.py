"""What a paper reports beside ``m, x, rho``: quantities derived from the posterior's draws.

:func:`derived_table`: each body's moment of inertia about its centre of mass,
``I_com = m rho^2``, and, where the manifest gives the subject's ``body_mass`` and the body's
``segment_length``, ``m`` as % body mass and ``x``, ``rho`` as % segment length, each with its
median and HDI from the draws. :func:`published_table`: the published anthropometric tables'
predictions for the subject's segment (de Leva 1996, Dempster via Winter) beside the
posterior, in % of the posterior median and in posterior SDs.
"""

from __future__ import annotations

import json
from collections.abc import Mapping

import numpy as np
import pandas as pd

from inertiafit.errors import InputError
from inertiafit.inference.anthropometric import segment_values
from inertiafit.inference.priors import priors_from_posterior
from inertiafit.physics import REPORTED, gravity_moment, inertia
from inertiafit.posterior import Posterior

__all__ = [
    "DERIVED_COLUMNS",
    "PUBLISHED_COLUMNS",
    "body_sizes",
    "derived_table",
    "published_table",
]

#: Columns of :func:`derived_table`.
DERIVED_COLUMNS = ["body", "quantity", "unit", "median", "hdi_lower", "hdi_upper"]
#: Columns of :func:`published_table`.
PUBLISHED_COLUMNS = [
    "body",
    "table",
    "parameter",
    "table_value",
    "posterior_median",
    "posterior_sd",
    "percent_of_median",
    "posterior_sds",
]
_TABLE_NAMES = {
    "de-leva-female": "de Leva (1996), female",
    "de-leva-male": "de Leva (1996), male",
    "dempster": "Dempster (Winter)",
}


def _hdi(x: np.ndarray, prob: float) -> tuple[float, float]:
    from arviz_stats import hdi

    lo, hi = (float(v) for v in hdi(np.asarray(x, dtype=float).ravel(), prob=prob))
    return lo, hi


def _segment(post: Posterior, body: str) -> str | None:
    """The segment a body is: its anthropometric prior's, else its name if a table knows it."""
    try:
        named = priors_from_posterior(post)[body].anthropometric.get("segment")
    except (InputError, KeyError, AttributeError):
        named = None
    for candidate in (named, body):
        if not candidate:
            continue
        try:
            segment_values("dempster", str(candidate), 70.0, 0.3)
        except InputError:
            continue
        return str(candidate)
    return None


def body_sizes(post: Posterior) -> tuple[float | None, dict[str, float], str | None]:
    """The subject's body mass (kg), each body's segment length (m) and the subject's sex.

    As the manifest gave them (``[subject]``, ``[bodies.<name>] segment_length``), read from
    the posterior's ``inputs``; ``None`` and ``{}`` where not given.
    """
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    subject = inputs.get("subject") or {}
    mass = subject.get("body_mass")
    lengths = {str(k): float(v) for k, v in (inputs.get("segment_length") or {}).items()}
    sex = subject.get("sex")
    return (float(mass) if mass is not None else None), lengths, (str(sex) if sex else None)


def derived_table(
    post: Posterior,
    hdi_prob: float,
    *,
    body_mass: float | None = None,
    segment_lengths: Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """``I_com`` of every body, and its parameters relative to the subject where known.

    ``I_com = m rho^2`` (kg m^2) draw by draw; with ``body_mass`` (kg), ``m`` in % of it;
    with a body's ``segment_lengths`` (m), ``x`` and ``rho`` in % of it. Median and HDI of
    ``hdi_prob`` of each, from the draws (columns :data:`DERIVED_COLUMNS`).
    """
    lengths = dict(segment_lengths or {})
    rows = []
    for body in post.bodies:
        m = post.draws(body, "mass").ravel()
        x = post.draws(body, "com_distance").ravel()
        rho = post.draws(body, "radius_of_gyration").ravel()
        values = [("I_com = m rho^2", "kg m^2", m * rho**2)]
        if body_mass is not None:
            values.append(("m / body mass", "%", 100.0 * m / body_mass))
        if body in lengths:
            values.append(("x / segment length", "%", 100.0 * x / lengths[body]))
            values.append(("rho / segment length", "%", 100.0 * rho / lengths[body]))
        for quantity, unit, draws in values:
            lo, hi = _hdi(draws, hdi_prob)
            rows.append([body, quantity, unit, float(np.median(draws)), lo, hi])
    return pd.DataFrame(rows, columns=DERIVED_COLUMNS)


def published_table(
    post: Posterior,
    *,
    gravity: float,
    body_mass: float | None,
    segment_lengths: Mapping[str, float],
    sex: str | None = None,
) -> pd.DataFrame:
    """The published tables' values for each body that is a segment, beside its posterior.

    For every body naming a segment (:func:`_segment`) with the subject's ``body_mass`` and
    its own segment length: each table's ``m, x, rho, I, M_g``
    (:func:`~inertiafit.inference.anthropometric.segment_values`; de Leva's row of the
    subject's sex, both without one, and Dempster's), ``percent_of_median`` = ``100 (table /
    posterior median - 1)`` and ``posterior_sds`` = ``(table - median) / posterior SD``.
    Empty (columns :data:`PUBLISHED_COLUMNS`) where nothing is known.
    """
    rows: list[list] = []
    if body_mass is None:
        return pd.DataFrame(rows, columns=PUBLISHED_COLUMNS)
    sexes = [sex] if sex in ("female", "male") else ["female", "male"]
    for body in post.bodies:
        segment = _segment(post, body)
        if segment is None or body not in segment_lengths:
            continue
        for table in [*(f"de-leva-{s}" for s in sexes), "dempster"]:
            try:
                v = segment_values(table, segment, body_mass, segment_lengths[body])
            except InputError:
                continue
            m, x, rho = v.mass, v.com_distance, v.radius_of_gyration
            predicted: dict[str, float] = {
                "mass": m,
                "com_distance": x,
                "radius_of_gyration": rho,
                "inertia": float(inertia(m, rho, x)),
                "gravity_moment": float(gravity_moment(m, x, gravity)),
            }
            for p in REPORTED:
                draws = post.draws(body, p).ravel()
                median, sd = float(np.median(draws)), float(draws.std(ddof=1))
                value = predicted[p]
                rows.append(
                    [
                        body,
                        _TABLE_NAMES[table],
                        p,
                        value,
                        median,
                        sd,
                        100.0 * (value / median - 1.0),
                        (value - median) / sd,
                    ]
                )
    return pd.DataFrame(rows, columns=PUBLISHED_COLUMNS)
