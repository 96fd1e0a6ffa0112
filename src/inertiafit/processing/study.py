"""Every trial of a study processed: gravity model per condition, inertia per fast trial.

:func:`process_study` reads a manifest's trials (through :mod:`inertiafit.io`), fits the gravity
model of each condition from its quasi-static trials and estimates the inertia of every fast
trial. The per-trial values it returns (:class:`ProcessedStudy`) are what
:mod:`inertiafit.inference.evidence` turns into the evidence of each condition.

A trial that cannot be read or processed stops the study, or, with the manifest's
``on_trial_error = "skip"``, is skipped: it keeps a row (``status`` ``"skipped"``, the reason
in ``flags``) and a line in the warnings, and nothing of it reaches the evidence.

Trials read with EMG channels are checked for muscle activity
(:mod:`inertiafit.processing.activity`; the ``[emg]`` table's ``on_activity``): an active fast
trial is excluded (``status`` ``"excluded"``, its values and the muscle, times and ratio in
``flags``; nothing of it reaches the evidence), flagged, or stops the study; a quasi-static
sweep's active stretches are cut out of its fit. ``trials.csv`` then gains ``emg_peak_ratio``.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from inertiafit.errors import InputError, StudyRefused
from inertiafit.io import Study, TrialSpec, load_study
from inertiafit.io.manifest import file_sha256
from inertiafit.processing.gravity import GravityFit, pooled_noise
from inertiafit.processing.inertia import InertiaEstimate
from inertiafit.processing.kinds import KINDS, Stage
from inertiafit.processing.lag import lag_consistency_flags
from inertiafit.processing.living import (
    SMOOTH_AMPLITUDES,
    SMOOTH_EDGE_WEIGHT,
    LivingStatics,
    PostureGeometry,
    fit_statics,
    passive_basis,
    posture_geometry,
)
from inertiafit.processing.plausibility import (
    gravity_scatter_message,
)
from inertiafit.processing.trials import (
    DIAGNOSTIC_COLUMN,
    EMG_TRACE_COLUMNS,
    EMG_TRIAL_COLUMNS,
    LIVING_ROW_FLAG,
    LIVING_TRIAL_COLUMNS,
    STATUS_NOT_REACHED,
    STATUS_OK,
    STATUS_REFUSED,
    SWEEP_COLUMNS,
    TRACE_COLUMNS,
    TRIAL_COLUMNS,
    EmgCheck,
    TrialRun,
    relative_file,
    sweeps_frame,
    traces_frame,
    trial_row,
)
from inertiafit.stats import inverse_variance_mean

__all__ = [
    "DIAGNOSTIC_COLUMN",
    "EMG_TRACE_COLUMNS",
    "EMG_TRIAL_COLUMNS",
    "LIVING_ROW_FLAG",
    "LIVING_TRIAL_COLUMNS",
    "PHASE_TOLERANCE",
    "RATE_TOLERANCE",
    "SENSITIVITY_COLUMNS",
    "SWEEP_COLUMNS",
    "TRACE_COLUMNS",
    "TRIAL_COLUMNS",
    "ProcessedStudy",
    "combine_gravity",
    "condition_gravity",
    "diagnostics_table",
    "process_study",
    "usable_trials",
]

#: Columns of :attr:`ProcessedStudy.sensitivity`: ``dI/dA``, ``dI/dB``, ``dI/dC`` of each fast
#: trial for the gravity model ``A sin(theta) + B cos(theta) + C`` (kg m^2 per N m).
SENSITIVITY_COLUMNS = ["sin", "cos", "offset"]
#: Relative difference of sampling rates tolerated within one study.
RATE_TOLERANCE = 0.01
#: Phase difference between conditions (rad) beyond which bodies are not mounted in line.
PHASE_TOLERANCE = 0.05


@dataclass
class ProcessedStudy:
    """Per-trial results of a study.

    Attributes
    ----------
    study : Study
        The manifest.
    trials : pandas.DataFrame
        A row per trial used, in manifest order, columns :data:`TRIAL_COLUMNS` (SI units;
        ``speed`` in deg/s; ``status`` ``"ok"``): what the evidence is made of.
    gravity : dict of str to GravityFit
        The gravity model of each condition (combined over its quasi-static trials).
    traces : pandas.DataFrame
        Filtered velocity and acceleration of the fast trials' moving parts, columns
        :data:`TRACE_COLUMNS` (every move plotted as positive), for figures.
    warnings : list of str
        Flags worth a look and skipped trials: one line each, naming the file.
    skipped : pandas.DataFrame
        A row per trial left out, columns :data:`TRIAL_COLUMNS` (and, with EMG, those of
        ``trials``): skipped (``on_trial_error = "skip"``; ``status`` ``"skipped"``, the reason
        in ``flags``, no values), excluded for muscle activity (``status`` ``"excluded"``,
        the muscle, times and ratio in ``flags``, its values kept for the record), or an
        MVC trial (``kind`` ``"mvc"``, ``status`` ``"reference"``: its muscles' MVC levels
        in ``flags``, never evidence).
    provenance : list of dict
        Per trial in manifest order: ``file`` (relative to the manifest), ``path``,
        ``sha256`` (of the file as read; ``None`` if it could not be read), ``condition``,
        ``kind``, ``status``, ``reader`` (:meth:`~inertiafit.io.TrialSpec.reader_settings`)
        and, once read, ``sampling_rate`` (Hz; the Methods text reports it).
    sensitivity : pandas.DataFrame
        A row per fast trial used, indexed by ``file`` (as in ``trials``), columns
        :data:`SENSITIVITY_COLUMNS`: the trial's
        :attr:`~inertiafit.processing.inertia.InertiaEstimate.gravity_sensitivity`, the
        derivative of its inertia with respect to the condition's gravity model
        (not written to ``trials.csv``). Rigid conditions only.
    living : LivingStatics or None
        A living body's joint fit of gravity and the passive curve
        (:func:`~inertiafit.processing.living.fit_statics`); ``None`` for a rigid study.
    living_coupling : dict of str to (float, float)
        Per living condition, the static curve's error in its mean inertia, ``(coupling,
        shared_sd)`` (:meth:`~inertiafit.processing.living.LivingStatics.inertia_coupling`).
    damping : (float, float) or None
        The living joint's viscous damping ``b`` (N m s/rad) and its SE: the
        inverse-variance mean over the living conditions' fast trials.
    emg_traces : pandas.DataFrame
        The fast trials' EMG envelopes over their rest levels, columns
        :data:`EMG_TRACE_COLUMNS`, for figures; empty without EMG.
    sweeps : pandas.DataFrame
        The rigid conditions' quasi-static sweeps as fitted, columns :data:`SWEEP_COLUMNS`
        (means of consecutive samples), for the figure of the gravity fit.
    """

    study: Study
    trials: pd.DataFrame
    gravity: dict[str, GravityFit]
    traces: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=TRACE_COLUMNS))
    warnings: list[str] = field(default_factory=list)
    skipped: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=TRIAL_COLUMNS))
    provenance: list[dict[str, Any]] = field(default_factory=list)
    sensitivity: pd.DataFrame = field(default_factory=lambda: _sensitivity_frame({}))
    living: LivingStatics | None = None
    living_coupling: dict[str, tuple[float, float]] = field(default_factory=dict)
    damping: tuple[float, float] | None = None
    emg_traces: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=EMG_TRACE_COLUMNS)
    )
    sweeps: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=SWEEP_COLUMNS))

    @property
    def all_trials(self) -> pd.DataFrame:
        """Every trial of the manifest, used and skipped, in manifest order (``trials.csv``)."""
        if self.skipped.empty:
            return self.trials
        order = {relative_file(t.file, self.study.base_dir): t.index for t in self.study.trials}
        both = pd.concat([self.trials, self.skipped], ignore_index=True)
        return both.sort_values("file", key=lambda f: f.map(order), kind="stable").reset_index(
            drop=True
        )

    def diagnostics(self, refused: dict[str, str] | None = None) -> pd.DataFrame:
        """The per-trial table of a refused study (:func:`diagnostics_table`)."""
        return diagnostics_table(self.study, self.all_trials, refused or {})


def diagnostics_table(
    study: Study, gathered: pd.DataFrame, refused: dict[str, str]
) -> pd.DataFrame:
    """The per-trial table of a refused study: ``diagnostics.csv``.

    Parameters
    ----------
    study : Study
        The manifest: the table has a row per trial of it, in its order.
    gathered : pandas.DataFrame
        The rows gathered so far (columns of ``trials.csv``, indexed by nothing in particular);
        a trial without a row gets one without values, ``status`` ``"not reached"``.
    refused : dict of str to str
        The trials that caused the refusal, by ``file``: their ``status`` becomes
        ``"refused"`` and the reason goes into the column ``cause`` (empty for the others).
    """
    columns = [*TRIAL_COLUMNS, *(c for c in gathered.columns if c not in TRIAL_COLUMNS)]
    have = {str(r["file"]): r for r in gathered.to_dict(orient="records")}
    rows = []
    for spec in study.trials:
        name = relative_file(spec.file, study.base_dir)
        row = dict(have.get(name) or {**trial_row(study, spec), "status": STATUS_NOT_REACHED})
        cause = refused.get(name, "")
        if cause:
            row["status"] = STATUS_REFUSED
        row[DIAGNOSTIC_COLUMN] = cause
        rows.append(row)
    return pd.DataFrame(rows, columns=[*columns, DIAGNOSTIC_COLUMN])


def _sensitivity_frame(rows: dict[str, tuple[float, ...]]) -> pd.DataFrame:
    frame = pd.DataFrame.from_dict(rows, orient="index", columns=SENSITIVITY_COLUMNS)
    frame.index.name = "file"
    return frame.astype(float)


def usable_trials(trials: pd.DataFrame) -> pd.DataFrame:
    """The rows of a trial table whose values were used (``status`` ``"ok"``).

    A table without a ``status`` column (a ``trials.csv`` written before it existed) is
    used whole.
    """
    if "status" not in trials.columns:
        return trials
    return trials[trials["status"].fillna(STATUS_OK) == STATUS_OK]


def combine_gravity(fits: list[GravityFit], where: str) -> GravityFit:
    """One gravity model from several quasi-static fits: the inverse-covariance mean.

    The coefficients ``(A, B, C)`` of the fits (independent trials) are combined with weights
    their inverse covariances, ``Sigma = (sum Sigma_i^-1)^-1``, ``beta = Sigma sum Sigma_i^-1
    beta_i``; ``M_g``, ``phi``, the offset and their standard errors follow from ``beta`` and
    ``Sigma`` as for one fit. ``n`` and ``n_effective`` add up, ``se_dof`` too (the noise
    models are independent), ``residual_rms`` is the pooled one, ``angle_range`` the widest,
    ``median_speed`` the median of the fits' and the flags are all the fits' flags, the noise
    model the pooled one (:func:`pooled_noise`). A fit whose
    covariance is singular (an exact model) is used alone.
    """
    if len(fits) == 1:
        return fits[0]
    covs = [np.asarray(f.covariance, dtype=np.float64) for f in fits]
    if any(np.linalg.matrix_rank(c) < 3 for c in covs):
        exact = next(f for f, c in zip(fits, covs, strict=True) if np.linalg.matrix_rank(c) < 3)
        return dataclasses.replace(exact, source=where)
    precisions = [np.linalg.inv(c) for c in covs]
    cov = np.linalg.inv(sum(precisions))
    cov = 0.5 * (cov + cov.T)
    coef = cov @ sum(
        p @ np.asarray(f.coefficients, float) for p, f in zip(precisions, fits, strict=True)
    )
    a, b, c = (float(v) for v in coef)
    moment = math.hypot(a, b)
    g_m = np.array([a / moment, b / moment, 0.0])
    g_p = np.array([-b / moment**2, a / moment**2, 0.0])
    n = sum(f.n for f in fits)
    return dataclasses.replace(
        fits[0],
        gravity_moment=moment,
        gravity_moment_se=float(math.sqrt(g_m @ cov @ g_m)),
        gravity_phase=math.atan2(b, a),
        gravity_phase_se=float(math.sqrt(g_p @ cov @ g_p)),
        offset=c,
        offset_se=float(math.sqrt(cov[2, 2])),
        residual_rms=float(math.sqrt(sum(f.n * f.residual_rms**2 for f in fits) / n)),
        n=n,
        n_effective=float(sum(f.n_effective for f in fits)),
        angle_range=max(f.angle_range for f in fits),
        median_speed=float(np.median([f.median_speed for f in fits])),
        source=where,
        flags=tuple(dict.fromkeys(flag for f in fits for flag in f.flags)),
        coefficients=coef,
        covariance=cov,
        se_dof=float(sum(f.se_dof for f in fits)),
        noise=pooled_noise([f.noise for f in fits]),
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


def process_study(
    study: Study | str | Path,
    *,
    cutoff: float = 20.0,
    order: int = 2,
    echo: Callable[[str], None] | None = None,
    check_gravity: Callable[[pd.DataFrame, dict[str, GravityFit]], object] | None = None,
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
    check_gravity : callable, optional
        Called with the quasi-static rows (columns :data:`TRIAL_COLUMNS`) and each
        condition's gravity model once they are fitted, before any fast trial is processed;
        it may raise ``InputError`` (the pipeline's check of ``M_g`` against the priors).

    Returns
    -------
    ProcessedStudy

    Raises
    ------
    InputError
        On any unreadable trial, unusable window, negative inertia, or sampling rates that
        differ between trials; the message names the file. With the manifest's
        ``on_trial_error = "skip"`` such a trial is skipped instead (a row in
        :attr:`ProcessedStudy.skipped`, a line in the warnings), and the error is for a
        condition left without a usable quasi-static trial (no gravity model) or, when it
        has fast trials, without a usable fast one; it names the condition and the skipped
        files. With EMG: a muscle without a rest level, and, with ``[emg] on_activity =
        "stop"``, the first active trial (its muscle, times and peak ratio), whatever
        ``on_trial_error`` says; a condition whose fast trials were all excluded for muscle
        activity is one error naming them.

    Notes
    -----
    A reader's own flags (``trial.attrs["flags"]``, e.g. a velocity sign it corrected) join
    the trial's ``flags`` and the warnings. Every trial file is hashed (SHA-256) as it is
    read, for :attr:`ProcessedStudy.provenance`.

    The torque channel's lag is removed from every fast trial: fixed by the manifest
    (:attr:`~inertiafit.io.TrialSpec.lag`) or estimated within the manifest's
    ``[calibration] lag_bounds``. One recording chain has one lag, so an estimated lag that
    differs from the median of the study's estimated lags by more than
    ``max(max_lag_spread, 3 x lag_se)`` is flagged
    (:func:`~inertiafit.processing.lag.lag_consistency_flags`).
    """
    if not isinstance(study, Study):
        study = load_study(study)
    say = echo or (lambda _msg: None)
    run = TrialRun(study)
    try:
        return _process(study, run, cutoff=cutoff, order=order, say=say, check=check_gravity)
    except InputError as exc:  # the table gathered so far travels with the error
        gathered = [run.rows.get(t.index) or run.skipped.get(t.index) for t in study.trials]
        table = pd.DataFrame([r for r in gathered if r is not None], columns=TRIAL_COLUMNS)
        refused = {**run.failed, **getattr(exc, "refused", {})}
        raise StudyRefused(
            str(exc), refused=refused, table=diagnostics_table(study, table, refused)
        ) from exc


def _process(
    study: Study,
    run: TrialRun,
    *,
    cutoff: float,
    order: int,
    say: Callable[[str], None],
    check: Callable[[pd.DataFrame, dict[str, GravityFit]], object] | None,
) -> ProcessedStudy:
    """:func:`process_study`'s stages; ``run`` keeps what was gathered when one raises.

    Each trial goes to the handler of its kind (:data:`~inertiafit.processing.kinds.KINDS`):
    trial by trial before the gravity models, then each kind's trials together after them.
    """
    say(f"reading {len(study.trials)} trials")
    data = []
    for spec in study.trials:
        ds = run.attempt(spec, functools.partial(_read, spec, run))
        if ds is not None:
            data.append((spec, ds))
    data = _check_rates(data, run)
    rows = run.rows  # by manifest order
    notes = run.notes
    emg = EmgCheck.of(study, data, notes)
    say("fitting the gravity model of each condition (quasi-static trials)")
    living_conditions = _living_conditions(study)
    postures = _posture_geometry(study)
    stage = Stage(
        study,
        run,
        emg,
        living_conditions,
        _check_rigid_postures(study, living_conditions),
        cutoff,
        order,
        say,
    )
    for spec, ds in data:
        KINDS[spec.kind].read(stage, spec, ds)
    qs_fits, records, homes = stage.qs_fits, stage.records, stage.homes
    rotation_fits = stage.rotation_fits
    run.check_left(qs_fits, "quasi-static")
    _check_gravity_scatter(study, qs_fits, living_conditions)
    gravity = {
        cond: combine_gravity(fits, f"{study.path}: condition {cond}")
        for cond, fits in qs_fits.items()
        if cond not in living_conditions
    }
    statics = None
    if living_conditions:
        say("fitting gravity and the passive curve of the living body together")
        assert study.passive is not None
        postures = _measured_rotations(study, postures, gravity, homes, rotation_fits, notes)
        statics = fit_statics(
            records, postures, passive_basis(study.passive), where=f"{study.path}: [passive]"
        )
        if not statics.converged:
            notes.append(
                f"{study.path}: the joint fit of gravity and the passive curve did not settle "
                "(the postures' rotations or the trials' noise weights still moved after 30 "
                "iterations); its M_g is the last iteration's"
            )
        _apply_checks(study, statics, data, rows, notes)
        _check_rotations(study, statics, postures, notes)
        used = {spec.posture for spec, _ in data}
        notes.extend(
            f"{study.path}: postures.{name}: declared, but no trial is in it; its rotation is "
            "neither measured nor used (add its trials, or remove it)"
            for name in study.postures
            if name not in used
        )
        if statics.at_amplitude_edge() > SMOOTH_EDGE_WEIGHT:
            notes.append(
                f"{study.path}: the passive curve's smooth part took the largest amplitude its "
                f"prior allows ({max(SMOOTH_AMPLITUDES):g} N m) with weight "
                f"{statics.at_amplitude_edge():.2f}: the joint's curve is far from the prior "
                "file's; check joint_angle_at_zero, the joint and the torque's sign"
            )
        if not statics.gravity_identified:
            fast = any(s.kind == "fast" and s.condition in living_conditions for s, _ in data)
            inertia = "its I is measured" if fast else "without fast trials its I is not either"
            notes.append(
                f"{study.path}: one posture: the living body's M_g is not measured (a passive "
                "curve of any smooth shape can mimic gravity over one sweep), so its prior "
                f"decides it; {inertia}. A second posture >= 30 deg away or a "
                "horizontal-plane condition measures M_g"
            )
        if len(statics.conditions) > 1:
            notes.append(
                f"{study.path}: conditions {', '.join(statics.conditions)} hold the living body "
                "and share its passive curve; their gravity moments enter the posterior as "
                "independent evidence, so the correlation through the passive curve is dropped "
                "(intervals may be a little too narrow)"
            )
        for cond in statics.conditions:
            gravity[cond] = statics.gravity_fit(cond, source=f"{study.path}: condition {cond}")
            notes.extend(f"{study.path}: condition {cond}: {f}" for f in gravity[cond].flags)
        gravity = {c: gravity[c] for c in qs_fits}  # the manifest's order
    _check_phases(study, gravity, notes)
    if check is not None:
        check(pd.DataFrame([rows[i] for i in sorted(rows)], columns=TRIAL_COLUMNS), gravity)
    stage.gravity, stage.statics = gravity, statics
    for kind in KINDS.values():
        kind.after_gravity(stage, [(spec, ds) for spec, ds in data if spec.kind == kind.name])
    fast_estimates, traces = stage.fast_estimates, stage.traces
    _check_lags(study, fast_estimates, rows, notes)
    sensitivity = _sensitivity_frame(
        {
            rows[spec.index]["file"]: est.gravity_sensitivity
            for spec, est in fast_estimates
            if spec.index in rows and spec.condition not in living_conditions
        }
    )
    columns = TRIAL_COLUMNS
    left_columns = TRIAL_COLUMNS
    living_coupling: dict[str, tuple[float, float]] = {}
    damping = None
    if statics is not None:
        columns = [*TRIAL_COLUMNS, *LIVING_TRIAL_COLUMNS]
        for spec, _ in data:
            if spec.index in rows:
                rows[spec.index]["posture"] = spec.posture
            elif spec.index in run.skipped:
                run.skipped[spec.index]["posture"] = spec.posture
        living_fast = [(s_, e) for s_, e in fast_estimates if s_.condition in living_conditions]
        for spec, est in living_fast:
            rows[spec.index].update(damping=est.damping, damping_se=est.damping_se)
        for cond in statics.conditions:
            sens = [e.gravity_sensitivity for s_, e in living_fast if s_.condition == cond]
            if sens:
                living_coupling[cond] = statics.inertia_coupling(cond, np.array(sens))
        if living_fast:
            damping = statics.damping(
                [e.damping for _, e in living_fast],
                [e.damping_se for _, e in living_fast],
                [e.damping_sensitivity for _, e in living_fast],
            )
    if emg is not None:
        columns = left_columns = [*columns, *EMG_TRIAL_COLUMNS]
        for index, row in (*rows.items(), *run.skipped.items()):
            row["emg_peak_ratio"] = emg.peak.get(index, math.nan)
    trials = pd.DataFrame([rows[i] for i in sorted(rows)], columns=columns)
    return ProcessedStudy(
        study=study,
        trials=trials,
        gravity=gravity,
        traces=traces_frame(traces),
        warnings=list(dict.fromkeys(notes)),  # a reader flag a later step repeats: once
        skipped=pd.DataFrame([run.skipped[i] for i in sorted(run.skipped)], columns=left_columns),
        provenance=[run.provenance[t.index] for t in study.trials],
        sensitivity=sensitivity,
        living=statics,
        living_coupling=living_coupling,
        damping=damping,
        emg_traces=emg.traces() if emg is not None else pd.DataFrame(columns=EMG_TRACE_COLUMNS),
        sweeps=sweeps_frame(stage.sweeps),
    )


def _check_gravity_scatter(
    study: Study, fits: dict[str, list[GravityFit]], living: set[str]
) -> None:
    """Refuse a rigid condition whose quasi-static ``M_g`` disagree (naming every one)."""
    for cond, group in fits.items():
        message = None if cond in living else gravity_scatter_message(group, cond)
        if message is not None:
            files = {relative_file(Path(f.source), study.base_dir): message for f in group}
            raise StudyRefused(f"{study.path}: {message}", refused=files)


def _living_conditions(study: Study) -> set[str]:
    """The conditions that hold the study's living body (none for a rigid study)."""
    body = study.living_body
    return {c for c, m in study.mountings.items() if body and body in m.bodies}


def _posture_geometry(study: Study) -> dict[str, PostureGeometry]:
    """The manifest's postures in radians (one posture ``""`` when it names none)."""
    if not study.postures:
        return {"": PostureGeometry("")}
    return {name: posture_geometry(p) for name, p in study.postures.items()}


def _apply_checks(
    study: Study,
    statics: LivingStatics,
    data: list[tuple[TrialSpec, xr.Dataset]],
    rows: dict[int, dict],
    notes: list[str],
) -> None:
    """The joint fit's check of every sweep and hold: a flag on each that fails, a warning.

    With the prior file's fixed curve (``[passive] curve = "fixed"``) a failed check refuses
    the study: that curve's intervals would be narrow and wrong. With the smooth curve the
    study goes on with a warning (a trial left with structure weighs less in the fit through
    its residual's noise model, which widens the answer).
    """
    failed = []
    for spec, _ in data:
        check = statics.checks.get(relative_file(spec.file, study.base_dir))
        if check is None or not check.flagged or spec.index not in rows:
            continue
        row = rows[spec.index]
        row["flags"] = "; ".join(filter(None, [row["flags"], check.flag]))
        failed.append((spec, check))
    if not failed:
        return
    names = ", ".join(relative_file(spec.file, study.base_dir) for spec, _ in failed)
    worst = max(check.structure for _, check in failed)
    if not statics.basis.smooth:
        raise InputError(
            f'{study.path}: [passive] curve = "fixed": the prior file\'s passive curve leaves '
            f"structure of up to {worst:.3f} N m in {names} beyond their noise (the joint's curve "
            'is not of its shape); remove curve = "fixed" to let the data shape the curve'
        )
    notes.append(
        f"{study.path}: the fit of gravity and the passive curve leaves structure of up to "
        f"{worst:.3f} N m beyond the noise in {names} (a curve that differs between postures "
        "or sweeps: thixotropy, a contraction, drift); those trials weigh less in the fit, "
        "so check them before trusting the living body's M_g and I"
    )


#: A posture's fitted gravity rotation this many prior SDs from its declaration is warned of...
ROTATION_WARN_SD = 3.0
#: ... and this many refuses the study (a sign, a label or a protractor reading gone wrong).
ROTATION_REFUSE_SD = 6.0


def _check_rotations(
    study: Study,
    statics: LivingStatics,
    declared: dict[str, PostureGeometry],
    notes: list[str],
) -> None:
    """Each posture's fitted gravity rotation against its declaration (issue 36).

    The sweeps measure the rotation between postures; one far from what the manifest says
    (``[postures.<name>] gravity_rotation``) is a slip there — a sign, swapped labels, a
    reading — which a normal prior of 2 deg would otherwise pull the fit through, moving
    ``M_g``. Beyond :data:`ROTATION_WARN_SD` prior SDs a warning names the key; beyond
    :data:`ROTATION_REFUSE_SD` the study is refused.
    """
    names = list(statics.postures)
    if len(names) < 2:
        return
    ref = declared[names[0]]
    for name in names[1:]:
        sd = declared[name].relative_sd(ref)
        if not math.isfinite(sd):
            continue
        fitted = statics.postures[name].rotation
        off = (fitted - declared[name].rotation) / sd
        if abs(off) <= ROTATION_WARN_SD:
            continue
        said = (
            f"{study.path}: postures.{name}.gravity_rotation: declared "
            f"{math.degrees(declared[name].rotation):g} deg, the sweeps put it at "
            f"{math.degrees(fitted):.1f} deg ({abs(off):.1f} prior SDs away, against "
            f"postures.{names[0]}); check its value, its sign and the trials' posture labels"
        )
        if abs(off) > ROTATION_REFUSE_SD:
            raise InputError(f'{said} (or give gravity_rotation_sd = "free" to fit it)')
        notes.append(said)


def _check_rigid_postures(study: Study, living: set[str]) -> dict[str, str]:
    """Each rigid condition's home posture: that of its fast trials, its M_g's frame.

    Its fast trials share one posture, the axis horizontal there; its quasi-static trials
    may be in others too (axis horizontal), where they measure that posture's gravity
    rotation (:func:`_measured_rotations`) and do not enter its ``M_g``. A tilted axis scales
    ``M_g`` (not modelled for rigid conditions in this version).
    """
    homes = {}
    for cond in study.conditions:
        if cond in living:
            continue
        trials = [t for t in study.trials if t.condition == cond]
        fast = {t.posture for t in trials if t.kind == "fast"}
        if len(fast) > 1:
            raise InputError(
                f"{study.path}: condition {cond}: fast trials in postures {sorted(fast)}; a "
                "rigid condition's fast trials share one posture (its quasi-static trials may "
                "be in others, to measure their gravity rotation)"
            )
        home = next(iter(fast)) if fast else trials[0].posture
        for name in {t.posture for t in trials}:
            if name and study.postures[name].axis_tilt != 0:
                raise InputError(
                    f"{study.path}: condition {cond}: posture '{name}' tilts the axis "
                    f"({study.postures[name].axis_tilt:g} deg); a rigid condition is measured "
                    "with the axis horizontal (axis_tilt = 0)"
                )
        if not any(t.posture == home and t.kind == "quasi-static" for t in trials):
            raise InputError(
                f"{study.path}: condition {cond}: no quasi-static trial in posture '{home}', "
                "where its fast trials are; its gravity model is fitted there"
            )
        homes[cond] = home
    return homes


def _measured_rotations(
    study: Study,
    postures: dict[str, PostureGeometry],
    gravity: dict[str, GravityFit],
    homes: dict[str, str],
    rotation_fits: dict[str, dict[str, list[GravityFit]]],
    notes: list[str],
) -> dict[str, PostureGeometry]:
    """The postures' gravity rotations that rigid sweeps measured (issue 32, item 2).

    A rigid condition swept in its home posture and in another measures the rotation
    between them: the difference of its gravity phases there, to a fraction of a degree,
    where a protractor gives 2 deg. Such a rotation replaces the declared one for the living
    fit (:attr:`PostureGeometry.measured_sd`, relative to the reference posture, the first);
    one far from the declaration is said (the manifest's ``gravity_rotation`` to check).
    """
    names = list(postures)
    if not rotation_fits or len(names) < 2:
        return postures
    phases: dict[str, dict[str, GravityFit]] = {}
    for cond, by_posture in rotation_fits.items():
        if cond not in gravity:  # its home sweeps were all skipped: no reference phase
            continue
        phases[cond] = {homes[cond]: gravity[cond]}
        for name, fits in by_posture.items():
            phases[cond][name] = combine_gravity(fits, f"{study.path}: condition {cond}")
    reference = names[0]
    out = dict(postures)
    for name in names[1:]:
        found = [(p[name], p[reference]) for p in phases.values() if name in p and reference in p]
        if not found:
            continue
        # the most precise of the rigid conditions that swept both
        there, here = min(
            found, key=lambda f: math.hypot(f[0].gravity_phase_se, f[1].gravity_phase_se)
        )
        delta = math.remainder(there.gravity_phase - here.gravity_phase, 2 * math.pi)
        se = math.hypot(there.gravity_phase_se, here.gravity_phase_se)
        declared = postures[name].rotation - postures[reference].rotation
        sd = math.hypot(postures[name].rotation_sd, postures[reference].rotation_sd)
        off = math.remainder(delta - declared, 2 * math.pi)
        if math.isfinite(sd) and abs(off) > ROTATION_WARN_SD * math.hypot(sd, se):
            notes.append(
                f"{study.path}: postures.{name}.gravity_rotation: declared "
                f"{math.degrees(declared):g} deg from postures.{reference}, a rigid sweep "
                f"measures {math.degrees(delta):.1f} ± {math.degrees(se):.1f} deg; the "
                "measured rotation is used (check the declared value, its sign and the "
                "trials' posture labels)"
            )
        out[name] = dataclasses.replace(
            postures[name],
            rotation=postures[reference].rotation + delta,
            measured_sd=max(se, 1e-6),
        )
    return out


def _read(spec: TrialSpec, run: TrialRun) -> xr.Dataset:
    """Hash and read one trial; its reader flags go to the warnings.

    A file whose content is that of a trial read before (a copy, a hard link) is refused:
    one recording counted twice would narrow the intervals as if it were two.
    """
    digest = file_sha256(spec.file)
    run.provenance[spec.index]["sha256"] = digest
    first = run.contents.setdefault(digest, spec)
    if first is not spec:
        raise InputError(
            f"{spec.file}: the same recording as {relative_file(first.file, run.study.base_dir)} "
            f"(identical content, SHA-256 {digest[:12]}...); list each recording once"
        )
    ds = spec.read()
    # the same samples saved again (other line ends, another delimiter or format): one
    # recording all the same (issue 36: a CRLF copy counted twice)
    samples = hashlib.sha256()
    for name in ("angle", "torque"):
        samples.update(np.ascontiguousarray(ds[name].values, dtype=np.float64).tobytes())
    same = run.contents.setdefault(f"samples:{samples.hexdigest()}", spec)
    if same is not spec:
        raise InputError(
            f"{spec.file}: the same recording as {relative_file(same.file, run.study.base_dir)} "
            "(the same angle and torque samples, saved differently); list each recording once"
        )
    run.provenance[spec.index]["sampling_rate"] = float(ds.attrs["sampling_rate"])
    flags = tuple(str(f) for f in (ds.attrs.get("flags", ()) or ()))
    if isinstance(ds.attrs.get("flags"), str):  # one flag stored as a string
        flags = (ds.attrs["flags"],)
    run.flags[spec.index] = flags
    run.notes.extend(f"{spec.file}: {flag}" for flag in flags)
    return ds


def _check_rates(data: list, run: TrialRun) -> list:
    """One sampling rate per study; the trials that differ stop the study or are skipped.

    The reference is the first trial's rate, or, when bad trials are skipped, the median
    trial's (so that one odd first trial does not take every other with it).
    """
    if not data:
        return data
    rates = [float(ds.attrs["sampling_rate"]) for _, ds in data]
    ref = int(np.argsort(rates, kind="stable")[(len(rates) - 1) // 2]) if run.skip else 0
    ref_spec, ref_rate = data[ref][0], rates[ref]
    kept = []
    for (spec, ds), rate in zip(data, rates, strict=True):
        if abs(rate - ref_rate) > RATE_TOLERANCE * ref_rate:
            message = (
                f"{spec.file}: sampling rate {rate:g} Hz differs from {ref_rate:g} Hz of "
                f"{ref_spec.file.name}; resample so every trial of a study has one rate"
            )
            if not run.skip:
                run.refuse(spec, message)
                raise InputError(message)
            run.drop(spec, message)
            continue
        kept.append((spec, ds))
    return kept


def _check_lags(
    study: Study,
    estimates: list[tuple[TrialSpec, InertiaEstimate]],
    rows: dict[int, dict],
    notes: list[str],
) -> None:
    """Flag estimated lags far from the study's median (one recording chain, one lag)."""
    estimated = {
        spec.index: (est.lag, est.lag_se)
        for spec, est in estimates
        if est.lag_source == "estimated"
    }
    flags = lag_consistency_flags(estimated, max_spread=study.calibration.max_lag_spread)
    for spec, est in estimates:
        flag = flags.get(spec.index)
        if flag:
            row = rows[spec.index]
            row["flags"] = "; ".join(filter(None, [row["flags"], flag]))
            notes.append(f"{est.source}: {flag}")


def _rotation(study: Study, condition: str) -> float:
    """The gravity rotation (rad) a condition's fitted phase holds.

    Its posture's for a rigid condition (one posture); 0 for a living one (fitted in the
    frame of rotation 0).
    """
    if study.living_body and study.living_body in study.mountings[condition].bodies:
        return 0.0
    names = {t.posture for t in study.trials if t.condition == condition}
    name = next(iter(names))
    return math.radians(study.postures[name].gravity_rotation) if name else 0.0


def _check_phases(study: Study, gravity: dict[str, GravityFit], notes: list[str]) -> None:
    """Bodies mounted in line share the device's phase; a difference deserves a warning."""
    conds = list(gravity)
    phase = {c: gravity[c].gravity_phase - _rotation(study, c) for c in conds}
    for c in conds[1:]:
        diff = abs(phase[c] - phase[conds[0]])
        if diff > PHASE_TOLERANCE:
            notes.append(
                f"{study.path}: the gravity phase of condition '{c}' differs from '{conds[0]}' "
                f"by {diff:.3f} rad; are the bodies mounted in line?"
            )
