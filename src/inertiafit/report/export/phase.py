"""The dynamometer's phase ``phi`` a results folder carries, for the exported models.

The device reads ``M_g sin(theta + phi)``: ``phi`` is the offset between its angle's zero and
the gravity vertical, one number for the shaft (bodies are mounted in line). A study measures
it in every quasi-static sweep (``trials.csv``'s ``gravity_phase``, kept in ``posterior.nc``)
and, for a living body, in the joint fit of gravity and the passive curve (``atan2(B, A)``).
:func:`data_phase` pools them in the reference posture (the joint fit's first, else the first
quasi-static trial's): a circular mean weighted by ``(M_g / SE)^2``, the inverse variance of a
phase. The rigid conditions' sweeps count once the living conditions' own rows are left out
(their single-trial phases mix gravity with the passive curve; the joint fit replaces them).
A folder of ``inertiafit fit`` (numbers, no trials) carries none: ``phi = 0``.
"""

from __future__ import annotations

import json
import math

import numpy as np

from inertiafit.posterior import Posterior
from inertiafit.processing.living import LIVING_GROUP

__all__ = ["data_phase"]


def _living(post: Posterior) -> tuple[list[tuple[float, float]], set[str], str]:
    """The joint fit's phases with weights, its conditions and its reference posture."""
    tree = post.tree
    if LIVING_GROUP not in tree.children or "fit" not in tree[LIVING_GROUP].children:
        return [], set(), ""
    fit = tree[LIVING_GROUP]["fit"].to_dataset()
    names = [str(n) for n in fit["coefficient"].values]
    mean = np.asarray(fit["mean"].values, dtype=float)
    cov = np.asarray(fit["covariance"].values, dtype=float)
    conds = [n.partition(":")[2] for n in names if n.startswith("A:")]
    out = []
    for c in conds:
        ia, ib = names.index(f"A:{c}"), names.index(f"B:{c}")
        a, b = mean[ia], mean[ib]
        length = math.hypot(a, b)
        grad = np.zeros(len(names))
        grad[ia], grad[ib] = -b / length**2, a / length**2
        se = math.sqrt(float(grad @ cov @ grad))
        out.append((math.atan2(b, a), 1.0 / se**2 if se > 0 else 0.0))
    postures = [str(p) for p in fit["posture"].values] if "posture" in fit.coords else []
    return out, set(conds), postures[0] if postures else ""


def data_phase(post: Posterior) -> tuple[float, str]:
    """``phi`` (rad) of the study behind ``post`` and a line saying where it comes from."""
    found, living, reference = _living(post)
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    trials = inputs.get("trials") or {}
    if isinstance(trials, str):  # an old file's table as text: not read back
        trials = {}
    rows = len(trials.get("kind", []))

    def column(name: str) -> list:
        return list(trials.get(name, [None] * rows))

    kinds, conds, status = column("kind"), column("condition"), column("status")
    phases, moments, ses = (
        column("gravity_phase"),
        column("gravity_moment"),
        column("gravity_moment_se"),
    )
    postures = [p if isinstance(p, str) else "" for p in column("posture")]
    if not reference:
        reference = next(
            (p for p, k in zip(postures, kinds, strict=True) if k == "quasi-static"), ""
        )
    n_trials = 0
    for i in range(rows):
        if kinds[i] != "quasi-static" or conds[i] in living or postures[i] != reference:
            continue
        if status[i] not in (None, "ok"):
            continue
        values = (phases[i], moments[i], ses[i])
        if not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
            continue
        if ses[i] <= 0 or moments[i] <= 0:
            continue
        found.append((float(phases[i]), (moments[i] / ses[i]) ** 2))
        n_trials += 1
    weight = sum(w for _, w in found)
    if not found or weight <= 0:
        return 0.0, "the results carry no gravity phase: 0"
    phase = math.atan2(
        sum(w * math.sin(p) for p, w in found), sum(w * math.cos(p) for p, w in found)
    )
    parts = []
    if n_trials:
        parts.append(f"{n_trials} quasi-static trial(s)")
    if len(found) > n_trials:
        parts.append("the living joint's fit")
    where = f" in posture {reference}" if reference else ""
    return phase, f"the gravity phase of {' and '.join(parts)}{where}"
