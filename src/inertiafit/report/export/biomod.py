"""biorbd's ``.bioMod`` (``version 4``): one segment per body, turned to feel gravity.

Each body is a ``segment`` on the root with one rotation about its joint axis, its ``mass``,
``com`` and ``inertia`` about the centre of mass in the body frame. The segment's ``rt`` (a
matrix) turns the body frame so that its joint axis lies along biorbd's world ``x`` and,
under the file's ``gravity 0 0 -g`` (biorbd's own axis, the posterior's ``g``), inverse
dynamics at rest gives the dynamometer's ``M_g sin(q + phi)`` (:meth:`Frame.placement`).

A living body's passive moment goes into a ``passivetorque`` of type ``linear``
(``T0 + slope q``, ``q`` in rad in biorbd 1.12), the closest of the types biorbd reads
(``constant``, ``linear`` and an ``exponential`` whose form cannot hold a stiffness curve with
end stops, one passive torque per degree of freedom): the straight line closest to the
fitted curve over the swept range (:attr:`JointCurve.line`), as the joint's own moment on
the segment (``-P``), its largest distance from the curve written beside it. biorbd has no
viscous passive torque; ``b`` and ``h`` are written as comments (and in ``passive.csv``).
"""

from __future__ import annotations

from inertiafit.errors import InputError
from inertiafit.report.export.registry import ExportModel, decimal, register_format

__all__ = ["GRAVITY_AXIS", "JOINT_WORLD", "write_biomod"]

#: biorbd's gravity axis and the world axis the segments turn about.
GRAVITY_AXIS = "-z"
JOINT_WORLD = "x"


@register_format("biomod", suffix=".bioMod", description="biorbd .bioMod (version 4)")
def write_biomod(model: ExportModel) -> str:
    """One model as a ``.bioMod`` file's text."""
    frame = model.frame
    rotation = frame.placement(GRAVITY_AXIS, JOINT_WORLD, model.phase)
    lines = [
        "version 4",
        "",
        f"// {model.title}",
        "// Written by inertiafit export: one segment per body, its frame's origin at the joint",
        f"// on the dynamometer axis ({frame.joint_axis}); centre of mass on {frame.long_axis};",
        "// inertia about the centre of mass (kg m^2), mass kg, lengths m.",
        f"// Each segment's rt lays its joint axis along the world's {JOINT_WORLD}, normal to gravity;",
        "// its coordinate q is the dynamometer's angle: inverse dynamics at rest gives",
        f"// M_g sin(q + phi), phi = {decimal(model.phase)} rad ({model.phase_source}).",
        f"gravity 0 0 {decimal(-model.gravity)}",
        "",
    ]
    for body in model.bodies:
        if not body.name or any(c.isspace() for c in body.name):
            raise InputError(f"body '{body.name}': a bioMod segment name cannot hold spaces")
        lines += [
            f"// {body.name}: other radii: {body.source}",
            f"segment {body.name}",
            "    rtinmatrix 1",
            "    rt",
            *("        " + " ".join(decimal(v) for v in (*row, 0.0)) for row in rotation),
            "        0 0 0 1",
            f"    rotations {frame.joint_axis}",
            f"    mass {decimal(body.mass)}",
            "    com " + " ".join(decimal(v) for v in body.com),
            "    inertia",
            *("        " + " ".join(decimal(v) for v in row) for row in body.inertia),
            "endsegment",
            "",
        ]
        if body.joint is not None:
            p0, k = body.joint.line
            h = body.joint.hysteresis
            lines += [
                (
                    f"// {body.name}'s joint: passive moment P = {decimal(p0)} + {decimal(k)} q "
                    "N m (the device's moment against it),"
                ),
                (
                    "// the line closest to the fitted curve over the swept range (q from "
                    f"{decimal(body.joint.angle[0])} to {decimal(body.joint.angle[-1])} rad), "
                    f"within {body.joint.line_error:.3g} N m of it;"
                ),
                (
                    "// the joint's moment on the segment is -P. Not in biorbd's passive torques: "
                    f"damping b = {decimal(body.joint.damping)} N m s/rad (adds b qdot),"
                ),
                f"// hysteresis h sgn(qdot) with h from {min(h):.3g} to {max(h):.3g} N m.",
                f"passivetorque {body.name}",
                "    type linear",
                f"    dof Rot{frame.joint_axis.upper()}",
                f"    T0 {decimal(-p0)}",
                f"    slope {decimal(-k)}",
                "endpassivetorque",
                "",
            ]
    return "\n".join(lines)
