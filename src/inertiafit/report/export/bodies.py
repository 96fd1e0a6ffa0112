"""A posterior's bodies as model segments: mass, centre of mass, inertia tensor, a joint's curve.

Each body becomes a :class:`BodyInertia` in its :class:`~inertiafit.report.export.frames.Frame`:
the centre of mass on the long axis at ``x`` from the joint, ``I = m rho^2`` about the centre
of mass about the joint axis, and the other two radii from the body's declaration
(:mod:`~inertiafit.report.export.radii`). The *median* model takes the posterior medians of
``m``, ``x`` and ``rho``; a *draw* takes one joint posterior draw of every body (the same draw
index for all: their correlations are kept).

A living body also carries its joint (:class:`JointCurve`): the passive moment tabulated over
the swept range, its hysteresis and the viscous damping, the fit's mean in the median model
and, in a draw, a draw conditioned on that draw's gravity moment
(:mod:`inertiafit.report.living_joint`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from inertiafit.posterior import Posterior
from inertiafit.report.export.frames import Frame
from inertiafit.report.export.radii import OtherRadii, radii_for
from inertiafit.report.living_joint import LivingJoint, condition_moments

__all__ = [
    "CURVE_STEP_DEG",
    "EXPORT_COLUMNS",
    "BodyInertia",
    "JointCurve",
    "exported_bodies",
    "joint_grid",
]

#: Columns of ``export.csv``: a row per model (``median`` or draw number) and body.
EXPORT_COLUMNS = [
    "model",
    "body",
    "mass",
    "com_x",
    "com_y",
    "com_z",
    "inertia_xx",
    "inertia_yy",
    "inertia_zz",
    "radius_joint",
    "radius_long",
    "radius_cross",
    "posterior_draw",
    "phase",
    "damping",
    "passive_line_error",
]
#: Step (deg) of a living joint's tabulated curve over the swept range.
CURVE_STEP_DEG = 1.0


@dataclass(frozen=True)
class JointCurve:
    """A living joint in one model: its passive moment, hysteresis and damping.

    Attributes
    ----------
    angle : tuple of float
        Device angles (rad), the model's coordinate: every :data:`CURVE_STEP_DEG` over the
        swept range, its ends included.
    moment : tuple of float
        ``P`` at each angle (N m): the moment the device applies against the joint's elastic
        resistance, 0 at ``reference`` (the joint's own moment on the segment is ``-P``).
    hysteresis : tuple of float
        ``h`` at each angle (N m): the joint adds ``h sgn(omega)``.
    damping : float
        ``b`` (N m s/rad): the joint adds ``b omega``.
    zero : float
        The joint angle (rad) at the device's 0.
    reference : float
        The device angle (rad) where ``P`` is 0, the middle of the swept range.
    """

    angle: tuple[float, ...]
    moment: tuple[float, ...]
    hysteresis: tuple[float, ...]
    damping: float
    zero: float
    reference: float

    def at(self, theta: Any) -> NDArray:
        """The tabulated curve at device angles ``theta`` (rad), as a model file holds it.

        Linear between the tabulated angles, continued with the end slopes beyond them.
        """
        x, y = np.asarray(self.angle), np.asarray(self.moment)
        t = np.asarray(theta, dtype=float)
        out = np.interp(t, x, y)
        low, high = t < x[0], t > x[-1]
        out = np.where(low, y[0] + (t - x[0]) * (y[1] - y[0]) / (x[1] - x[0]), out)
        return np.where(high, y[-1] + (t - x[-1]) * (y[-1] - y[-2]) / (x[-1] - x[-2]), out)

    @property
    def line(self) -> tuple[float, float]:
        """``(P0, k)``: the straight line ``P0 + k theta`` (N m, N m/rad) closest to the curve.

        Least squares over the tabulated angles (uniform in angle): what a format with linear
        passive torques only (biorbd) holds.
        """
        slope, intercept = np.polyfit(np.asarray(self.angle), np.asarray(self.moment), 1)
        return float(intercept), float(slope)

    @property
    def line_error(self) -> float:
        """The line's largest distance from the curve over the swept range (N m)."""
        p0, k = self.line
        return float(np.max(np.abs(np.asarray(self.moment) - p0 - k * np.asarray(self.angle))))


@dataclass(frozen=True)
class BodyInertia:
    """One body as a model segment: mass, centre of mass and inertia tensor (SI units).

    ``com`` is in the body frame (origin at the joint); ``inertia`` is 3 x 3 about the centre
    of mass in the body frame; ``radii`` are the radii of gyration about the centre of mass
    (``joint``, ``long``, ``cross``); ``extra["other_radii"]`` how the long and cross radii
    were declared (``kind``, ``long``, ``cross``, ``sd_log``: the uncertainty the draws carry);
    ``joint`` a living body's joint (``None`` for a rigid body).
    """

    name: str
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[tuple[float, float, float], ...]
    radii: dict[str, float]
    source: str = ""
    draw: int = -1
    extra: dict[str, Any] = field(default_factory=dict)
    joint: JointCurve | None = None


def joint_grid(joint: LivingJoint) -> NDArray:
    """The device angles (rad) of a living joint's tabulated curve (:class:`JointCurve`)."""
    lo, hi = (math.degrees(v) for v in joint.angle_range)
    degrees = np.arange(lo, hi, CURVE_STEP_DEG)
    if hi - degrees[-1] < 1e-9:  # hi on the grid (within rounding): it replaces the last
        degrees = degrees[:-1]
    return np.radians(np.r_[degrees, hi])


def _curve(
    joint: LivingJoint, theta: NDArray, coefficients: NDArray, damping: float
) -> JointCurve:
    return JointCurve(
        angle=tuple(float(v) for v in theta),
        moment=tuple(float(v) for v in joint.passive(theta, coefficients)[0]),
        hysteresis=tuple(float(v) for v in joint.hysteresis(theta, coefficients)[0]),
        damping=float(damping),
        zero=joint.zero,
        reference=joint.reference,
    )


def _body(
    name: str,
    m: float,
    x: float,
    rho: float,
    long: float,
    cross: float,
    frame: Frame,
    spec: OtherRadii,
    draw: int,
    joint: JointCurve | None,
) -> BodyInertia:
    sign = 1.0 if frame.long_axis[0] == "+" else -1.0
    com = [0.0, 0.0, 0.0]
    com[frame.index("long")] = sign * x
    diag = [0.0, 0.0, 0.0]
    diag[frame.index("long")] = m * long * long
    diag[frame.index("joint")] = m * rho * rho
    diag[frame.index("cross")] = m * cross * cross
    tensor = ((diag[0], 0.0, 0.0), (0.0, diag[1], 0.0), (0.0, 0.0, diag[2]))
    return BodyInertia(
        name=name,
        mass=m,
        com=(com[0], com[1], com[2]),
        inertia=tensor,
        radii={"joint": rho, "long": long, "cross": cross},
        source=spec.source,
        draw=draw,
        extra={
            "other_radii": {
                "kind": spec.kind,
                "long": spec.long,
                "cross": spec.cross,
                "sd_log": spec.sd_log,
            }
        },
        joint=joint,
    )


def exported_bodies(
    posterior: Posterior,
    radii: Mapping[str, OtherRadii],
    *,
    frame: Frame | None = None,
    draws: int = 0,
    seed: int = 0,
    joint: LivingJoint | None = None,
) -> tuple[list[BodyInertia], list[list[BodyInertia]]]:
    """The median model's bodies and ``draws`` models' bodies sampled from the posterior.

    Parameters
    ----------
    posterior : Posterior
    radii : mapping
        Each body's :class:`OtherRadii` (:func:`~inertiafit.report.export.radii.other_radii`).
    frame : Frame, optional
        Default ``Frame()``: long axis ``+x``, joint axis ``z``.
    draws : int
        How many models sampled from the posterior (0: the median model only). Posterior
        draws are taken without replacement while there are enough.
    seed : int
        Seeds the choice of draws, the draws of uncertain radii and of the living joint.
    joint : LivingJoint, optional
        The living body's joint (:func:`~inertiafit.report.living_joint.living_joint`).
    """
    frame = frame or Frame()
    rng = np.random.default_rng(seed)
    values = {
        b: {
            p: posterior.draws(b, p).reshape(-1)
            for p in ("mass", "com_distance", "radius_of_gyration")
        }
        for b in posterior.bodies
    }
    total = next(iter(values.values()))["mass"].size
    grid = joint_grid(joint) if joint is not None else np.zeros(0)
    living = joint.body if joint is not None else ""
    median = []
    for b in posterior.bodies:
        m, x, rho = (float(np.median(values[b][p])) for p in values[b])
        long, cross = radii_for(np.array([rho]), radii[b], None, b)
        curve = (
            _curve(joint, grid, joint.mean, joint.damping[0])
            if joint is not None and b == living
            else None
        )
        median.append(
            _body(b, m, x, rho, float(long[0]), float(cross[0]), frame, radii[b], -1, curve)
        )
    sampled: list[list[BodyInertia]] = []
    if draws:
        index = rng.choice(total, size=draws, replace=draws > total)
        per_body = {}
        for b in posterior.bodies:
            per_body[b] = radii_for(values[b]["radius_of_gyration"][index], radii[b], rng, b)
        curves: list[JointCurve | None] = [None] * draws
        if joint is not None:
            coefficients = joint.draws(rng, draws, condition_moments(posterior, joint, index))
            damping = joint.damping_draws(rng, draws)
            curves = [_curve(joint, grid, coefficients[k], damping[k]) for k in range(draws)]
        for k, i in enumerate(index):
            sampled.append(
                [
                    _body(
                        b,
                        float(values[b]["mass"][i]),
                        float(values[b]["com_distance"][i]),
                        float(values[b]["radius_of_gyration"][i]),
                        float(per_body[b][0][k]),
                        float(per_body[b][1][k]),
                        frame,
                        radii[b],
                        int(i),
                        curves[k] if b == living else None,
                    )
                    for b in posterior.bodies
                ]
            )
    return median, sampled
