"""Every trial of a study processed: gravity model per condition, inertia per fast trial.

:func:`process_study` reads a manifest's trials (through :mod:`inertiafit.io`), fits the gravity
model of each condition from its quasi-static trials and estimates the inertia of every fast
trial. The per-trial values it returns (:class:`ProcessedStudy`) are what
:mod:`inertiafit.inference.evidence` turns into the evidence of each condition.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from inertiafit.errors import InputError
from inertiafit.io import Study, TrialSpec, load_study
from inertiafit.processing.gravity import GravityFit, fit_gravity
from inertiafit.processing.inertia import InertiaEstimate, estimate_inertia
from inertiafit.stats import inverse_variance_mean

__all__ = [
    "PHASE_TOLERANCE",
    "RATE_TOLERANCE",
    "TRACE_COLUMNS",
    "TRIAL_COLUMNS",
    "ProcessedStudy",
    "combine_gravity",
    "condition_gravity",
    "process_study",
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
]
#: Columns of ``traces.csv``: the filtered moving part of every fast trial, for figures.
TRACE_COLUMNS = [
    "condition",
    "trial",
    "speed",
    "window_start",
    "window_end",
    "time",
    "velocity",
    "acceleration",
]
#: Relative difference of sampling rates tolerated within one study.
RATE_TOLERANCE = 0.01
#: Phase difference between conditions (rad) beyond which bodies are not mounted in line.
PHASE_TOLERANCE = 0.05
#: Points kept of each fast trial's moving part in the figure traces.
TRACE_POINTS = 600


@dataclass
class ProcessedStudy:
    """Per-trial results of a study.

    Attributes
    ----------
    study : Study
        The manifest.
    trials : pandas.DataFrame
        A row per trial, columns :data:`TRIAL_COLUMNS` (SI units; ``speed`` in deg/s).
    gravity : dict of str to GravityFit
        The gravity model of each condition (combined over its quasi-static trials).
    traces : pandas.DataFrame
        Filtered velocity and acceleration of the fast trials' moving parts, columns
        :data:`TRACE_COLUMNS` (every move plotted as positive), for figures.
    warnings : list of str
        Flags worth a look: one line each, naming the file.
    """

    study: Study
    trials: pd.DataFrame
    gravity: dict[str, GravityFit]
    traces: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=TRACE_COLUMNS))
    warnings: list[str] = field(default_factory=list)


def _relative(path: Path, base: Path) -> str:
    try:
        return str(path.relative_to(base))
    except ValueError:
        return str(path)


def combine_gravity(fits: list[GravityFit], where: str) -> GravityFit:
    """One gravity model from several quasi-static fits: inverse-variance means."""
    if len(fits) == 1:
        return fits[0]
    ses = [f.gravity_moment_se for f in fits]

    def mean(name: str) -> float:
        return inverse_variance_mean([getattr(f, name) for f in fits], ses)[0]

    moment, moment_se = inverse_variance_mean([f.gravity_moment for f in fits], ses)
    return dataclasses.replace(
        fits[0],
        gravity_moment=moment,
        gravity_moment_se=moment_se,
        gravity_phase=mean("gravity_phase"),
        offset=mean("offset"),
        source=where,
    )


def condition_gravity(trials: pd.DataFrame) -> dict[str, float]:
    """Each condition's gravity moment from its quasi-static rows (inverse-variance mean)."""
    out = {}
    qs = trials[trials["kind"] == "quasi-static"]
    for label, rows in qs.groupby("condition", sort=False):
        out[str(label)] = inverse_variance_mean(rows["gravity_moment"], rows["gravity_moment_se"])[
            0
        ]
    return out


def _trace(condition: str, number: int, time, est: InertiaEstimate, speed: float) -> pd.DataFrame:
    """The moving part of a fast trial for plotting: its filtered velocity and acceleration.

    They are the ones the inertia was estimated from (the same zero-lag filter).
    """
    v, a = np.asarray(est.velocity), np.asarray(est.acceleration)
    moving = np.flatnonzero(np.abs(v) > 0.02 * np.max(np.abs(v)))
    lo, hi = (moving[0], moving[-1] + 1) if len(moving) else (0, len(time))
    step = max(1, (hi - lo) // TRACE_POINTS)
    sl = slice(lo, hi, step)
    sign = 1.0 if np.median(v[lo:hi]) >= 0 else -1.0  # plot every move as positive
    n = len(time[sl])
    return pd.DataFrame(
        {
            "condition": [condition] * n,
            "trial": np.full(n, number),
            "speed": np.full(n, speed),
            "window_start": np.full(n, est.window_start),
            "window_end": np.full(n, est.window_end),
            "time": time[sl],
            "velocity": sign * v[sl],
            "acceleration": sign * a[sl],
        },
        columns=TRACE_COLUMNS,
    )


def process_study(
    study: Study | str | Path,
    *,
    cutoff: float = 20.0,
    order: int = 2,
    echo: Callable[[str], None] | None = None,
) -> ProcessedStudy:
    """Read and process every trial of a study.

    Parameters
    ----------
    study : Study or path
        A loaded manifest or the path of one.
    cutoff, order : float, int
        Zero-lag Butterworth low-pass applied to torque and velocity (Hz, design order).
    echo : callable, optional
        Receives one progress line per stage.

    Returns
    -------
    ProcessedStudy

    Raises
    ------
    InputError
        On any unreadable trial, unusable window, negative inertia, or sampling rates that
        differ between trials; the message names the file.
    """
    if not isinstance(study, Study):
        study = load_study(study)
    say = echo or (lambda _msg: None)
    say(f"reading {len(study.trials)} trials")
    data = [(spec, study.read(spec)) for spec in study.trials]
    rates = [(spec, float(ds.attrs["sampling_rate"])) for spec, ds in data]
    ref_spec, ref_rate = rates[0]
    for spec, rate in rates[1:]:
        if abs(rate - ref_rate) > RATE_TOLERANCE * ref_rate:
            raise InputError(
                f"{spec.file}: sampling rate {rate:g} Hz differs from {ref_rate:g} Hz of "
                f"{ref_spec.file.name}; resample so every trial of a study has one rate"
            )
    rows: dict[int, dict] = {}  # by manifest order
    notes: list[str] = []
    say("fitting the gravity model of each condition (quasi-static trials)")
    qs_fits: dict[str, list[GravityFit]] = {}
    for spec, ds in data:
        if spec.kind != "quasi-static":
            continue
        fit = fit_gravity(ds)
        notes.extend(f"{fit.source}: {flag}" for flag in fit.flags)
        qs_fits.setdefault(spec.condition, []).append(fit)
        rows[spec.index] = _row(study, spec, gravity=fit)
    gravity = {
        cond: combine_gravity(fits, f"{study.path}: condition {cond}")
        for cond, fits in qs_fits.items()
    }
    _check_phases(study, gravity, notes)
    say("estimating the inertia of each fast trial")
    traces: list[pd.DataFrame] = []
    count: dict[str, int] = {}
    for spec, ds in data:
        if spec.kind != "fast":
            continue
        est = estimate_inertia(
            ds,
            gravity[spec.condition],
            window=spec.window,
            speed_deg_s=spec.speed,
            cutoff=cutoff,
            order=order,
        )
        notes.extend(f"{est.source}: {flag}" for flag in est.flags)
        rows[spec.index] = _row(study, spec, inertia=est)
        number = count[spec.condition] = count.get(spec.condition, 0) + 1
        traces.append(
            _trace(spec.condition, number, ds["time"].values, est, float(spec.speed or 0.0))
        )
    trials = pd.DataFrame([rows[i] for i in sorted(rows)], columns=TRIAL_COLUMNS)
    return ProcessedStudy(
        study=study,
        trials=trials,
        gravity=gravity,
        traces=pd.concat(traces, ignore_index=True)
        if traces
        else pd.DataFrame(columns=TRACE_COLUMNS),
        warnings=notes,
    )


def _row(
    study: Study,
    spec: TrialSpec,
    *,
    gravity: GravityFit | None = None,
    inertia: InertiaEstimate | None = None,
) -> dict:
    nan = math.nan
    row: dict[str, Any] = dict.fromkeys(TRIAL_COLUMNS, nan)
    row.update(
        file=_relative(spec.file, study.base_dir),
        condition=spec.condition,
        kind=spec.kind,
        speed=spec.speed if spec.speed is not None else nan,
    )
    if gravity is not None:
        row.update(
            gravity_moment=gravity.gravity_moment,
            gravity_moment_se=gravity.gravity_moment_se,
            gravity_phase=gravity.gravity_phase,
            offset=gravity.offset,
            residual_rms=gravity.residual_rms,
            n_window=gravity.n,
            flags="; ".join(gravity.flags),
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
            flags="; ".join(inertia.flags),
        )
    return row


def _check_phases(study: Study, gravity: dict[str, GravityFit], notes: list[str]) -> None:
    """Bodies mounted in line share the device's phase; a difference deserves a warning."""
    conds = list(gravity)
    for c in conds[1:]:
        diff = abs(gravity[c].gravity_phase - gravity[conds[0]].gravity_phase)
        if diff > PHASE_TOLERANCE:
            notes.append(
                f"{study.path}: the gravity phase of condition '{c}' differs from '{conds[0]}' "
                f"by {diff:.3f} rad; are the bodies mounted in line?"
            )
