"""A study's trials as they are processed: their table, the bookkeeping of a run, the EMG check.

What every kind of trial's handler (:mod:`inertiafit.processing.kinds`) and
:func:`~inertiafit.processing.study.process_study` share: the columns and statuses of
``trials.csv`` (:data:`TRIAL_COLUMNS`), a trial's row (:func:`trial_row`), the bookkeeping of
one run — skips, exclusions, reader flags, provenance (:class:`TrialRun`) — and the EMG check
of a study whose trials record EMG (:class:`EmgCheck`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pandas as pd
import xarray as xr

from inertiafit.errors import InputError, StudyRefused
from inertiafit.io import Study, TrialSpec
from inertiafit.io.emg import EmgSettings
from inertiafit.processing.activity import (
    ActivityCheck,
    RestLevels,
    check_fast,
    check_sweep,
    study_rest_levels,
)
from inertiafit.processing.emg import mvc_levels
from inertiafit.processing.filtering import sampling_rate
from inertiafit.processing.gravity import GravityFit, moving_part
from inertiafit.processing.inertia import InertiaEstimate
from inertiafit.processing.living import StaticRecord

__all__ = [
    "DECELERATION_TRACE_COLUMNS",
    "DIAGNOSTIC_COLUMN",
    "EMG_TRACE_COLUMNS",
    "EMG_TRIAL_COLUMNS",
    "LIVING_ROW_FLAG",
    "LIVING_TRIAL_COLUMNS",
    "STATUS_EXCLUDED",
    "STATUS_NOT_REACHED",
    "STATUS_OK",
    "STATUS_REFERENCE",
    "STATUS_REFUSED",
    "STATUS_SKIPPED",
    "SWEEP_COLUMNS",
    "SWEEP_POINTS",
    "TRACE_COLUMNS",
    "TRACE_POINTS",
    "TRIAL_COLUMNS",
    "EmgCheck",
    "TrialRun",
    "fast_trace",
    "move_direction",
    "relative_file",
    "static_record",
    "sweep_trace",
    "sweeps_frame",
    "traces_frame",
    "trial_row",
]

#: Columns of ``trials.csv``, a row per trial (SI units; ``speed`` in deg/s).
TRIAL_COLUMNS = [
    "file",
    "condition",
    "kind",
    "speed",
    "inertia",
    "inertia_frame_mean",
    "gravity_moment",
    "gravity_phase",
    "window_start",
    "window_end",
    "n_window",
    "residual_rms",
    "flags",
    "inertia_se",
    "gravity_moment_se",
    "offset",
    "lag",
    "lag_se",
    "status",
]
#: Columns ``trials.csv`` gains when a body is living: the trial's posture and a fast trial's
#: viscous damping ``b`` (N m s/rad) with its standard error.
LIVING_TRIAL_COLUMNS = ["posture", "damping", "damping_se"]
#: The column ``trials.csv`` gains when the study has EMG: the largest EMG envelope over its
#: rest level, over the muscles, in the windows checked (a fast trial's analysis and reflex
#: windows, a quasi-static sweep's or rest trial's length, an MVC trial's peak; empty for a
#: trial without EMG).
EMG_TRIAL_COLUMNS = ["emg_peak_ratio"]
#: Columns of :attr:`ProcessedStudy.emg_traces` (``emg_traces.csv``): each fast trial's EMG
#: envelope over its rest level around the windows checked, for figures. ``time`` is in s
#: after the motion's onset; ``active`` (0 or 1) marks an active stretch that counts;
#: ``status`` is the trial's (``ok``, ``flagged`` or ``excluded``).
EMG_TRACE_COLUMNS = [
    "condition",
    "trial",
    "muscle",
    "time",
    "ratio",
    "threshold",
    "active",
    "status",
]
#: The flag of a living condition's quasi-static row: what its gravity moment is.
LIVING_ROW_FLAG = (
    "living body: gravity_moment here is the rigid fit of this sweep alone, which absorbs the "
    "passive curve (the paper's method); the condition's M_g is the joint fit's "
    "(passive_parameters.csv)"
)
#: ``status`` of a trial whose values were used, of one skipped (``on_trial_error``), and of
#: one excluded for muscle activity (``[emg] on_activity = "exclude"``).
STATUS_OK, STATUS_SKIPPED, STATUS_EXCLUDED = "ok", "skipped", "excluded"
#: ``status`` of a ``kind = "mvc"`` trial: read for its EMG's MVC levels, never evidence.
STATUS_REFERENCE = "reference"
#: ``status`` in ``diagnostics.csv`` of a trial that caused a refusal, and of one the study
#: stopped before.
STATUS_REFUSED, STATUS_NOT_REACHED = "refused", "not reached"
#: The column ``diagnostics.csv`` adds to those of ``trials.csv``: why a trial was refused.
DIAGNOSTIC_COLUMN = "cause"
#: Columns of ``traces.csv``: the filtered moving part of every fast trial, for figures;
#: ``inertial_torque`` (N m) is the torque its inertia was fitted to
#: (:attr:`~inertiafit.processing.inertia.InertiaEstimate.inertial_torque`), signed as the
#: move (every move plotted as positive).
TRACE_COLUMNS = [
    "condition",
    "trial",
    "speed",
    "window_start",
    "window_end",
    "time",
    "velocity",
    "acceleration",
    "inertial_torque",
]
#: Columns ``traces.csv`` gains when a fast trial was fitted over its deceleration too (a
#: living body's: the inertia and the viscous damping together): that window's start and end
#: (s), on the trial's clock as ``window_start``; empty for the other trials.
DECELERATION_TRACE_COLUMNS = ["deceleration_start", "deceleration_end"]
#: Points kept of each fast trial's moving part in the figure traces.
TRACE_POINTS = 600
#: Columns of ``sweeps.csv``: each rigid condition's quasi-static sweeps as fitted (the move
#: without its rests), means of consecutive samples, for the figure of the gravity fit.
SWEEP_COLUMNS = ["condition", "file", "angle", "torque"]
#: Points kept of each sweep (means of as many consecutive samples as it takes).
SWEEP_POINTS = 240
_T = TypeVar("_T")


def relative_file(path: Path, base: Path) -> str:
    """A trial's file as ``trials.csv`` names it: relative to the manifest's folder if inside."""
    try:
        return str(path.relative_to(base))
    except ValueError:
        return str(path)


class TrialRun:
    """The bookkeeping of one :func:`process_study` call: skips, reader flags, provenance."""

    def __init__(self, study: Study) -> None:
        self.study = study
        self.skip = study.on_trial_error == "skip"
        self.notes: list[str] = []
        self.skipped: dict[int, dict] = {}  # rows of skipped trials, by manifest index
        self.reasons: dict[int, str] = {}
        self.flags: dict[int, tuple[str, ...]] = {}  # reader flags, by manifest index
        self.contents: dict[str, TrialSpec] = {}  # first trial read of each SHA-256
        self.rows: dict[int, dict] = {}  # rows of the trials processed, by manifest index
        self.failed: dict[str, str] = {}  # the trial that stopped the study: file -> reason
        self.provenance: dict[int, dict[str, Any]] = {
            t.index: {
                "file": relative_file(t.file, study.base_dir),
                "path": str(t.file),
                "sha256": None,
                "condition": t.condition,
                "kind": t.kind,
                "status": STATUS_OK,
                "reader": t.reader_settings(),
            }
            for t in study.trials
        }

    def attempt(self, spec: TrialSpec, step: Callable[[], _T]) -> _T | None:
        """``step()``, or ``None`` when it raised InputError and bad trials are skipped."""
        try:
            return step()
        except InputError as exc:
            if not self.skip:
                self.refuse(spec, str(exc))
                raise
            self.drop(spec, str(exc))
            return None

    def refuse(self, spec: TrialSpec, message: str) -> None:
        """Note the trial that stops the study (its row in the diagnostics is ``refused``)."""
        self.failed[relative_file(spec.file, self.study.base_dir)] = message.removeprefix(
            f"{spec.file}: "
        )

    def drop(self, spec: TrialSpec, message: str) -> None:
        """Skip a trial: its row (no values, the reason in ``flags``) and a warning line."""
        reason = message.removeprefix(f"{spec.file}: ")
        self.reasons[spec.index] = reason
        self.notes.append(f"{spec.file}: trial skipped: {reason}")
        row = trial_row(self.study, spec, reader=self.reader_flags(spec))
        row.update(
            status=STATUS_SKIPPED,
            flags="; ".join(filter(None, [f"skipped: {reason}", row["flags"]])),
        )
        self.skipped[spec.index] = row
        self.provenance[spec.index]["status"] = STATUS_SKIPPED

    def exclude(self, spec: TrialSpec, row: dict, reason: str) -> None:
        """Exclude a trial for muscle activity; nothing of it is used.

        Its row keeps its values, the reason first in ``flags``, ``status`` ``"excluded"``;
        a line joins the warnings.
        """
        self.reasons[spec.index] = reason
        self.notes.append(f"{spec.file}: trial excluded: {reason}")
        row.update(
            status=STATUS_EXCLUDED,
            flags="; ".join(filter(None, [f"excluded: {reason}", row["flags"]])),
        )
        self.skipped[spec.index] = row
        self.provenance[spec.index]["status"] = STATUS_EXCLUDED

    def reference(self, spec: TrialSpec, row: dict) -> None:
        """Keep an MVC trial's row (``status`` ``"reference"``): listed, never evidence."""
        row["status"] = STATUS_REFERENCE
        self.skipped[spec.index] = row
        self.provenance[spec.index]["status"] = STATUS_REFERENCE

    def reader_flags(self, spec: TrialSpec) -> tuple[str, ...]:
        """The reader's own flags of a trial (a velocity sign it corrected, ...)."""
        return self.flags.get(spec.index, ())

    def check_left(self, used: dict[str, list], kind: str) -> None:
        """Every condition with trials of ``kind`` in the manifest keeps at least one."""
        for condition in self.study.conditions:
            listed = [t for t in self.study.trials if t.condition == condition and t.kind == kind]
            if not listed or used.get(condition):
                continue
            gone = [t for t in listed if t.index in self.skipped]
            how = (
                "skipped"
                if all(self.skipped[t.index]["status"] == STATUS_SKIPPED for t in gone)
                else "left out"
            )
            named = ", ".join(
                f"{relative_file(t.file, self.study.base_dir)} ({self.reasons[t.index]})"
                for t in gone[:3]
            ) + (", ..." if len(gone) > 3 else "")
            need = (
                "its fast trials need the gravity model it gives"
                if kind == "quasi-static"
                else "its inertia has no evidence"
            )
            raise InputError(
                f"{self.study.path}: condition '{condition}': no usable {kind} trial; "
                f"{how}: {named}; {need}"
            )


def trial_row(
    study: Study,
    spec: TrialSpec,
    *,
    gravity: GravityFit | None = None,
    inertia: InertiaEstimate | None = None,
    reader: tuple[str, ...] = (),
) -> dict:
    """A trial's row of ``trials.csv`` (:data:`TRIAL_COLUMNS`), with its fit's values if any.

    ``gravity``: a quasi-static sweep's fit; ``inertia``: a fast trial's estimate;
    ``reader``: the reader's flags, first in ``flags``.
    """
    nan = math.nan
    row: dict[str, Any] = dict.fromkeys(TRIAL_COLUMNS, nan)
    row.update(
        file=relative_file(spec.file, study.base_dir),
        condition=spec.condition,
        kind=spec.kind,
        speed=spec.speed if spec.speed is not None else nan,
        flags="; ".join(reader),
        status=STATUS_OK,
    )
    if gravity is not None:
        row.update(
            gravity_moment=gravity.gravity_moment,
            gravity_moment_se=gravity.gravity_moment_se,
            gravity_phase=gravity.gravity_phase,
            offset=gravity.offset,
            residual_rms=gravity.residual_rms,
            n_window=gravity.n,
            flags="; ".join(dict.fromkeys([*reader, *gravity.flags])),
        )
    if inertia is not None:
        row.update(
            inertia=inertia.inertia,
            inertia_se=inertia.inertia_se,
            inertia_frame_mean=inertia.inertia_frame_mean,
            window_start=inertia.window_start,
            window_end=inertia.window_end,
            n_window=inertia.n_window,
            residual_rms=inertia.residual_rms,
            flags="; ".join(dict.fromkeys([*reader, *inertia.flags])),
            lag=inertia.lag,
            lag_se=inertia.lag_se,
        )
    return row


def static_record(spec: TrialSpec, ds: xr.Dataset, base: Path) -> StaticRecord:
    """A living condition's quasi-static or rest trial as the joint fit takes it.

    Its ``source`` is the file as ``trials.csv`` names it (relative to ``base``, the
    manifest's folder): the fit's checks and ``static_fit.csv`` name the trial so.
    """
    return StaticRecord(
        angle=ds["angle"].values,
        torque=ds["torque"].values,
        condition=spec.condition,
        posture=spec.posture,
        kind=spec.kind,
        source=relative_file(spec.file, base),
        rate=sampling_rate(ds),
    )


def sweep_trace(condition: str, file: str, angle, torque) -> dict:
    """A quasi-static sweep for plotting: the samples its gravity model was fitted to.

    The move without its rests (:func:`~inertiafit.processing.gravity.moving_part`, as the
    fit takes it), as :data:`SWEEP_POINTS` means of consecutive samples of the angle (rad)
    and the torque (N m); columns :data:`SWEEP_COLUMNS` as arrays.
    """
    theta = np.asarray(angle, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    fitted = moving_part(theta)
    theta, tau = theta[fitted], tau[fitted]
    size = max(1, math.ceil(theta.size / SWEEP_POINTS))
    n = theta.size // size
    means = [x[: n * size].reshape(n, size).mean(axis=1) for x in (theta, tau)]
    return {
        "condition": np.full(n, condition, dtype=object),
        "file": np.full(n, file, dtype=object),
        "angle": means[0],
        "torque": means[1],
    }


def sweeps_frame(parts: list[dict]) -> pd.DataFrame:
    """One frame of every sweep (:func:`sweep_trace`), in order (:data:`SWEEP_COLUMNS`)."""
    if not parts:
        return pd.DataFrame(columns=SWEEP_COLUMNS)
    return pd.DataFrame(
        {c: np.concatenate([p[c] for p in parts]) for c in SWEEP_COLUMNS}, columns=SWEEP_COLUMNS
    )


def move_direction(ds: xr.Dataset) -> int:
    """The direction of a fast move: the sign of its fastest velocity."""
    v = ds["velocity"].values
    return 1 if v[int(np.argmax(np.abs(v)))] >= 0 else -1


def fast_trace(condition: str, number: int, time, est: InertiaEstimate, speed: float) -> dict:
    """The moving part of a fast trial for plotting: its filtered velocity and acceleration.

    They are the ones the inertia was estimated from (the same zero-lag filter), with the
    torque fitted to them (``inertial_torque``; NaN when the estimate has none). Columns
    (:data:`TRACE_COLUMNS`) as arrays: :func:`traces_frame` makes one frame of all trials (a
    frame per trial, concatenated, costs more than the rest of a fast trial's processing).
    """
    v, a = np.asarray(est.velocity), np.asarray(est.acceleration)
    moving = np.flatnonzero(np.abs(v) > 0.02 * np.max(np.abs(v)))
    lo, hi = (moving[0], moving[-1] + 1) if len(moving) else (0, len(time))
    step = max(1, (hi - lo) // TRACE_POINTS)
    sl = slice(lo, hi, step)
    sign = 1.0 if np.median(v[lo:hi]) >= 0 else -1.0  # plot every move as positive
    n = len(time[sl])
    out = {
        "condition": np.full(n, condition, dtype=object),
        "trial": np.full(n, number),
        "speed": np.full(n, speed),
        "window_start": np.full(n, est.window_start),
        "window_end": np.full(n, est.window_end),
        "time": time[sl],
        "velocity": sign * v[sl],
        "acceleration": sign * a[sl],
        "inertial_torque": (
            sign * np.asarray(est.inertial_torque)[sl]
            if est.inertial_torque is not None
            else np.full(n, np.nan)
        ),
    }
    if est.deceleration_start is not None and est.deceleration_end is not None:
        out["deceleration_start"] = np.full(n, est.deceleration_start)
        out["deceleration_end"] = np.full(n, est.deceleration_end)
    return out


def traces_frame(parts: list[dict]) -> pd.DataFrame:
    """One frame of the traces of every fast trial, in order.

    :data:`TRACE_COLUMNS`, and :data:`DECELERATION_TRACE_COLUMNS` when a trial has them (NaN
    for the trials that do not).
    """
    if not parts:
        return pd.DataFrame(columns=TRACE_COLUMNS)
    columns = list(TRACE_COLUMNS)
    if any(DECELERATION_TRACE_COLUMNS[0] in p for p in parts):
        columns += DECELERATION_TRACE_COLUMNS
    return pd.DataFrame(
        {
            c: np.concatenate([p.get(c, np.full(len(p["time"]), np.nan)) for p in parts])
            for c in columns
        },
        columns=columns,
    )


@dataclass
class EmgCheck:
    """The EMG check of one :func:`process_study` call: settings, rest levels, peak ratios."""

    study: Study
    settings: EmgSettings
    rest: RestLevels
    mvc: dict[str, float] | None = None  # each muscle's MVC level (V), with mvc trials
    peak: dict[int, float] = field(default_factory=dict)  # emg_peak_ratio by manifest index
    checks: list[tuple[TrialSpec, ActivityCheck]] = field(default_factory=list)  # fast trials

    @property
    def action(self) -> str:
        """``[emg] on_activity``: ``"exclude"``, ``"flag"`` or ``"stop"``."""
        return self.settings.on_activity

    @classmethod
    def of(cls, study: Study, data: list, notes: list[str]) -> EmgCheck | None:
        """The check, when a trial read has EMG; ``None`` otherwise.

        Rest levels from the rest trials, else the quasi-static ones (said in ``notes``);
        with ``kind = "mvc"`` trials, each checked muscle's MVC level (:func:`mvc_levels`,
        its largest peak envelope over them).
        """
        if not any("emg" in ds for _, ds in data):
            return None
        settings = study.emg if study.emg is not None else EmgSettings()
        rest, lines = study_rest_levels(
            [ds for spec, ds in data if spec.kind == "rest"],
            [ds for spec, ds in data if spec.kind == "quasi-static"],
            settings,
            base_dir=str(study.base_dir),
        )
        notes.extend(f"{study.path}: {line}" for line in lines)
        mvc = None
        listed = [t for t in study.trials if t.kind == "mvc"]
        if listed:
            read = [ds for spec, ds in data if spec.kind == "mvc"]
            if not read:
                names = ", ".join(relative_file(t.file, study.base_dir) for t in listed[:3])
                raise InputError(
                    f"{study.path}: no mvc trial could be read ({names}, skipped); the "
                    "activity check's %MVC threshold needs one"
                )
            checked = dict.fromkeys(
                str(m)
                for spec, ds in data
                if spec.kind != "mvc" and "emg" in ds
                for m in ds["emg"]["muscle"].values
            )
            mvc = mvc_levels(
                read,
                band=settings.band,
                rms_window=settings.rms_window,
                muscles=list(checked) or None,
            )
        return cls(study, settings, rest, mvc)

    def mvc_row(self, spec: TrialSpec, ds: xr.Dataset, *, reader: tuple[str, ...]) -> dict:
        """An MVC trial's row: each muscle's peak envelope, in V and over its rest level."""
        own = mvc_levels(ds, band=self.settings.band, rms_window=self.settings.rms_window)
        parts, ratios = [], []
        for m, peak in own.items():
            mean = self.rest.levels.get(m, (math.nan, math.nan))[0]
            if math.isfinite(mean):
                ratios.append(peak / mean)
            shown = f" ({peak / mean:.0f} x rest)" if math.isfinite(mean) else ""
            parts.append(f"{m} {peak * 1e3:.3g} mV{shown}")
        self.peak[spec.index] = max(ratios, default=math.nan)
        row = trial_row(self.study, spec, reader=reader)
        text = "MVC reference (not evidence): peak envelope " + ", ".join(parts)
        row["flags"] = "; ".join(filter(None, [text, row["flags"]]))
        return row

    def summary(self, left: dict[int, dict]) -> list[str]:
        """One line counting the fast trials excluded for muscle activity (none: no line)."""
        fast = [t for t in self.study.trials if t.kind == "fast" and t.index in self.peak]
        out = [t for t in fast if left.get(t.index, {}).get("status") == STATUS_EXCLUDED]
        if not out:
            return []
        return [
            (
                f"{self.study.path}: {len(out)} of {len(fast)} fast trials with EMG excluded for "
                'muscle activity ([emg] on_activity = "exclude"); trials.csv keeps them with '
                'status "excluded" and the reason in flags'
            )
        ]

    def traces(self) -> pd.DataFrame:
        """The fast trials' envelopes for figures (:data:`EMG_TRACE_COLUMNS`)."""
        status = {False: STATUS_OK, True: "flagged" if self.action == "flag" else STATUS_EXCLUDED}
        parts = []
        for spec, check in self.checks:
            trace = check.trace()
            n = len(trace["time"])
            parts.append(
                {
                    "condition": np.full(n, spec.condition, dtype=object),
                    "trial": np.full(
                        n, relative_file(spec.file, self.study.base_dir), dtype=object
                    ),
                    **trace,
                    "active": trace["active"].astype(int),
                    "status": np.full(n, status[check.active], dtype=object),
                }
            )
        if not parts:
            return pd.DataFrame(columns=EMG_TRACE_COLUMNS)
        return pd.DataFrame(
            {c: np.concatenate([p[c] for p in parts]) for c in EMG_TRACE_COLUMNS},
            columns=EMG_TRACE_COLUMNS,
        )

    def stop(self, spec: TrialSpec, check: ActivityCheck) -> None:
        """With ``on_activity = "stop"``, an active trial refuses the study in one line."""
        if check.active and self.action == "stop":
            reason = (
                f"{check.describe()}; the muscle was not relaxed "
                '([emg] on_activity = "stop"; "exclude" leaves such trials out)'
            )
            raise StudyRefused(
                f"{spec.file}: {reason}",
                refused={relative_file(spec.file, self.study.base_dir): reason},
            )

    def fast(self, spec: TrialSpec, ds: xr.Dataset, est: InertiaEstimate) -> ActivityCheck:
        """A fast trial's check (its ``emg_peak_ratio`` kept)."""
        deceleration = None
        if est.deceleration_start is not None and est.deceleration_end is not None:
            deceleration = (est.deceleration_start, est.deceleration_end)
        check = check_fast(
            ds,
            self.rest,
            self.settings,
            window=(est.window_start, est.window_end),
            deceleration=deceleration,
            velocity=est.velocity,
            mvc=self.mvc,
        )
        self.peak[spec.index] = check.peak_ratio
        self.checks.append((spec, check))
        return check

    def sweep(
        self, spec: TrialSpec, ds: xr.Dataset
    ) -> tuple[xr.Dataset, tuple[str, ...], ActivityCheck]:
        """A quasi-static sweep's check: the trial to fit, its flag, and the check.

        With ``"exclude"``, the trial to fit has its active stretches cut out.
        """
        check = check_sweep(ds, self.rest, self.settings, mvc=self.mvc)
        self.peak[spec.index] = check.peak_ratio
        if not check.active or self.action == "stop":
            return ds, (), check
        text = check.describe()
        if self.action == "exclude":
            time = np.asarray(ds["time"].values)
            keep = check.cut(time)
            ds = ds.isel(time=np.flatnonzero(keep))
            text += f"; {int((~keep).sum())} samples cut out of the fit"
        return ds, (text,), check
