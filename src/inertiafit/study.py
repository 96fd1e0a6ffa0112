"""A whole study: trial files → per-trial estimates → joint posterior over every body.

:func:`process_study` reads and processes every trial of a manifest; :func:`study_model`
turns the per-trial values into the evidence of each condition; :func:`run_study` does both,
samples, and writes every output file. Each step is usable on its own.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from inertiafit.errors import InputError, TrialWarning
from inertiafit.io import Study, TrialSpec, load_study
from inertiafit.model import Condition, Model
from inertiafit.observations import Observation
from inertiafit.physics import PARAMETERS, UNITS
from inertiafit.priors import Prior, load_prior

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
        A row per trial, columns :data:`TRIAL_COLUMNS` (SI units; ``speed`` in deg/s).
    gravity : dict of str to GravityFit
        The gravity model of each condition (combined over its quasi-static trials).
    traces : dict of str to list of dict
        Filtered velocity and acceleration of each condition's fast trials, for figures.
    warnings : list of str
        Flags worth a look: one line each, naming the file.
    """

    study: Study
    trials: pd.DataFrame
    gravity: dict[str, Any]
    traces: dict[str, list[dict]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def _relative(path: Path, base: Path) -> str:
    try:
        return str(path.relative_to(base))
    except ValueError:
        return str(path)


def _inverse_variance_mean(values, ses) -> tuple[float, float]:
    """Weighted mean of estimates with standard errors ``ses``, and its standard error."""
    w = 1 / np.asarray(ses, float) ** 2
    return float(np.sum(w * np.asarray(values, float)) / w.sum()), float(1 / math.sqrt(w.sum()))


def _combine_gravity(fits: list, where: str):
    """One gravity model from several quasi-static fits: inverse-variance means."""
    if len(fits) == 1:
        return fits[0]
    ses = [f.gravity_moment_se for f in fits]
    mean = lambda name: _inverse_variance_mean([getattr(f, name) for f in fits], ses)[0]
    moment, moment_se = _inverse_variance_mean([f.gravity_moment for f in fits], ses)
    return dataclasses.replace(
        fits[0],
        gravity_moment=moment,
        gravity_moment_se=moment_se,
        gravity_phase=mean("gravity_phase"),
        offset=mean("offset"),
        source=where,
    )


def _trace(t, v, a, window, speed: float) -> dict:
    """The moving part of a fast trial for plotting: its filtered velocity and acceleration.

    ``v`` and ``a`` are the ones the inertia was estimated from (the same zero-lag filter).
    """
    moving = np.flatnonzero(np.abs(v) > 0.02 * np.max(np.abs(v)))
    lo, hi = (moving[0], moving[-1] + 1) if len(moving) else (0, len(t))
    step = max(1, (hi - lo) // 600)
    sl = slice(lo, hi, step)
    sign = 1.0 if np.median(v[lo:hi]) >= 0 else -1.0  # plot every move as positive
    return {
        "time": t[sl],
        "velocity": sign * v[sl],
        "acceleration": sign * a[sl],
        "window": (window[0], window[1]),
        "speed": speed,
    }


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
    from inertiafit.processing import fit_gravity
    from inertiafit.processing.inertia import _estimate

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
    gravity: dict[str, Any] = {}
    say("fitting the gravity model of each condition (quasi-static trials)")
    qs_fits: dict[str, list] = {}
    for spec, ds in data:
        if spec.kind != "quasi-static":
            continue
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", TrialWarning)
            fit = fit_gravity(ds)
        notes.extend(str(w.message) for w in caught if issubclass(w.category, TrialWarning))
        qs_fits.setdefault(spec.condition, []).append(fit)
        rows[spec.index] = _row(study, spec, gravity=fit)
    for cond, fits in qs_fits.items():
        gravity[cond] = _combine_gravity(fits, f"{study.path}: condition {cond}")
    _check_phases(study, gravity, notes)
    say("estimating the inertia of each fast trial")
    traces: dict[str, list[dict]] = {}
    for spec, ds in data:
        if spec.kind != "fast":
            continue
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", TrialWarning)
            # estimate_inertia, also giving the filtered velocity and acceleration it used
            est, velocity, alpha = _estimate(
                ds,
                gravity[spec.condition],
                window=spec.window,
                speed_deg_s=spec.speed,
                cutoff=cutoff,
                order=order,
            )
        notes.extend(str(w.message) for w in caught if issubclass(w.category, TrialWarning))
        rows[spec.index] = _row(study, spec, inertia=est)
        traces.setdefault(spec.condition, []).append(
            _trace(
                ds["time"].values,
                velocity,
                alpha,
                (est.window_start, est.window_end),
                float(spec.speed or 0.0),
            )
        )
    trials = pd.DataFrame([rows[i] for i in sorted(rows)], columns=TRIAL_COLUMNS)
    return ProcessedStudy(
        study=study, trials=trials, gravity=gravity, traces=traces, warnings=notes
    )


def _row(study: Study, spec: TrialSpec, *, gravity=None, inertia=None) -> dict:
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


def _check_phases(study: Study, gravity: dict, notes: list[str]) -> None:
    """Bodies mounted in line share the device's phase; a difference deserves a warning."""
    conds = list(gravity)
    for c in conds[1:]:
        diff = abs(gravity[c].gravity_phase - gravity[conds[0]].gravity_phase)
        if diff > PHASE_TOLERANCE:
            notes.append(
                f"{study.path}: the gravity phase of condition '{c}' differs from '{conds[0]}' "
                f"by {diff:.3f} rad; are the bodies mounted in line?"
            )


def study_priors(study: Study) -> dict[str, Prior]:
    """Resolve every body's prior (shipped name, path relative to the manifest, or table)."""
    priors = {}
    for name, body in study.bodies.items():
        try:
            priors[name] = load_prior(body.prior, base_dir=study.base_dir, name=name)
        except InputError as exc:
            raise InputError(f"{study.path}: bodies.{name}.prior: {exc}") from None
    return priors


def study_ideals(study: Study) -> dict[str, Any]:
    """Ideal (textbook) models of the bodies that declare one (``[bodies.NAME.ideal]``)."""
    from inertiafit.shapes import ideal_body

    return {
        name: ideal_body(body.ideal, f"{study.path}: bodies.{name}.ideal")
        for name, body in study.bodies.items()
        if body.ideal
    }


def condition_evidence(processed: ProcessedStudy) -> list[Condition]:
    """Evidence per condition: Student-t of its trials' inertia, Gaussian of its ``M_g``."""
    study = processed.study
    out = []
    for label, bodies in study.conditions.items():
        sub = processed.trials[processed.trials["condition"] == label]
        fast = sub[sub["kind"] == "fast"]
        where = f"{study.path}: condition {label}"
        obs_i = None
        if len(fast) >= 2:
            obs_i = Observation.from_values(fast["inertia"].to_numpy(), where=f"{where} inertia")
        elif len(fast) == 1:
            r = fast.iloc[0]
            obs_i = Observation.from_mean_se(
                r["inertia"], r["inertia_se"], where=f"{where} inertia"
            )
        obs_g = None
        if label in processed.gravity:
            g = processed.gravity[label]
            obs_g = Observation.from_mean_se(
                g.gravity_moment, g.gravity_moment_se, where=f"{where} gravity moment"
            )
        out.append(Condition(tuple(bodies), obs_i, obs_g, label=label))
    return out


def study_model(processed: ProcessedStudy) -> Model:
    """The joint model over every body of the study."""
    return Model(
        study_priors(processed.study),
        condition_evidence(processed),
        gravity=processed.study.gravity,
    )


def condition_gravity(trials: pd.DataFrame) -> dict[str, float]:
    """Each condition's gravity moment from its quasi-static rows (inverse-variance mean)."""
    out = {}
    qs = trials[trials["kind"] == "quasi-static"]
    for label, rows in qs.groupby("condition", sort=False):
        out[str(label)] = _inverse_variance_mean(
            rows["gravity_moment"], rows["gravity_moment_se"]
        )[0]
    return out


def paper_baselines(
    trials: pd.DataFrame,
    conditions: dict[str, tuple[str, ...]],
    priors: dict[str, Prior],
    *,
    gravity: float,
    notes: list[str] | None = None,
) -> dict[str, Any]:
    """The paper's estimator per body, as the paper applies it.

    A body measured alone gets the multi-start fit of its condition's mean ``I`` and ``M_g``;
    a body added to another condition gets the fit of the differences of the condition means
    (Son et al., section 3.2: ``I_w = mean(I_b) - mean(I_a)``). Bodies measured neither way
    have no baseline.
    """
    from inertiafit.baseline import paper_baseline
    from inertiafit.commands import BASELINE_METHOD

    grav = condition_gravity(trials)
    means = {}
    for label, bodies in conditions.items():
        fast = trials[(trials["condition"] == label) & (trials["kind"] == "fast")]
        if len(fast) and label in grav:
            means[frozenset(bodies)] = (float(fast["inertia"].mean()), grav[label])
    out = {}
    for name, prior in priors.items():
        target = means.get(frozenset([name]))
        if target is None:
            for key, (i_b, g_b) in means.items():
                rest = key - {name}
                if name in key and rest in means:
                    i_a, g_a = means[rest]
                    target = (i_b - i_a, g_b - g_a)
                    break
        if target is None or target[0] <= 0 or target[1] <= 0:
            continue
        try:
            out[name] = paper_baseline(
                inertia=target[0],
                gravity_moment=target[1],
                nominal=prior.nominal,
                lower=prior.lower,
                upper=prior.upper,
                gravity=gravity,
                method=BASELINE_METHOD,
            )
        except InputError as exc:
            if notes is not None:
                notes.append(f"baseline of '{name}' not computed: {exc}")
    return out


def comparison_table(post, ideals, baselines, hdi_prob: float) -> pd.DataFrame:
    """Per body and parameter: ideal, posterior, baseline, differences, who identifies it.

    The paper's Tables 2 and 3 with the posterior beside them. ``ideals`` maps a body to a dict
    of its ideal values (SI units).
    """
    s = post.summary(hdi_prob).set_index(["body", "parameter"])
    ident = post.identification().set_index(["body", "parameter"])
    rows = []
    for body in post.bodies:
        ideal = ideals.get(body, {})
        base = baselines[body].estimate if body in baselines else {}
        for p in (*PARAMETERS, "inertia", "gravity_moment"):
            med = float(s.loc[(body, p), "median"])
            lo, hi = float(s.loc[(body, p), "hdi_lower"]), float(s.loc[(body, p), "hdi_upper"])
            iv = float(ideal.get(p, math.nan))
            bv = float(base.get(p, math.nan))
            has_ideal = not math.isnan(iv)
            rows.append(
                {
                    "body": body,
                    "parameter": p,
                    "unit": UNITS[p],
                    "ideal": iv,
                    "posterior_median": med,
                    "hdi_lower": lo,
                    "hdi_upper": hi,
                    "baseline": bv,
                    "posterior_vs_ideal": (med - iv) / iv if has_ideal else math.nan,
                    "baseline_vs_ideal": (bv - iv) / iv if has_ideal else math.nan,
                    "ideal_in_hdi": (lo <= iv <= hi) if has_ideal else None,
                    "sd_ratio": float(ident.loc[(body, p), "sd_ratio"]),
                    "identified_by": ident.loc[(body, p), "identified_by"],
                }
            )
    return pd.DataFrame(rows)


@dataclass
class StudyResult:
    """Everything the outputs of a study are drawn from.

    Attributes
    ----------
    name : str
        The study's name.
    posterior : Posterior
        Joint posterior over every body.
    trials : pandas.DataFrame
        A row per trial (columns :data:`TRIAL_COLUMNS`).
    conditions : dict of str to tuple of str
        Condition label → mounted bodies.
    priors : dict of str to Prior
        Each body's prior box.
    ideals : dict of str to dict
        Ideal (textbook) values of the bodies that declare one (SI units).
    traces : dict of str to list of dict
        Filtered fast trials for figures (empty when redrawn without the trial files).
    warnings : list of str
        Trial flags and other notes, one line each.
    manifest : str
        Path of the manifest.
    gravity : float
        m/s^2.
    hdi_prob : float
        Probability of the HDIs in the comparison table.
    baselines : dict of str to BaselineResult, optional
        The paper's estimator per body; computed from the trials when not given.
    kind : str
        ``"study"`` (from trial files) or ``"fit"`` (one body from numbers).
    """

    name: str
    posterior: Any
    trials: pd.DataFrame
    conditions: dict[str, tuple[str, ...]]
    priors: dict[str, Prior]
    ideals: dict[str, dict[str, float]]
    traces: dict[str, list[dict]]
    warnings: list[str]
    manifest: str
    gravity: float
    hdi_prob: float = 0.95
    baselines: dict[str, Any] | None = None
    kind: str = "study"  # or "fit": one body fitted from numbers (no trials)
    speed_effect: pd.DataFrame = field(init=False)
    comparison: pd.DataFrame = field(init=False)

    def __post_init__(self) -> None:
        from inertiafit.processing import speed_effect

        self.speed_effect = speed_effect(self.trials[self.trials["kind"] == "fast"])
        if self.baselines is None:
            self.baselines = paper_baselines(
                self.trials,
                self.conditions,
                self.priors,
                gravity=self.gravity,
                notes=self.warnings,
            )
        self.comparison = comparison_table(
            self.posterior, self.ideals, self.baselines, self.hdi_prob
        )


def analyse_study(
    study: Study | str | Path,
    *,
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo: Callable[[str], None] | None = None,
) -> StudyResult:
    """Process every trial and sample the joint posterior (nothing written)."""
    from inertiafit.inference import fit

    if not 0 < hdi_prob < 1:
        raise InputError(f"--hdi-prob: expected a probability in (0, 1), got {hdi_prob}")
    if not isinstance(study, Study):
        study = load_study(study)
    say = echo or (lambda _msg: None)
    priors = study_priors(study)
    ideals = {name: body.as_dict(study.gravity) for name, body in study_ideals(study).items()}
    processed = process_study(study, echo=say)
    model = Model(priors, condition_evidence(processed), gravity=study.gravity)
    say(f"sampling the joint posterior of {len(priors)} bodies")
    inputs = {
        "manifest": str(study.path),
        "name": study.name,
        "conditions": {k: list(v) for k, v in study.conditions.items()},
        "ideals": ideals,
        "warnings": processed.warnings,
        "trials": processed.trials.to_dict(orient="list"),
    }
    post = fit(model, seed=seed, inputs=inputs)
    return StudyResult(
        name=study.name,
        posterior=post,
        trials=processed.trials,
        conditions=dict(study.conditions),
        priors=priors,
        ideals=ideals,
        traces=processed.traces,
        warnings=list(processed.warnings),
        manifest=str(study.path),
        gravity=study.gravity,
        hdi_prob=hdi_prob,
    )


def run_study(
    manifest: str | Path,
    *,
    out: str | Path,
    seed: int = 0,
    hdi_prob: float = 0.95,
    formats: tuple[str, ...] = ("pdf", "png"),
    echo: Callable[[str], None] = print,
    progress: Callable[[str], None] | None = None,
) -> StudyResult:
    """``inertiafit run``: the whole pipeline, outputs written to ``out`` (replaced whole)."""
    from inertiafit.outputs import output_folder
    from inertiafit.rendering import write_study_outputs

    say = progress or (lambda msg: print(msg, file=sys.stderr))
    result = analyse_study(manifest, seed=seed, hdi_prob=hdi_prob, echo=say)
    say(f"writing {out}")
    with output_folder(out) as folder:
        write_study_outputs(folder, result, hdi_prob=hdi_prob, formats=formats)
    echo(result.posterior.report(hdi_prob))
    for w in result.warnings:
        echo(f"warning: {w}")
    return result
