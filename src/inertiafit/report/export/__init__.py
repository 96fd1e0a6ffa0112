"""A posterior as segments of a musculoskeletal model: ``.bioMod``, ``.osim``, JSON, ...

Any format registered like them is written the same way. The package's modules:

- :mod:`~inertiafit.report.export.frames`: the body frame (:class:`Frame`) and the placement
  that makes a model feel gravity as the body did on the dynamometer;
- :mod:`~inertiafit.report.export.radii`: the two radii of gyration the dynamometer does not
  measure (:class:`OtherRadii`, :func:`declared_radii`, :func:`load_declarations`,
  :func:`other_radii`);
- :mod:`~inertiafit.report.export.bodies`: the posterior's bodies as segments
  (:class:`BodyInertia`, a living joint's :class:`JointCurve`, :func:`exported_bodies`);
- :mod:`~inertiafit.report.export.phase`: the dynamometer's phase the results carry
  (:func:`data_phase`);
- :mod:`~inertiafit.report.export.registry`: :class:`ExportModel`, :func:`register_format`,
  :func:`available_formats`, :func:`export_format`;
- one module per format: :mod:`~inertiafit.report.export.biomod`,
  :mod:`~inertiafit.report.export.osim`, :mod:`~inertiafit.report.export.jsonmodel`.
  Importing this package imports them, which registers the formats.

docs/export.md documents the formats and the frame; docs/architecture.md the recipe for a new
format.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from inertiafit.physics import GRAVITY
from inertiafit.report.export.bodies import (
    EXPORT_COLUMNS,
    BodyInertia,
    JointCurve,
    exported_bodies,
)
from inertiafit.report.export.frames import Frame
from inertiafit.report.export.phase import data_phase
from inertiafit.report.export.radii import (
    TRIANGLE_TOLERANCE,
    OtherRadii,
    declared_radii,
    load_declarations,
    other_radii,
)
from inertiafit.report.export.registry import (
    EXPORT_FORMATS,
    ExportFormat,
    ExportModel,
    available_formats,
    export_format,
    register_format,
)

# Importing a format's module registers it; the order is available_formats()'s.
# isort: off
from inertiafit.report.export.biomod import write_biomod
from inertiafit.report.export.osim import write_osim
from inertiafit.report.export.jsonmodel import write_json

# isort: on

__all__ = [
    "EXPORT_COLUMNS",
    "EXPORT_FORMATS",
    "TRIANGLE_TOLERANCE",
    "BodyInertia",
    "ExportFormat",
    "ExportModel",
    "Frame",
    "JointCurve",
    "OtherRadii",
    "available_formats",
    "data_phase",
    "declared_radii",
    "export_format",
    "exported_bodies",
    "load_declarations",
    "model_text",
    "other_radii",
    "register_format",
    "write_biomod",
    "write_json",
    "write_model",
    "write_osim",
]


def model_text(
    bodies: Sequence[BodyInertia],
    fmt: str,
    *,
    frame: Frame | None = None,
    title: str = "",
    gravity: float = GRAVITY,
    phase: float = 0.0,
    phase_source: str = "given",
) -> str:
    """One model's file text in the registered format ``fmt`` (``biomod``, ``osim``, ...)."""
    model = ExportModel(tuple(bodies), frame or Frame(), title, gravity, phase, phase_source)
    return export_format(fmt).write(model)


def write_model(path: str | Path, model: ExportModel, fmt: str) -> Path:
    """Write one model file in ``fmt`` (into a staging folder: see ``pipeline.export``)."""
    path = Path(path)
    path.write_text(export_format(fmt).write(model), encoding="utf-8")
    return path
