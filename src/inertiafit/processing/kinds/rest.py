"""``kind = "rest"``: a living joint's quiet hold, a point of its static curve."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from inertiafit.processing.kinds.base import Stage, register_kind
from inertiafit.processing.plausibility import check_rest_hold
from inertiafit.processing.trials import static_record, trial_row

if TYPE_CHECKING:
    import xarray as xr

    from inertiafit.io import Study, TrialSpec

__all__ = ["Rest", "rest_row"]


def rest_row(study: Study, spec: TrialSpec, ds: xr.Dataset, *, reader: tuple[str, ...]) -> dict:
    """A rest trial's row: its mean torque (``offset``) and spread (``residual_rms``)."""
    row = trial_row(study, spec, reader=reader)
    torque = ds["torque"].values
    row.update(offset=float(np.mean(torque)), residual_rms=float(np.std(torque)))
    return row


class Rest:
    """A hold that must not move (:func:`check_rest_hold`), checked for EMG like a sweep."""

    name = "rest"

    def read(self, stage: Stage, spec: TrialSpec, ds: xr.Dataset) -> None:
        """Its row and its record for the living joint's static fit."""
        run, emg, study = stage.run, stage.emg, stage.study
        if run.attempt(spec, functools.partial(check_rest_hold, ds)) is None:
            return
        held: xr.Dataset = ds
        rest_flag: tuple[str, ...] = ()
        if emg is not None and "emg" in ds:  # checked like a sweep: a hold can contract
            checked = run.attempt(spec, functools.partial(emg.sweep, spec, ds))
            if checked is None:
                return
            held, rest_flag, rest_check = checked
            emg.stop(spec, rest_check)
            if held.sizes["time"] < 2:  # active throughout: nothing of it is used
                row = rest_row(study, spec, ds, reader=run.reader_flags(spec))
                run.exclude(spec, row, rest_check.describe())
                return
        row = rest_row(study, spec, held, reader=run.reader_flags(spec))
        row["flags"] = "; ".join(filter(None, [*rest_flag, row["flags"]]))
        stage.notes.extend(f"{spec.file}: {flag}" for flag in rest_flag)
        stage.records.append(static_record(spec, held, study.base_dir))
        stage.rows[spec.index] = row

    def after_gravity(self, stage: Stage, trials: list[tuple[TrialSpec, xr.Dataset]]) -> None:
        """Nothing: the static fit took the hold's record."""


register_kind(Rest())
