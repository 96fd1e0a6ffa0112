"""The body frame of an exported segment, and where the segment sits in a model's world.

**The body frame** (:class:`Frame`) has its origin at the joint centre on the dynamometer
axis: the centre of mass on the *long axis* (``+x`` by default), the dynamometer's axis the
*joint axis* (``z`` by default), the *cross axis* normal to both. Its axes are the inertia
tensor's principal axes.

**The placement** (:meth:`Frame.placement`): a model tool has its own world with gravity along
one axis (biorbd ``-z``, OpenSim ``-y``). The segment's parent frame is turned so that the
body feels gravity as it did on the dynamometer, whose moment was ``M_g sin(theta + phi)``
(``theta + phi`` the angle from hanging, ``phi`` the dynamometer's phase):

* the joint axis is horizontal (normal to gravity), along the world axis the tool's models
  turn a limb about (``joint_world``);
* at the model's angle ``q = -phi`` the centre of mass hangs straight down, and a positive
  ``q`` turns the body about ``+joint axis`` (right-handed).

Then the model's coordinate ``q`` is the dynamometer's angle ``theta`` and inverse dynamics at
rest gives ``M_g sin(q + phi)``, the dynamometer's gravity moment: largest, ``M_g``, at
``q = pi/2 - phi`` (derivation in docs/export.md). The rotation is ``A R_J(phi)``: ``A`` takes
the long axis to gravity's direction and the joint axis to ``joint_world``, ``R_J(phi)`` turns
by ``phi`` about the joint axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from inertiafit.errors import InputError

__all__ = ["AXES", "Frame", "axis_vector", "euler_xyz", "rotation_about"]

AXES = ("x", "y", "z")


def axis_vector(axis: str) -> NDArray:
    """``"+x"``, ``"-y"``, ``"z"`` ... as a unit vector."""
    name = axis.strip().lower()
    sign = -1.0 if name.startswith("-") else 1.0
    out = np.zeros(3)
    out[AXES.index(name.lstrip("+-"))] = sign
    return out


def rotation_about(axis: NDArray, angle: float) -> NDArray:
    """The rotation matrix by ``angle`` (rad) about the unit vector ``axis`` (right-handed)."""
    u = np.asarray(axis, dtype=float)
    cross = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return np.eye(3) + math.sin(angle) * cross + (1.0 - math.cos(angle)) * (cross @ cross)


def euler_xyz(rotation: NDArray) -> tuple[float, float, float]:
    """Body-fixed X-Y-Z angles (rad) of a rotation: ``R = R_x(a) R_y(b) R_z(c)``.

    OpenSim's ``orientation`` of a frame. At ``b = +-pi/2`` (gimbal lock) ``c`` is 0.
    """
    r = np.asarray(rotation, dtype=float)
    b = math.asin(max(-1.0, min(1.0, r[0, 2])))
    if abs(r[0, 2]) < 1.0 - 1e-12:
        a = math.atan2(-r[1, 2], r[2, 2])
        c = math.atan2(-r[0, 1], r[0, 0])
    else:  # R_x(a) R_y(+-pi/2): the rest of the turn goes into a
        a = math.atan2(r[2, 1], r[1, 1])
        c = 0.0
    return a, b, c


@dataclass(frozen=True)
class Frame:
    """Where the body frame's axes point.

    Attributes
    ----------
    long_axis : str
        The direction from the joint to the centre of mass: ``+x`` (default), ``-y``, ...
    joint_axis : str
        The dynamometer's axis: ``x``, ``y`` or ``z`` (default); not the long axis.
    """

    long_axis: str = "+x"
    joint_axis: str = "z"

    def __post_init__(self) -> None:
        long = self.long_axis.strip().lower()
        if long in AXES:
            long = "+" + long
        if len(long) != 2 or long[0] not in "+-" or long[1] not in AXES:
            raise InputError(
                f"long_axis: expected one of +x, -x, +y, -y, +z, -z, got {self.long_axis!r}"
            )
        joint = self.joint_axis.strip().lower().lstrip("+-")
        if joint not in AXES:
            raise InputError(f"joint_axis: expected x, y or z, got {self.joint_axis!r}")
        if joint == long[1]:
            raise InputError(
                f"joint_axis: the dynamometer axis ({joint}) cannot be the long axis "
                f"({long}); choose another"
            )
        object.__setattr__(self, "long_axis", long)
        object.__setattr__(self, "joint_axis", joint)

    @property
    def cross_axis(self) -> str:
        """The third axis, normal to the long and the joint axis."""
        return next(a for a in AXES if a not in (self.long_axis[1], self.joint_axis))

    def index(self, which: str) -> int:
        """Position (0, 1, 2) of the ``long``, ``joint`` or ``cross`` axis."""
        axis = {"long": self.long_axis[1], "joint": self.joint_axis, "cross": self.cross_axis}
        return AXES.index(axis[which])

    def describe(self) -> dict[str, str]:
        """The frame in words (the JSON file's ``frame``)."""
        return {
            "origin": "the joint centre on the dynamometer axis",
            "long_axis": f"{self.long_axis} (joint to centre of mass)",
            "joint_axis": f"{self.joint_axis} (the dynamometer axis; the measured radius)",
            "cross_axis": f"{self.cross_axis} (normal to both)",
        }

    def placement(self, gravity_axis: str, joint_world: str, phase: float) -> NDArray:
        """The rotation from the segment's parent frame to the world (see the module notes).

        Parameters
        ----------
        gravity_axis : str
            The world axis gravity points along (``"-z"`` for biorbd, ``"-y"`` for OpenSim).
        joint_world : str
            The world axis the joint axis lies along; normal to ``gravity_axis``.
        phase : float
            ``phi`` (rad): the model's angle ``q`` is the dynamometer's ``theta``.
        """
        down, across = axis_vector(gravity_axis), axis_vector(joint_world)
        if abs(float(down @ across)) > 0.5:
            raise ValueError(f"joint_world {joint_world} is not normal to gravity {gravity_axis}")
        long, joint = axis_vector(self.long_axis), axis_vector(self.joint_axis)
        body = np.column_stack([long, joint, np.cross(long, joint)])
        world = np.column_stack([down, across, np.cross(down, across)])
        return world @ body.T @ rotation_about(joint, phase)

    def gravity_at_zero(self, phase: float) -> NDArray:
        """Gravity's direction in the body frame at the model's angle 0: ``R_J(-phi)`` long."""
        return rotation_about(axis_vector(self.joint_axis), -phase) @ axis_vector(self.long_axis)
