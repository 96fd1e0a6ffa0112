"""A whole study: trial files → per-trial estimates → joint posterior → every output file.

:func:`analyse_study` runs the stages in order — :func:`~inertiafit.processing.study.process_study`
(trials read and processed), :func:`~inertiafit.inference.evidence.condition_evidence` (trials
become evidence), :func:`~inertiafit.inference.fit.fit` (the posterior is sampled), the speed
effect and the paper's estimator — and returns a :class:`~inertiafit.report.result.Result`.
:func:`run_study` also writes every output (:func:`~inertiafit.report.outputs.write_outputs`).

A study refused before its posterior raises :class:`~inertiafit.errors.StudyRefused`, which
carries the per-trial table gathered so far; :func:`run_study` prints it and writes it as
``diagnostics.csv`` (:data:`DIAGNOSTICS`) where that replaces nothing but an earlier refused
run's table.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from inertiafit._checks import check_probability, check_seed
from inertiafit.errors import InputError, StudyRefused
from inertiafit.inference.evidence import check_trials_in_priors, study_model, study_priors
from inertiafit.inference.fit import fit
from inertiafit.inference.model import Model
from inertiafit.inference.priors import Prior
from inertiafit.inference.sampler import sampler_settings
from inertiafit.io import Study, load_study
from inertiafit.io.manifest import file_sha256
from inertiafit.io.outputs import check_out, guard_outputs, holds_only, output_folder, write_csv
from inertiafit.io.shipped import passive_prior_path
from inertiafit.plotting.style import DEFAULT_FORMATS
from inertiafit.posterior import Posterior, inputs_json
from inertiafit.processing.living import LIVING_GROUP, living_datatree, living_tables
from inertiafit.processing.speed import speed_effect
from inertiafit.processing.study import (
    ProcessedStudy,
    process_study,
)
from inertiafit.report.comparison import paper_baselines
from inertiafit.report.outputs import figure_workers, write_outputs
from inertiafit.report.result import Result, make_result
from inertiafit.report.text import diagnostics_text
from inertiafit.shapes import ideal_body

__all__ = [
    "DIAGNOSTICS",
    "analyse_study",
    "run_study",
    "study_ideals",
    "study_inputs",
    "study_posterior",
    "study_provenance",
]


#: The file a refused run writes: its per-trial table (the columns of ``trials.csv`` and
#: ``cause``).
DIAGNOSTICS = "diagnostics.csv"


def study_ideals(study: Study) -> dict[str, dict[str, float]]:
    """Ideal (textbook) values of the bodies that declare one (``[bodies.NAME.ideal]``)."""
    return {
        name: ideal_body(body.ideal, f"{study.path}: bodies.{name}.ideal").as_dict(study.gravity)
        for name, body in study.bodies.items()
        if body.ideal
    }


def study_provenance(
    study: Study, priors: Mapping[str, Prior], processed: ProcessedStudy
) -> dict[str, Any]:
    """What a study's posterior was computed from: every input file's SHA-256 and settings.

    ``manifest`` (``path``, ``sha256``), ``on_trial_error``, ``trials`` (per trial: file,
    path, sha256, condition, kind, status and the reader settings, see
    :attr:`~inertiafit.processing.study.ProcessedStudy.provenance`) and ``priors`` (per body:
    the prior file's ``path`` and ``sha256``, or ``"inline"`` for a table in the manifest);
    for a living body, ``passive``: its joint's shipped prior file (``path``, ``sha256``), the
    prior used (``prior``: the ``[passive]`` table merged into that file, each entry's source
    beside it) and the ``postures`` (rotation, its prior SD, ``"free"`` for none, and tilt, in
    deg), which the Methods text states.
    """
    out = {
        "manifest": {"path": str(study.path), "sha256": file_sha256(study.path)},
        "on_trial_error": study.on_trial_error,
        "trials": processed.provenance,
        "priors": {
            name: (
                {"path": str(prior.path), "sha256": file_sha256(prior.path)}
                if prior.path is not None
                else {"path": "inline"}
            )
            for name, prior in priors.items()
        },
    }
    if study.passive is not None:  # the living joint's shipped prior file
        path = passive_prior_path(study.passive.joint)
        out["passive"] = {
            "path": str(path),
            "sha256": file_sha256(path),
            "prior": dataclasses.asdict(study.passive),
            "postures": {
                name: {
                    "gravity_rotation": p.gravity_rotation,
                    "gravity_rotation_sd": (
                        p.gravity_rotation_sd if math.isfinite(p.gravity_rotation_sd) else "free"
                    ),
                    "axis_tilt": p.axis_tilt,
                }
                for name, p in study.postures.items()
            },
        }
    return out


def study_inputs(study: Study) -> list[Path]:
    """Every file a study reads: the manifest, its trial files and its prior files."""
    priors = [p.path for p in study_priors(study).values() if p.path is not None]
    if study.passive is not None:
        priors.append(passive_prior_path(study.passive.joint))
    return [study.path, *(t.file for t in study.trials), *priors]


def _sample_study(
    study: Study | str | Path,
    seed: int,
    say: Callable[[str], None],
    ess_min: float | None = None,
) -> tuple[Study, dict[str, Prior], dict, ProcessedStudy, dict, Posterior]:
    """Every trial processed and the joint posterior sampled (what two functions share).

    Returns ``(study, priors, ideals, processed, living tables, posterior)`` for
    :func:`analyse_study` and :func:`study_posterior`.
    """
    settings = sampler_settings(ess_min)
    if not isinstance(study, Study):
        study = load_study(study)
    priors = study_priors(study)
    ideals = study_ideals(study)

    def in_priors(trials: pd.DataFrame, gravity: dict) -> list[str]:
        return check_trials_in_priors(study, trials, gravity, priors)

    # a refusal in there carries the table gathered; M_g is held to the priors before any
    # fast trial is processed (a wrong gravity model would be blamed on their torque's sign)
    processed = process_study(study, echo=say, check_gravity=in_priors)
    try:
        processed.warnings.extend(in_priors(processed.trials, processed.gravity))
        model = study_model(processed, priors)
        model.check_feasible()
    except InputError as exc:  # refused before sampling: the per-trial table goes with it
        refused = getattr(exc, "refused", {}) or _condition_trials(processed, str(exc))
        raise StudyRefused(
            str(exc), refused=refused, table=processed.diagnostics(refused)
        ) from exc
    provenance = study_provenance(study, priors, processed)
    say(f"sampling the joint posterior of {len(priors)} bodies")
    inputs: dict[str, Any] = {
        "manifest": str(study.path),
        "name": study.name,
        "conditions": {k: list(v) for k, v in study.conditions.items()},
        "ideals": ideals,
        "warnings": processed.warnings,
        "trials": processed.all_trials.to_dict(orient="list"),  # skipped trials listed too
        # who was measured, for a population of studies (issue 33)
        "subject": study.subject.as_dict() if study.subject is not None else None,
        "segment_length": {
            b: spec.segment_length
            for b, spec in study.bodies.items()
            if spec.segment_length is not None
        },
    }
    living = (
        living_tables(processed.living, processed.damping, body=study.living_body)
        if processed.living is not None
        else {}
    )
    post = fit(model, seed=seed, inputs=inputs, provenance=provenance, settings=settings)
    if processed.living is not None:  # its own group of posterior.nc, for `inertiafit report`
        post.tree[LIVING_GROUP] = living_datatree(living, processed.living)
    conflicts = evidence_conflicts(model, post, where=str(study.path))
    worst = max(conflicts, key=lambda c: c.apart, default=None)
    if worst is not None and worst.apart > CONFLICT_REFUSE_SD:
        refused = _trials_marked(processed, worst.condition, worst.line)
        raise StudyRefused(
            f"{worst.line.removesuffix(CONFLICT_ADVICE)}refused: past {CONFLICT_REFUSE_SD:g} "
            "SEs no interval of this posterior holds; check the keys that link the conditions "
            f"({_CONFLICT_KEYS})",
            refused=refused,
            table=processed.diagnostics(refused),
        )
    # a body's data where its prior allows almost nothing (posterior.conflict)
    prior_conflicts = post.conflict_warnings()
    if conflicts or prior_conflicts:  # said in the study's warnings, kept in posterior.nc
        processed.warnings.extend(c.line for c in conflicts)
        processed.warnings.extend(prior_conflicts)
        post.tree.attrs["inputs"] = inputs_json(inputs)
    return study, priors, ideals, processed, living, post


#: A condition's own evidence this many of its SEs from the joint posterior is said.
CONFLICT_SD = 5.0
#: ... and this many refuses the study, with the per-trial table (issue 36, item 1): beyond
#: any tail of its Student-t (with 2 degrees of freedom, 30 scales out has probability 1e-3;
#: with 4, 7e-6), the conditions measured different bodies. The issue's slips gave 60-120.
CONFLICT_REFUSE_SD = 30.0
#: How a conflict's line ends: what to check.
_CONFLICT_KEYS = "joint_angle_at_zero, gravity_rotation, the passive priors' units, torque_sign"
CONFLICT_ADVICE = (
    "the conditions do not describe the same bodies; check the keys that link them "
    f"({_CONFLICT_KEYS}) before trusting the intervals"
)


@dataclass(frozen=True)
class Conflict:
    """A condition whose own evidence contradicts the joint posterior.

    ``line``: the warning; ``condition`` its label; ``apart``: how many of the evidence's own
    SEs separate it from the posterior.
    """

    line: str
    condition: str
    apart: float


def evidence_conflicts(model: Model, post: Posterior, *, where: str) -> list[Conflict]:
    """Conditions whose own trials contradict the joint posterior (issue 36, item 1).

    Each plain condition's evidence (its fast trials' mean ``I``, its ``M_g``) against the
    mean of its bodies' summed posterior draws: beyond :data:`CONFLICT_SD` of the evidence's
    own SEs (a Student-t's SD; 3 scales below 3 degrees of freedom) the conditions do not
    describe the same bodies — a slip in a key that links them (a living joint's
    ``joint_angle_at_zero``, a posture's ``gravity_rotation``, a stiffness prior, a trial's
    ``torque_sign``) — and a line says so, naming them. The posterior is then a compromise
    that fits no condition: its narrow intervals are not to be trusted. Past
    :data:`CONFLICT_REFUSE_SD` the study is refused (:func:`analyse_study`).
    """
    lines = []
    for cond in model.conditions:
        if not cond.mounting.plain:
            continue
        for quantity, obs in (("inertia", cond.inertia), ("gravity_moment", cond.gravity_moment)):
            if obs is None:
                continue
            total = sum(post.draws(b, quantity).ravel() for b in cond.mounting.bodies)
            # a Student-t's variance; a Gaussian's (df = inf) is its scale's square, where
            # inf / (inf - 2) was nan and hid every conflict of an M_g or a one-trial I
            factor = 1.0 if math.isinf(obs.df) else obs.df / (obs.df - 2) if obs.df > 2 else 3.0
            spread = obs.scale**2 * factor
            # the condition's own error alone: its data are in the posterior already
            sd = math.sqrt(spread + obs.shared_sd**2)
            off = (obs.center - float(np.mean(total))) / sd if sd > 0 else 0.0
            if abs(off) <= CONFLICT_SD:
                continue
            symbol = "I" if quantity == "inertia" else "M_g"
            line = (
                f"{where}: condition {cond.label}: its own trials give {symbol} = "
                f"{obs.center:.4g}, the joint posterior {float(np.mean(total)):.4g} "
                f"({abs(off):.0f} of its SEs apart): {CONFLICT_ADVICE}"
            )
            lines.append(Conflict(line, cond.label, abs(off)))
    return lines


def study_posterior(
    study: Study | str | Path,
    *,
    seed: int = 0,
    echo: Callable[[str], None] | None = None,
    ess_min: float | None = None,
) -> Posterior:
    """The joint posterior of :func:`analyse_study`, alone: the same draws for the same seed.

    Every trial is processed and the posterior sampled as there, without the speed effect,
    the paper's estimator and the result's tables (about a seventh of a small study's time):
    for callers that read only the posterior, such as
    :func:`~inertiafit.validation.widths.simulated_widths`. Refuses a study as
    :func:`analyse_study` does (:class:`~inertiafit.errors.StudyRefused`).
    """
    check_seed(seed)
    return _sample_study(study, seed, echo or (lambda _msg: None), ess_min)[-1]


def analyse_study(
    study: Study | str | Path,
    *,
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo: Callable[[str], None] | None = None,
    ess_min: float | None = None,
) -> Result:
    """Process every trial and sample the joint posterior (nothing written).

    Parameters
    ----------
    study : Study or path
        A loaded manifest or the path of one.
    seed : int
        Seed of every random draw.
    hdi_prob : float
        Probability of the highest-density intervals of the comparison table.
    echo : callable, optional
        Receives one progress line per stage.
    ess_min : float, optional
        The bulk ESS every reported quantity must reach before sampling stops (default
        1000, :class:`~inertiafit.inference.sampler.SamplerSettings`); more gives more stored
        draws, which a population of studies (``inertiafit population``) reads.

    Returns
    -------
    Result
        Its ``trials`` hold every trial of the manifest (a skipped one with ``status``
        ``"skipped"``); the evidence, the speed effect and the baselines use the others.
        The posterior's ``provenance`` attribute holds :func:`study_provenance`.
    """
    check_seed(seed)
    check_probability(hdi_prob, "hdi_prob")
    say = echo or (lambda _msg: None)
    study, priors, ideals, processed, living, post = _sample_study(study, seed, say, ess_min)
    trials = processed.all_trials  # trials.csv: skipped trials listed too
    used = processed.trials
    notes = list(processed.warnings)
    # The paper's estimator knows bodies mounted as they are: a second mounting or added masses
    # would pass for the same set of bodies (and overwrite its means).
    plain = {k: v.bodies for k, v in study.mountings.items() if v.plain}
    baselines = paper_baselines(used, plain, priors, gravity=study.gravity, notes=notes)
    return make_result(
        name=study.name,
        posterior=post,
        priors=priors,
        gravity=study.gravity,
        hdi_prob=hdi_prob,
        trials=trials,
        speed_effect=speed_effect(used[used["kind"] == "fast"]),
        traces=processed.traces,
        conditions=study.conditions,
        ideals=ideals,
        baselines=baselines,
        warnings=notes,
        manifest=str(study.path),
        living=living,
        emg_traces=processed.emg_traces,
        sweeps=processed.sweeps,
    )


@guard_outputs
def run_study(
    manifest: str | Path,
    *,
    out: str | Path,
    seed: int = 0,
    hdi_prob: float = 0.95,
    formats: tuple[str, ...] = DEFAULT_FORMATS,
    echo: Callable[[str], None] = print,
    progress: Callable[[str], None] | None = None,
    ess_min: float | None = None,
) -> Result:
    """``inertiafit run``: the whole pipeline, outputs written to ``out`` (replaced whole).

    ``out`` is checked before any trial is read (:func:`~inertiafit.io.outputs.check_out`):
    it may not hold the manifest, a trial file or a prior file.
    """
    say = progress or (lambda msg: print(msg, file=sys.stderr))
    sampler_settings(ess_min)  # a bad value before anything is read
    check_out(out, inputs=[manifest])  # before the manifest is read
    study = load_study(manifest)
    check_out(out, inputs=study_inputs(study))
    # The figure workers start now and ready matplotlib while the trials are read and sampled.
    with figure_workers() as pool:
        try:
            result = analyse_study(study, seed=seed, hdi_prob=hdi_prob, echo=say, ess_min=ess_min)
        except StudyRefused as exc:
            _diagnose(exc, out, say)
            raise
        say(f"writing {out}")
        with output_folder(out) as folder:
            write_outputs(folder, result, formats=formats, pool=pool)
    echo(result.posterior.report(hdi_prob))
    for w in result.warnings:
        echo(f"warning: {w}")
    return result


def _condition_trials(processed: ProcessedStudy, message: str) -> dict[str, str]:
    """The used trials of the condition a message names (``condition 'LABEL'``), to mark.

    A prior box that no point of a condition's evidence reaches is the condition's refusal
    (:meth:`~inertiafit.inference.model.Model.check_feasible`): its trials are what the table
    marks, each with the message.
    """
    named = [c for c in processed.study.conditions if f"condition '{c}'" in message]
    return _trials_marked(processed, named[0], message) if len(named) == 1 else {}


def _trials_marked(processed: ProcessedStudy, condition: str, message: str) -> dict[str, str]:
    """Each used trial of ``condition`` (its file as ``trials.csv`` names it) -> ``message``."""
    trials = processed.trials
    return {str(f): message for f in trials.loc[trials["condition"] == condition, "file"]}


def _diagnose(exc: StudyRefused, out: str | Path, say: Callable[[str], None]) -> None:
    """Show a refused study's table and write it as ``diagnostics.csv``.

    The table is printed (``say``) and written into ``out`` through the output folder's swap
    when ``out`` is new, empty or holds only an earlier :data:`DIAGNOSTICS`; an earlier run's
    outputs are kept as they are. A line before the error says where the table is.
    """
    if exc.table is None or exc.table.empty:
        return
    say(f"per-trial table of the refused study ({DIAGNOSTICS}):")
    say(diagnostics_text(exc.table))
    if holds_only(out, [DIAGNOSTICS]):
        with output_folder(out) as folder:
            write_csv(exc.table, folder / DIAGNOSTICS)
        say(f"per-trial table written to {Path(out) / DIAGNOSTICS}")
    else:
        say(f"{DIAGNOSTICS} not written: {out} holds an earlier run's outputs, kept as they are")
