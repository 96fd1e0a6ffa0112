"""Simulated EMG: resting noise on every channel, and stretch reflexes in chosen fast trials.

A muscle at rest shows band-limited noise of a few microvolts; an incompletely relaxed one
answers a fast stretch with a reflex (Hallett et al. 1981): an EMG burst 35-60 ms after the
stretch starts, 8-20 times the resting level, and a torque that resists the stretch. With
:class:`EmgSimulation` given to :func:`~inertiafit.simulate.simulate_study` or
:func:`~inertiafit.simulate.simulate_living_study` (``emg=``), every EMG trial gets its
channels, and a fast trial with a reflex gets both its burst and its torque (through
:func:`~inertiafit.simulate.signals.simulate_trial`'s ``extra_torque``).

The model of one reflex (:class:`Reflex`), ``s`` the time since the stretch started:

- EMG: the rest noise plus ``sqrt(ratio^2 - 1) x rest_rms x w(s - latency)`` times
  independent unit-RMS noise of the same band, ``w`` a flat-topped window (cosine edges of
  5 ms) of ``duration``, so the burst's RMS is ``ratio`` times the rest's;
- torque: ``direction x torque x g(s - latency - EMD)`` with ``g(u) = (u / tau) exp(1 - u /
  tau)`` for ``u > 0`` (a twitch, 1 at ``u = tau``), the electromechanical delay ``EMD`` 10 ms
  and ``tau`` 40 ms; it has the sign of the move, so it resists the stretch (the motor pushes
  harder) and reads as more inertia during the acceleration.

The stretched muscle is the last of ``muscles`` for a move towards the larger angle, the first
for one towards the smaller (an elbow flexed by the move stretches its extensor).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from inertiafit.simulate.files import toml_value

__all__ = [
    "EMD",
    "TWITCH_TIME",
    "EmgSimulation",
    "Reflex",
    "emg_channels",
    "reflex_torque",
    "trial_emg",
    "truth_lines",
]

#: Electromechanical delay (s): from the EMG burst's onset to the start of its torque.
EMD = 0.010
#: Time to peak (s) of the reflex torque's twitch after it starts.
TWITCH_TIME = 0.040
#: Cosine edges (s) of the burst's window.
_EDGE = 0.005
#: Order of the Butterworth band-pass that shapes the simulated noise.
_ORDER = 4


@dataclass(frozen=True)
class EmgSimulation:
    """What simulated EMG a study gets.

    Attributes
    ----------
    muscles : tuple of str
        Channel names (columns of the CSV files; ``[emg] columns`` of the manifest).
    rest_rms : float
        RMS (V) of the resting noise, band-limited to ``band``: 5 µV.
    band : (float, float)
        Band (Hz) of the noise and of the bursts (a 4th-order Butterworth band-pass of white
        Gaussian noise, renormalised to its RMS).
    reflex : float or sequence of str
        A probability (each fast trial of a condition with EMG draws whether it has a reflex)
        or the file names of the fast trials that have one. Default 0: none.
    latency, ratio, torque, duration : (float, float)
        Ranges of a reflex's values, drawn uniformly per reflex: onset of the burst (s after
        the stretch starts), its RMS over the rest's, the peak reflex torque (N m) and the
        burst's length (s).
    """

    muscles: tuple[str, ...] = ("biceps", "triceps")
    rest_rms: float = 5e-6
    band: tuple[float, float] = (20.0, 450.0)
    reflex: float | Sequence[str] = 0.0
    latency: tuple[float, float] = (0.035, 0.060)
    ratio: tuple[float, float] = (8.0, 20.0)
    torque: tuple[float, float] = (0.6, 2.0)
    duration: tuple[float, float] = (0.030, 0.060)

    def __post_init__(self) -> None:
        if not self.muscles or len(set(self.muscles)) != len(self.muscles):
            msg = f"muscles: expected distinct channel names, got {self.muscles!r}"
            raise ValueError(msg)
        if not (math.isfinite(self.rest_rms) and self.rest_rms > 0):
            msg = f"rest_rms must be a positive voltage, got {self.rest_rms!r}"
            raise ValueError(msg)
        if isinstance(self.reflex, int | float) and not 0 <= self.reflex <= 1:
            msg = f"reflex: expected a probability in [0, 1] or file names, got {self.reflex!r}"
            raise ValueError(msg)
        for name in ("band", "latency", "ratio", "torque", "duration"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                msg = f"{name}: expected 0 < low <= high, got {(lo, hi)!r}"
                raise ValueError(msg)

    def draws_reflex(self, filename: str, rng: np.random.Generator) -> bool:
        """Whether the fast trial ``filename`` has a reflex (one draw of ``rng``, always)."""
        u = rng.random()
        if isinstance(self.reflex, int | float):
            return bool(u < self.reflex)
        return filename in self.reflex

    def draw(self, rng: np.random.Generator, muscle: str) -> Reflex:
        """A reflex's values drawn uniformly from the ranges."""

        def uniform(pair: tuple[float, float]) -> float:
            return float(rng.uniform(*pair))

        return Reflex(
            muscle=muscle,
            latency=uniform(self.latency),
            ratio=uniform(self.ratio),
            torque=uniform(self.torque),
            duration=uniform(self.duration),
        )

    def stretched(self, direction: float) -> str:
        """The muscle a move stretches: the last for ``direction > 0``, else the first."""
        return self.muscles[-1] if direction > 0 else self.muscles[0]


@dataclass(frozen=True)
class Reflex:
    """One stretch reflex.

    The muscle, the burst's onset (s after the stretch starts), its RMS over the rest's, the
    peak torque (N m) and the burst's length (s).
    """

    muscle: str
    latency: float
    ratio: float
    torque: float
    duration: float

    def truth(self) -> dict[str, float | str]:
        """Its values for ``truth.toml``."""
        return {
            "muscle": self.muscle,
            "latency": self.latency,
            "ratio": self.ratio,
            "torque": self.torque,
            "duration": self.duration,
        }


def _band_noise(
    rng: np.random.Generator, n: int, rate: float, band: tuple[float, float]
) -> NDArray:
    """Gaussian noise of unit RMS in ``band`` (the upper edge below 0.95 x Nyquist)."""
    hi = min(band[1], 0.95 * rate / 2)
    sos = signal.butter(_ORDER, [band[0], hi], btype="bandpass", fs=rate, output="sos")
    x = signal.sosfilt(sos, rng.standard_normal(n + int(rate)))[int(rate) :]  # settled
    return x / float(np.sqrt(np.mean(x**2)))


def _window(t: NDArray, start: float, length: float) -> NDArray:
    """1 over ``[start, start + length]`` with cosine edges of ``_EDGE``, 0 elsewhere."""
    w = np.zeros_like(t)
    inside = (t >= start) & (t <= start + length)
    w[inside] = 1.0
    edge = min(_EDGE, length / 2)
    for side, ref in ((1.0, start), (-1.0, start + length)):
        s = side * (t - ref)
        ramp = inside & (s < edge)
        w[ramp] = 0.5 * (1.0 - np.cos(math.pi * s[ramp] / edge))
    return w


def emg_channels(
    sim: EmgSimulation,
    rng: np.random.Generator,
    time: NDArray,
    rate: float,
    *,
    stretch_start: float = 0.0,
    reflex: Reflex | None = None,
) -> dict[str, NDArray]:
    """Each muscle's EMG (V) at ``time``: rest noise, and the reflex's burst when given."""
    n = len(time)
    out = {}
    for muscle in sim.muscles:
        emg = sim.rest_rms * _band_noise(rng, n, rate, sim.band)
        if reflex is not None and muscle == reflex.muscle:
            shape = _window(time - stretch_start, reflex.latency, reflex.duration)
            burst = _band_noise(rng, n, rate, sim.band)
            emg = emg + math.sqrt(reflex.ratio**2 - 1.0) * sim.rest_rms * shape * burst
        out[muscle] = emg
    return out


def reflex_torque(
    reflex: Reflex, *, rate: float, stretch_start: float, lag: float, direction: float
) -> Callable[[int], NDArray]:
    """The reflex's torque (N m) at the torque channel's samples, from their count.

    For :func:`~inertiafit.simulate.signals.simulate_trial`'s ``extra_torque``: sample ``i``
    of the torque channel is the torque at ``i / rate - lag``.
    """

    def torque(n: int) -> NDArray:
        u = np.arange(n) / rate - lag - stretch_start - reflex.latency - EMD
        g = np.where(u > 0, u / TWITCH_TIME * np.exp(1.0 - np.maximum(u, 0) / TWITCH_TIME), 0)
        return math.copysign(reflex.torque, direction) * g

    return torque


#: The last word of the spawn key of a trial's EMG random source: its own stream, so that
#: EMG on or off leaves the trial's other channels as they were.
_EMG_STREAM = 0xE36


def trial_emg(
    sim: EmgSimulation,
    seed: np.random.SeedSequence,
    filename: str,
    *,
    kind: str,
    start: float,
    end: float,
    rest: float,
    rate: float,
    lag: float,
    extra_torque: Callable[[NDArray, NDArray], NDArray] | None,
) -> tuple[
    Callable[[NDArray], dict[str, NDArray]],
    Callable[[NDArray, NDArray], NDArray] | None,
    Reflex | None,
]:
    """One trial's EMG: a maker of its channels, its ``extra_torque`` and its reflex (or None).

    ``seed`` is the trial's own seed; the EMG draws from a stream of its own (a child key of
    it), so the trial's other channels do not change. A fast trial draws whether it has a
    reflex (:meth:`EmgSimulation.draws_reflex`); the reflex's torque joins ``extra_torque``.
    ``start``, ``end`` (rad) and ``rest`` (s) are the motion's; the stretch starts at ``rest``.
    """
    rng = np.random.default_rng(
        np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, _EMG_STREAM))
    )
    direction = 1.0 if end >= start else -1.0
    reflex = None
    if kind == "fast" and sim.draws_reflex(filename, rng):
        reflex = sim.draw(rng, sim.stretched(direction))
    torque = extra_torque
    if reflex is not None:
        added = reflex_torque(reflex, rate=rate, stretch_start=rest, lag=lag, direction=direction)

        def torque(angle: NDArray, velocity: NDArray) -> NDArray:
            base = extra_torque(angle, velocity) if extra_torque is not None else 0.0
            return base + added(len(angle))

    def channels(time: NDArray) -> dict[str, NDArray]:
        return emg_channels(sim, rng, time, rate, stretch_start=rest, reflex=reflex)

    return channels, torque, reflex


def truth_lines(sim: EmgSimulation, reflexes: Mapping[str, Reflex]) -> list[str]:
    """The ``[emg]`` table of ``truth.toml``: the channels, the rest RMS and every reflex."""
    lines = [
        "[emg]",
        f"muscles = {toml_value(list(sim.muscles))}",
        f"rest_rms = {sim.rest_rms!r}",
        f"reflex_trials = {toml_value(list(reflexes))}",
        "",
    ]
    for name, reflex in reflexes.items():
        lines += [f"[emg.reflexes.{toml_value(name)}]"]
        lines += [f"{k} = {toml_value(v)}" for k, v in reflex.truth().items()]
        lines += [""]
    return lines
