"""The star structure of a model: shared bodies (an attachment) and leaves (its segments).

A *leaf* body is mounted in exactly one condition, with no other leaf, and that condition has
both observables; every other body is *shared*. The blocked sampler
(:mod:`inertiafit.inference.blocked`) and the exact reference
(:func:`inertiafit.inference.reference.star_reference`) both work in this decomposition; it
lives here so that the reference imports nothing of the sampler it judges.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inertiafit.inference.model import Model

__all__ = ["Star", "star_structure"]


@dataclass(frozen=True)
class Star:
    """Which bodies are shared, which are leaves, and how the conditions combine them.

    Attributes
    ----------
    shared, leaves : tuple of int
        Body indices into ``model.bodies``.
    leaf_conditions : tuple of int
        Index of each leaf's condition in ``model.conditions``.
    shared_conditions : tuple of int
        Conditions that hold shared bodies only.
    weights : ndarray, shape (n_leaves, n_shared)
        1 where a shared body is mounted in a leaf's condition.
    """

    shared: tuple[int, ...]
    leaves: tuple[int, ...]
    leaf_conditions: tuple[int, ...]
    shared_conditions: tuple[int, ...]
    weights: np.ndarray


def star_structure(model: Model) -> Star | None:
    """The shared/leaf decomposition of ``model``, or ``None`` where the blocked sampler can't run.

    It runs when at least one body is a leaf (see the module docstring) and every shared body is
    measured in some condition without leaves, with both observables in every such condition:
    their evidence anchors the shared proposal.
    """
    if any(c.offset_body or c.has_added for c in model.conditions):
        return None  # a moved body or a known added mass: the joint sampler handles those
    member = model.membership.astype(bool)  # (conditions, bodies)
    n_cond_of_body = member.sum(0)
    candidates = [j for j in range(len(model.bodies)) if n_cond_of_body[j] == 1]
    leaves, leaf_conds = [], []
    for j in candidates:
        ci = int(np.flatnonzero(member[:, j])[0])
        cond = model.conditions[ci]
        if cond.inertia is None or cond.gravity_moment is None:
            continue
        others = [i for i in np.flatnonzero(member[ci]) if i != j]
        if any(i in candidates for i in others):
            continue  # two single-condition bodies in one condition: not a star
        leaves.append(j)
        leaf_conds.append(ci)
    if not leaves:
        return None
    names = {model.bodies[j] for j in leaves}
    for t in model.extra_terms:  # on a leaf, only a term on its own angle (its prior's curve)
        if names.intersection(t.bodies) and (len(t.bodies) > 1 or t.angle_body not in names):
            return None
    shared = [j for j in range(len(model.bodies)) if j not in leaves]
    shared_conds = [ci for ci in range(len(model.conditions)) if ci not in leaf_conds]
    if shared:
        covered = member[shared_conds][:, shared].any(0) if shared_conds else np.zeros(len(shared))
        if not np.all(covered):
            return None
        if any(member[ci][leaves].any() for ci in shared_conds):
            return None
        own = [model.conditions[ci] for ci in shared_conds]
        if any(c.inertia is None or c.gravity_moment is None for c in own):
            return None  # the shared proposal's Laplace fit needs both observables
    weights = np.array([[member[ci, s] for s in shared] for ci in leaf_conds], dtype=float)
    return Star(
        tuple(shared),
        tuple(leaves),
        tuple(leaf_conds),
        tuple(shared_conds),
        weights.reshape(len(leaves), len(shared)),
    )
