"""Ideal rigid bodies with textbook inertia formulas, to validate estimates against.

Each constructor returns an :class:`IdealBody`: mass ``m`` (kg, given or from a density and the
volume), the distance ``x`` of its centroid from the joint (m), and its radius of gyration ``rho``
(m) about the axis through the centroid **parallel to the dynamometer shaft**. The inertia about
the joint follows from the parallel-axis theorem, ``I = m (rho² + x²)``.

Coordinates used in every docstring below: the shaft (rotation axis) is ``z``; the lever arm, from
the joint towards the body, is ``x``; ``y`` completes the frame. Every body is uniform (constant
density), so ``rho`` depends on the geometry only and the mass only scales ``I``.

======================  =============================================  ===============
shape                   ``rho²`` about the centroidal axis ∥ shaft     default ``x``
======================  =============================================  ===============
solid disk, ``along``   ``r²/2`` (its symmetry axis ∥ shaft)           none (required)
solid disk, ``across``  ``(3 r² + h²)/12`` (symmetry axis ⊥ shaft)     none (required)
thin rod                ``L²/12`` (length along the lever arm)         ``L/2``
square tube             ``(A² + a² + l²)/12``                          ``l/2``
rectangular tube        ``[WH(W² + l²) − wh(w² + l²)] / 12(WH − wh)``  ``l/2``
box                     ``(b² + c²)/12`` (edge ``a`` ∥ shaft)          ``b/2``
solid sphere            ``2 r²/5``                                     none (required)
======================  =============================================  ===============

The default ``x`` of the elongated bodies is that of a body starting at the shaft and reaching
out along the lever arm. Son et al.'s Table 1 prints the square tube's density as
``d = (A² l − a² l) / m``, a volume per mass; the density is ``m / V``, and only that gives their
Table 2 (``docs/shapes.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ._checks import check_non_negative, check_positive
from .errors import InputError
from .physics import GRAVITY

__all__ = [
    "SHAPES",
    "IdealBody",
    "box",
    "ideal_body",
    "rectangular_tube",
    "rod",
    "solid_cylinder",
    "solid_disk",
    "sphere",
    "square_tube",
]

AXES = ("along", "across")


@dataclass(frozen=True)
class IdealBody:
    """A uniform rigid body on the shaft, with its inertial parameters.

    Attributes
    ----------
    mass : float
        ``m`` (kg), positive.
    com_distance : float
        ``x`` (m), distance of the centroid from the joint (shaft axis), ``>= 0``.
    radius_of_gyration : float
        ``rho`` (m), about the axis through the centroid parallel to the shaft, ``>= 0``.
    shape : str
        Name of the shape (``"solid-disk"``, ``"rod"``, ...; ``"custom"`` if built directly).
    axis : str
        How the body is oriented relative to the shaft, in words.
    dimensions : tuple of (str, float)
        The lengths it was built from (m), in constructor order.
    volume : float or None
        ``V`` (m^3), if the shape has one (a thin rod has none).
    density : float or None
        ``m / V`` (kg/m^3), given or derived; ``None`` without a volume.
    """

    mass: float
    com_distance: float
    radius_of_gyration: float
    shape: str = "custom"
    axis: str = ""
    dimensions: tuple[tuple[str, float], ...] = ()
    volume: float | None = None
    density: float | None = None

    def __post_init__(self) -> None:
        where = "IdealBody: "
        object.__setattr__(self, "mass", check_positive(self.mass, f"{where}mass", "kg"))
        object.__setattr__(
            self,
            "com_distance",
            check_non_negative(self.com_distance, f"{where}com_distance", "m"),
        )
        object.__setattr__(
            self,
            "radius_of_gyration",
            check_non_negative(self.radius_of_gyration, f"{where}radius_of_gyration", "m"),
        )

    @property
    def inertia_about_com(self) -> float:
        """``m rho²`` (kg m^2), about the centroidal axis parallel to the shaft."""
        return self.mass * self.radius_of_gyration**2

    @property
    def inertia(self) -> float:
        """``m (rho² + x²)`` (kg m^2), about the joint (parallel-axis theorem)."""
        return self.mass * (self.radius_of_gyration**2 + self.com_distance**2)

    def gravity_moment(self, gravity: float = GRAVITY) -> float:
        """Largest gravitational moment about the joint, ``m g x`` (N m); ``gravity`` in m/s^2."""
        return self.mass * gravity * self.com_distance

    def as_dict(self, gravity: float = GRAVITY) -> dict[str, float]:
        """The parameters and derived quantities under the names of ``summary.csv``.

        Returns
        -------
        dict
            ``mass`` (kg), ``com_distance`` (m), ``radius_of_gyration`` (m), ``inertia``
            (kg m^2, about the joint) and ``gravity_moment`` (N m, with ``gravity`` in m/s^2).
        """
        return {
            "mass": self.mass,
            "com_distance": self.com_distance,
            "radius_of_gyration": self.radius_of_gyration,
            "inertia": self.inertia,
            "gravity_moment": self.gravity_moment(gravity),
        }

    def describe(self) -> str:
        """A few lines of text: shape, dimensions, orientation, parameters and inertias."""
        dims = ", ".join(f"{name} {value:.4g} m" for name, value in self.dimensions)
        head = f"{self.shape} ({dims})" if dims else self.shape
        lines = [head]
        if self.axis:
            lines.append(f"  rotation axis: {self.axis}")
        if self.density is not None:
            lines.append(f"  density {self.density:.5g} kg/m^3, volume {self.volume:.5g} m^3")
        parameters = (
            f"  mass m = {self.mass:.4g} kg, CoM distance x = {self.com_distance:.4g} m, "
            f"radius of gyration rho = {self.radius_of_gyration:.4g} m"
        )
        inertias = (
            f"  inertia about the CoM m rho^2 = {self.inertia_about_com:.4g} kg m^2, "
            f"about the joint m (rho^2 + x^2) = {self.inertia:.4g} kg m^2"
        )
        lines += [parameters, inertias]
        return "\n".join(lines)


# --- constructors ------------------------------------------------------------------------------


def solid_disk(
    radius: float,
    thickness: float,
    *,
    mass: float | None = None,
    density: float | None = None,
    com_distance: float,
    axis: str = "along",
) -> IdealBody:
    """A solid disk (or cylinder) of radius ``r`` and thickness ``h``.

    Parameters
    ----------
    radius, thickness : float
        ``r`` and ``h`` (m), positive.
    mass, density : float, optional
        Exactly one: ``m`` (kg) or the density (kg/m^3), ``m = density * pi r² h``.
    com_distance : float
        ``x`` (m), from the joint to the disk's centre, ``>= 0``.
    axis : {"along", "across"}
        ``"along"``: the disk's symmetry axis is parallel to the shaft (a weight plate on the
        lever arm), ``rho² = r²/2``. ``"across"``: the symmetry axis is perpendicular to the
        shaft, ``rho² = (3 r² + h²)/12``.

    Returns
    -------
    IdealBody

    Raises
    ------
    InputError
        A length not positive and finite, not exactly one of ``mass``/``density``, an unknown
        ``axis``.
    """
    return _solid_disk("solid_disk: ", radius, thickness, mass, density, com_distance, axis)


def solid_cylinder(
    radius: float,
    thickness: float,
    *,
    mass: float | None = None,
    density: float | None = None,
    com_distance: float,
    axis: str = "along",
) -> IdealBody:
    """Same as :func:`solid_disk`; ``thickness`` is the cylinder's length along its axis."""
    return _solid_disk("solid_cylinder: ", radius, thickness, mass, density, com_distance, axis)


def rod(length: float, *, mass: float, com_distance: float | None = None) -> IdealBody:
    """A thin rod of length ``L`` lying along the lever arm, ``rho² = L²/12``.

    Parameters
    ----------
    length : float
        ``L`` (m), positive.
    mass : float
        ``m`` (kg), positive.
    com_distance : float, optional
        ``x`` (m); default ``L/2``, a rod that starts at the shaft (then ``I = m L²/3``).

    Returns
    -------
    IdealBody

    Raises
    ------
    InputError
        A value not positive and finite (``com_distance`` may be zero).
    """
    return _rod("rod: ", length, mass, com_distance)


def square_tube(
    outer: float,
    inner: float,
    length: float,
    *,
    mass: float | None = None,
    density: float | None = None,
    com_distance: float | None = None,
) -> IdealBody:
    """A square tube (hollow square section) lying along the lever arm.

    The model of Son et al.'s elbow attachment (Table 1): an ``A x A`` cuboid of length ``l``
    minus its ``a x a`` core, turning about an axis perpendicular to its length,
    ``rho² = (A² + a² + l²)/12``.

    Parameters
    ----------
    outer, inner : float
        Outer and inner edge of the section, ``A`` and ``a`` (m), ``0 < a < A``.
    length : float
        ``l`` (m), positive, along the lever arm.
    mass, density : float, optional
        Exactly one: ``m`` (kg) or the density (kg/m^3), ``m = density (A² − a²) l``.
    com_distance : float, optional
        ``x`` (m); default ``l/2``, a tube that starts at the shaft.

    Returns
    -------
    IdealBody

    Raises
    ------
    InputError
        A length not positive and finite, ``inner >= outer``, not exactly one of
        ``mass``/``density``.
    """
    return _square_tube("square_tube: ", outer, inner, length, mass, density, com_distance)


def rectangular_tube(
    outer_w: float,
    outer_h: float,
    inner_w: float,
    inner_h: float,
    length: float,
    *,
    mass: float | None = None,
    density: float | None = None,
    com_distance: float | None = None,
) -> IdealBody:
    """A tube of hollow rectangular section lying along the lever arm.

    The section is ``W x H`` outside and ``w x h`` inside. The ``H`` and ``h`` sides are
    **parallel to the shaft**; the ``W`` and ``w`` sides lie in the plane of rotation, across the
    lever arm. So ``rho² = [W H (W² + l²) − w h (w² + l²)] / (12 (W H − w h))``: the heights do
    not enter except through the mass distribution. Swap the ``_w`` and ``_h`` arguments for a
    tube turned a quarter turn about its length.

    Parameters
    ----------
    outer_w, outer_h, inner_w, inner_h : float
        ``W``, ``H``, ``w``, ``h`` (m), ``0 < w < W`` and ``0 < h < H``.
    length : float
        ``l`` (m), positive, along the lever arm.
    mass, density : float, optional
        Exactly one: ``m`` (kg) or the density (kg/m^3), ``m = density (W H − w h) l``.
    com_distance : float, optional
        ``x`` (m); default ``l/2``, a tube that starts at the shaft.

    Returns
    -------
    IdealBody

    Raises
    ------
    InputError
        A length not positive and finite, an inner side not smaller than its outer side, not
        exactly one of ``mass``/``density``.
    """
    return _rectangular_tube(
        "rectangular_tube: ",
        outer_w,
        outer_h,
        inner_w,
        inner_h,
        length,
        mass,
        density,
        com_distance,
    )


def box(
    a: float,
    b: float,
    c: float,
    *,
    mass: float | None = None,
    density: float | None = None,
    com_distance: float | None = None,
) -> IdealBody:
    """A solid rectangular box (cuboid) with edges ``a`` ∥ shaft, ``b`` along the lever arm.

    ``rho² = (b² + c²)/12``; ``c`` is the edge perpendicular to both the shaft and the lever arm.

    Parameters
    ----------
    a, b, c : float
        Edges (m), positive: ``a`` parallel to the shaft, ``b`` along the lever arm, ``c`` across.
    mass, density : float, optional
        Exactly one: ``m`` (kg) or the density (kg/m^3), ``m = density a b c``.
    com_distance : float, optional
        ``x`` (m); default ``b/2``, a box that starts at the shaft.

    Returns
    -------
    IdealBody

    Raises
    ------
    InputError
        A length not positive and finite, not exactly one of ``mass``/``density``.
    """
    return _box("box: ", a, b, c, mass, density, com_distance)


def sphere(
    radius: float,
    *,
    mass: float | None = None,
    density: float | None = None,
    com_distance: float,
) -> IdealBody:
    """A solid sphere of radius ``r``, ``rho² = 2 r²/5``.

    Parameters
    ----------
    radius : float
        ``r`` (m), positive.
    mass, density : float, optional
        Exactly one: ``m`` (kg) or the density (kg/m^3), ``m = density 4/3 pi r³``.
    com_distance : float
        ``x`` (m), from the joint to the centre, ``>= 0``.

    Returns
    -------
    IdealBody

    Raises
    ------
    InputError
        A length not positive and finite, not exactly one of ``mass``/``density``.
    """
    return _sphere("sphere: ", radius, mass, density, com_distance)


# --- manifest tables ---------------------------------------------------------------------------

_MASS = ("mass", "density")


@dataclass(frozen=True)
class _Shape:
    build: Callable[..., IdealBody]
    required: tuple[str, ...]
    optional: tuple[str, ...]
    needs_mass: bool = True  # exactly one of mass/density (or mass alone when not in optional)

    @property
    def keys(self) -> tuple[str, ...]:
        return ("shape", *self.required, *self.optional)


_DISK = _Shape(
    lambda w, radius, thickness, com_distance, mass=None, density=None, axis="along": _solid_disk(
        w, radius, thickness, mass, density, com_distance, axis
    ),
    required=("radius", "thickness", "com_distance"),
    optional=(*_MASS, "axis"),
)

#: Shape names accepted by :func:`ideal_body` and the keys each takes (besides ``shape``).
SHAPES: dict[str, _Shape] = {
    "solid-disk": _DISK,
    "solid-cylinder": _DISK,
    "rod": _Shape(
        lambda w, length, mass, com_distance=None: _rod(w, length, mass, com_distance),
        required=("length", "mass"),
        optional=("com_distance",),
        needs_mass=False,
    ),
    "square-tube": _Shape(
        lambda w, outer, inner, length, mass=None, density=None, com_distance=None: _square_tube(
            w, outer, inner, length, mass, density, com_distance
        ),
        required=("outer", "inner", "length"),
        optional=(*_MASS, "com_distance"),
    ),
    "rectangular-tube": _Shape(
        lambda w, outer_w, outer_h, inner_w, inner_h, length, **kw: _rectangular_tube(
            w,
            outer_w,
            outer_h,
            inner_w,
            inner_h,
            length,
            kw.get("mass"),
            kw.get("density"),
            kw.get("com_distance"),
        ),
        required=("outer_w", "outer_h", "inner_w", "inner_h", "length"),
        optional=(*_MASS, "com_distance"),
    ),
    "box": _Shape(
        lambda w, a, b, c, mass=None, density=None, com_distance=None: _box(
            w, a, b, c, mass, density, com_distance
        ),
        required=("a", "b", "c"),
        optional=(*_MASS, "com_distance"),
    ),
    "sphere": _Shape(
        lambda w, radius, com_distance, mass=None, density=None: _sphere(
            w, radius, mass, density, com_distance
        ),
        required=("radius", "com_distance"),
        optional=_MASS,
    ),
}


def ideal_body(spec: Mapping[str, Any], where: str) -> IdealBody:
    """Build an :class:`IdealBody` from a manifest table such as ``[bodies.NAME.ideal]``.

    Parameters
    ----------
    spec : mapping
        ``shape`` (one of :data:`SHAPES`) and that shape's keyword arguments, e.g.
        ``{shape = "solid-disk", radius = 0.05, thickness = 0.06, mass = 2.92,
        com_distance = 0.45, axis = "along"}``. Lengths in m, mass in kg, density in kg/m^3.
    where : str
        Where the table is, for messages, e.g. ``"study.toml: bodies.weight.ideal"``; a field is
        named ``f"{where}.{key}"``.

    Returns
    -------
    IdealBody

    Raises
    ------
    InputError
        Not a table, a missing or unknown ``shape``, a missing or unknown key (the message lists
        what the shape takes), or any bad value the constructor rejects.
    """
    if not isinstance(spec, Mapping):
        raise InputError(f"{where}: expected a table of ideal-shape values, got {spec!r}")
    names = ", ".join(repr(name) for name in SHAPES)
    name = spec.get("shape")
    if name is None:
        raise InputError(f"{where}.shape: missing; expected one of {names}")
    if not isinstance(name, str) or name not in SHAPES:
        raise InputError(f"{where}.shape: unknown shape {name!r}; expected one of {names}")
    shape = SHAPES[name]
    for key in spec:
        if key not in shape.keys:
            raise InputError(
                f"{where}.{key}: unknown key for shape {name!r} (allowed: {', '.join(shape.keys)})"
            )
    for key in shape.required:
        if key not in spec:
            raise InputError(
                f"{where}.{key}: missing; shape {name!r} needs {', '.join(shape.required)}"
                + (" and one of mass/density" if shape.needs_mass else "")
            )
    kwargs = {key: value for key, value in spec.items() if key != "shape"}
    return shape.build(f"{where}.", **kwargs)


# --- implementations (``where`` prefixes every message: "box: " or "study.toml: ...ideal.") ----


def _solid_disk(where, radius, thickness, mass, density, com_distance, axis) -> IdealBody:
    r = check_positive(radius, f"{where}radius", "m")
    h = check_positive(thickness, f"{where}thickness", "m")
    x = check_non_negative(com_distance, f"{where}com_distance", "m")
    if axis == "along":
        rho2, text = r**2 / 2, "parallel to the disk's symmetry axis"
    elif axis == "across":
        rho2, text = (3 * r**2 + h**2) / 12, "perpendicular to the disk's symmetry axis"
    else:
        raise InputError(
            f"{where}axis: expected one of {', '.join(map(repr, AXES))}, got {axis!r}"
        )
    volume = math.pi * r**2 * h
    m, d = _mass_and_density(where, volume, mass, density)
    return IdealBody(
        m, x, math.sqrt(rho2), "solid-disk", text, (("radius", r), ("thickness", h)), volume, d
    )


def _rod(where, length, mass, com_distance) -> IdealBody:
    length = check_positive(length, f"{where}length", "m")
    m = check_positive(mass, f"{where}mass", "kg")
    x = (
        length / 2
        if com_distance is None
        else check_non_negative(com_distance, f"{where}com_distance", "m")
    )
    text = "perpendicular to the rod, which lies along the lever arm"
    return IdealBody(m, x, length / math.sqrt(12), "rod", text, (("length", length),))


def _square_tube(where, outer, inner, length, mass, density, com_distance) -> IdealBody:
    outer = check_positive(outer, f"{where}outer", "m")
    inner = check_positive(inner, f"{where}inner", "m")
    if inner >= outer:
        raise InputError(f"{where}inner: must be smaller than outer = {outer!r} m, got {inner!r}")
    length = check_positive(length, f"{where}length", "m")
    rho2 = _tube_rho2(outer, outer, inner, inner, length)
    volume = (outer**2 - inner**2) * length
    m, d = _mass_and_density(where, volume, mass, density)
    x = _default_com(where, com_distance, length)
    text = "perpendicular to the tube, which lies along the lever arm"
    dims = (("outer", outer), ("inner", inner), ("length", length))
    return IdealBody(m, x, math.sqrt(rho2), "square-tube", text, dims, volume, d)


def _rectangular_tube(
    where, outer_w, outer_h, inner_w, inner_h, length, mass, density, com_distance
) -> IdealBody:
    big_w = check_positive(outer_w, f"{where}outer_w", "m")
    big_h = check_positive(outer_h, f"{where}outer_h", "m")
    small_w = check_positive(inner_w, f"{where}inner_w", "m")
    small_h = check_positive(inner_h, f"{where}inner_h", "m")
    if small_w >= big_w:
        raise InputError(
            f"{where}inner_w: must be smaller than outer_w = {big_w!r} m, got {small_w!r}"
        )
    if small_h >= big_h:
        raise InputError(
            f"{where}inner_h: must be smaller than outer_h = {big_h!r} m, got {small_h!r}"
        )
    length = check_positive(length, f"{where}length", "m")
    rho2 = _tube_rho2(big_w, big_h, small_w, small_h, length)
    volume = (big_w * big_h - small_w * small_h) * length
    m, d = _mass_and_density(where, volume, mass, density)
    x = _default_com(where, com_distance, length)
    text = "perpendicular to the tube (along the lever arm), parallel to the outer_h sides"
    dims = (
        ("outer_w", big_w),
        ("outer_h", big_h),
        ("inner_w", small_w),
        ("inner_h", small_h),
        ("length", length),
    )
    return IdealBody(m, x, math.sqrt(rho2), "rectangular-tube", text, dims, volume, d)


def _box(where, a, b, c, mass, density, com_distance) -> IdealBody:
    a = check_positive(a, f"{where}a", "m")
    b = check_positive(b, f"{where}b", "m")
    c = check_positive(c, f"{where}c", "m")
    volume = a * b * c
    m, d = _mass_and_density(where, volume, mass, density)
    x = _default_com(where, com_distance, b)
    text = "parallel to edge a; edge b along the lever arm"
    rho = math.sqrt((b**2 + c**2) / 12)
    return IdealBody(m, x, rho, "box", text, (("a", a), ("b", b), ("c", c)), volume, d)


def _sphere(where, radius, mass, density, com_distance) -> IdealBody:
    r = check_positive(radius, f"{where}radius", "m")
    x = check_non_negative(com_distance, f"{where}com_distance", "m")
    volume = 4 / 3 * math.pi * r**3
    m, d = _mass_and_density(where, volume, mass, density)
    rho = r * math.sqrt(2 / 5)
    return IdealBody(m, x, rho, "sphere", "through the centre", (("radius", r),), volume, d)


def _tube_rho2(big_w: float, big_h: float, small_w: float, small_h: float, length: float):
    # The tube is the solid W x H x l cuboid minus the w x h x l core of the same density; about
    # an axis parallel to the H sides each contributes (area l) (side² + l²) / 12 per density.
    outer = big_w * big_h * (big_w**2 + length**2)
    inner = small_w * small_h * (small_w**2 + length**2)
    return (outer - inner) / (12 * (big_w * big_h - small_w * small_h))


def _default_com(where: str, com_distance: object, extent: float) -> float:
    if com_distance is None:
        return extent / 2
    return check_non_negative(com_distance, f"{where}com_distance", "m")


def _mass_and_density(
    where: str, volume: float, mass: object, density: object
) -> tuple[float, float]:
    if (mass is None) == (density is None):
        got = "neither" if mass is None else f"both ({mass!r} and {density!r})"
        raise InputError(
            f"{where}mass: give exactly one of mass (kg) or density (kg/m^3), got {got}"
        )
    if mass is not None:
        m = check_positive(mass, f"{where}mass", "kg")
        return m, m / volume
    d = check_positive(density, f"{where}density", "kg/m^3")
    return d * volume, d
