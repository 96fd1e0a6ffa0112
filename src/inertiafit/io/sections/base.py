"""The manifest's tables, each read by its own section reader, in one registry.

:func:`~inertiafit.io.manifest.load_study` reads the manifest's top level and its bodies, then
every table registered here (:data:`SECTIONS`), in order: each section's reader checks its own
keys with the one set of validators (:mod:`inertiafit._checks` and the helpers below) and
returns what :class:`~inertiafit.io.manifest.Study` keeps of it (``Study.sections[name]``, and
the named attribute of the sections the study has always had). A new table is one module: a
reader registered with :func:`register_section`, imported by :mod:`inertiafit.io.sections`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from inertiafit._checks import unnameable
from inertiafit.errors import InputError

__all__ = [
    "BODY_NAME_FORBIDDEN",
    "MAX_BODY_NAME",
    "SECTIONS",
    "Section",
    "SectionContext",
    "as_table",
    "check_keys",
    "check_name",
    "expand_user",
    "fail",
    "number",
    "number_within",
    "register_section",
    "resolve_file",
]


@dataclass(frozen=True)
class SectionContext:
    """What a section's reader may need of the rest of the manifest.

    ``where``: the manifest's path, starting every message; ``read``: the sections read before
    this one, by name (their readers' values); ``base``: the folder relative paths are
    resolved against (the manifest's); ``doc``: the whole manifest as TOML read it.
    """

    where: str
    read: Mapping[str, Any] = field(default_factory=dict)
    base: Path | None = None
    doc: Mapping[str, Any] = field(default_factory=dict)

    @property
    def living(self) -> str:
        """The living body's name (``""``: none), once ``[bodies]`` is read."""
        bodies = self.read.get("bodies") or {}
        return next((b for b, spec in bodies.items() if getattr(spec, "living", False)), "")


@dataclass(frozen=True)
class Section:
    """A top-level table of the manifest and its reader.

    ``read(value, context)`` gets the table (``None`` when the manifest has none) and returns
    what the study keeps of it; ``field`` is the :class:`~inertiafit.io.manifest.Study`
    attribute it fills (``""``: only ``Study.sections``); ``order`` when it is read among the
    sections (smaller first: a section whose checks need another's comes after it).
    """

    name: str
    read: Callable[[object, SectionContext], Any]
    field: str = ""
    order: int = 100


#: Every section, by its table's name, in the order they are read.
SECTIONS: dict[str, Section] = {}


def register_section(section: Section) -> Section:
    """Add a section to :data:`SECTIONS` (one reader per table), kept in reading order."""
    if section.name in SECTIONS:
        msg = f"section [{section.name}] has a reader already"
        raise ValueError(msg)
    ordered = sorted([*SECTIONS.values(), section], key=lambda s: s.order)
    SECTIONS.clear()
    SECTIONS.update((s.name, s) for s in ordered)
    return section


def fail(where: str, message: str) -> InputError:
    """The one-line error of a manifest key: ``<where>: <message>``."""
    return InputError(f"{where}: {message}")


def expand_user(text: str, *, where: str) -> Path:
    """``text`` as a path with a leading ``~`` or ``~user`` expanded.

    A one-line error when the home folder it names is unknown here (``Path.expanduser`` raises
    RuntimeError then).
    """
    try:
        return Path(text).expanduser()
    except RuntimeError:
        user = text.split("/", 1)[0]
        raise fail(where, f"{text!r}: {user} names no home folder on this machine") from None


def resolve_file(text: str, base: Path, *, where: str) -> Path:
    """The absolute path of ``text`` (relative to ``base``, ``~`` expanded).

    A one-line error when this machine's file names cannot hold one of its characters (an
    ASCII file-system encoding, ``LC_ALL=C``, meets a non-ASCII name).
    """
    try:
        return (base / expand_user(text, where=where)).resolve()
    except UnicodeEncodeError as exc:
        raise fail(
            where, f"{text!r}: {unnameable(exc)}; rename the file or run in a UTF-8 locale"
        ) from None


def number(value: object, *, where: str, what: str) -> float:
    """A finite number (not a bool), else a one-line error saying ``what`` was expected."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise fail(where, f"expected {what}, got {value!r}")
    return float(value)


def number_within(
    value: object, where: str, bounds: tuple[float, float], unit: str, *, what: str, hint: str
) -> float:
    """A :func:`number` within ``bounds`` (in ``unit``), else one line with the likely slip.

    ``what`` says what was expected of a non-number; ``hint`` ends the out-of-range message
    (``" (in cm?)"``).
    """
    out = number(value, where=where, what=what)
    lo, hi = bounds
    if not lo <= out <= hi:
        raise fail(where, f"expected {lo:g} to {hi:g} {unit}, got {value!r}{hint}")
    return out


def check_keys(table: Mapping[str, Any], allowed: Sequence[str], *, where: str) -> None:
    """Refuse a key of ``table`` not in ``allowed``: ``<where>.<key>: unknown key (allowed: ...)``."""
    for key in table:
        if key not in allowed:
            raise fail(f"{where}.{key}", f"unknown key (allowed: {', '.join(allowed)})")


def as_table(value: object, *, where: str, what: str) -> dict[str, Any]:
    """A TOML table, else a one-line error saying ``what`` it should hold."""
    if not isinstance(value, dict):
        raise fail(where, f"expected a table ({what}), got {value!r}")
    return value


#: Longest body name, in UTF-8 bytes: it becomes part of file names (``corner-<body>.pdf``)
#: and condition labels, and file systems count bytes (64 emoji are 256).
MAX_BODY_NAME = 64
#: Characters a body name may not hold: path separators and what Windows refuses in a file
#: name, and ``+``/``@``, which join bodies and offsets in a condition's label.
BODY_NAME_FORBIDDEN = frozenset('/\\:*?"<>|+@')


def check_name(name: str, where: str, what: str = "body") -> None:
    """A body's (or posture's) name must be safe as part of a file name and a condition label."""
    shown = repr(name[:40] + ("..." if len(name) > 40 else ""))
    bad = sorted({c for c in name if c in BODY_NAME_FORBIDDEN or not c.isprintable()})
    if not name.strip() or name != name.strip() or name.startswith("."):
        why = "a name that does not start with '.' or a space and is not empty"
    elif len(name.encode("utf-8")) > MAX_BODY_NAME:
        size = len(name.encode("utf-8"))
        why = (
            f"at most {MAX_BODY_NAME} bytes in UTF-8 (it names output files), got {size} "
            f"({len(name)} characters)"
        )
    elif bad:
        listed = " ".join(repr(c) for c in bad)
        why = f"no {listed} in a name (it names output files and condition labels)"
    else:
        return
    raise fail(where, f"{what} {shown}: expected {why}")
