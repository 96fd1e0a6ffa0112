"""JSON: every number of a model, for any tool (``"format": "inertiafit-export"``).

Version 2 adds to version 1 the phase (``phase``, ``phase_source``), gravity's direction in
the body frame at the model's angle 0 (``gravity_at_zero``: the body feels gravity along it
when ``q = 0``, and ``M_g sin(q + phi)`` at ``q``), and a living body's ``joint``: its passive
moment tabulated over the swept range, its hysteresis and damping (docs/export.md).
"""

from __future__ import annotations

import json

from inertiafit.report.export.registry import ExportModel, register_format

__all__ = ["VERSION", "write_json"]

#: The JSON file's ``version``.
VERSION = 2


@register_format("json", suffix=".json", description="JSON, every number")
def write_json(model: ExportModel) -> str:
    """One model as a JSON document's text."""
    data = {
        "format": "inertiafit-export",
        "version": VERSION,
        "title": model.title,
        "units": {
            "mass": "kg",
            "com": "m",
            "inertia": "kg m^2 about the centre of mass",
            "angle": "rad",
            "moment": "N m",
            "damping": "N m s/rad",
        },
        "gravity": model.gravity,
        "phase": model.phase,
        "phase_source": model.phase_source,
        "gravity_at_zero": [float(v) for v in model.frame.gravity_at_zero(model.phase)],
        "frame": model.frame.describe(),
        "bodies": {},
    }
    for b in model.bodies:
        entry = {
            "mass": b.mass,
            "com": list(b.com),
            "inertia": [list(row) for row in b.inertia],
            "radii_of_gyration": b.radii,
            "other_radii": {**b.extra.get("other_radii", {}), "source": b.source},
            **({"posterior_draw": b.draw} if b.draw >= 0 else {}),
        }
        if b.joint is not None:
            entry["joint"] = {
                "angle": list(b.joint.angle),
                "passive_moment": list(b.joint.moment),
                "hysteresis": list(b.joint.hysteresis),
                "damping": b.joint.damping,
                "joint_angle_at_zero": b.joint.zero,
                "reference_angle": b.joint.reference,
                "meaning": (
                    "the moment the joint adds to what must be applied to it: "
                    "passive_moment(q) + damping qdot + hysteresis(q) sgn(qdot), q the "
                    "dynamometer's angle (the joint's is q + joint_angle_at_zero); "
                    "passive_moment is 0 at reference_angle, the middle of the swept range"
                ),
            }
        data["bodies"][b.name] = entry  # type: ignore[index]
    return json.dumps(data, indent=2) + "\n"
