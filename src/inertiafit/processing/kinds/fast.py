"""``kind = "fast"``: a passive move at speed, the inertia of its condition."""

from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING

from inertiafit.errors import InputError
from inertiafit.processing.inertia import InertiaEstimate, estimate_inertia
from inertiafit.processing.kinds.base import Stage, register_kind
from inertiafit.processing.plausibility import (
    SignVerdict,
    cruise_slope,
    fast_trial_flags,
    gravity_scale_flag,
    inertia_sign_checks,
)
from inertiafit.processing.trials import fast_trace, move_direction, trial_row

if TYPE_CHECKING:
    import xarray as xr

    from inertiafit.io import Study, TrialSpec
    from inertiafit.processing.gravity import GravityFit
    from inertiafit.processing.living import StaticCurve

__all__ = ["Fast"]


def _refuse(message: str) -> None:
    raise InputError(message)


def _sign_verdicts(
    study: Study,
    estimated: list[tuple[TrialSpec, xr.Dataset, InertiaEstimate]],
    gravity: dict[str, GravityFit],
) -> dict[int, SignVerdict]:
    """The negative inertias judged per condition (:func:`inertia_sign_checks`), by index."""
    out: dict[int, SignVerdict] = {}
    for cond in study.conditions:
        group = [(spec, ds, est) for spec, ds, est in estimated if spec.condition == cond]
        if not any(est.inertia < 0 for _, _, est in group):
            continue
        entries = [
            (spec.torque_sign, est, cruise_slope(ds, est, gravity[cond]))
            for spec, ds, est in group
        ]
        checked = inertia_sign_checks(entries, cond)
        for (spec, _, _), verdict in zip(group, checked, strict=True):
            if verdict is not None:
                out[spec.index] = verdict
    return out


class Fast:
    """Each trial's inertia over its acceleration window, less its condition's static moment.

    A rigid condition's gravity model, or a living one's static curve (gravity, the passive
    moment and the hysteresis, at the trial's posture and direction). A negative inertia is
    judged with the condition's other fast trials (:func:`inertia_sign_checks`); then each
    trial's plausibility flags and, with EMG, its activity check.
    """

    name = "fast"

    def read(self, stage: Stage, spec: TrialSpec, ds: xr.Dataset) -> None:
        """Nothing yet: a fast trial needs its condition's gravity model."""

    def after_gravity(self, stage: Stage, trials: list[tuple[TrialSpec, xr.Dataset]]) -> None:
        """Every fast trial's inertia, its row, its trace; refusals as the manifest says."""
        study, run, emg, rows = stage.study, stage.run, stage.emg, stage.rows
        gravity, statics = stage.gravity, stage.statics
        stage.say("estimating the inertia of each fast trial")
        count: dict[str, int] = {}
        used_fast: dict[str, list[InertiaEstimate]] = {}
        estimated: list[tuple[TrialSpec, xr.Dataset, InertiaEstimate]] = []
        for spec, ds in trials:
            subtracted: GravityFit | StaticCurve = gravity[spec.condition]
            if statics is not None and spec.condition in stage.living:
                subtracted = statics.curve(spec.condition, spec.posture, move_direction(ds))
            est = run.attempt(
                spec,
                functools.partial(
                    estimate_inertia,
                    ds,
                    subtracted,
                    window=spec.window,
                    speed_deg_s=spec.speed,
                    cutoff=stage.cutoff,
                    order=stage.order,
                    lag=spec.lag,
                    lag_bounds=study.calibration.lag_bounds,
                    refuse_negative=False,  # judged with the condition's other fast trials
                ),
            )
            if est is not None:
                estimated.append((spec, ds, est))
        for spec, _, est in estimated:  # in a refused study's table until they are judged
            rows[spec.index] = trial_row(study, spec, inertia=est, reader=run.reader_flags(spec))
        verdicts = _sign_verdicts(study, estimated, gravity)
        errors = [
            (spec, verdicts[spec.index].error)
            for spec, _, _ in estimated
            if spec.index in verdicts and verdicts[spec.index].error
        ]
        if errors and not run.skip:  # every negative trial marked in the refused study's table
            for spec, message in errors:
                run.refuse(spec, message)
            raise InputError(errors[0][1])
        for spec, ds, first in estimated:
            verdict = verdicts.get(spec.index)
            est = first
            if verdict is not None and verdict.error:
                run.attempt(spec, functools.partial(_refuse, verdict.error))  # raises, or skips
                del rows[spec.index]
                continue
            if verdict is not None and verdict.flag:
                est = dataclasses.replace(est, flags=(verdict.flag, *est.flags))
            more = run.attempt(
                spec,
                functools.partial(
                    fast_trial_flags,
                    ds,
                    est,
                    gravity[spec.condition],
                    speed_deg_s=spec.speed,
                    window=spec.window,
                    lag_bounds=study.calibration.lag_bounds,
                ),
            )
            if more is None:
                del rows[spec.index]
                continue
            if spec.condition not in stage.living:  # a living cruise holds the passive curve
                scale = gravity_scale_flag(cruise_slope(ds, est, gravity[spec.condition]))
                more = [*more, scale] if scale else more
            if emg is not None and "emg" in ds:
                activity = run.attempt(spec, functools.partial(emg.fast, spec, ds, est))
                if activity is None:
                    del rows[spec.index]
                    continue
                emg.stop(spec, activity)
                if activity.active and emg.action == "exclude":
                    est = dataclasses.replace(est, flags=(*est.flags, *more))
                    row = trial_row(study, spec, inertia=est, reader=run.reader_flags(spec))
                    if spec.condition in stage.living:
                        row.update(damping=est.damping, damping_se=est.damping_se)
                    del rows[spec.index]
                    run.exclude(spec, row, activity.describe())
                    continue
                if activity.active:
                    more = [*more, activity.describe()]
            if more:
                est = dataclasses.replace(est, flags=(*est.flags, *more))
            stage.notes.extend(f"{est.source}: {flag}" for flag in est.flags)
            used_fast.setdefault(spec.condition, []).append(est)
            stage.fast_estimates.append((spec, est))
            rows[spec.index] = trial_row(study, spec, inertia=est, reader=run.reader_flags(spec))
            number = count[spec.condition] = count.get(spec.condition, 0) + 1
            stage.traces.append(
                fast_trace(
                    spec.condition, number, ds["time"].values, est, float(spec.speed or 0.0)
                )
            )
        run.check_left(used_fast, "fast")
        if emg is not None:
            stage.notes.extend(emg.summary(run.skipped))


register_kind(Fast())
