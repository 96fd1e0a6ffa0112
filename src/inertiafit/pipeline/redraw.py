"""``inertiafit report``: redraw every table, figure and ``report.html`` of an output folder.

:func:`load_result` rebuilds the :class:`~inertiafit.report.result.Result` from the files saved
when the posterior was sampled — ``posterior.nc``, ``trials.csv`` and ``traces.csv`` (the
filtered fast trials) — and never from the raw trial files, which may have moved or changed.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from inertiafit._checks import check_probability
from inertiafit.errors import InputError
from inertiafit.inference.priors import Prior, priors_from_posterior
from inertiafit.io.outputs import check_as_written, replace_files
from inertiafit.pipeline.fit import fit_result
from inertiafit.plotting.style import DEFAULT_FORMATS, check_formats
from inertiafit.posterior import Posterior, open_posterior
from inertiafit.processing.living import living_tables_from_tree
from inertiafit.processing.speed import speed_effect
from inertiafit.processing.study import (
    EMG_TRACE_COLUMNS,
    SWEEP_COLUMNS,
    TRACE_COLUMNS,
    TRIAL_COLUMNS,
    usable_trials,
)
from inertiafit.report.comparison import paper_baselines
from inertiafit.report.outputs import DATA_FILES, write_outputs
from inertiafit.report.result import Result, make_result

__all__ = ["LATER_TRACE_COLUMNS", "LATER_TRIAL_COLUMNS", "load_result", "redraw"]


#: Columns added to ``trials.csv`` later, with the value of a table written before them.
LATER_TRIAL_COLUMNS: dict[str, object] = {"status": "ok", "lag": math.nan, "lag_se": math.nan}
#: Columns added to ``traces.csv`` later: a table written before them draws no tau-alpha fits.
LATER_TRACE_COLUMNS: dict[str, object] = {"inertial_torque": math.nan}


def _read_table(
    path: Path,
    columns: list[str],
    dtypes: Mapping[str, type],
    later: Mapping[str, object] | None = None,
) -> pd.DataFrame:
    """A table inertiafit wrote (``trials.csv``, ``traces.csv``), or an empty one.

    ``later`` columns may be missing (a file written before they existed): they are added
    with the value given.
    """
    if not path.is_file():
        return pd.DataFrame(columns=columns)
    try:
        table = pd.read_csv(path, dtype=dtypes)
    except (ValueError, pd.errors.ParserError) as exc:
        raise InputError(f"{path}: not a table written by inertiafit ({exc})") from None
    for column, value in (later or {}).items():
        if column not in table.columns:
            table[column] = value
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise InputError(
            f"{path}: column '{missing[0]}' missing; not a {path.name} written by inertiafit"
        )
    for column in (c for c in columns if c not in dtypes):  # the others hold numbers
        values = pd.to_numeric(table[column], errors="coerce")
        bad = values.isna() & table[column].notna()
        if bad.any():
            row = int(bad.to_numpy().argmax())
            raise InputError(
                f"{path}: line {row + 2}, column '{column}': {table[column].iloc[row]!r} is not a "
                f"number; not a {path.name} as inertiafit wrote it"
            )
        table[column] = values
    return table


def load_result(folder: str | Path, *, hdi_prob: float = 0.95) -> Result:
    """Rebuild a :class:`~inertiafit.report.result.Result` from an output folder.

    Nothing is sampled and the raw trial files are not read.
    Needs ``posterior.nc``; ``trials.csv`` for the trial tables and ``traces.csv`` for the
    fast-trial figures (a folder of ``inertiafit fit`` has neither).
    """
    check_probability(hdi_prob, "hdi_prob")
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such output folder")
    post = open_posterior(folder / "posterior.nc")
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    priors = priors_from_posterior(post)
    gravity = float(post.tree["constant_data"]["gravity"])
    conditions = {k: tuple(v) for k, v in inputs.get("conditions", {}).items()}
    if not conditions:  # one body fitted from numbers
        return _fit_result(post, priors[post.bodies[0]], inputs, gravity, hdi_prob)
    text = {
        "flags": str,
        "file": str,
        "condition": str,
        "kind": str,
        "status": str,
        "posture": str,
    }
    trials = _read_table(folder / "trials.csv", TRIAL_COLUMNS, text, LATER_TRIAL_COLUMNS)
    trials["flags"] = trials["flags"].fillna("").astype(str)
    used = usable_trials(trials)
    traces = _read_table(
        folder / "traces.csv", TRACE_COLUMNS, {"condition": str}, LATER_TRACE_COLUMNS
    )
    emg_traces = _read_table(
        folder / "emg_traces.csv",
        EMG_TRACE_COLUMNS,
        {"condition": str, "trial": str, "muscle": str, "status": str},
    )
    sweeps = _read_table(folder / "sweeps.csv", SWEEP_COLUMNS, {"condition": str, "file": str})
    check_as_written(folder, DATA_FILES)
    warnings = list(inputs.get("warnings", []))
    baselines = paper_baselines(trials, conditions, priors, gravity=gravity, notes=warnings)
    return make_result(
        name=inputs.get("name", post.bodies[0]),
        posterior=post,
        priors=priors,
        gravity=gravity,
        hdi_prob=hdi_prob,
        trials=trials,
        speed_effect=speed_effect(used[used["kind"] == "fast"]),
        traces=traces,
        conditions=conditions,
        ideals=inputs.get("ideals", {}),
        baselines=baselines,
        warnings=warnings,
        manifest=inputs.get("manifest", ""),
        living=living_tables_from_tree(post.tree),
        emg_traces=emg_traces,
        sweeps=sweeps,
    )


def _fit_result(
    post: Posterior, prior: Prior, inputs: dict, gravity: float, hdi_prob: float
) -> Result:
    try:
        i = float(inputs["inertia"]["center"])
        g = float(inputs["gravity_moment"]["center"])
    except (KeyError, TypeError, ValueError):
        i = g = math.nan
    return fit_result(
        post,
        prior,
        inertia=i,
        gravity_moment=g,
        gravity=gravity,
        hdi_prob=hdi_prob,
        require_baseline=False,
    )


def redraw(
    folder: str | Path,
    *,
    formats: tuple[str, ...] | list[str] = DEFAULT_FORMATS,
    hdi_prob: float = 0.95,
    echo: Callable[[str], None] = print,
) -> Result:
    """``inertiafit report``: redraw tables, figures and ``report.html`` in place.

    Everything is drawn into a temporary folder first, and ``folder`` is replaced by a copy
    holding the new files only when all of it succeeded
    (:func:`~inertiafit.io.outputs.replace_files`): a failure half-way leaves the old complete
    set. :data:`~inertiafit.report.outputs.DATA_FILES` are read, never rewritten.
    """
    fmts = check_formats(formats)
    folder = Path(folder)
    with replace_files(folder) as tmp:
        result = load_result(folder, hdi_prob=hdi_prob)
        written = write_outputs(tmp, result, hdi_prob=hdi_prob, formats=fmts, save_data=False)
    echo(
        f"redrew {len(written)} files in {folder}: report.html and "
        + ", ".join(n for n in written if n != "report.html" and n not in DATA_FILES)
    )
    return result
