"""The ``[passive]`` table: the living body's joint and the priors of its passive model."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from inertiafit._checks import check_interval
from inertiafit.io.sections.base import (
    Section,
    as_table,
    check_keys,
    fail,
    register_section,
)
from inertiafit.io.shipped import (
    CURVE_JOINTS,
    PASSIVE_ENTRIES,
    check_passive_entry,
    load_passive_prior,
)
from inertiafit.passive import JOINTS

__all__ = ["PASSIVE_CURVES", "PASSIVE_KEYS", "PassivePrior", "read_passive"]

#: Keys of the ``[passive]`` table: the living body's joint, where the device's zero sits on it,
#: and overrides of the joint's shipped prior (``priors/passive/<joint>.toml``).
PASSIVE_KEYS = ("joint", "joint_angle_at_zero", "curve", *PASSIVE_ENTRIES)
#: ``[passive] curve``: the passive curve shaped by the data around the prior file's (a smooth
#: part, the default) or the prior file's fixed shape alone (to compare with).
PASSIVE_CURVES = ("smooth", "fixed")
#: ``[passive]`` entries per radian, which a value per degree would make 57 times too small.
_PER_RADIAN = ("stiffness",)


@dataclass(frozen=True)
class PassivePrior:
    """The ``[passive]`` table: the living body's joint and the priors of its passive model.

    The joint's shipped prior (``priors/passive/<joint>.toml``,
    :func:`inertiafit.io.shipped.load_passive_prior`) with the manifest's overrides merged in.
    Pairs are ``(mean, sd)`` of a normal prior (not truncated: the fit integrates the passive
    coefficients out in closed form; the means of moments, damping, hysteresis
    and the curve's scale are non-negative).

    Attributes
    ----------
    joint : {"elbow", "knee", "ankle", "generic"}
        Picks the prior file (and, for the knee and the ankle, the literature curve ``P0``).
    joint_angle_at_zero : float
        The anatomical joint angle (deg, flexion positive; the ankle's plantarflexion) at the
        device's angle 0: joint angle = ``joint_angle_at_zero`` + device angle.
    stiffness : (float, float)
        ``k`` (N m/rad), the linear spring (for the knee and the ankle: around the curve).
    stop_moment : (float, float)
        ``a_lo``, ``a_hi`` (N m), each end stop's moment at its range end.
    stop_width : float
        ``w`` (deg), the stops' typical e-folding width (each stop is fitted as two
        exponentials, ``w / sqrt(2)`` and ``w sqrt(2)`` wide).
    range : (float, float)
        ``(theta_lo, theta_hi)`` (deg), the joint angles of the range ends, lo < hi.
    curve_scale : (float, float) or None
        ``s``, which multiplies the literature curve; ``None`` for the elbow and a generic
        joint (no curve).
    damping : (float, float)
        ``b`` (N m s/rad), viscous damping.
    hysteresis : (float, float)
        ``h`` (N m), a moment against the direction of motion.
    sources : dict of str to str
        Entry -> where its number comes from: the prior file's citation, or ``"manifest"``
        for an override.
    curve : {"smooth", "fixed"}
        ``"smooth"`` (default): the curve of the prior file plus a smooth part shaped by the
        data (a Gaussian process in the joint angle); ``"fixed"``: the prior file's shape alone.
    """

    joint: str
    joint_angle_at_zero: float
    stiffness: tuple[float, float]
    stop_moment: tuple[float, float]
    stop_width: float
    range: tuple[float, float]
    curve_scale: tuple[float, float] | None
    damping: tuple[float, float]
    hysteresis: tuple[float, float]
    sources: dict[str, str] = field(default_factory=dict)
    curve: str = "smooth"


def read_passive(value: object, *, living: str, where: str) -> PassivePrior | None:
    """A ``[passive]`` table read as the manifest reads it (the planner's design files too).

    ``living`` names the living body (``""``: none, and the table must then be absent);
    ``where`` starts every error message.
    """
    return _passive(value, living=living, where=where)


def _passive(value: object, *, living: str, where: str) -> PassivePrior | None:
    """The ``[passive]`` table: the joint's shipped prior with the manifest's overrides."""
    here = f"{where}: passive"
    if value is None:
        if living:
            raise fail(
                here,
                f"missing; body '{living}' is living: add a [passive] table with joint "
                f"({', '.join(JOINTS)}) and joint_angle_at_zero (deg)",
            )
        return None
    table = as_table(value, where=here, what="joint = ..., joint_angle_at_zero = ...")
    if not living:
        raise fail(
            here,
            "no body is living; mark the living one with living = true under "
            "[bodies.<name>], or remove [passive]",
        )
    check_keys(table, PASSIVE_KEYS, where=here)
    joint = table.get("joint")
    if joint is None:
        raise fail(f"{here}.joint", f"missing; one of {', '.join(JOINTS)}")
    if joint not in JOINTS:
        raise fail(f"{here}.joint", f"unknown joint {joint!r} (joints: {', '.join(JOINTS)})")
    if "joint_angle_at_zero" not in table:
        raise fail(
            f"{here}.joint_angle_at_zero",
            "missing; the joint angle (deg, flexion positive) at the device's angle 0",
        )
    at_zero = check_interval(
        table["joint_angle_at_zero"], f"{here}.joint_angle_at_zero", -360.0, 360.0, "deg"
    )
    if "curve_scale" in table and joint not in CURVE_JOINTS:
        raise fail(
            f"{here}.curve_scale",
            f"only the joints with a literature curve have one ({', '.join(CURVE_JOINTS)}), "
            f"not '{joint}'",
        )
    curve = table.get("curve", "smooth")
    if curve not in PASSIVE_CURVES:
        raise fail(
            f"{here}.curve",
            f'expected "smooth" (shaped by the data) or "fixed" (the prior file\'s shape), '
            f"got {curve!r}",
        )
    shipped = load_passive_prior(joint)
    values: dict[str, Any] = {}
    sources: dict[str, str] = {}
    for key in PASSIVE_ENTRIES:
        if key in table:
            values[key] = check_passive_entry(key, table[key], f"{here}.{key}")
            sources[key] = "manifest"
            if key in _PER_RADIAN and key in shipped:
                _check_per_radian(key, values[key], shipped[key]["value"], f"{here}.{key}")
        elif key in shipped:
            values[key] = shipped[key]["value"]
            sources[key] = shipped[key]["source"]
        else:  # curve_scale of a joint without a curve
            values[key] = None
    return PassivePrior(
        joint=joint, joint_angle_at_zero=at_zero, sources=sources, curve=curve, **values
    )


def _check_per_radian(
    key: str, value: tuple[float, float], shipped: tuple[float, float], where: str
) -> None:
    """Refuse a prior per radian that was written per degree.

    Such a value is more than 20 times below the joint's shipped prior mean while, times
    180/pi, it would sit within 2 of its SDs: a stiffness of 0.03 N m/deg written as 0.03
    N m/rad for an elbow of 1.7 N m/rad moved the forearm's I by +170 % (issue 36).
    """
    mean, sd = value
    ref_mean, ref_sd = shipped
    per_degree = math.degrees(mean)
    if 0 <= 20.0 * mean < ref_mean and abs(per_degree - ref_mean) <= 2.0 * ref_sd:
        unit = PASSIVE_ENTRIES[key][0]
        raise fail(
            where,
            f"mean {mean:g} {unit} is {ref_mean / mean if mean else math.inf:.0f} times below "
            f"the joint's prior ({ref_mean:g} ± {ref_sd:g}) and looks like a value per degree; "
            f"give it per radian: {{ mean = {per_degree:.3g}, sd = {math.degrees(sd):.3g} }}",
        )


register_section(
    Section(
        "passive",
        lambda value, ctx: _passive(value, living=ctx.living, where=ctx.where),
        "passive",
        20,
    )
)
