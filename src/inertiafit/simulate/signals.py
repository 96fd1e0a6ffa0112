"""The signal model: one simulated trial, with the imperfections of a real recording.

Every trial follows the rigid-body model of ``docs/method.md``::

    tau(t) = I alpha(t) + M_g sin(theta(t) + phi) + c

sampled at 1 kHz by default, with a trapezoidal velocity profile, servo ripple, channel noise,
a drifting torque disturbance and a quantised angle (:class:`Noise`, :class:`Motion`). Two harder
imperfections are off by default: a servo ripple sized against the ramp's acceleration
(``Noise.servo_ripple``) and a start overshoot that carries the speed past the preset, up to
twice it, before the servo brakes it back (``Motion.start_overshoot``); see
``docs/processing.md``, "Simulated trials". :func:`simulate_trial` returns the Trial in SI
units.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from scipy import signal

from inertiafit.io.units import DEG
from inertiafit.physics import GRAVITY
from inertiafit.physics import gravity_moment as _gravity_moment
from inertiafit.physics import inertia as _inertia

__all__ = ["KINDS", "SAMPLINGS", "Body", "Motion", "Noise", "simulate_trial", "with_servo_ripple"]

#: The kinds of trial: a slow move for the gravity model, a fast one for the inertia, and a
#: quiet hold at one angle (a living joint's elastic moment there, without its viscous part).
KINDS = ("quasi-static", "fast", "rest")
#: How a channel is sampled: its value at the sample's time, or its mean over the period.
SAMPLINGS = ("instant", "average")


@dataclass(frozen=True)
class Noise:
    """Imperfections of a simulated recording (SI units).

    Attributes
    ----------
    torque_sd : float
        Standard deviation of white torque noise (N m). A Biodex analog torque output read on
        its +-64 ft lbf range has 15-35 mV noise at 78.1 mV per ft lbf, 0.25-0.6 N m.
    velocity_sd : float
        Standard deviation of white velocity noise (rad/s); default 0.5 deg/s.
    ripple : float
        Relative amplitude of the servo's sinusoidal velocity ripple (0.005 = 0.5 % of the
        instantaneous speed). It is real motion: the torque contains its ``I alpha``.
    ripple_frequency : float
        Frequency of the ripple (Hz); its phase is random per trial.
    angle_step : float
        Quantum of the angle channel (rad); default 0.1 deg. ``0`` leaves the angle exact.
    drift_sd : float
        Standard deviation of a slowly drifting torque disturbance (N m): a stationary AR(1)
        process standing for friction, cable drag and sensor drift. It makes the residuals of
        a quasi-static fit autocorrelated.
    drift_time : float
        Correlation time of the drift (s).
    trial_offset_sd : float
        Standard deviation of a per-trial shift of the offset ``c`` (N m), drawn once per
        fast trial (the quasi-static trial is the reference): the sensor zero and the friction
        are not the same in every trial. When set, it is the largest source of trial-to-trial
        scatter of the inertia (``shift / alpha``).
    servo_ripple : float
        Amplitude of a sinusoidal servo ripple of the velocity, given as the amplitude of its
        *acceleration* relative to the ramp's (``Motion.acceleration``): 0.3 puts the true
        acceleration +-30 % around its plateau during the ramp. The velocity amplitude is
        ``servo_ripple * acceleration / (2 pi servo_ripple_frequency)``, the same at every
        speed, during the whole move (faded in over a quarter period at its start and out at
        its end, so the shaft starts and stops at rest). Real motion, like ``ripple``; its
        phase is random per trial. Default 0 (none); unlike ``ripple`` it is meant to be
        large, near the filter's cut-off.
    servo_ripple_frequency : float
        Frequency of the servo ripple (Hz); 10-25 Hz straddles the 20 Hz default cut-off.
    lag : float
        Delay (s) of the torque channel behind the angle and velocity channels (a
        dynamometer's own filtering, an analog-to-digital card): the torque sample at ``t`` is
        the true torque at ``t - lag``, computed from the same analytic motion at that time,
        not interpolated. The channel noise is not delayed (it has no timing). Default 0;
        ``|lag|`` must be below ``Motion.rest``.
    torque_gain : float
        Gain of the torque channel: the recorded torque is this times the torque the channel
        would record with a perfect calibration (every part of it, noise included). Default
        1; must be positive.
    hysteresis : float
        Direction-dependent friction (N m), a rate-independent hysteresis: after the shaft
        starts or reverses, the friction torque relaxes towards ``hysteresis`` times the
        direction of motion (it opposes the motion, so the motor's torque carries it with the
        motion's sign) exponentially with the angle travelled, over ``hysteresis_angle`` (a
        Dahl friction model); at rest it holds its value. It follows the torque channel's
        angle (so ``lag`` delays it too). Default 0 (none).
    hysteresis_angle : float
        Angle (rad) over which the friction builds up after a start or a reversal; default
        2 deg. ``0`` switches it instantly (Coulomb friction).
    """

    torque_sd: float = 0.4
    velocity_sd: float = 0.5 * DEG
    ripple: float = 0.005
    ripple_frequency: float = 10.0
    angle_step: float = 0.1 * DEG
    drift_sd: float = 0.03
    drift_time: float = 0.2
    trial_offset_sd: float = 0.0
    servo_ripple: float = 0.0
    servo_ripple_frequency: float = 15.0
    lag: float = 0.0
    torque_gain: float = 1.0
    hysteresis: float = 0.0
    hysteresis_angle: float = 2.0 * DEG

    @classmethod
    def none(cls) -> Noise:
        """No noise at all: exact channels (useful to test the processing arithmetic)."""
        return cls(0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.5, 0.0)

    @classmethod
    def paper(cls) -> Noise:
        """Noise with a trial-to-trial scatter like the paper's attachment (SD 0.017 kg m^2).

        The channel noise alone gives a per-trial SD of the inertia near 0.0015 kg m^2; the
        paper's 0.017 kg m^2 at 35 rad/s^2 needs a per-trial torque shift of about 0.6 N m.
        The shift is the same in N m whatever is mounted, so the attachment + disk condition
        gets the same 0.017 kg m^2, not the paper's 0.055.
        """
        return cls(trial_offset_sd=0.6)


@dataclass(frozen=True)
class Motion:
    """The commanded passive move.

    Attributes
    ----------
    start, end : float
        Angles (rad) where the move starts and ends; the paper's range is 0 to 90 deg.
    acceleration : float
        Uniform acceleration and deceleration of the servo (rad/s^2); default 2000 deg/s^2,
        which reaches 300 deg/s in 0.15 s.
    overshoot : float
        Relative isokinetic overshoot after the ramp (0.05 = 5 % above the preset speed), a
        half-sine bump of duration ``overshoot_time``; 0 for none.
    overshoot_time : float
        Duration of the overshoot bump (s).
    rest : float
        Time at rest before and after the move (s).
    start_overshoot : float
        Relative velocity overshoot at the start of the move (1.0 = twice the preset speed):
        the uniform acceleration carries the speed past the preset up to ``(1 +
        start_overshoot)`` times it, then the servo brakes it back to the preset over
        ``settle_time`` (a half-cosine of the velocity: the braking spike). The
        uniform-acceleration period is then the whole rise, up to the peak. Isokinetic
        devices overshoot up to about twice the preset speed during the acceleration
        (isokinetics.net, "Moment artifacts"; Schwartz et al. 2010, J Sports Sci Med 9:140).
        0 for none; not combined with ``overshoot``.
    settle_time : float
        Time (s) the servo takes to brake the start overshoot back to the preset speed.
    hold : float
        Duration (s) of a rest trial (``kind="rest"``): the shaft held still at ``start``.
    """

    start: float = 0.0
    end: float = 90.0 * DEG
    acceleration: float = 2000.0 * DEG
    overshoot: float = 0.0
    overshoot_time: float = 0.04
    rest: float = 0.2
    start_overshoot: float = 0.0
    settle_time: float = 0.05
    hold: float = 5.0


@dataclass(frozen=True)
class Body:
    """A rigid body's true inertial parameters (SI units)."""

    mass: float
    radius_of_gyration: float
    com_distance: float

    @property
    def inertia(self) -> float:
        """Moment of inertia about the joint (kg m^2)."""
        return float(_inertia(self.mass, self.radius_of_gyration, self.com_distance))

    def gravity_moment(self, gravity: float = GRAVITY) -> float:
        """Largest gravitational moment ``m g x`` (N m)."""
        return float(_gravity_moment(self.mass, self.com_distance, gravity))


@dataclass(frozen=True)
class _Profile:
    velocity: np.ndarray
    acceleration: np.ndarray
    ramp_start: float
    ramp_end: float
    peak_speed: float
    extras: dict[str, float] = field(default_factory=dict)


def with_servo_ripple(
    velocity: np.ndarray,
    acceleration: np.ndarray,
    t: np.ndarray,
    ripple: float,
    frequency: float,
    phase: float,
) -> tuple[np.ndarray, np.ndarray]:
    """A speed profile times ``1 + ripple sin(2 pi f t + phase)``, and its derivative.

    The ripple scales the commanded velocity (so it fades in and out with the move); the
    acceleration is the exact derivative of the product.
    """
    w = 2.0 * math.pi * frequency
    factor = 1.0 + ripple * np.sin(w * t + phase)
    return (
        velocity * factor,
        acceleration * factor + velocity * ripple * w * np.cos(w * t + phase),
    )


def _profile(
    t: np.ndarray, speed: float, motion: Motion, ripple: float, ripple_frequency: float, phase
) -> _Profile:
    """Nominal trapezoidal velocity with ripple; speed (rad/s) > 0, direction from the motion."""
    if motion.start_overshoot:
        return _start_overshoot_profile(t, speed, motion, ripple, ripple_frequency, phase)
    distance = abs(motion.end - motion.start)
    direction = 1.0 if motion.end >= motion.start else -1.0
    a = motion.acceleration
    v = speed
    overshoot = motion.overshoot
    t_over = motion.overshoot_time
    bump = overshoot * v * 2.0 * t_over / math.pi
    t_ramp = v / a
    t_flat = (distance - v * v / a - bump) / v
    if overshoot and t_flat < t_over:
        overshoot, bump = 0.0, 0.0
        t_flat = (distance - v * v / a) / v
    if t_flat < 0.0:  # too short a range for this speed: triangular profile
        v = math.sqrt(a * distance)
        t_ramp, t_flat = v / a, 0.0
    t0 = motion.rest
    tau = t - t0
    up = (tau >= 0) & (tau < t_ramp)
    flat = (tau >= t_ramp) & (tau < t_ramp + t_flat)
    down = (tau >= t_ramp + t_flat) & (tau < 2 * t_ramp + t_flat)
    vel = np.zeros_like(t)
    acc = np.zeros_like(t)
    vel[up] = a * tau[up]
    acc[up] = a
    vel[flat] = v
    vel[down] = v - a * (tau[down] - t_ramp - t_flat)
    acc[down] = -a
    if overshoot:
        s = tau - t_ramp
        bumping = (s >= 0) & (s < t_over)
        w = math.pi / t_over
        vel[bumping] += overshoot * v * np.sin(w * s[bumping])
        acc[bumping] += overshoot * v * w * np.cos(w * s[bumping])
    if ripple:
        vel, acc = with_servo_ripple(vel, acc, t, ripple, ripple_frequency, phase)
    return _Profile(
        velocity=direction * vel,
        acceleration=direction * acc,
        ramp_start=t0,
        ramp_end=t0 + t_ramp,
        peak_speed=v,
        extras={"motion_end": t0 + 2 * t_ramp + t_flat},
    )


def _start_overshoot_times(speed: float, motion: Motion) -> tuple[float, float, float]:
    """Durations (s) of the rise to the peak, of the constant speed and of the braking.

    Raises
    ------
    ValueError
        If the range is too short for the speed with this overshoot.
    """
    a, v, over, settle = motion.acceleration, speed, motion.start_overshoot, motion.settle_time
    peak = (1.0 + over) * v
    distance = abs(motion.end - motion.start)
    # rise to the peak, half-cosine settle from the peak to v, braking from v to rest
    used = peak * peak / (2 * a) + settle * (v + 0.5 * over * v) + v * v / (2 * a)
    t_flat = (distance - used) / v
    if t_flat < 0:
        msg = (
            f"motion: a range of {math.degrees(distance):.4g} deg is too short for "
            f"{math.degrees(v):.4g} deg/s with start_overshoot={over:g} at "
            f"{math.degrees(a):.4g} deg/s^2 (needs {math.degrees(used):.4g} deg)"
        )
        raise ValueError(msg)
    return peak / a, t_flat, v / a


def _start_overshoot_profile(
    t: np.ndarray, speed: float, motion: Motion, ripple: float, ripple_frequency: float, phase
) -> _Profile:
    """Uniform rise past the preset to ``(1 + start_overshoot)`` times it, settle, isokinetic."""
    direction = 1.0 if motion.end >= motion.start else -1.0
    a, v, over, settle = motion.acceleration, speed, motion.start_overshoot, motion.settle_time
    t_up, t_flat, t_down = _start_overshoot_times(speed, motion)
    t0 = motion.rest
    tau = t - t0
    t_settle_end = t_up + settle
    t_brake = t_settle_end + t_flat
    up = (tau >= 0) & (tau < t_up)
    settling = (tau >= t_up) & (tau < t_settle_end)
    flat = (tau >= t_settle_end) & (tau < t_brake)
    down = (tau >= t_brake) & (tau < t_brake + t_down)
    vel = np.zeros_like(t)
    acc = np.zeros_like(t)
    vel[up] = a * tau[up]
    acc[up] = a
    w = math.pi / settle
    s = tau[settling] - t_up
    vel[settling] = v + 0.5 * over * v * (1.0 + np.cos(w * s))
    acc[settling] = -0.5 * over * v * w * np.sin(w * s)
    vel[flat] = v
    vel[down] = v - a * (tau[down] - t_brake)
    acc[down] = -a
    if ripple:
        vel, acc = with_servo_ripple(vel, acc, t, ripple, ripple_frequency, phase)
    return _Profile(
        velocity=direction * vel,
        acceleration=direction * acc,
        ramp_start=t0,
        ramp_end=t0 + t_up,
        peak_speed=(1.0 + over) * v,
        extras={"motion_end": t0 + t_brake + t_down},
    )


def _servo_ripple(
    t: np.ndarray, start: float, end: float, amplitude: float, frequency: float, phase: float
) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of a sinusoidal ripple during ``[start, end]``.

    The ripple fades in over a quarter period after ``start`` and out over a quarter period
    before ``end`` (half-cosine envelopes), so the velocity is continuous and zero at rest.
    """
    w = 2.0 * math.pi * frequency
    fade = min(0.25 / frequency, 0.5 * (end - start))
    env = np.zeros_like(t)
    denv = np.zeros_like(t)
    inside = (t >= start) & (t <= end)
    env[inside] = 1.0
    for edge, sign in ((start, 1.0), (end, -1.0)):
        s = sign * (t - edge)  # time since the start, or left until the end
        ramp = inside & (s < fade)
        env[ramp] = 0.5 * (1.0 - np.cos(math.pi * s[ramp] / fade))
        denv[ramp] = sign * 0.5 * math.pi / fade * np.sin(math.pi * s[ramp] / fade)
    sine = np.sin(w * t + phase)
    velocity = amplitude * env * sine
    acceleration = amplitude * (denv * sine + env * w * np.cos(w * t + phase))
    return velocity, acceleration


def _hysteresis_torque(angle: np.ndarray, amplitude: float, angle_scale: float) -> np.ndarray:
    """Direction-dependent friction torque (N m) along an angle trace (Dahl model).

    From zero at the first sample, the friction relaxes towards ``amplitude`` times the
    direction of motion, ``F = d A + (F0 - d A) exp(-s / angle_scale)``, with ``s`` the angle
    travelled since the motion started or last reversed and ``F0`` the friction then; where the
    angle does not change it holds its value. ``angle_scale = 0`` switches it at once
    (Coulomb friction).
    """
    theta = np.asarray(angle, dtype=np.float64)
    out = np.zeros(theta.size)
    step = np.diff(theta, prepend=theta[:1])
    moving = np.flatnonzero(step)
    if moving.size == 0 or amplitude == 0.0:
        return out
    # the direction of the last move, carried through the samples at rest
    last = np.maximum.accumulate(np.where(step != 0, np.arange(theta.size), 0))
    direction = np.where(np.arange(theta.size) >= moving[0], np.sign(step[last]), 0.0)
    bounds = [int(moving[0]), *(np.flatnonzero(np.diff(direction)) + 1).tolist(), theta.size]
    bounds = sorted(set(bounds))
    held = 0.0
    for k in range(len(bounds) - 1):
        lo, hi = bounds[k], bounds[k + 1]
        target = amplitude * direction[lo]
        travelled = np.cumsum(np.abs(step[lo:hi]))
        if angle_scale > 0:
            out[lo:hi] = target + (held - target) * np.exp(-travelled / angle_scale)
        else:
            out[lo:hi] = np.where(travelled > 0, target, held)
        held = float(out[hi - 1])
    return out


def _ar1(rng: np.random.Generator, n: int, sd: float, rho: float) -> np.ndarray:
    """Stationary AR(1) noise of standard deviation ``sd`` and lag-one correlation ``rho``."""
    if sd == 0.0 or n == 0:
        return np.zeros(n)
    e = rng.standard_normal(n)
    zi = np.array([rho * e[0] / math.sqrt(1.0 - rho * rho)])  # start in the stationary law
    e[0] = 0.0
    x, _ = signal.lfilter([1.0], [1.0, -rho], e, zi=zi)
    return sd * math.sqrt(1.0 - rho * rho) * x


def _dataset(
    time: np.ndarray,
    angle: np.ndarray,
    velocity: np.ndarray,
    torque: np.ndarray,
    *,
    source: str,
    rate: float,
    attrs: Mapping[str, Any],
) -> xr.Dataset:
    """A Trial with exactly the layout of :func:`inertiafit.io.make_trial`."""
    long = {
        "angle": "angle of the dynamometer shaft",
        "velocity": "angular velocity of the shaft",
        "torque": "moment measured at the shaft",
    }
    units = {"angle": "rad", "velocity": "rad/s", "torque": "N m"}
    data = {"angle": angle, "velocity": velocity, "torque": torque}
    return xr.Dataset(
        {
            q: ("time", np.asarray(v, dtype=np.float64), {"units": units[q], "long_name": long[q]})
            for q, v in data.items()
        },
        coords={"time": ("time", time, {"units": "s", "long_name": "time"})},
        attrs={"source": source, "sampling_rate": float(rate), "format": "simulated", **attrs},
    )


def _check_hard_imperfections(noise: Noise, motion: Motion) -> None:
    """Reject a negative servo ripple, start overshoot or hysteresis, and both overshoots."""
    if not (noise.servo_ripple >= 0 and noise.servo_ripple_frequency > 0):
        msg = (
            "noise: servo_ripple must be >= 0 and servo_ripple_frequency > 0, got "
            f"{noise.servo_ripple!r}, {noise.servo_ripple_frequency!r}"
        )
        raise ValueError(msg)
    if not (motion.start_overshoot >= 0 and motion.settle_time > 0):
        msg = (
            "motion: start_overshoot must be >= 0 and settle_time > 0, got "
            f"{motion.start_overshoot!r}, {motion.settle_time!r}"
        )
        raise ValueError(msg)
    if motion.start_overshoot and motion.overshoot:
        msg = "motion: set overshoot or start_overshoot, not both"
        raise ValueError(msg)
    if not (noise.hysteresis >= 0 and noise.hysteresis_angle >= 0):
        msg = (
            "noise: hysteresis and hysteresis_angle must be >= 0, got "
            f"{noise.hysteresis!r}, {noise.hysteresis_angle!r}"
        )
        raise ValueError(msg)


def _check_torque_channel(noise: Noise, motion: Motion) -> None:
    """Reject a torque lag of ``Motion.rest`` or more, and a gain that is not positive."""
    if not (math.isfinite(noise.lag) and abs(noise.lag) < motion.rest):
        msg = f"noise: lag must be finite and below rest={motion.rest!r} s, got {noise.lag!r}"
        raise ValueError(msg)
    if not (math.isfinite(noise.torque_gain) and noise.torque_gain > 0):
        msg = f"noise: torque_gain must be positive, got {noise.torque_gain!r}"
        raise ValueError(msg)


def _torque_kinematics(
    n: int,
    rate: float,
    speed: float,
    motion: Motion,
    noise: Noise,
    phase: float,
    servo_phase: float,
    sampling: str,
) -> tuple[_Profile, np.ndarray]:
    """Acceleration and angle at the torque channel's times ``t - noise.lag``.

    The same analytic profile and the same integration as the angle and velocity channels,
    on the delayed grid; the move starts after ``Motion.rest`` and ``|lag| < rest``, so the
    delayed grid starts at rest too. The grid is ``(k - lag rate) / rate``: a lag of whole
    samples gives exactly the undelayed channel's times, so a corner of the profile that
    falls on a sample falls on the same side of it.
    """
    dt = 1.0 / rate
    delay = noise.lag * rate  # in samples
    t = (np.arange(n) - delay) / rate
    profile = _at_samples(t, speed, motion, noise, phase, servo_phase)
    theta = np.empty(n)
    theta[0] = motion.start
    np.cumsum(0.5 * dt * (profile.velocity[1:] + profile.velocity[:-1]), out=theta[1:])
    theta[1:] += motion.start
    if sampling == "average":
        edges = _motion(
            (np.arange(n + 1) - 0.5 - delay) * dt, speed, motion, noise, phase, servo_phase
        )
        profile = dataclasses.replace(profile, acceleration=np.diff(edges.velocity) / dt)
    return profile, theta


def _at_samples(
    t: np.ndarray, speed: float, motion: Motion, noise: Noise, phase: float, servo_phase: float
) -> _Profile:
    """:func:`_motion` at sample times, a jump of the acceleration on a sample split in half.

    Where a corner of the profile (the start or end of a ramp) falls on a sample, the
    acceleration there is either side's by the rounding of the times: the ramp's or zero.
    The velocity samples' central difference shows half of it, so one side's value would put
    half a sample of ``I alpha`` into the torque that the velocity does not show (+0.5 % on
    the inertia of a 90 ms ramp at 1 kHz). Such a sample gets the mean of the two sides;
    every other sample keeps its exact value.
    """
    profile = _motion(t, speed, motion, noise, phase, servo_phase)
    eps = 1e-6 * float(np.median(np.diff(t))) if t.size > 1 else 0.0
    left = _motion(t - eps, speed, motion, noise, phase, servo_phase).acceleration
    right = _motion(t + eps, speed, motion, noise, phase, servo_phase).acceleration
    # a jump is a step of the ramp's size; the smooth ripples change by ~1e-6 of theirs
    jump = np.abs(right - left) > 0.01 * motion.acceleration
    if not jump.any():
        return profile
    acceleration = profile.acceleration.copy()
    acceleration[jump] = 0.5 * (left[jump] + right[jump])
    return dataclasses.replace(profile, acceleration=acceleration)


def _motion(
    t: np.ndarray, speed: float, motion: Motion, noise: Noise, phase: float, servo_phase: float
) -> _Profile:
    """Velocity and acceleration at times ``t``: the profile, its ripple, the servo ripple."""
    profile = _profile(t, speed, motion, noise.ripple, noise.ripple_frequency, phase)
    if not noise.servo_ripple:
        return profile
    w = 2 * math.pi * noise.servo_ripple_frequency
    amplitude = noise.servo_ripple * motion.acceleration / w
    direction = 1.0 if motion.end >= motion.start else -1.0
    vel, acc = _servo_ripple(
        t,
        profile.ramp_start,
        profile.extras["motion_end"],
        amplitude,
        noise.servo_ripple_frequency,
        servo_phase,
    )
    return dataclasses.replace(
        profile,
        velocity=profile.velocity + direction * vel,
        acceleration=profile.acceleration + direction * acc,
    )


_Kinematics = tuple[np.ndarray, _Profile, np.ndarray, _Profile, np.ndarray]


def _moving(
    rng: np.random.Generator,
    speed: float,
    rate: float,
    motion: Motion,
    noise: Noise,
    sampling: str,
) -> _Kinematics:
    """Times, profile and angle of a move, and the torque channel's profile and angle.

    Draws the ripple's phase (and the servo ripple's, from a child generator) from ``rng``.
    """
    distance = abs(motion.end - motion.start)
    if motion.start_overshoot:
        t_up, t_flat, t_down = _start_overshoot_times(speed, motion)
        duration = 2 * motion.rest + t_up + motion.settle_time + t_flat + t_down
    else:
        duration = 2 * motion.rest + distance / speed + speed / motion.acceleration
        duration += motion.overshoot_time if motion.overshoot else 0.0
    n = math.ceil(duration * rate) + 1
    t = np.arange(n) / rate

    phase = rng.uniform(0, 2 * math.pi)
    # The servo ripple's phase comes from a child generator, which draws nothing from ``rng``:
    # the channel noise of a trial is the same with and without the servo ripple.
    servo_phase = rng.spawn(1)[0].uniform(0, 2 * math.pi) if noise.servo_ripple else 0.0
    profile = _at_samples(t, speed, motion, noise, phase, servo_phase)
    # Angle: the integral of the true velocity (trapezoid rule, exact for the linear ramps).
    dt = 1.0 / rate
    theta = np.empty(n)
    theta[0] = motion.start
    np.cumsum(0.5 * dt * (profile.velocity[1:] + profile.velocity[:-1]), out=theta[1:])
    theta[1:] += motion.start
    if sampling == "average":
        # Means over [t - dt/2, t + dt/2]: the acceleration's is exact (the change of the
        # velocity over the period), the velocity's is Simpson's rule (exact on the ramps).
        edges = _motion((np.arange(n + 1) - 0.5) * dt, speed, motion, noise, phase, servo_phase)
        profile = dataclasses.replace(
            profile,
            velocity=(edges.velocity[:-1] + 4 * profile.velocity + edges.velocity[1:]) / 6,
            acceleration=np.diff(edges.velocity) / dt,
        )

    # The torque channel's own times: t - lag (the same profile, not interpolated).
    torque_profile, torque_theta = profile, theta
    if noise.lag:
        torque_profile, torque_theta = _torque_kinematics(
            n, rate, speed, motion, noise, phase, servo_phase, sampling
        )
    return t, profile, theta, torque_profile, torque_theta


def _held(rate: float, motion: Motion) -> tuple[np.ndarray, _Profile, np.ndarray]:
    """Times, profile and angle of a rest trial: the shaft still at ``motion.start``."""
    n = math.ceil(motion.hold * rate) + 1
    t = np.arange(n) / rate
    still = _Profile(
        velocity=np.zeros(n),
        acceleration=np.zeros(n),
        ramp_start=0.0,
        ramp_end=0.0,
        peak_speed=0.0,
    )
    return t, still, np.full(n, float(motion.start))


def simulate_trial(
    *,
    inertia: float,
    gravity_moment: float,
    kind: str = "fast",
    speed_deg_s: float | None = None,
    phi: float = 0.0,
    offset: float = 0.0,
    rng: np.random.Generator | int | None = None,
    rate: float = 1000.0,
    noise: Noise | None = None,
    motion: Motion | None = None,
    source: str = "simulated",
    sampling: str = "instant",
    extra_torque: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> xr.Dataset:
    """Simulate one passive dynamometer trial of a rigid body (and, optionally, more torque).

    Parameters
    ----------
    inertia : float
        Moment of inertia about the joint, summed over the mounted bodies (kg m^2).
    gravity_moment : float
        Largest gravitational moment ``M_g``, summed over the mounted bodies (N m).
    kind : {"fast", "quasi-static", "rest"}
        A fast isokinetic move, a quasi-static one (default speed 1 deg/s), or a rest trial: the
        shaft held still at ``motion.start`` for ``motion.hold`` seconds (velocity and
        acceleration exactly zero; the channel noise, drift and quantisation as in a move).
    speed_deg_s : float, optional
        Preset speed (deg/s); default 1 for quasi-static and 240 for fast trials; none for a
        rest trial (``attrs["speed"]`` is then 0).
    phi : float
        Angle between the device's zero and the gravity vertical (rad).
    offset : float
        Constant torque offset ``c`` (N m).
    rng : numpy.random.Generator or int, optional
        Random source or seed.
    rate : float
        Sampling rate (Hz).
    noise : Noise, optional
        Imperfections; default :class:`Noise` ().
    motion : Motion, optional
        Range, acceleration, overshoot and rest; default :class:`Motion` () (0 to 90 deg).
    source : str
        Recorded in ``attrs["source"]``.
    sampling : {"instant", "average"}
        ``"instant"`` (the default): each sample is the value at its time; a sample on a
        corner of the profile, where the acceleration jumps, takes the mean of its two sides.
        A corner between two samples puts up to half a sample of ``I alpha`` in the torque
        that the velocity does not show locally: negligible at 1 kHz, a bias of several per
        cent on a 100 ms ramp at 100 Hz. ``"average"``: the
        torque and the velocity are their means over the sample period centred on each
        sample (an integrating front end), so the torque's ``I alpha`` always adds up to the
        velocity's change; use it below 1 kHz.
    extra_torque : callable, optional
        ``extra_torque(angle, velocity)`` (rad, rad/s arrays -> N m array): a torque added to
        the rigid-body model, such as a living joint's passive and viscous moments
        (:mod:`inertiafit.simulate.living`). It gets the true (noise-free) angle and velocity
        at the torque channel's times (so ``noise.lag`` delays it too), and its torque goes
        through the channel like the rest (noise added, ``torque_gain`` applied). None (the
        default) leaves the trial exactly as without it.

    Returns
    -------
    xarray.Dataset
        A Trial (``time`` s; ``angle`` rad, ``velocity`` rad/s, ``torque`` N m) with extra
        attrs: ``kind``, ``speed`` (deg/s), ``true_inertia``, ``true_gravity_moment``,
        ``true_phi``, ``true_offset`` (including any per-trial shift), ``ramp_start`` and
        ``ramp_end`` (s, the simulated uniform-acceleration period, in the velocity's time),
        ``true_lag`` (s) and ``true_torque_gain`` (``Noise.lag``, ``Noise.torque_gain``).

    Raises
    ------
    ValueError
        If ``kind`` or ``sampling`` is unknown, ``speed_deg_s`` or ``rate`` is not positive
        (or a rest trial is given a speed, or ``motion.hold`` is not positive),
        the servo ripple, start overshoot or hysteresis is negative, the range is too short for the
        speed with the start overshoot, ``noise.lag`` is not below ``motion.rest`` in
        magnitude or ``noise.torque_gain`` is not positive.
    """
    if kind not in KINDS:
        msg = f"kind must be one of {KINDS}, got {kind!r}"
        raise ValueError(msg)
    if sampling not in SAMPLINGS:
        msg = f"sampling must be one of {SAMPLINGS}, got {sampling!r}"
        raise ValueError(msg)
    if kind == "rest":
        if speed_deg_s is not None:
            msg = f"a rest trial has no speed, got speed_deg_s={speed_deg_s!r}"
            raise ValueError(msg)
        if motion is not None and not motion.hold > 0:
            msg = f"motion: hold must be positive for a rest trial, got {motion.hold!r}"
            raise ValueError(msg)
    elif speed_deg_s is None:
        speed_deg_s = 1.0 if kind == "quasi-static" else 240.0
    if not (speed_deg_s is None or speed_deg_s > 0) or not rate > 0:
        msg = f"speed_deg_s and rate must be positive, got {speed_deg_s!r}, {rate!r}"
        raise ValueError(msg)
    rng = np.random.default_rng(rng)
    noise = Noise() if noise is None else noise
    motion = Motion() if motion is None else motion
    speed = 0.0 if speed_deg_s is None else speed_deg_s * DEG
    _check_hard_imperfections(noise, motion)
    _check_torque_channel(noise, motion)

    if kind == "rest":
        t, profile, theta = _held(rate, motion)
        torque_profile, torque_theta = profile, theta
    else:
        t, profile, theta, torque_profile, torque_theta = _moving(
            rng, speed, rate, motion, noise, sampling
        )
    n = t.size

    # The shift is relative to the quasi-static trial, whose offset is the reference.
    shift = 0.0
    if noise.trial_offset_sd and kind == "fast":
        shift = rng.normal(0.0, noise.trial_offset_sd)
    rho = math.exp(-1.0 / (rate * noise.drift_time)) if noise.drift_time > 0 else 0.0
    torque = (
        inertia * torque_profile.acceleration
        + gravity_moment * np.sin(torque_theta + phi)
        + offset
        + shift
        + _ar1(rng, n, noise.drift_sd, rho)
    )
    if extra_torque is not None:
        torque += extra_torque(torque_theta, torque_profile.velocity)
    if noise.hysteresis:
        torque += _hysteresis_torque(torque_theta, noise.hysteresis, noise.hysteresis_angle)
    if noise.torque_sd:
        torque += rng.normal(0.0, noise.torque_sd, n)
    if noise.torque_gain != 1.0:
        torque *= noise.torque_gain
    velocity = profile.velocity.copy()
    if noise.velocity_sd:
        velocity += rng.normal(0.0, noise.velocity_sd, n)
    angle = theta
    if noise.angle_step:
        angle = np.round(theta / noise.angle_step) * noise.angle_step

    attrs = {
        "kind": kind,
        "speed": 0.0 if speed_deg_s is None else float(speed_deg_s),
        "true_inertia": float(inertia),
        "true_gravity_moment": float(gravity_moment),
        "true_phi": float(phi),
        "true_offset": float(offset + shift),
        "ramp_start": float(profile.ramp_start),
        "ramp_end": float(profile.ramp_end),
        "true_lag": float(noise.lag),
        "true_torque_gain": float(noise.torque_gain),
    }
    if noise.hysteresis:
        attrs["true_hysteresis"] = float(noise.hysteresis)
    return _dataset(t, angle, velocity, torque, source=source, rate=rate, attrs=attrs)
