"""The data files shipped with inertiafit (``priors/``), and the passive priors among them.

:func:`shipped_dirs` finds the ``priors/`` folder: inside the installed wheel, or the source
tree's. Body priors (``priors/*.toml``) are read by :mod:`inertiafit.inference.priors`; the
anthropometric tables live in ``priors/anthropometric/``; the passive priors of a living joint
in ``priors/passive/<joint>.toml``, read by :func:`load_passive_prior`.

A passive prior file holds a ``description``, its ``joint`` (the file's name) and one table
per entry of :data:`PASSIVE_ENTRIES`, each with a ``source`` and its ``unit``::

    description = "Passive elastic moment and damping of a relaxed elbow"
    joint = "elbow"
    [stiffness]
    mean = 1.1
    sd = 0.45
    unit = "N m/rad"
    source = "Wiegner & Watts 1986 ..."
    [stop_width]
    value = 10.0
    unit = "deg"
    source = "..."
    [range]
    value = [30.0, 150.0]
    unit = "deg"
    source = "..."

``curve_scale`` belongs to the joints with a literature curve (:data:`CURVE_JOINTS`) only.
Files are parsed against this schema; nothing in them is executed.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from inertiafit._checks import check_finite, check_increasing_pair, check_positive
from inertiafit.errors import InputError
from inertiafit.passive import JOINTS

__all__ = [
    "CURVE_JOINTS",
    "PASSIVE_ENTRIES",
    "check_passive_entry",
    "load_passive_prior",
    "passive_prior_path",
    "shipped_dirs",
]

#: Joints whose passive moment has a published curve ``P0`` (Riener & Edrich 1999), scaled by
#: ``curve_scale``; the elbow and a generic joint have none.
CURVE_JOINTS = ("knee", "ankle")
#: Entries of a passive prior, in order, with their unit and form: ``"normal"`` a
#: ``{mean, sd}`` pair, ``"number"`` a positive number, ``"range"`` two increasing numbers.
PASSIVE_ENTRIES: dict[str, tuple[str, str]] = {
    "stiffness": ("N m/rad", "normal"),
    "stop_moment": ("N m", "normal"),
    "stop_width": ("deg", "number"),
    "range": ("deg", "range"),
    "curve_scale": ("1", "normal"),
    "damping": ("N m s/rad", "normal"),
    "hysteresis": ("N m", "normal"),
}
#: Entries whose parameter cannot be negative (a moment at a stop, damping, hysteresis, a
#: curve's scale): their prior mean must not be either.
_NON_NEGATIVE = ("stop_moment", "curve_scale", "damping", "hysteresis")
#: Joint angles (deg) are anatomical angles: less than a turn either way.
_MAX_DEG = 360.0


def shipped_dirs(*parts: str) -> list[Path]:
    """Folders holding shipped data files: the wheel's ``priors/``, then the source tree's.

    ``parts`` name a sub-folder (``shipped_dirs("passive")``). Only folders that exist are
    listed.
    """
    dirs = []
    packaged = Path(str(resources.files("inertiafit"))) / "priors"
    source_tree = Path(__file__).resolve().parents[3] / "priors"  # src/inertiafit/io/
    for root in (packaged, source_tree):
        folder = root.joinpath(*parts)
        if folder.is_dir() and folder not in dirs:
            dirs.append(folder)
    return dirs


def passive_prior_path(joint: str) -> Path:
    """The shipped prior file ``priors/passive/<joint>.toml``.

    Raises
    ------
    InputError
        ``joint`` is not one of :data:`inertiafit.passive.JOINTS`, or its file is missing.
    """
    if joint not in JOINTS:
        raise InputError(f"passive prior: unknown joint {joint!r} (joints: {', '.join(JOINTS)})")
    for folder in shipped_dirs("passive"):
        path = folder / f"{joint}.toml"
        if path.is_file():
            return path
    raise InputError(
        f"passive prior '{joint}': the shipped file priors/passive/{joint}.toml is missing"
    )


def check_passive_entry(key: str, value: object, where: str) -> Any:
    """One passive prior value, checked: ``(mean, sd)``, a number or ``(lo, hi)``.

    ``value`` is what a manifest's ``[passive]`` gives for ``key`` (a ``{mean, sd}`` table, a
    number or a two-number list, as :data:`PASSIVE_ENTRIES` says); ``where`` names it in the
    one-line :class:`~inertiafit.errors.InputError`.
    """
    unit, form = PASSIVE_ENTRIES[key]
    shown = "" if unit == "1" else unit
    if form == "normal":
        if not isinstance(value, dict) or set(value) != {"mean", "sd"}:
            raise InputError(
                f"{where}: expected {{ mean = ..., sd = ... }} ({unit}), got {value!r}"
            )
        mean = check_finite(value["mean"], f"{where}.mean", shown)
        if key in _NON_NEGATIVE and mean < 0:
            raise InputError(f"{where}.mean: must not be negative ({unit}), got {value['mean']!r}")
        sd = check_positive(value["sd"], f"{where}.sd", shown)
        return (mean, sd)
    if form == "number":
        return check_positive(value, where, shown)
    lo, hi = check_increasing_pair(value, where, f"joint angles [lo, hi] in {unit}")
    if max(abs(lo), abs(hi)) >= _MAX_DEG:
        raise InputError(f"{where}: joint angles must be within ±{_MAX_DEG:g} deg, got {value!r}")
    return (lo, hi)


def load_passive_prior(joint: str) -> dict[str, Any]:
    """Read and check a joint's shipped passive prior, ``priors/passive/<joint>.toml``.

    Returns
    -------
    dict
        ``"description"`` (str) and, per entry of :data:`PASSIVE_ENTRIES` the file holds,
        ``{"value": ..., "source": str}``: ``value`` as :func:`check_passive_entry` returns
        it (``(mean, sd)``, a number or ``(lo, hi)``). ``curve_scale`` is there exactly for the
        :data:`CURVE_JOINTS`.

    Raises
    ------
    InputError
        An unknown joint, a missing or unreadable file, or a file that breaks the schema
        (unknown or missing entry, no source, a wrong unit, a bad value), naming the file.
    """
    path = passive_prior_path(joint)
    where = str(path)
    try:
        table = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where}: not valid TOML ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{where}: cannot read the passive prior file ({exc})") from None
    allowed = ("description", "joint", *PASSIVE_ENTRIES)
    for key in table:
        if key not in allowed:
            raise InputError(f"{where}: {key}: unknown key (allowed: {', '.join(allowed)})")
    if table.get("joint") != joint:
        raise InputError(f"{where}: joint: expected {joint!r}, got {table.get('joint')!r}")
    description = table.get("description", "")
    if not isinstance(description, str):
        raise InputError(f"{where}: description: expected a string, got {description!r}")
    out: dict[str, Any] = {"description": description}
    for key, (unit, form) in PASSIVE_ENTRIES.items():
        wanted = key != "curve_scale" or joint in CURVE_JOINTS
        if key not in table:
            if wanted:
                raise InputError(f"{where}: {key}: missing ({unit})")
            continue
        if not wanted:
            raise InputError(
                f"{where}: {key}: only the joints with a literature curve have one "
                f"({', '.join(CURVE_JOINTS)})"
            )
        entry = table[key]
        here = f"{where}: {key}"
        if not isinstance(entry, dict):
            raise InputError(f"{here}: expected a table with source and unit, got {entry!r}")
        fields = ("mean", "sd") if form == "normal" else ("value",)
        for k in entry:
            if k not in (*fields, "unit", "source"):
                raise InputError(
                    f"{here}.{k}: unknown key (allowed: {', '.join((*fields, 'unit', 'source'))})"
                )
        source = entry.get("source")
        if not isinstance(source, str) or not source.strip():
            raise InputError(f"{here}.source: missing; every number cites where it comes from")
        if entry.get("unit") != unit:
            raise InputError(f"{here}.unit: expected {unit!r}, got {entry.get('unit')!r}")
        raw = (
            {k: entry[k] for k in ("mean", "sd") if k in entry}
            if form == "normal"
            else entry.get("value")
        )
        out[key] = {"value": check_passive_entry(key, raw, here), "source": source.strip()}
    return out
