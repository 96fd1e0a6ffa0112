"""Simulated studies of a living limb: a joint's passive moments, postures and rest trials.

A condition that holds the living body (issue 19; ``docs/processing.md``, "Simulated living
limbs") follows, in posture ``p``,

    tau = I alpha + cos(t_p) M_g sin(theta + phi + r_p) + c
          + P(theta_j) + b omega + h smooth_sign(omega)

with ``theta_j = radians(joint_angle_at_zero) + theta`` the joint angle, ``P`` the passive
elastic moment of :func:`inertiafit.passive.passive_moment`, ``b`` the viscous damping, ``h``
the hysteresis, ``r_p`` the posture's gravity rotation and ``t_p`` its axis tilt (90 deg: a
vertical axis, no gravity moment). The rigid part and the recording's imperfections are
:func:`~inertiafit.simulate.signals.simulate_trial`'s; the joint's moments enter through its
``extra_torque``. :class:`PassiveTruth` holds the joint's true parameters and
:func:`simulate_living_study` writes a whole study with the manifest keys of a living segment
(``docs/formats.md``).
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertiafit.io.units import DEG
from inertiafit.mounting import Mounting
from inertiafit.passive import JOINTS, literature_curve, passive_moment
from inertiafit.physics import GRAVITY
from inertiafit.simulate.emg import EmgSimulation, Reflex
from inertiafit.simulate.emg import truth_lines as emg_truth_lines
from inertiafit.simulate.files import check_units, toml_value
from inertiafit.simulate.signals import Body, Motion, Noise
from inertiafit.simulate.study import (
    PlannedTrial,
    TrialWriter,
    condition_totals,
    emg_manifest_lines,
    manifest_head,
    truth_lines,
)

__all__ = [
    "DEFAULT_LIVING_BODIES",
    "HYSTERESIS_SPEED",
    "PASSIVE_KEYS",
    "POSTURE_DESIGNS",
    "PassiveTruth",
    "rigid_view",
    "simulate_living_study",
    "smooth_sign",
]

#: The speed (rad/s) over which the hysteresis ``h smooth_sign(omega)`` switches sign:
#: ``tanh(omega / HYSTERESIS_SPEED)``, 0.1 deg/s (a tenth of a quasi-static sweep's speed, so
#: the sweeps and the fast trials see the full ``+-h``, and a still shaft none).
HYSTERESIS_SPEED = 0.1 * DEG
#: Posture designs by name: posture -> (gravity rotation, axis tilt), degrees. "two" rotates
#: gravity by 45 deg in the second posture; "horizontal" adds one with a vertical axis.
POSTURE_DESIGNS: dict[str, dict[str, tuple[float, float]]] = {
    "one": {"upright": (0.0, 0.0)},
    "two": {"upright": (0.0, 0.0), "rotated": (45.0, 0.0)},
    "horizontal": {"upright": (0.0, 0.0), "horizontal": (0.0, 90.0)},
}
#: The default bodies (mass kg, radius of gyration m, centre-of-mass distance m): the Biodex
#: elbow attachment's nominal values (``priors/biodex-elbow-attachment.toml``) and an adult's
#: forearm and hand (about 2 % of a 75 kg body's mass, its centre of mass 0.15 m from the
#: elbow).
DEFAULT_LIVING_BODIES: dict[str, tuple[float, float, float]] = {
    "attachment": (2.91, 0.130, 0.225),
    "forearm": (1.5, 0.08, 0.15),
}
#: The joint's true parameters, as :class:`PassiveTruth` and ``truth.toml``'s ``[passive]``
#: name them (angles in degrees).
PASSIVE_KEYS = (
    "stiffness",
    "relaxed_angle",
    "stop_moment_low",
    "stop_moment_high",
    "stop_width",
    "range",
    "curve_scale",
    "damping",
    "hysteresis",
    "shape",
    "shape_size",
    "shape_width",
    "hysteresis_slope",
    "hip_angle",
    "ankle_angle",
    "knee_angle",
)
#: Passive curves outside the model's family (spring, exponential stops, scaled literature
#: curve), added to ``P`` by :attr:`PassiveTruth.shape` to check that the analysis does not
#: depend on that family (issue 32). With ``u = (theta_j - mid) / half`` over the joint's
#: ``range`` and ``w`` its ``shape_width`` (deg), ``shape_size`` (N m) times: ``"cubic"``
#: ``u**3`` (stiffening towards both ends), ``"tanh"`` ``tanh((theta_j - mid) / w)`` (a
#: saturating resistance), ``"kink"`` ``max(u, 0)`` (a stiffness that doubles halfway),
#: ``"bump"`` ``exp(-((theta_j - mid) / w)**2 / 2)`` (a bi-articular muscle going slack and
#: taut again), ``"none"`` nothing.
SHAPES = ("none", "cubic", "tanh", "kink", "bump")
#: Joints with a literature curve whose scale is drawn.
_CURVED = ("knee", "ankle")
_DIRECTIONS = ("up", "down")
#: File-name suffix of a fast trial's direction.
_SUFFIX = {"up": "", "down": "_down"}
_NAME = re.compile(r"^[A-Za-z0-9_-]+$")


def smooth_sign(omega: ArrayLike, scale: float = HYSTERESIS_SPEED) -> NDArray:
    """``tanh(omega / scale)``: the sign of the velocity, 0 at rest, continuous."""
    return np.tanh(np.asarray(omega, dtype=np.float64) / scale)


@dataclass(frozen=True)
class PassiveTruth:
    """A living joint's true passive parameters.

    Attributes
    ----------
    joint : str
        One of :data:`inertiafit.passive.JOINTS`.
    joint_angle_at_zero : float
        The joint angle (deg) at the device's angle 0; the joint angle rises with the device's.
    stiffness : float
        ``k`` (N m/rad) of the spring about ``relaxed_angle`` (deg, joint).
    stop_moment_low, stop_moment_high : float
        The end stops' moments (N m) at the range ends ``range`` (deg, joint), growing by
        ``e`` every ``stop_width`` (deg) beyond them.
    curve_scale : float
        Multiplies the joint's literature curve (knee, ankle; 0 for none).
    damping : float
        ``b`` (N m s/rad), the viscous moment ``b omega``.
    hysteresis : float
        ``h`` (N m), the moment ``h smooth_sign(omega)`` (:func:`smooth_sign`).
    shape, shape_size, shape_width : str, float, float
        A curve outside the model's family added to ``P`` (:data:`SHAPES`).
    hysteresis_slope : float
        How much ``h`` changes (N m) from the middle of :attr:`range` to its ends.
    hip_angle, ankle_angle, knee_angle : float
        The other joints' angles (deg) at which this subject's literature curve is taken:
        the hip's and the ankle's for the knee, the knee's for the ankle. Riener & Edrich's
        curves change with them (bi-articular muscles), so a subject seated other than as the
        prior file assumes (hip 90, ankle 0, knee 90) has a curve of another shape, not only
        another scale.
    """

    joint: str
    joint_angle_at_zero: float
    stiffness: float
    relaxed_angle: float
    stop_moment_low: float
    stop_moment_high: float
    stop_width: float
    range: tuple[float, float]
    curve_scale: float
    damping: float
    hysteresis: float
    shape: str = "none"
    shape_size: float = 0.0
    shape_width: float = 20.0
    hysteresis_slope: float = 0.0
    hip_angle: float = 90.0
    ankle_angle: float = 0.0
    knee_angle: float = 90.0

    def _unit(self, theta_j: NDArray) -> tuple[NDArray, float]:
        """``(theta_j - mid)`` (rad) over :attr:`range`, and its half width (rad)."""
        lo, hi = np.radians(self.range)
        return theta_j - 0.5 * (lo + hi), 0.5 * (hi - lo)

    def extra(self, theta_j: ArrayLike) -> NDArray:
        """The moment (N m) of :attr:`shape` at joint angles ``theta_j`` (rad): :data:`SHAPES`."""
        dev, half = self._unit(np.asarray(theta_j, dtype=np.float64))
        u, w = dev / half, math.radians(self.shape_width)
        curves = {
            "none": lambda: np.zeros_like(u),
            "cubic": lambda: u**3,
            "tanh": lambda: np.tanh(dev / w),
            "kink": lambda: np.maximum(u, 0.0),
            "bump": lambda: np.exp(-0.5 * (dev / w) ** 2),
        }
        return self.shape_size * curves[self.shape]()

    def hysteresis_at(self, angle: ArrayLike) -> NDArray:
        """``h(theta_j) = h + hysteresis_slope u`` (N m) at device angles (rad), ``u`` in [-1, 1].

        The direction-dependent moment changing over the range, as a real ankle's does.
        """
        theta_j = math.radians(self.joint_angle_at_zero) + np.asarray(angle, dtype=np.float64)
        dev, half = self._unit(theta_j)
        return self.hysteresis + self.hysteresis_slope * dev / half

    def elastic(self, angle: ArrayLike) -> NDArray:
        """``P`` (N m) at device angles ``angle`` (rad)."""
        theta_j = math.radians(self.joint_angle_at_zero) + np.asarray(angle, dtype=np.float64)
        return (
            self.extra(theta_j)
            + self.literature(theta_j)
            + passive_moment(
                theta_j,
                stiffness=self.stiffness,
                relaxed=math.radians(self.relaxed_angle),
                stop_low=self.stop_moment_low,
                stop_high=self.stop_moment_high,
                range_low=math.radians(self.range[0]),
                range_high=math.radians(self.range[1]),
                width=math.radians(self.stop_width),
            )
        )

    def literature(self, theta_j: ArrayLike) -> NDArray:
        """``curve_scale`` times this subject's literature curve (N m) at ``theta_j`` (rad).

        :func:`inertiafit.passive.literature_curve` at :attr:`hip_angle`,
        :attr:`ankle_angle` and :attr:`knee_angle`; zero for the elbow and a generic joint.
        """
        curve = literature_curve(
            self.joint,
            theta_j,
            hip_deg=self.hip_angle,
            ankle_deg=self.ankle_angle,
            knee_deg=self.knee_angle,
        )
        return self.curve_scale * curve

    def torque(self, angle: ArrayLike, velocity: ArrayLike) -> NDArray:
        """The joint's whole moment (N m): ``P + b omega + h smooth_sign(omega)``.

        ``angle`` (rad) and ``velocity`` (rad/s) are the device's; a still shaft gets ``P``
        alone. This is the ``extra_torque`` of :func:`~inertiafit.simulate.signals.simulate_trial`.
        """
        omega = np.asarray(velocity, dtype=np.float64)
        return (
            self.elastic(angle)
            + self.damping * omega
            + self.hysteresis_at(angle) * smooth_sign(omega)
        )

    @classmethod
    def draw(
        cls,
        rng: np.random.Generator,
        *,
        joint: str = "elbow",
        joint_angle_at_zero: float,
        joint_range: tuple[float, float],
        given: Mapping[str, Any] | None = None,
    ) -> PassiveTruth:
        """A joint drawn at random, with the values in ``given`` (:data:`PASSIVE_KEYS`) kept.

        Stiffness ``U(0.4, 1.8)`` N m/rad and relaxed angle ``N(107, 10)`` deg (a relaxed
        elbow, Wiegner & Watts 1986), end stops ``U(0.1, 0.5)`` N m at the ends of
        ``joint_range`` (deg) with a 10 deg width, damping ``U(0.02, 0.25)`` N m s/rad,
        hysteresis ``U(0, 0.1)`` N m and, for the knee and the ankle, the literature curve's
        scale ``U(0.5, 1.5)``. Every number is drawn whatever ``given`` holds, so giving one
        leaves the others as they were.

        Raises
        ------
        ValueError
            On an unknown joint or key of ``given``, or a value out of its range (negative
            stops, damping or hysteresis; a range with ``lo >= hi``; a width <= 0).
        """
        if joint not in JOINTS:
            msg = f"joint must be one of {', '.join(JOINTS)}, got {joint!r}"
            raise ValueError(msg)
        given = dict(given or {})
        shape = str(given.pop("shape", "none"))
        unknown = sorted(set(given) - set(PASSIVE_KEYS))
        if unknown:
            msg = f"passive: unknown keys {unknown}; expected some of {', '.join(PASSIVE_KEYS)}"
            raise ValueError(msg)
        drawn: dict[str, Any] = {
            "stiffness": rng.uniform(0.4, 1.8),
            "relaxed_angle": rng.normal(107.0, 10.0),
            "stop_moment_low": rng.uniform(0.1, 0.5),
            "stop_moment_high": rng.uniform(0.1, 0.5),
            "stop_width": 10.0,
            "range": tuple(map(float, joint_range)),
            "damping": rng.uniform(0.02, 0.25),
            "hysteresis": rng.uniform(0.0, 0.1),
        }
        scale = rng.uniform(0.5, 1.5)
        drawn["curve_scale"] = scale if joint in _CURVED else 0.0
        drawn.update(given)
        values = {k: float(v) for k, v in drawn.items() if k != "range"}
        lo, hi = map(float, drawn["range"])
        truth = cls(
            joint=joint,
            joint_angle_at_zero=float(joint_angle_at_zero),
            range=(lo, hi),
            shape=shape,
            **values,
        )
        truth.check()
        return truth

    def check(self) -> None:
        """Raise ``ValueError`` for a value out of its range (see :meth:`draw`)."""
        numbers = dataclasses.asdict(self)
        del numbers["joint"]
        if numbers.pop("shape") not in SHAPES:
            msg = f"passive: shape must be one of {', '.join(SHAPES)}, got {self.shape!r}"
            raise ValueError(msg)
        lo, hi = numbers.pop("range")
        if not all(math.isfinite(v) for v in (*numbers.values(), lo, hi)):
            msg = f"passive: every value must be finite, got {self!r}"
            raise ValueError(msg)
        for key in ("stop_moment_low", "stop_moment_high", "damping", "hysteresis"):
            if numbers[key] < 0:
                msg = f"passive: {key} must be >= 0, got {numbers[key]!r}"
                raise ValueError(msg)
        if not (lo < hi and self.stop_width > 0 and self.shape_width > 0):
            msg = (
                "passive: need range lo < hi, stop_width > 0 and shape_width > 0, got "
                f"{self.range!r}, {self.stop_width!r}, {self.shape_width!r}"
            )
            raise ValueError(msg)

    def truth_lines(self) -> list[str]:
        """The ``key = value`` lines of ``truth.toml``'s ``[passive]`` table."""
        return [f"{k} = {toml_value(v)}" for k, v in dataclasses.asdict(self).items()]


def _postures(
    postures: str | Mapping[str, Sequence[float]],
) -> dict[str, tuple[float, float]]:
    """Posture name -> (gravity rotation, axis tilt) in degrees, checked."""
    if isinstance(postures, str):
        if postures not in POSTURE_DESIGNS:
            msg = f"postures must be one of {', '.join(POSTURE_DESIGNS)} or a mapping, got {postures!r}"
            raise ValueError(msg)
        return dict(POSTURE_DESIGNS[postures])
    out = {}
    for name, values in postures.items():
        rotation, tilt = map(float, values)
        if not _NAME.match(name):
            msg = f"postures: name {name!r} must be letters, digits, '_' or '-'"
            raise ValueError(msg)
        if not (-360 < rotation < 360 and 0 <= tilt <= 90):
            msg = (
                f"postures.{name}: need a gravity rotation in (-360, 360) deg and an axis tilt "
                f"in [0, 90] deg, got {rotation!r}, {tilt!r}"
            )
            raise ValueError(msg)
        out[name] = (rotation, tilt)
    if not out:
        msg = "postures: none given"
        raise ValueError(msg)
    return out


def _tilt_factor(tilt_deg: float) -> float:
    """``cos(tilt)``, exactly 0 for a vertical axis (90 deg)."""
    return 0.0 if tilt_deg == 90.0 else math.cos(math.radians(tilt_deg))


def _directions(values: Sequence[str], what: str, *, required: bool) -> tuple[str, ...]:
    out = tuple(values)
    if (
        any(d not in _DIRECTIONS for d in out)
        or len(set(out)) != len(out)
        or (required and not out)
    ):
        need = "one or both" if required else "none, one or both"
        msg = f"{what} must be {need} of {_DIRECTIONS}, got {values!r}"
        raise ValueError(msg)
    return out


def _moved(motion: Motion, direction: str) -> Motion:
    """The motion up (towards the larger angle) or down its range."""
    lo, hi = sorted((motion.start, motion.end))
    start, end = (lo, hi) if direction == "up" else (hi, lo)
    return dataclasses.replace(motion, start=start, end=end)


def simulate_living_study(
    out_dir: str | Path,
    *,
    seed: int | None = 0,
    postures: str | Mapping[str, Sequence[float]] = "one",
    speeds: Sequence[float] = (180.0,),
    trials_per_speed: int = 5,
    passive: Mapping[str, Any] | None = None,
    joint: str = "elbow",
    joint_angle_at_zero: float = 30.0,
    bodies: Mapping[str, Sequence[float]] | None = None,
    living: str = "forearm",
    sweeps: Sequence[str] = ("up", "down"),
    fast_directions: Sequence[str] = ("up",),
    rest_angles: Sequence[float] | None = None,
    gravity_rotation_sd: float = 2.0,
    angle_unit: str = "deg",
    torque_unit: str = "N*m",
    time_unit: str = "s",
    phi: float = 0.0,
    offset: float = 0.0,
    gravity: float = GRAVITY,
    rate: float = 1000.0,
    quasi_static_speed: float = 1.0,
    noise: Noise | None = None,
    quasi_static_noise: Noise | None = None,
    motion: Motion | None = None,
    sampling: str = "instant",
    priors: Mapping[str, str | Mapping[str, Any]] | None = None,
    passive_prior: Mapping[str, Any] | None = None,
    declare_stops: bool = True,
    rigid_rotation_sweeps: bool = False,
    name: str = "Simulated living study",
    emg: EmgSimulation | None = None,
) -> Path:
    """Write a simulated study of a living limb: CSV files, ``study.toml`` and ``truth.toml``.

    Two conditions: the rigid bodies alone (label A; by default the elbow attachment), and
    the rigid bodies with the living one (label B; the attachment and a forearm). The rigid
    condition has one quasi-static trial and ``trials_per_speed`` fast trials at every speed,
    in the first posture, as :func:`~inertiafit.simulate.simulate_study` writes them.
    The living condition has, in every posture, quasi-static sweeps (``sweeps``: up, down),
    rest trials (``kind = "rest"``: a still hold of ``motion.hold`` s) at ``rest_angles`` and
    ``trials_per_speed`` fast trials at every speed and in every ``fast_directions``. Its torque
    adds the joint's moments and the posture's gravity (the module's model); the rigid
    condition's has only the posture's gravity.

    The joint's truth (:class:`PassiveTruth`) is drawn from ``seed`` (:meth:`PassiveTruth.draw`),
    or given in ``passive``; every posture but the first has a true gravity rotation drawn
    ``N(nominal, gravity_rotation_sd)``, as a real setup's would be off its nominal angle (the
    first posture is the reference, exactly at its nominal). ``study.toml`` has ``[bodies.<living>]
    living = true``, a ``[passive]`` table (``joint``, ``joint_angle_at_zero`` and, as known
    quantities of the model, the true ``range`` and ``stop_width``; then ``passive_prior``'s
    entries), ``[postures.<name>]`` tables (nominal ``gravity_rotation``,
    ``gravity_rotation_sd``, ``axis_tilt``) and a ``posture`` on every trial. ``truth.toml``
    has what :func:`simulate_study` writes (bodies; conditions A and B with their true ``I``
    and ``M_g``), a ``[passive]`` table (:data:`PASSIVE_KEYS`, angles in degrees, plus
    ``joint``, ``joint_angle_at_zero``) and ``[passive.postures.<name>]`` tables with the true
    ``gravity_rotation`` and ``axis_tilt`` (deg). The offset ``offset`` there is the device's;
    ``P`` adds its own constant ``k (theta_j(0) - theta_rel)`` on top.

    Parameters
    ----------
    out_dir : str or Path
        Folder to write into (created; files of the same names are replaced).
    seed : int, optional
        Seed of the whole study: the truth and every trial (each trial its own child seed).
    postures : {"one", "two", "horizontal"} or mapping of str to (float, float)
        A design of :data:`POSTURE_DESIGNS`, or posture name -> (gravity rotation, axis tilt)
        in degrees; the first is the rigid condition's and the reference.
    speeds : sequence of float
        Preset speeds of the fast trials (deg/s).
    trials_per_speed : int
        Fast trials per speed, direction, posture and condition.
    passive : mapping, optional
        True values of the joint (:data:`PASSIVE_KEYS`; angles in degrees); the rest drawn.
    joint : str
        The living body's joint (:data:`inertiafit.passive.JOINTS`), written as
        ``[passive] joint``.
    joint_angle_at_zero : float
        Joint angle (deg) at the device's angle 0: with the default range 0-90 deg, the elbow
        moves from 30 to 120 deg of flexion, through its relaxed angle.
    bodies : mapping of str to (mass, radius_of_gyration, com_distance), optional
        True parameters of each body (kg, m, m); default :data:`DEFAULT_LIVING_BODIES`.
    living : str
        The living body among ``bodies``; the others are rigid (condition A, if any).
    sweeps : sequence of {"up", "down"}
        Directions of the living condition's quasi-static sweeps (at least one).
    fast_directions : sequence of {"up", "down"}
        Directions of the living condition's fast trials (the rigid condition's take ``motion``).
    rest_angles : sequence of float, optional
        Device angles (deg) of the rest trials; default 1/6, 1/2 and 5/6 of the range.
    gravity_rotation_sd : float
        SD (deg, > 0) of the postures' gravity rotations, written to the manifest and used to
        draw their truth.
    angle_unit, torque_unit, time_unit, phi, offset, gravity, rate : str or float
        As :func:`~inertiafit.simulate.simulate_study`.
    quasi_static_speed, noise, quasi_static_noise, motion, sampling : float, Noise or str
        As :func:`~inertiafit.simulate.simulate_study`; ``quasi_static_noise`` is also the
        rest trials'. ``motion``'s range is the sweeps' and the fast trials' (up: towards the
        larger angle), and the rigid condition's trials take it as given; its ``hold`` is the
        rest trials' duration.
    priors : mapping of str to (str or mapping), optional
        Prior spec per body instead of the default inline table centred on its values (the
        prior loader's default spread, +-50 %).
    passive_prior : mapping, optional
        Further entries of the manifest's ``[passive]`` table, written as given (overrides of
        the joint's prior, such as ``{"stiffness": {"mean": 1.1, "sd": 0.45}}``).
    declare_stops : bool
        Write the true ``range`` and ``stop_width`` into ``[passive]`` (default), as a lab that
        measured them would; ``False`` leaves them to the joint's prior file, as a lab that
        did not would, so the stops sit where the analysis does not expect them.
    rigid_rotation_sweeps : bool
        Also sweep the rigid condition (quasi-statically, up) in every posture after the first
        whose axis is horizontal (``A_<posture>_quasistatic.csv``): each measures that
        posture's gravity rotation. Default False: the files exactly as without the option.
    name : str
        The manifest's ``name``.
    emg : EmgSimulation, optional
        EMG channels in the living condition's trials (:mod:`inertiafit.simulate.emg`): rest
        noise, and a stretch reflex (burst and torque) in the fast trials it chooses. Its
        trials name their channels (``emg = [...]``), the manifest gets ``[emg] unit = "V"``
        and ``truth.toml`` an ``[emg]`` table with every reflex. Default None: no EMG, the
        files exactly as without the option.

    Returns
    -------
    Path
        Path of the written ``study.toml``.

    Raises
    ------
    ValueError
        On an unknown unit, joint, posture design, direction or passive key; a living body
        not among ``bodies``; a passive value or posture out of its range; a
        ``gravity_rotation_sd`` that is not positive; or a ``passive_prior`` key the table
        already has.
    """
    check_units(angle_unit=angle_unit, torque_unit=torque_unit, time_unit=time_unit)
    motion = Motion() if motion is None else motion
    truth = {
        b: Body(*map(float, values))
        for b, values in (DEFAULT_LIVING_BODIES if bodies is None else bodies).items()
    }
    if living not in truth:
        msg = f"living body {living!r} is not among the bodies {sorted(truth)}"
        raise ValueError(msg)
    design = _postures(postures)
    sweeps = _directions(sweeps, "sweeps", required=True)
    fast_directions = _directions(fast_directions, "fast_directions", required=False)
    if not (math.isfinite(gravity_rotation_sd) and gravity_rotation_sd > 0):
        msg = f"gravity_rotation_sd must be a positive number of degrees, got {gravity_rotation_sd!r}"
        raise ValueError(msg)
    lo, hi = sorted((motion.start, motion.end))
    if rest_angles is None:
        rest_angles = [math.degrees(lo + f * (hi - lo)) for f in (1 / 6, 1 / 2, 5 / 6)]

    root = np.random.SeedSequence(seed)
    truth_seed, rigid_seed, living_seed, rotation_seed = root.spawn(4)
    truth_rng = np.random.default_rng(truth_seed)
    joint_range = (joint_angle_at_zero + math.degrees(lo), joint_angle_at_zero + math.degrees(hi))
    passive_truth = PassiveTruth.draw(
        truth_rng,
        joint=joint,
        joint_angle_at_zero=joint_angle_at_zero,
        joint_range=joint_range,
        given=passive,
    )
    # The first posture is the reference; the others' setups are off their nominal rotation.
    posture_truth = {
        p: (rot + (gravity_rotation_sd * truth_rng.standard_normal() if k else 0.0), tilt)
        for k, (p, (rot, tilt)) in enumerate(design.items())
    }

    rigid_bodies = tuple(b for b in truth if b != living)
    whole = Mounting(tuple(truth))
    rigid = Mounting(rigid_bodies) if rigid_bodies else None
    mountings, labels = ([rigid, whole], ["A", "B"]) if rigid else ([whole], ["B"])
    out = Path(out_dir)
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    lines = manifest_head(
        name=name,
        gravity=gravity,
        truth=truth,
        priors=dict(priors or {}),
        readings={},
        angle_unit=angle_unit,
        torque_unit=torque_unit,
        time_unit=time_unit,
        living=living,
    )
    lines += _passive_table(passive_truth, passive_prior, declare_stops=declare_stops)
    for p, (rot, tilt) in design.items():
        lines += [
            f"[postures.{p}]",
            f"gravity_rotation = {toml_value(rot)}",
            f"gravity_rotation_sd = {toml_value(float(gravity_rotation_sd))}",
            f"axis_tilt = {toml_value(tilt)}",
            "",
        ]
    if emg is not None:
        lines += emg_manifest_lines()
    reflexes: dict[str, Reflex] = {}

    # Per condition and posture: its seed and its trials (kind, speed, motion, file name).
    plans: list[tuple[np.random.SeedSequence, Mounting, str, list[PlannedTrial]]] = []
    plan: list[PlannedTrial]
    if rigid:  # as simulate_study: the motion as given
        plan = [("quasi-static", quasi_static_speed, motion, "A_quasistatic.csv")]
        plan += [
            ("fast", float(s), motion, f"A_{s:g}_{k + 1:02d}.csv")
            for s in speeds
            for k in range(trials_per_speed)
        ]
        plans.append((rigid_seed, rigid, next(iter(design)), plan))
        others = [p for p, (_, tilt) in design.items() if tilt == 0.0][1:]
        if rigid_rotation_sweeps and others:
            for p, pseed in zip(others, rotation_seed.spawn(len(others)), strict=True):
                sweep: list[PlannedTrial] = [
                    ("quasi-static", quasi_static_speed, motion, f"A_{p}_quasistatic.csv")
                ]
                plans.append((pseed, rigid, p, sweep))
    for p, pseed in zip(design, living_seed.spawn(len(design)), strict=True):
        plan = [
            ("quasi-static", quasi_static_speed, _moved(motion, d), f"B_{p}_quasistatic_{d}.csv")
            for d in sweeps
        ]
        plan += [
            ("rest", None, dataclasses.replace(motion, start=a * DEG), f"B_{p}_rest_{k + 1}.csv")
            for k, a in enumerate(map(float, rest_angles))
        ]
        plan += [
            ("fast", float(s), _moved(motion, d), f"B_{p}_{s:g}{_SUFFIX[d]}_{k + 1:02d}.csv")
            for s in speeds
            for d in fast_directions
            for k in range(trials_per_speed)
        ]
        plans.append((pseed, whole, p, plan))

    writer = TrialWriter(
        data,
        angle_unit=angle_unit,
        torque_unit=torque_unit,
        time_unit=time_unit,
        offset=offset,
        rate=rate,
        noise=noise,
        quasi_static_noise=quasi_static_noise,
        sampling=sampling,
    )
    for cseed, mounting, p, plan in plans:
        i_total, mg_total = condition_totals(mounting, truth, gravity)
        rotation, tilt = posture_truth[p]
        written, condition_reflexes = writer.write(
            plan,
            cseed,
            bodies=mounting.bodies,
            inertia=i_total,
            gravity_moment=_tilt_factor(tilt) * mg_total,
            phi=phi + math.radians(rotation),
            emg=emg if mounting is whole else None,
            extra_torque=passive_truth.torque if mounting is whole else None,
            entry=[f"posture = {toml_value(p)}"],
            emg_per_trial=True,
        )
        lines += written
        reflexes.update(condition_reflexes)

    manifest = out / "study.toml"
    manifest.write_text("\n".join(lines), encoding="utf-8")
    text = truth_lines(truth, mountings, labels, gravity, phi, offset, noise or Noise())
    text += ["[passive]", *passive_truth.truth_lines(), ""]
    for p, (rotation, tilt) in posture_truth.items():
        text += [
            f"[passive.postures.{p}]",
            f"gravity_rotation = {toml_value(rotation)}",
            f"axis_tilt = {toml_value(tilt)}",
            "",
        ]
    if emg is not None:
        text += emg_truth_lines(emg, reflexes)
    (out / "truth.toml").write_text("\n".join(text), encoding="utf-8")
    return manifest


def _passive_table(
    truth: PassiveTruth, extra: Mapping[str, Any] | None, *, declare_stops: bool = True
) -> list[str]:
    """The manifest's ``[passive]`` table: the joint, its zero and the known range and width."""
    table: dict[str, Any] = {
        "joint": truth.joint,
        "joint_angle_at_zero": float(truth.joint_angle_at_zero),
    }
    if declare_stops:
        table |= {"range": list(truth.range), "stop_width": float(truth.stop_width)}
    for key, value in (extra or {}).items():
        if key in table:
            msg = f"passive_prior: {key!r} is written from the truth; give it in passive="
            raise ValueError(msg)
        table[key] = value
    return ["[passive]", *(f"{k} = {toml_value(v)}" for k, v in table.items()), ""]


def rigid_view(manifest: str | Path) -> Path:
    """The same simulated study as today's rigid analysis would read it: ``rigid.toml``.

    Beside ``manifest``: the bodies without ``living``, no ``[passive]`` or ``[postures]``,
    the first posture's up sweep and fast trials only (one sweep per condition, as for a
    rigid body), no rest trials. For showing the bias a rigid model makes on a living limb
    (the demo, ``benchmarks/living_coverage.py``).
    """
    manifest = Path(manifest)
    doc = tomllib.loads(manifest.read_text(encoding="utf-8"))
    first = next(iter(doc.get("postures", {"": None})))
    lines = [f"name = {toml_value(doc['name'] + ' (rigid)')}", f"gravity = {doc['gravity']!r}"]
    for name, body in doc["bodies"].items():
        lines += ["", f"[bodies.{name}]", f"prior = {toml_value(body['prior'])}"]
    lines += ["", "[defaults]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in doc["defaults"].items() if k != "posture"]
    for trial in doc["trials"]:
        if trial["kind"] == "rest" or trial.get("posture", first) != first:
            continue
        if trial["kind"] == "quasi-static" and trial["file"].endswith("_down.csv"):
            continue  # today's protocol: one sweep per condition
        lines += ["", "[[trials]]"]
        lines += [f"{k} = {toml_value(v)}" for k, v in trial.items() if k != "posture"]
    out = manifest.with_name("rigid.toml")
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return out
