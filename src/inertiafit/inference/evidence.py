"""Where trials become evidence: per-trial values → the likelihood terms of each condition.

:func:`condition_evidence` turns a processed study (:mod:`inertiafit.processing.study`) into one
:class:`~inertiafit.inference.model.Condition` per set of mounted bodies: a Student-t on the mean
of its fast trials' inertia, a Gaussian on its quasi-static gravity moment, and the error of the
condition's gravity model, shared by all its fast trials (:func:`shared_gravity_error`).
:func:`evidence_from_numbers` does the same for numbers quoted in a paper (values, mean ± SE,
or mean with SD and ``n``).

Extra information from the manifest enters the same way: a condition's second mounting
(``offset``) and known added masses become fields of its :class:`Condition`, and a body's
weighed mass and balance point become Gaussians in :func:`study_model` (:func:`measured_evidence`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from inertiafit._checks import check_positive
from inertiafit.errors import InputError, StudyRefused
from inertiafit.inference.model import Condition, Model, observable_ranges
from inertiafit.inference.observations import Observation, check_resolvable
from inertiafit.inference.population import population_prior_table
from inertiafit.inference.priors import Prior, load_prior
from inertiafit.measured import Measurement, measurements
from inertiafit.stats import shared_error

if TYPE_CHECKING:  # evidence reads these; importing them would load the processing stack
    import pandas as pd

    from inertiafit.io import Study
    from inertiafit.processing.gravity import GravityFit
    from inertiafit.processing.study import ProcessedStudy

__all__ = [
    "PRIOR_RANGE_SE",
    "check_trials_in_priors",
    "condition_evidence",
    "evidence_from_numbers",
    "measured_evidence",
    "measured_from_numbers",
    "measurement_observations",
    "shared_gravity_error",
    "study_model",
    "study_priors",
]


def study_priors(study: Study) -> dict[str, Prior]:
    """Resolve every body's prior (shipped name, path relative to the manifest, or table)."""
    priors = {}
    for name, body in study.bodies.items():
        spec = body.prior
        try:
            if isinstance(spec, dict) and "population" in spec:
                spec = population_prior_table(
                    spec,
                    where=f"{study.path}: bodies.{name}.prior",
                    base_dir=study.base_dir,
                    body=name,
                    known=_known_covariates(study, name),
                )
            priors[name] = load_prior(spec, base_dir=study.base_dir, name=name)
        except InputError as exc:
            raise InputError(f"{study.path}: bodies.{name}.prior: {exc}") from None
    return priors


def _known_covariates(study: Study, body: str) -> dict[str, float]:
    """What the manifest says of the subject and the body, for a population prior."""
    out: dict[str, float] = {}
    subject = study.subject
    if subject is not None:
        out["body_mass"] = subject.body_mass
        if subject.height is not None:
            out["height"] = subject.height
        out.update(subject.covariates)
    length = study.bodies[body].segment_length
    if length is not None:
        out["segment_length"] = length
    return out


def shared_gravity_error(coefficients, covariance, sensitivities) -> tuple[float, float]:
    """The gravity model's error in a condition's mean inertia: ``(coupling, shared_sd)``.

    The gravity model ``A sin(theta) + B cos(theta) + C`` is fitted once per condition and
    subtracted from every fast trial, so its error ``delta`` (covariance ``Sigma``) moves each
    trial's inertia by ``J_j delta`` (``J_j`` = the trial's ``gravity_sensitivity``) and their
    mean by ``u = J delta`` (``J`` the mean sensitivity); the gravity moment's error is
    ``v = g_m delta`` with ``g_m = (A, B, 0) / M_g``. Given ``v``, ``u`` is Gaussian with mean
    ``coupling * v``, ``coupling = J Sigma g_m' / g_m Sigma g_m'``, and SD
    ``shared_sd = sqrt(J Sigma J' - coupling * J Sigma g_m')``.

    Parameters
    ----------
    coefficients : array_like, shape (3,)
        ``(A, B, C)`` of the condition's gravity fit.
    covariance : array_like, shape (3, 3)
        Their covariance.
    sensitivities : array_like, shape (n_trials, 3)
        ``dI/d(A, B, C)`` of each fast trial.
    """
    coef = np.asarray(coefficients, float)
    jac = np.mean(np.atleast_2d(np.asarray(sensitivities, float)), axis=0)
    moment = math.hypot(coef[0], coef[1])
    g_m = np.array([coef[0] / moment, coef[1] / moment, 0.0])
    return shared_error(jac, covariance, g_m)


#: A trial's value is outside what the priors allow when it misses their range by more than
#: this many of its own standard errors.
PRIOR_RANGE_SE = 4.0


def check_trials_in_priors(
    study: Study,
    trials: pd.DataFrame,
    gravity: Mapping[str, GravityFit],
    priors: Mapping[str, Prior],
) -> list[str]:
    """Each trial's ``I`` and ``M_g`` against what its condition's priors allow, before sampling.

    For a condition of bodies mounted as they are (no moved body, no added mass), the range
    of each observable (:func:`~inertiafit.inference.model.observable_ranges`) is held
    against every usable trial: a fast trial's ``inertia``, a quasi-static trial's
    ``gravity_moment`` (not for a living body, whose ``M_g`` is the joint fit's). A value
    beyond the range by more than :data:`PRIOR_RANGE_SE` of its standard errors is outside.

    When the condition's own value is outside too, by more than :data:`PRIOR_RANGE_SE` of its
    errors (the median of its fast trials' ``I``, give or take their scatter over ``sqrt(n)``
    or their median SE; its combined ``M_g``, give or take its SE), no point of the priors can explain its trials: the study is refused
    with one line naming those trials and their values against the range (before the
    sampler's feasibility check blames a bound). When only some trials are outside, each gets
    a flag in ``trials`` (changed in place) and a line in the list returned (the warnings).

    ``trials`` are a study's rows as :func:`~inertiafit.processing.study.process_study`
    gathers them (its ``check_gravity`` passes the quasi-static rows alone, before any fast
    trial is processed), ``gravity`` each condition's gravity model.

    Raises
    ------
    StudyRefused
        Naming the condition and its trials outside the range (``refused``: file -> reason).
    """
    notes: list[str] = []
    living = study.living_body
    for label, mounting in study.mountings.items():
        if not mounting.plain:
            continue
        ranges = observable_ranges([priors[b] for b in mounting.bodies], study.gravity)
        names = ", ".join(f"'{b}'" for b in mounting.bodies)
        sub = trials[trials["condition"] == label]
        for key, kind in (("inertia", "fast"), ("gravity_moment", "quasi-static")):
            if key == "gravity_moment" and living and living in mounting.bodies:
                continue
            r = ranges[key]
            rows = sub[sub["kind"] == kind]
            values = rows[key].to_numpy(dtype=float)
            ses = np.nan_to_num(rows[f"{key}_se"].to_numpy(dtype=float))
            slack = PRIOR_RANGE_SE * ses
            outside = (values < r.low - slack) | (values > r.high + slack)
            if not outside.any():
                continue
            if key == "inertia":  # the median, give or take its trials' scatter and errors
                scatter = (
                    float(np.std(values, ddof=1)) / math.sqrt(len(values))
                    if len(values) > 1
                    else 0.0
                )
                center = float(np.median(values))
                spread = PRIOR_RANGE_SE * max(scatter, float(np.median(ses)))
            else:
                g = gravity[label]
                center, spread = g.gravity_moment, PRIOR_RANGE_SE * g.gravity_moment_se
            allowed = f"the {r.low:.3g} to {r.high:.3g} {r.unit} that the priors of {names} allow"
            files = rows["file"].to_numpy()[outside]
            shown = values[outside]
            if center + spread < r.low or center - spread > r.high:
                listed = ", ".join(
                    f"{f} {v:.3g}" for f, v in zip(files[:4], shown[:4], strict=True)
                )
                more = f" and {len(files) - 4} more" if len(files) > 4 else ""
                cause = f"{r.symbol} = {{:.3g}} {r.unit}, outside {allowed}"
                low, high = f"{np.min(values):.3g}", f"{np.max(values):.3g}"
                given = low if low == high else f"{low} to {high}"
                raise StudyRefused(
                    f"{study.path}: condition '{label}': its {r.trials} give {r.symbol} = "
                    f"{given} {r.unit} ({listed}{more}), "
                    f"outside {allowed}: check those trials ({r.causes}?) before the priors",
                    refused={str(f): cause.format(v) for f, v in zip(files, shown, strict=True)},
                )
            for f, v in zip(files, shown, strict=True):
                flag = (
                    f"{r.symbol} = {v:.3g} {r.unit} is outside {allowed}, unlike its condition's "
                    f"{center:.3g} {r.unit}: an outlier? check this trial ({r.causes}?)"
                )
                at = trials.index[trials["file"] == f]
                trials.loc[at, "flags"] = trials.loc[at, "flags"].map(
                    lambda old, flag=flag: "; ".join(
                        filter(None, [old if isinstance(old, str) else "", flag])
                    )
                )
                notes.append(f"{study.base_dir / str(f)}: {flag}")
    return notes


def condition_evidence(processed: ProcessedStudy) -> list[Condition]:
    """Evidence per condition: Student-t of its trials' inertia, Gaussian of its ``M_g``.

    The inertia's evidence carries the error of the condition's gravity model
    (:func:`shared_gravity_error`): a ``coupling`` to the gravity moment and a Gaussian
    ``shared_sd``. A condition whose trials move a body along the lever (``offset``) or add
    known masses (``added_mass``) carries them (:attr:`inertiafit.io.Study.mountings`).
    """
    study = processed.study
    mountings = study.mountings
    out = []
    for label in study.conditions:
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
        coupling = 0.0
        living = processed.living
        if living is not None and label in living.conditions and not living.gravity_identified:
            # one posture and a smooth passive curve: no M_g measured, the priors decide it
            if obs_i is not None and label in processed.living_coupling:
                obs_i = obs_i.with_shared_error(processed.living_coupling[label][1])
        elif label in processed.gravity:
            g = processed.gravity[label]
            obs_g = Observation.from_mean_se(
                g.gravity_moment, g.gravity_moment_se, where=f"{where} gravity moment"
            )
            if obs_i is not None and label in processed.living_coupling:
                # a living body: the static curve's error over all its coefficients
                coupling, shared = processed.living_coupling[label]
                obs_i = obs_i.with_shared_error(shared)
            elif obs_i is not None:
                sens = processed.sensitivity.loc[fast["file"], ["sin", "cos", "offset"]]
                coupling, shared = shared_gravity_error(g.coefficients, g.covariance, sens)
                obs_i = obs_i.with_shared_error(shared)
        out.append(Condition(mountings[label], obs_i, obs_g, label=label, coupling=coupling))
    return out


def measured_evidence(
    measured: dict[str, dict[str, tuple[float, float]]], *, where: str = "measured"
) -> dict[str, dict[str, Observation]]:
    """Direct measurements ``{body: {"mass" | "com_distance": (value, sd)}}`` as Gaussians.

    The ``measured`` argument of :class:`~inertiafit.inference.model.Model`; values and SDs
    in kg and m (:attr:`inertiafit.io.BodySpec.measured`).
    """
    return {
        body: {
            key: Observation.from_mean_se(value, sd, where=f"{where}: bodies.{body}.{key}")
            for key, (value, sd) in table.items()
        }
        for body, table in measured.items()
    }


def study_model(processed: ProcessedStudy, priors: dict[str, Prior] | None = None) -> Model:
    """The joint model over every body of the study (priors resolved when not given).

    Bodies weighed or balanced in the manifest (``[bodies.<name>] mass``, ``com_distance``)
    carry that evidence (:func:`measured_evidence`).
    """
    study = processed.study
    return Model(
        priors if priors is not None else study_priors(study),
        condition_evidence(processed),
        gravity=study.gravity,
        torque_gain_sd=study.calibration.torque_gain_sd,
        measured=measured_evidence(study.measured, where=str(study.path)) or None,
    )


def evidence_from_numbers(
    name: str,
    values: float | Sequence[float],
    se: float | None = None,
    sd: float | None = None,
    n: int | None = None,
) -> Observation:
    """Evidence on one observable from reported numbers.

    Parameters
    ----------
    name : str
        The observable's argument name (``inertia``, ``gravity_moment``), used in messages as
        ``name``, ``name_se``, ``name_sd`` and ``name_n``.
    values : float or sequence of float
        Trial values, or one value with ``se`` or with ``sd`` and ``n``.
    se : float, optional
        Standard error of a single value (Gaussian); at least
        :data:`~inertiafit.inference.observations.MIN_RELATIVE_SE` of the value.
    sd, n : float, int, optional
        SD and number of the trials behind one mean (the same Student-t as the trials); the SD
        at least ``MIN_RELATIVE_SE`` of the mean.
    """
    if values is None or isinstance(values, str | bytes):  # type: ignore[redundant-expr]
        raise InputError(f"{name}: expected a number or a sequence of numbers, got {values!r}")
    if np.isscalar(values):
        vals = [values]
    else:
        try:
            vals = list(values)  # type: ignore[arg-type]
        except TypeError:
            raise InputError(
                f"{name}: expected a number or a sequence of numbers, got {values!r}"
            ) from None
    if se is not None:
        se = check_positive(se, f"{name}_se")
    if sd is not None:
        sd = check_positive(sd, f"{name}_sd")
    if sd is not None or n is not None:
        if sd is None or n is None:
            raise InputError(f"{name}_sd and {name}_n go together; give both")
        if len(vals) != 1 or se is not None:
            raise InputError(f"{name}_sd and {name}_n describe one mean; give one {name} value")
        obs = Observation.from_mean_sd(vals[0], sd, n, where=name)
        check_resolvable(sd, obs.center, f"{name}_sd")
        return obs
    obs = Observation.from_values(vals, se=se, where=name)
    if se is not None:
        check_resolvable(se, obs.center, f"{name}_se")
    return obs


def measured_from_numbers(
    **given: tuple[float | None, float | None],
) -> dict[str, Observation]:
    """Direct measurements given as numbers, ``name=(value, sd)``, as Gaussians by name.

    :func:`~inertiafit.measured.measurements` then :func:`measurement_observations`: a pair
    of ``None`` is left out, a value without its SD (or an SD without its value) is an error
    naming ``name`` and ``name_sd`` (the arguments of
    :func:`~inertiafit.inference.fit.fit_body`), and so is an SD below
    :data:`~inertiafit.inference.observations.MIN_RELATIVE_SE` of its value.
    """
    return measurement_observations(measurements(**given))


def measurement_observations(measured: Sequence[Measurement]) -> dict[str, Observation]:
    """One body's direct measurements as Gaussians, by the quantity's name.

    Each SD must be positive and no less than
    :data:`~inertiafit.inference.observations.MIN_RELATIVE_SE` of its value; a message names
    the quantity's ``name_sd`` (``mass_sd``). A quantity given twice is an error.
    """
    out: dict[str, Observation] = {}
    for m in measured:
        name = m.name
        if name in out:
            raise InputError(f"{name}: given twice")
        out[name] = Observation.from_mean_se(
            m.value, check_positive(m.sd, f"{name}_sd"), where=name
        )
        check_resolvable(m.sd, out[name].center, f"{name}_sd")
    return out
