"""Rigid-body relations between the inertial parameters of a body on a dynamometer shaft.

Symbols (SI units throughout): mass ``m`` (kg), distance of the centre of mass from the joint
``x`` (m), radius of gyration about the centre of mass ``rho`` (m), moment of inertia about the
joint ``I = m (rho**2 + x**2)`` (kg m^2) and gravitational moment ``M_g = m g x`` (N m).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DERIVED",
    "GRAVITY",
    "LABELS",
    "PARAMETERS",
    "REPORTED",
    "SYMBOLS",
    "UNITS",
    "curve_at_mass",
    "gravity_moment",
    "inertia",
    "joint_moment",
    "maximum_com_distance",
    "minimum_mass",
    "moved_moments",
    "parameters_from_identified",
    "point_moments",
]

#: Standard gravity used by the paper (m/s^2); every function takes ``gravity=`` to change it.
GRAVITY = 9.81

#: Parameter names in the order used for arrays of shape ``(..., 3)``.
PARAMETERS = ("mass", "com_distance", "radius_of_gyration")
#: Derived quantities reported beside the parameters.
DERIVED = ("inertia", "gravity_moment")
#: Every quantity a posterior reports, in table order.
REPORTED = (*PARAMETERS, *DERIVED)
UNITS = {
    "mass": "kg",
    "com_distance": "m",
    "radius_of_gyration": "m",
    "inertia": "kg m^2",
    "gravity_moment": "N m",
}
LABELS = {
    "mass": "mass $m$ [kg]",
    "com_distance": "CoM distance $x$ [m]",
    "radius_of_gyration": r"radius of gyration $\rho$ [m]",
    "inertia": r"inertia $I$ [kg m$^2$]",
    "gravity_moment": r"gravity moment $M_g$ [N m]",
}


SYMBOLS = {
    "mass": "$m$",
    "com_distance": "$x$",
    "radius_of_gyration": r"$\rho$",
    "inertia": "$I$",
    "gravity_moment": "$M_g$",
}


def inertia(mass: ArrayLike, radius_of_gyration: ArrayLike, com_distance: ArrayLike) -> NDArray:
    """Moment of inertia about the joint, ``m (rho^2 + x^2)`` (kg m^2), parallel-axis theorem."""
    m, rho, x = np.asarray(mass), np.asarray(radius_of_gyration), np.asarray(com_distance)
    return m * (rho**2 + x**2)


def gravity_moment(mass: ArrayLike, com_distance: ArrayLike, gravity: float = GRAVITY) -> NDArray:
    """Largest gravitational moment about the joint, ``m g x`` (N m)."""
    return np.asarray(mass) * gravity * np.asarray(com_distance)


def joint_moment(
    inertia: ArrayLike,
    gravity_moment: ArrayLike,
    angle: ArrayLike,
    acceleration: ArrayLike,
    phase: float = 0.0,
) -> NDArray:
    """Moment about the joint that turns the body: ``I alpha + M_g sin(theta + phi)`` (N m).

    The rigid-body part of the dynamometer's equation (``tau`` less its offset ``c``):
    positive in the direction of increasing ``theta``; ``theta + phi`` is the angle from
    the hanging position (the gravity vertical), so gravity resists a lift from it.
    Arrays broadcast (draws against time samples).
    """
    return np.asarray(inertia) * np.asarray(acceleration) + np.asarray(gravity_moment) * np.sin(
        np.asarray(angle) + phase
    )


def minimum_mass(inertia: ArrayLike, gravity_moment: ArrayLike, gravity: float = GRAVITY):
    """Smallest mass consistent with ``I`` and ``M_g``: ``(M_g/g)^2 / I`` (kg).

    It follows from ``rho^2 >= 0``: ``I = m rho^2 + (m x)^2 / m >= (M_g/g)^2 / m``.
    """
    return (np.asarray(gravity_moment) / gravity) ** 2 / np.asarray(inertia)


def maximum_com_distance(inertia: ArrayLike, gravity_moment: ArrayLike, gravity: float = GRAVITY):
    """Largest centre-of-mass distance consistent with ``I`` and ``M_g``: ``I g / M_g`` (m)."""
    return np.asarray(inertia) * gravity / np.asarray(gravity_moment)


def curve_at_mass(
    first_moment: ArrayLike, inertia: ArrayLike, mass: ArrayLike
) -> tuple[NDArray, NDArray]:
    """The identification curve at given masses: ``x = a / m``, ``rho = sqrt(I / m - x^2)``.

    Rotation about one axis identifies only ``a = m x = M_g / g`` (kg m) and
    ``I = m (rho^2 + x^2)`` (kg m^2); every body with those two values lies on this curve,
    one body per mass. Below :func:`minimum_mass` (``rho^2 < 0``) ``rho`` is clipped to 0.

    Parameters
    ----------
    first_moment : array_like
        ``a = m x`` (kg m).
    inertia : array_like
        ``I`` (kg m^2), about the joint.
    mass : array_like
        ``m`` (kg), positive.

    Returns
    -------
    com_distance, radius_of_gyration : ndarray
        ``x`` (m) and ``rho`` (m) at each mass, broadcast together.
    """
    a, b, m = np.asarray(first_moment), np.asarray(inertia), np.asarray(mass)
    x = a / m
    rho = np.sqrt(np.clip(b / m - x * x, 0.0, None))
    return x, rho


def moved_moments(
    first_moment: ArrayLike, inertia: ArrayLike, mass: ArrayLike, offset: ArrayLike
) -> tuple[NDArray, NDArray]:
    """``a`` and ``I`` of a body moved ``offset`` further along the lever (``x -> x + d``).

    ``a(d) = m (x + d) = a + m d`` and ``I(d) = m (rho^2 + (x + d)^2) = I + 2 a d + m d^2``:
    a second mounting adds the mass to what the first one identifies.
    """
    a, b, m, d = (np.asarray(v, dtype=float) for v in (first_moment, inertia, mass, offset))
    return a + m * d, b + 2 * a * d + m * d * d


def point_moments(
    mass: ArrayLike, com_distance: ArrayLike, radius_of_gyration: ArrayLike = 0.0
) -> tuple[NDArray, NDArray]:
    """``a = m x`` (kg m) and ``I = m (rho^2 + x^2)`` (kg m^2) of a known body (an added mass)."""
    m, x, r = (np.asarray(v, dtype=float) for v in (mass, com_distance, radius_of_gyration))
    return m * x, m * (r * r + x * x)


def parameters_from_identified(
    first_moment: ArrayLike, inertia: ArrayLike, angle: ArrayLike, *, radius: bool = True
) -> tuple[NDArray, NDArray, NDArray]:
    """Map the identified pair and the unidentified angle back to ``(m, x, rho)``.

    Every body with first moment of mass ``a = m x`` (kg m) and inertia ``I = b`` (kg m^2) lies
    on the curve ``x = R sin^2(psi)``, ``rho = R sin(psi) cos(psi)``, ``m = a / x`` with
    ``R = b / a`` (the distance from the joint to the centre of percussion) and
    ``psi = atan(x / rho)`` in ``(0, pi/2)``. A uniform prior on ``(m, x, rho)`` is, in
    ``(a, b, psi)``, the density ``1/a`` on the image of the box: uniform in ``psi`` for fixed
    ``(a, b)``. The data speak to ``(a, b)`` only; ``psi`` is where the prior decides.

    Parameters
    ----------
    first_moment : array_like
        ``a = m x`` (kg m).
    inertia : array_like
        ``b = I`` (kg m^2), about the joint.
    angle : array_like
        ``psi`` (rad) in ``(0, pi/2)``.
    radius : bool
        With ``False``, ``rho`` is not computed (``None`` in its place): for a caller that does
        not read it, one cosine fewer per point.

    Returns
    -------
    mass, com_distance, radius_of_gyration : ndarray
        ``m`` (kg), ``x`` (m), ``rho`` (m), broadcast together.
    """
    a, b, psi = np.asarray(first_moment), np.asarray(inertia), np.asarray(angle)
    r = b / a
    s = np.sin(psi)
    rs = r * s
    x = rs * s
    rho = rs * np.cos(psi) if radius else None
    return a / x, x, rho  # type: ignore[return-value]
