"""Where trials become evidence: per-trial values → the likelihood terms of each condition.

:func:`condition_evidence` turns a processed study (:mod:`inertiafit.processing.study`) into one
:class:`~inertiafit.inference.model.Condition` per set of mounted bodies: a Student-t on the mean
of its fast trials' inertia, a Gaussian on its quasi-static gravity moment.
:func:`evidence_from_numbers` does the same for numbers quoted in a paper (values, mean ± SE,
or mean with SD and ``n``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from inertiafit._checks import check_positive
from inertiafit.errors import InputError
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior, load_prior

if TYPE_CHECKING:  # evidence reads these; importing them would load the processing stack
    from inertiafit.io import Study
    from inertiafit.processing.study import ProcessedStudy

__all__ = ["condition_evidence", "evidence_from_numbers", "study_model", "study_priors"]


def study_priors(study: Study) -> dict[str, Prior]:
    """Resolve every body's prior (shipped name, path relative to the manifest, or table)."""
    priors = {}
    for name, body in study.bodies.items():
        try:
            priors[name] = load_prior(body.prior, base_dir=study.base_dir, name=name)
        except InputError as exc:
            raise InputError(f"{study.path}: bodies.{name}.prior: {exc}") from None
    return priors


def condition_evidence(processed: ProcessedStudy) -> list[Condition]:
    """Evidence per condition: Student-t of its trials' inertia, Gaussian of its ``M_g``."""
    study = processed.study
    out = []
    for label, bodies in study.conditions.items():
        sub = processed.trials[processed.trials["condition"] == label]
        fast = sub[sub["kind"] == "fast"]
        where = f"{study.path}: condition {label}"
        obs_i = None
        if len(fast) >= 2:
            obs_i = Observation.from_values(fast["inertia"].to_numpy(), where=f"{where} inertia")
        elif len(fast) == 1:
            r = fast.iloc[0]
            obs_i = Observation.from_mean_se(
                r["inertia"], r["inertia_se"], where=f"{where} inertia"
            )
        obs_g = None
        if label in processed.gravity:
            g = processed.gravity[label]
            obs_g = Observation.from_mean_se(
                g.gravity_moment, g.gravity_moment_se, where=f"{where} gravity moment"
            )
        out.append(Condition(tuple(bodies), obs_i, obs_g, label=label))
    return out


def study_model(processed: ProcessedStudy, priors: dict[str, Prior] | None = None) -> Model:
    """The joint model over every body of the study (priors resolved when not given)."""
    return Model(
        priors if priors is not None else study_priors(processed.study),
        condition_evidence(processed),
        gravity=processed.study.gravity,
    )


def evidence_from_numbers(
    name: str,
    values: float | Sequence[float],
    se: float | None = None,
    sd: float | None = None,
    n: int | None = None,
) -> Observation:
    """Evidence on one observable from reported numbers.

    Parameters
    ----------
    name : str
        The observable's argument name (``inertia``, ``gravity_moment``), used in messages as
        ``name``, ``name_se``, ``name_sd`` and ``name_n``.
    values : float or sequence of float
        Trial values, or one value with ``se`` or with ``sd`` and ``n``.
    se : float, optional
        Standard error of a single value (Gaussian).
    sd, n : float, int, optional
        SD and number of the trials behind one mean (the same Student-t as the trials).
    """
    vals = [values] if np.isscalar(values) else list(values)  # type: ignore[list-item]
    if se is not None:
        se = check_positive(se, f"{name}_se")
    if sd is not None:
        sd = check_positive(sd, f"{name}_sd")
    if sd is not None or n is not None:
        if sd is None or n is None:
            raise InputError(f"{name}_sd and {name}_n go together; give both")
        if len(vals) != 1 or se is not None:
            raise InputError(f"{name}_sd/{name}_n describe one mean; give one {name} value")
        return Observation.from_mean_sd(vals[0], sd, n, where=name)
    return Observation.from_values(vals, se=se, where=name)
