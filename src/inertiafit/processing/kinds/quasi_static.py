"""``kind = "quasi-static"``: a slow sweep, the gravity model of its condition (or its part)."""

from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING

from inertiafit.processing.gravity import fit_gravity
from inertiafit.processing.kinds.base import Stage, register_kind
from inertiafit.processing.plausibility import check_quasi_static_sweep
from inertiafit.processing.trials import (
    LIVING_ROW_FLAG,
    relative_file,
    static_record,
    sweep_trace,
    trial_row,
)

if TYPE_CHECKING:
    import xarray as xr

    from inertiafit.io import TrialSpec

__all__ = ["QuasiStatic"]


class QuasiStatic:
    """A sweep's gravity fit, checked; where it goes depends on what the condition holds.

    A rigid condition's sweep in the posture of its fast trials joins the condition's gravity
    model; one in another posture measures that posture's rotation; a living condition's is
    a record for the joint fit of gravity and the passive curve (its row keeps the rigid fit
    of the sweep alone, the paper's method, flagged as such).
    """

    name = "quasi-static"

    def read(self, stage: Stage, spec: TrialSpec, ds: xr.Dataset) -> None:
        """The sweep's fit, its row, and its place in the study."""
        run, emg, study = stage.run, stage.emg, stage.study
        emg_flag: tuple[str, ...] = ()
        if emg is not None and "emg" in ds:
            checked = run.attempt(spec, functools.partial(emg.sweep, spec, ds))
            if checked is None:
                return
            fitted, emg_flag, sweep_check = checked
            emg.stop(spec, sweep_check)  # refuses the study, whatever on_trial_error says
        else:
            fitted = ds
        fit = run.attempt(spec, functools.partial(fit_gravity, fitted))
        if fit is None:
            return
        living = spec.condition in stage.living  # a living sweep's M_g: the joint fit's
        if not living:
            # its values go into a refused study's table (a skipped trial has its own row)
            stage.rows[spec.index] = trial_row(
                study, spec, gravity=fit, reader=run.reader_flags(spec)
            )
            if run.attempt(spec, functools.partial(check_quasi_static_sweep, fit)) is None:
                del stage.rows[spec.index]
                return
        else:
            # the rigid fit of one sweep absorbs the passive curve: its drift and friction
            # flags describe that curve, and its M_g is the rigid model's (the paper's)
            kept = [f for f in fit.flags if f.startswith(("not quasi-static", "small angle"))]
            fit = dataclasses.replace(fit, flags=(*kept, LIVING_ROW_FLAG))
        if emg_flag:
            fit = dataclasses.replace(fit, flags=(*fit.flags, *emg_flag))
        stage.notes.extend(
            f"{fit.source}: {flag}" for flag in fit.flags if flag != LIVING_ROW_FLAG
        )
        if not living and spec.posture != stage.homes[spec.condition]:
            # a rigid sweep away from the condition's fast trials: it measures the posture's
            # gravity rotation (its phase), not the condition's M_g
            by_posture = stage.rotation_fits.setdefault(spec.condition, {})
            by_posture.setdefault(spec.posture, []).append(fit)
        else:
            stage.qs_fits.setdefault(spec.condition, []).append(fit)
        stage.rows[spec.index] = trial_row(study, spec, gravity=fit, reader=run.reader_flags(spec))
        if living:
            stage.records.append(static_record(spec, fitted, study.base_dir))
        else:  # its samples beside its fit: the figure of the gravity fit and its residuals
            file = relative_file(spec.file, study.base_dir)
            angle, torque = fitted["angle"].values, fitted["torque"].values
            stage.sweeps.append(sweep_trace(spec.condition, file, angle, torque))

    def after_gravity(self, stage: Stage, trials: list[tuple[TrialSpec, xr.Dataset]]) -> None:
        """Nothing: the study combines the sweeps' fits into its gravity models."""


register_kind(QuasiStatic())
