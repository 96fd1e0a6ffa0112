"""The ``[postures.<name>]`` tables: how each setup turns gravity about the device's axis."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from inertiafit._checks import check_finite, check_interval, check_positive
from inertiafit.io.sections.base import (
    Section,
    as_table,
    check_keys,
    check_name,
    fail,
    register_section,
)

__all__ = [
    "DEFAULT_GRAVITY_ROTATION_SD",
    "POSTURE_KEYS",
    "Posture",
    "posture_name",
    "read_postures",
]

#: Keys of a ``[postures.<name>]`` table (deg).
POSTURE_KEYS = ("gravity_rotation", "gravity_rotation_sd", "axis_tilt")
#: A posture's ``gravity_rotation_sd`` (deg) when the manifest gives none.
DEFAULT_GRAVITY_ROTATION_SD = 2.0


@dataclass(frozen=True)
class Posture:
    """One ``[postures.<name>]`` table: how a setup turns gravity about the device's axis.

    Attributes
    ----------
    name : str
        The key under ``[postures]``.
    gravity_rotation : float
        ``r_p`` (deg): the rotation of gravity about the axis against the posture with 0; the
        gravity phase of every body mounted becomes ``phi + r_p``.
    gravity_rotation_sd : float
        Its prior SD (deg), default 2; ``math.inf`` when the manifest says ``"free"`` (fitted).
    axis_tilt : float
        ``t_p`` (deg, 0 to 90): the axis's tilt from horizontal; the gravity moment is
        multiplied by ``cos(t_p)`` (90: a vertical axis, motion in the horizontal plane, no
        gravity moment). Default 0.
    """

    name: str
    gravity_rotation: float
    gravity_rotation_sd: float = DEFAULT_GRAVITY_ROTATION_SD
    axis_tilt: float = 0.0


def read_postures(value: object, *, where: str) -> dict[str, Posture]:
    """``[postures.<name>]`` tables read as the manifest reads them (design files too)."""
    return _postures(value, where=where)


def _postures(value: object, *, where: str) -> dict[str, Posture]:
    """The ``[postures.<name>]`` tables, in manifest order."""
    here = f"{where}: postures"
    raw = as_table(value, where=here, what="[postures.<name>] tables")
    out = {}
    for name, raw_entry in raw.items():
        check_name(name, f"{where}: postures", "posture")
        at = f"{here}.{name}"
        entry = as_table(raw_entry, where=at, what="gravity_rotation = deg, ...")
        check_keys(entry, POSTURE_KEYS, where=at)
        if "gravity_rotation" not in entry:
            raise fail(
                f"{at}.gravity_rotation",
                "missing; the rotation of gravity about the axis (deg) against the posture with 0",
            )
        rotation = check_interval(
            entry["gravity_rotation"], f"{at}.gravity_rotation", -360.0, 360.0, "deg"
        )
        sd = entry.get("gravity_rotation_sd", DEFAULT_GRAVITY_ROTATION_SD)
        if sd == "free":
            sd = math.inf
        elif isinstance(sd, str):
            raise fail(
                f"{at}.gravity_rotation_sd",
                f'expected an SD in deg (> 0) or "free", got {sd!r}',
            )
        else:
            sd = check_positive(sd, f"{at}.gravity_rotation_sd", "deg")
        tilt = check_finite(entry.get("axis_tilt", 0.0), f"{at}.axis_tilt", "deg")
        if not 0.0 <= tilt <= 90.0:
            raise fail(
                f"{at}.axis_tilt",
                f"expected an angle in [0, 90] deg (0: a horizontal axis, 90: a vertical one), "
                f"got {entry['axis_tilt']!r}",
            )
        out[name] = Posture(
            name=name, gravity_rotation=rotation, gravity_rotation_sd=sd, axis_tilt=tilt
        )
    return out


def posture_name(value: object, postures: Mapping[str, Posture], *, where: str) -> str:
    """A trial's (or ``[defaults]``) ``posture``: a name defined under ``[postures]``."""
    if not postures:
        raise fail(
            where,
            f"no [postures] in the manifest to name; define [postures.{value}] with its "
            "gravity_rotation, or remove posture",
        )
    if not isinstance(value, str) or value not in postures:
        raise fail(where, f"unknown posture {value!r} (postures: {', '.join(postures)})")
    return value


register_section(
    Section(
        "postures",
        lambda value, ctx: _postures({} if value is None else value, where=ctx.where),
        "postures",
        30,
    )
)
