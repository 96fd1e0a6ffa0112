"""The EMG activity check of a study: rest levels, and each trial's active stretches.

:func:`~inertiafit.processing.study.process_study` uses it for every trial read with EMG
channels (``docs/processing.md``, "The EMG check in a study"):

- the **rest level** of each muscle (:func:`study_rest_levels`): from the study's
  ``kind = "rest"`` trials (the envelope's mean and SD over each, half a window trimmed at
  each end, pooled; a stretch active against the quietest :data:`QUIET_SPAN` seconds of the
  rest trials left out), else from the quietest :data:`QUIET_SPAN` seconds of the
  quasi-static trials (said in the warnings);
- a **fast trial** (:func:`check_fast`) is checked over its analysis windows (the
  acceleration window; the deceleration window of a living condition) and a reflex window
  :data:`REFLEX_WINDOW` after its motion starts: an active stretch of
  :func:`~inertiafit.processing.emg.emg_activity` that overlaps one of them makes the trial
  active;
- a **quasi-static sweep** (:func:`check_sweep`) over its whole length; its active stretches,
  widened by :data:`SWEEP_MARGIN`, are what ``on_activity = "exclude"`` cuts out of its fit.

Every check gives the trial's ``emg_peak_ratio``: the largest envelope over the rest level,
over the muscles, in the windows checked.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import xarray as xr

from inertiafit.errors import InputError
from inertiafit.io.emg import EmgSettings
from inertiafit.processing.emg import emg_activity, emg_envelope
from inertiafit.processing.filtering import sampling_rate, source_of

__all__ = [
    "MOTION_ONSET",
    "QUIET_SPAN",
    "REFLEX_WINDOW",
    "SWEEP_MARGIN",
    "TRACE_POINTS",
    "ActivityCheck",
    "RestLevels",
    "check_fast",
    "check_sweep",
    "motion_onset",
    "study_rest_levels",
]

#: The reflex window (s after the motion starts): short- and medium-latency stretch reflexes
#: of the arm and leg muscles answer 20-100 ms after a stretch starts; 150 ms leaves room for
#: the envelope's half window and a late onset.
REFLEX_WINDOW = (0.020, 0.150)
#: The motion starts where the filtered speed first exceeds this fraction of its peak.
MOTION_ONSET = 0.05
#: Length (s) of the quietest stretch of the quasi-static trials taken as rest when the study
#: has no rest trials.
QUIET_SPAN = 2.0
#: Margins (s, before and after) of an active stretch cut out of a quasi-static sweep: the
#: envelope finds an onset within half a window; a reflex's torque lasts some 0.2 s after its
#: EMG ends (electromechanical delay and relaxation).
SWEEP_MARGIN = (0.05, 0.25)
#: Points kept per muscle of a fast trial's envelope in the figure traces.
TRACE_POINTS = 400


@dataclass(frozen=True)
class RestLevels:
    """Each muscle's rest level ``(mean, sd)`` of the envelope (V), and where it came from."""

    levels: dict[str, tuple[float, float]]
    sources: dict[str, str]

    def of(self, muscles: Iterable[str], where: str) -> dict[str, tuple[float, float]]:
        """The levels of ``muscles``; a muscle without one is an error naming ``where``."""
        out = {}
        for m in muscles:
            if m not in self.levels:
                raise InputError(
                    f"{where}: EMG channel {m!r} has no rest level: no rest or quasi-static "
                    "trial of the study records it"
                )
            out[m] = self.levels[m]
        return out


@dataclass(frozen=True)
class ActivityCheck:
    """One trial's check: its active stretches in the windows checked, and its peak ratio.

    ``stretches`` has the columns of :func:`~inertiafit.processing.emg.emg_activity`;
    ``windows`` are the spans checked (s); ``peak_ratio`` is the largest envelope over rest
    in them.
    """

    stretches: pd.DataFrame
    windows: tuple[tuple[float, float], ...]
    peak_ratio: float
    envelope: xr.DataArray | None = field(default=None, repr=False, compare=False)
    levels: dict[str, tuple[float, float]] = field(default_factory=dict, repr=False)
    thresholds: dict[str, float] = field(default_factory=dict, repr=False)
    onset: float = math.nan

    @property
    def active(self) -> bool:
        """Whether a muscle is active in the windows checked."""
        return not self.stretches.empty

    def describe(self) -> str:
        """``EMG active: triceps 0.262-0.331 s (14.2 x rest)[; ...]``."""
        parts = [
            f"{r.muscle} {r.start:.3f}-{r.end:.3f} s ({r.peak_ratio:.1f} x rest)"
            for r in self.stretches.itertuples()
        ]
        return "EMG active: " + ", ".join(parts)

    def trace(
        self, *, before: float = 0.1, after: float = 0.1, points: int = TRACE_POINTS
    ) -> dict:
        """The envelope over the rest level around the windows checked, for a figure.

        Per muscle, from ``before`` s ahead of the first window to ``after`` s past the last,
        at most ``points`` samples (every n-th): arrays ``muscle``, ``time`` (s after the
        motion's onset, or the trial's time when it has none), ``ratio`` (envelope over the
        rest mean), ``threshold`` (the threshold over the rest mean) and ``active`` (inside an
        active stretch that counts).
        """
        if self.envelope is None:
            return {k: np.array([]) for k in ("muscle", "time", "ratio", "threshold", "active")}
        time = np.asarray(self.envelope["time"].values)
        lo = min(a for a, _ in self.windows) - before
        hi = max(b for _, b in self.windows) + after
        inside = np.flatnonzero((time >= lo) & (time <= hi))
        step = max(1, len(inside) // points)
        idx = inside[::step]
        zero = self.onset if math.isfinite(self.onset) else 0.0
        parts: dict[str, list] = {
            k: [] for k in ("muscle", "time", "ratio", "threshold", "active")
        }
        for name, row in zip(self.envelope["muscle"].values, self.envelope.values, strict=True):
            m = str(name)
            mean = self.levels[m][0]
            active = np.zeros(len(idx), dtype=bool)
            for r in self.stretches.itertuples():
                if r.muscle == m:
                    active |= (time[idx] >= r.start) & (time[idx] <= r.end)
            parts["muscle"].append(np.full(len(idx), m, dtype=object))
            parts["time"].append(time[idx] - zero)
            parts["ratio"].append(row[idx] / mean)
            parts["threshold"].append(np.full(len(idx), self.thresholds[m] / mean))
            parts["active"].append(active)
        return {k: np.concatenate(v) for k, v in parts.items()}

    def cut(self, time: np.ndarray) -> np.ndarray:
        """The samples kept when the active stretches (with :data:`SWEEP_MARGIN`) are cut."""
        keep = np.ones(len(time), dtype=bool)
        before, after = SWEEP_MARGIN
        for r in self.stretches.itertuples():
            keep &= ~((time >= r.start - before) & (time <= r.end + after))
        return keep


def _envelopes(
    ds: xr.Dataset, settings: EmgSettings, muscles: Sequence[str] | None = None
) -> xr.DataArray:
    return emg_envelope(ds, band=settings.band, rms_window=settings.rms_window, muscles=muscles)


def _quietest(
    envelopes: Sequence[tuple[xr.Dataset, xr.DataArray]], settings: EmgSettings
) -> dict[str, tuple[float, float, str, float, float]]:
    """Per muscle, the :data:`QUIET_SPAN` seconds of lowest mean envelope over ``envelopes``.

    ``(mean, sd, source, start, end)`` of that span (a trial shorter than it: its whole
    length less half a window at each end).
    """
    quiet: dict[str, tuple[float, float, str, float, float]] = {}
    for ds, env in envelopes:
        time = np.asarray(env["time"].values)
        rate = sampling_rate(ds)
        half = round(settings.rms_window * rate / 2)
        span = max(2, min(round(QUIET_SPAN * rate), len(time) - 2 * half))
        for name, row in zip(env["muscle"].values, env.values, strict=True):
            m = str(name)
            inner = row[half : len(row) - half] if len(row) > 2 * half + span else row
            offset = half if len(row) > 2 * half + span else 0
            csum = np.concatenate(([0.0], np.cumsum(inner)))
            means = (csum[span:] - csum[:-span]) / span
            k = int(np.argmin(means))
            piece = inner[k : k + span]
            if m not in quiet or float(means[k]) < quiet[m][0]:
                quiet[m] = (
                    float(piece.mean()),
                    float(piece.std()),
                    source_of(ds),
                    float(time[offset + k]),
                    float(time[offset + k + span - 1]),
                )
    return quiet


def _quiet_parts(
    ds: xr.Dataset,
    env: xr.DataArray,
    baseline: dict[str, tuple[float, float, str, float, float]],
    settings: EmgSettings,
) -> tuple[dict[str, np.ndarray], pd.DataFrame]:
    """A rest trial's envelope per muscle without its active stretches, and those stretches.

    The trial is checked against ``baseline`` (the quietest span of the study's rest trials);
    each active stretch is cut with :data:`SWEEP_MARGIN`, and half a window at each end.
    """
    levels = {m: baseline[m][:2] for m in (str(x) for x in env["muscle"].values)}
    table = emg_activity(ds, rest=levels, settings=settings)
    time = np.asarray(env["time"].values)
    half = round(settings.rms_window * sampling_rate(ds) / 2)
    ends = np.zeros(len(time), dtype=bool)
    if len(time) > 4 * half + 2:
        ends[:half] = ends[len(time) - half :] = True
    before, after = SWEEP_MARGIN
    out = {}
    for name, row in zip(env["muscle"].values, env.values, strict=True):
        m = str(name)
        keep = ~ends
        for r in table[table["muscle"] == m].itertuples():
            keep &= ~((time >= r.start - before) & (time <= r.end + after))
        out[m] = row[keep]
    return out, table


def study_rest_levels(
    rest_trials: Sequence[xr.Dataset],
    sweeps: Sequence[xr.Dataset],
    settings: EmgSettings,
    *,
    base_dir: str = "",
) -> tuple[RestLevels, list[str]]:
    """The rest level of every muscle a study's rest or quasi-static trials record.

    Parameters
    ----------
    rest_trials, sweeps : sequence of Trial
        The study's rest trials and quasi-static trials (those without EMG are ignored).
    settings : EmgSettings
        The study's ``[emg]`` table.

    Returns
    -------
    RestLevels, list of str
        The levels, and a line per muscle whose level comes from a quasi-static trial, and
        per rest trial with an active stretch (for the warnings).

    Notes
    -----
    From rest trials: each is first checked against the quietest :data:`QUIET_SPAN` seconds
    of all of them (a contraction during a "quiet" hold would raise the level and its SD,
    and with them the threshold every trial is checked against); an active stretch is left
    out (with :data:`SWEEP_MARGIN`), and the envelope's mean and SD over what remains of each
    trial (half a window trimmed at each end) are pooled as one population (the mean of the
    means; the SD from the mean of the variances plus the variance of the means). A rest
    trial with nothing active gives exactly its whole-length level. From quasi-static trials
    (a muscle no rest trial records, or whose rest trials are active throughout): the
    :data:`QUIET_SPAN` seconds of the lowest mean envelope over all of them.
    """
    levels: dict[str, tuple[float, float]] = {}
    sources: dict[str, str] = {}
    notes: list[str] = []

    def name_of(source: str) -> str:
        return source.removeprefix(base_dir).lstrip("/")

    rest_envs = [(ds, _envelopes(ds, settings)) for ds in rest_trials if "emg" in ds]
    baseline = _quietest(rest_envs, settings)
    _refuse_flat(baseline, name_of)
    per_muscle: dict[str, list[tuple[float, float]]] = {}
    for ds, env in rest_envs:
        parts, table = _quiet_parts(ds, env, baseline, settings)
        enough = max(2, round(settings.rms_window * sampling_rate(ds)))
        for m, values in parts.items():
            if len(values) >= enough:
                per_muscle.setdefault(m, []).append((float(values.mean()), float(values.std())))
        if not table.empty:
            stretches = ", ".join(
                f"{r.muscle} {r.start:.2f}-{r.end:.2f} s "
                f"({r.peak_ratio:.1f} x the quietest {QUIET_SPAN:g} s of the rest trials)"
                for r in table.itertuples()
            )
            notes.append(
                f"rest trial {name_of(source_of(ds))}: EMG active ({stretches}); left out of "
                "the rest level"
            )
    for m, pairs in per_muscle.items():
        means = np.array([v[0] for v in pairs])
        sds = np.array([v[1] for v in pairs])
        levels[m] = (float(means.mean()), float(math.sqrt(np.mean(sds**2) + np.var(means))))
        sources[m] = f"{len(pairs)} rest trial{'s' if len(pairs) > 1 else ''}"
    sweep_envs = [(ds, _envelopes(ds, settings)) for ds in sweeps if "emg" in ds]
    quiet = {m: q for m, q in _quietest(sweep_envs, settings).items() if m not in levels}
    _refuse_flat(quiet, name_of)
    for m, (mean, sd, source, start, end) in quiet.items():
        levels[m] = (mean, sd)
        sources[m] = (
            f"the quietest {end - start:.3g} s of {name_of(source)} ({start:.2f}-{end:.2f} s)"
        )
        why = (
            "its rest trials are active throughout"
            if m in baseline
            else "no rest trial records it"
        )
        notes.append(f"EMG channel {m!r}: {why}; its rest level is {sources[m]}")
    notes.extend(_unit_spread(levels))
    return RestLevels(levels, sources), notes


#: A rest level (V, the envelope's mean) at or below this is a flat channel: an amplifier's own
#: noise is 0.1-1 uV RMS referred to its input, so even a bare one reads 1000 times more.
DEAD_LEVEL = 1e-9
#: Rest levels of one study's channels this many times apart are in different units (uV among
#: V is 1e6; muscles and electrodes differ by 10 at most).
UNIT_SPREAD = 1e3


def _refuse_flat(
    quiet: Mapping[str, tuple[float, float, str, float, float]], name_of: Callable[[str], str]
) -> None:
    """Refuse a channel whose quietest stretch is flat (:data:`DEAD_LEVEL`), naming the file."""
    for m, (mean, _, source, start, end) in quiet.items():
        if not mean > DEAD_LEVEL:
            raise InputError(
                f"{name_of(source)}: EMG channel {m!r} is flat ({mean:.3g} V over {start:.2f}-"
                f"{end:.2f} s): a dead or unplugged electrode, or a column of zeros; record it "
                "again or leave it out of the [emg] columns"
            )


def _unit_spread(levels: Mapping[str, tuple[float, float]]) -> list[str]:
    """A warning line when the channels' rest levels are units apart (:data:`UNIT_SPREAD`)."""
    if len(levels) < 2:
        return []
    low = min(levels, key=lambda m: levels[m][0])
    high = max(levels, key=lambda m: levels[m][0])
    spread = levels[high][0] / levels[low][0]
    if spread < UNIT_SPREAD:
        return []
    line = (
        f"EMG channels {high!r} and {low!r} rest at levels {spread:.2g} times apart "
        f"({levels[high][0]:.3g} V and {levels[low][0]:.3g} V): one is in other units (uV "
        "read as V?); each channel is checked against its own rest level, so the verdicts "
        "stand, but check the [emg] unit and the channels' recording"
    )
    return [line]


def _peak_ratio(
    env: xr.DataArray, levels: dict[str, tuple[float, float]], windows: Sequence[tuple]
) -> float:
    time = np.asarray(env["time"].values)
    inside = np.zeros(len(time), dtype=bool)
    for a, b in windows:
        inside |= (time >= a) & (time <= b)
    if not inside.any():
        return math.nan
    return max(
        float(row[inside].max()) / levels[str(m)][0]
        for m, row in zip(env["muscle"].values, env.values, strict=True)
    )


def _overlapping(table: pd.DataFrame, windows: Sequence[tuple[float, float]]) -> pd.DataFrame:
    if table.empty:
        return table
    hit = np.zeros(len(table), dtype=bool)
    for a, b in windows:
        hit |= (table["end"].to_numpy() >= a) & (table["start"].to_numpy() <= b)
    return table[hit].reset_index(drop=True)


def _check(
    ds: xr.Dataset,
    rest: RestLevels,
    settings: EmgSettings,
    windows: Sequence[tuple[float, float]],
    onset: float = math.nan,
    mvc: Mapping[str, float] | None = None,
) -> ActivityCheck:
    muscles = [str(m) for m in ds["emg"]["muscle"].values]
    levels = rest.of(muscles, source_of(ds))
    peaks = None
    if mvc is not None:
        missing = [m for m in muscles if m not in mvc]
        if missing:
            raise InputError(
                f"{source_of(ds)}: EMG channel {missing[0]!r} has no MVC level: no mvc trial "
                "read records it"
            )
        peaks = {m: mvc[m] for m in muscles}
    table = emg_activity(ds, rest=levels, mvc=peaks, settings=settings)
    env = _envelopes(ds, settings)
    return ActivityCheck(
        stretches=_overlapping(table, windows),
        windows=tuple(windows),
        peak_ratio=_peak_ratio(env, levels, windows),
        envelope=env,
        levels=levels,
        thresholds={str(k): float(v) for k, v in table.attrs["threshold"].items()},
        onset=onset,
    )


def motion_onset(time: np.ndarray, velocity: np.ndarray) -> float:
    """When the motion starts: the filtered speed first above :data:`MOTION_ONSET` of its peak."""
    speed = np.abs(np.asarray(velocity, dtype=np.float64))
    first = int(np.argmax(speed > MOTION_ONSET * float(speed.max())))
    return float(time[first])


def check_fast(
    ds: xr.Dataset,
    rest: RestLevels,
    settings: EmgSettings,
    *,
    window: tuple[float, float],
    deceleration: tuple[float, float] | None,
    velocity: np.ndarray | None = None,
    mvc: Mapping[str, float] | None = None,
) -> ActivityCheck:
    """A fast trial's check over its analysis windows and its reflex window.

    ``velocity`` is the filtered velocity the inertia was estimated from (default the
    recorded one): the motion's onset is where its speed first exceeds :data:`MOTION_ONSET`
    of its peak. ``mvc``: each muscle's MVC level (V, :func:`~inertiafit.processing.emg.
    mvc_levels`), when the study has ``kind = "mvc"`` trials: the threshold is then also at
    least ``mvc_fraction`` of it.
    """
    time = np.asarray(ds["time"].values)
    v = ds["velocity"].values if velocity is None else velocity
    onset = motion_onset(time, v)
    windows = [window, (onset + REFLEX_WINDOW[0], onset + REFLEX_WINDOW[1])]
    if deceleration is not None:
        windows.append(deceleration)
    return _check(ds, rest, settings, windows, onset, mvc)


def check_sweep(
    ds: xr.Dataset,
    rest: RestLevels,
    settings: EmgSettings,
    *,
    mvc: Mapping[str, float] | None = None,
) -> ActivityCheck:
    """A quasi-static sweep's check over its whole length (``mvc`` as :func:`check_fast`)."""
    time = np.asarray(ds["time"].values)
    return _check(ds, rest, settings, [(float(time[0]), float(time[-1]))], mvc=mvc)
