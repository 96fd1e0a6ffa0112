"""The registry of export formats: one writer per format name, as trial readers are registered.

A format is a function that turns one model (:class:`ExportModel`: its bodies, frame, gravity
and phase) into the text of a file, registered under a name with its file suffix::

    @register_format("myformat", suffix=".my", description="My tool's model file")
    def write_myformat(model: ExportModel) -> str:
        ...

``inertiafit export --format myformat`` then writes ``model.my`` (and ``draws/model-0001.my``
...) through it; :func:`export_format` looks a name up and refuses an unknown one in one line.
The shipped formats register themselves when :mod:`inertiafit.report.export` is imported.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from inertiafit.errors import InputError
from inertiafit.physics import GRAVITY
from inertiafit.report.export.frames import Frame

if TYPE_CHECKING:
    from inertiafit.report.export.bodies import BodyInertia

__all__ = [
    "EXPORT_FORMATS",
    "ExportFormat",
    "ExportModel",
    "Writer",
    "available_formats",
    "decimal",
    "export_format",
    "register_format",
]


@dataclass(frozen=True)
class ExportModel:
    """One model to write: its bodies and where they sit.

    Attributes
    ----------
    bodies : tuple of BodyInertia
        The segments (a living body's with its :attr:`~BodyInertia.joint`).
    frame : Frame
        The body frame's axes.
    title : str
        One line: where the numbers come from.
    gravity : float
        ``g`` (m/s^2), the posterior's.
    phase : float
        ``phi`` (rad): the model's angle ``q`` is the dynamometer's ``theta``, and the body
        hangs at ``q = -phi`` (:meth:`Frame.placement`).
    phase_source : str
        Where ``phi`` comes from, one line.
    """

    bodies: tuple[BodyInertia, ...]
    frame: Frame = field(default_factory=Frame)
    title: str = ""
    gravity: float = GRAVITY
    phase: float = 0.0
    phase_source: str = ""


#: A format's writer: one model's file text.
Writer = Callable[[ExportModel], str]


@dataclass(frozen=True)
class ExportFormat:
    """A registered format: its name, file suffix, writer and a one-line description."""

    name: str
    suffix: str
    write: Writer
    description: str = ""


#: The registered formats, name -> format; filled by :func:`register_format`.
EXPORT_FORMATS: dict[str, ExportFormat] = {}
_NAME = re.compile(r"[a-z][a-z0-9_-]*")
_SUFFIX = re.compile(r"\.[A-Za-z0-9]+")


def register_format(
    name: str, *, suffix: str, description: str = ""
) -> Callable[[Writer], Writer]:
    """Register a writer under the format ``name`` (a decorator; the writer is unchanged).

    Parameters
    ----------
    name : str
        ``--format``'s word: lower case letters, digits, ``-`` and ``_``.
    suffix : str
        The files' suffix, with its dot (``.bioMod``).
    description : str
        One line for messages and help.
    """
    if not _NAME.fullmatch(name):
        raise ValueError(f"format name {name!r}: lower-case letters, digits, '-' and '_'")
    if not _SUFFIX.fullmatch(suffix):
        raise ValueError(f"format {name!r}: suffix {suffix!r} must be a dot and letters or digits")

    def decorator(write: Writer) -> Writer:
        EXPORT_FORMATS[name] = ExportFormat(name, suffix, write, description)
        return write

    return decorator


def available_formats() -> tuple[str, ...]:
    """The registered format names, in the order they were registered."""
    return tuple(EXPORT_FORMATS)


def export_format(name: object) -> ExportFormat:
    """The format registered as ``name``.

    Raises
    ------
    InputError
        ``format: expected one of ..., got ...`` for a name not registered.
    """
    if not isinstance(name, str) or name not in EXPORT_FORMATS:
        raise InputError(f"format: expected one of {', '.join(EXPORT_FORMATS)}, got {name!r}")
    return EXPORT_FORMATS[name]


def decimal(value: float) -> str:
    """A float as the shortest decimal that reads back to the same bits, never in e-notation."""
    return np.format_float_positional(float(value), unique=True, trim="-")
