"""OpenSim's ``.osim`` (an OpenSim 4 document): one body per body, turned to feel gravity.

Each body is a ``Body`` with ``mass``, ``mass_center`` and ``inertia`` about the centre of mass
(``Ixx Iyy Izz Ixy Ixz Iyz``), joined to ``ground`` by a ``CustomJoint`` whose one coordinate
``<body>_angle`` turns it about the joint axis (a ``CustomJoint`` rather than a ``PinJoint``,
whose axis is fixed to ``z`` and which biobuddy's reader does not take). ``gravity`` is
``0 -g 0`` (OpenSim's axis, the posterior's ``g``); the joint's parent frame
(``ground_offset``, its ``orientation`` in body-fixed X-Y-Z angles) lays the joint axis along
the world ``z`` and turns the body so that inverse dynamics at rest gives the dynamometer's
``M_g sin(q + phi)`` (:meth:`Frame.placement`).

A living body's joint is an ``ExpressionBasedCoordinateForce`` on its coordinate: the
generalized force ``-(P(q) + b qdot)``, ``P`` the fitted curve tabulated over the swept range
(:class:`JointCurve`) written as a sum of hinges (``max(q - q_i, 0)``: linear between the
tabulated angles, continued with the end slopes), ``b`` the damping. The hysteresis
``h sgn(qdot)`` is not in it (a step at rest, where a joint holds any moment within ``+-h``):
it is in the comment and in ``passive.csv``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from xml.etree import ElementTree as ET

from inertiafit.report.export.bodies import JointCurve
from inertiafit.report.export.frames import AXES, euler_xyz
from inertiafit.report.export.registry import ExportModel, decimal, register_format

__all__ = ["GRAVITY_AXIS", "JOINT_WORLD", "joint_expression", "write_osim"]

#: OpenSim's gravity axis and the world axis the bodies turn about (a gait model's flexion).
GRAVITY_AXIS = "-y"
JOINT_WORLD = "z"


def _unit(axis: str) -> str:
    return " ".join("1" if a == axis else "0" for a in AXES)


def _transform(spatial: ET.Element, name: str, axis: str, coordinate: str) -> None:
    """One TransformAxis of a CustomJoint: turned by ``coordinate``, or held at 0."""
    element = ET.SubElement(spatial, "TransformAxis", name=name)
    ET.SubElement(element, "coordinates").text = coordinate
    ET.SubElement(element, "axis").text = _unit(axis)
    if coordinate:
        function = ET.SubElement(element, "LinearFunction", name="function")
        ET.SubElement(function, "coefficients").text = "1 0"
    else:
        function = ET.SubElement(element, "Constant", name="function")
        ET.SubElement(function, "value").text = "0"


def _signed(value: float) -> str:
    """``+v`` or ``-v`` for a term of a sum (no whitespace: OpenSim's parser)."""
    return ("-" if value < 0 else "+") + decimal(abs(value))


def _shift(value: float) -> str:
    """``q - value`` without a double sign."""
    return "q" + _signed(-value)


def joint_expression(joint: JointCurve) -> str:
    """The generalized force ``-(P(q) + b qdot)`` in OpenSim's expression syntax (Lepton).

    ``P(q) = P_0 + s_0 (q - q_0) + sum_i (s_i - s_{i-1}) max(q - q_i, 0)``: the tabulated
    curve, linear between its angles ``q_i`` (slopes ``s_i``) and continued beyond them.
    """
    q: Sequence[float] = joint.angle
    p: Sequence[float] = joint.moment
    slopes = [(p[i + 1] - p[i]) / (q[i + 1] - q[i]) for i in range(len(q) - 1)]
    terms = [_signed(p[0]), f"{_signed(slopes[0])}*({_shift(q[0])})"]
    for i in range(1, len(slopes)):
        change = slopes[i] - slopes[i - 1]
        if change:
            terms.append(f"{_signed(change)}*max({_shift(q[i])},0)")
    terms.append(f"{_signed(joint.damping)}*qdot")
    return "-(" + "".join(terms).lstrip("+") + ")"


@register_format("osim", suffix=".osim", description="OpenSim 4 .osim")
def write_osim(model: ExportModel) -> str:
    """One model as an ``.osim`` file's text."""
    frame = model.frame
    orientation = euler_xyz(frame.placement(GRAVITY_AXIS, JOINT_WORLD, model.phase))
    doc = ET.Element("OpenSimDocument", Version="40000")
    osim = ET.SubElement(doc, "Model", name="inertiafit")
    ET.SubElement(osim, "credits").text = (
        f"{model.title}. Each body's coordinate is the dynamometer's angle: inverse dynamics at "
        f"rest gives M_g sin(q + phi), phi = {decimal(model.phase)} rad ({model.phase_source})."
    )
    ET.SubElement(osim, "gravity").text = f"0 {decimal(-model.gravity)} 0"
    ET.SubElement(osim, "length_units").text = "meters"
    ET.SubElement(osim, "force_units").text = "N"
    ground = ET.SubElement(osim, "Ground", name="ground")
    geometry = ET.SubElement(ground, "FrameGeometry", name="frame_geometry")
    ET.SubElement(geometry, "socket_frame").text = ".."
    ET.SubElement(geometry, "scale_factors").text = "0.2 0.2 0.2"
    objects = ET.SubElement(ET.SubElement(osim, "BodySet", name="bodyset"), "objects")
    joints = ET.SubElement(ET.SubElement(osim, "JointSet", name="jointset"), "objects")
    for body in model.bodies:
        element = ET.SubElement(objects, "Body", name=body.name)
        ET.SubElement(element, "mass").text = decimal(body.mass)
        ET.SubElement(element, "mass_center").text = " ".join(decimal(v) for v in body.com)
        tensor = body.inertia
        ET.SubElement(element, "inertia").text = " ".join(
            decimal(v)
            for v in (
                tensor[0][0],
                tensor[1][1],
                tensor[2][2],
                tensor[0][1],
                tensor[0][2],
                tensor[1][2],
            )
        )
        joint = ET.SubElement(joints, "CustomJoint", name=f"{body.name}_joint")
        ET.SubElement(joint, "socket_parent_frame").text = "ground_offset"
        ET.SubElement(joint, "socket_child_frame").text = f"{body.name}_offset"
        coords = ET.SubElement(joint, "coordinates")
        coord = ET.SubElement(coords, "Coordinate", name=f"{body.name}_angle")
        ET.SubElement(coord, "default_value").text = "0"
        ET.SubElement(coord, "range").text = f"{decimal(-math.pi)} {decimal(math.pi)}"
        ET.SubElement(coord, "clamped").text = "false"
        ET.SubElement(coord, "locked").text = "false"
        frames = ET.SubElement(joint, "frames")
        for name, parent, turn in (
            ("ground_offset", "/ground", orientation),
            (f"{body.name}_offset", f"/bodyset/{body.name}", (0.0, 0.0, 0.0)),
        ):
            offset = ET.SubElement(frames, "PhysicalOffsetFrame", name=name)
            ET.SubElement(offset, "socket_parent").text = parent
            ET.SubElement(offset, "translation").text = "0 0 0"
            ET.SubElement(offset, "orientation").text = " ".join(decimal(v) for v in turn)
        spatial = ET.SubElement(joint, "SpatialTransform")
        others = [a for a in AXES if a != frame.joint_axis]
        _transform(spatial, "rotation1", frame.joint_axis, f"{body.name}_angle")
        _transform(spatial, "rotation2", others[0], "")
        _transform(spatial, "rotation3", others[1], "")
        for k, axis in enumerate(AXES, start=1):
            _transform(spatial, f"translation{k}", axis, "")
    living = [(b.name, b.joint) for b in model.bodies if b.joint is not None]
    for name, curve in living:  # a comment beside the ForceSet: biobuddy reads its objects' tags
        h = curve.hysteresis
        osim.append(
            ET.Comment(
                f" {name}'s joint: -(P(q) + b qdot), P the device's moment against its "
                "elastic resistance (fitted over the swept range, 0 at its middle, continued "
                f"with its end slopes), b = {decimal(curve.damping)} N m s/rad; not in it: "
                f"the hysteresis h sgn(qdot), h from {min(h):.3g} to {max(h):.3g} N m "
            )
        )
    if living:
        forces = ET.SubElement(ET.SubElement(osim, "ForceSet", name="forceset"), "objects")
        for name, curve in living:
            force = ET.SubElement(
                forces, "ExpressionBasedCoordinateForce", name=f"{name}_joint_resistance"
            )
            ET.SubElement(force, "coordinate").text = f"{name}_angle"
            ET.SubElement(force, "expression").text = joint_expression(curve)
    ET.indent(doc)
    return (
        '<?xml version="1.0" encoding="UTF-8" ?>\n' + ET.tostring(doc, encoding="unicode") + "\n"
    )
