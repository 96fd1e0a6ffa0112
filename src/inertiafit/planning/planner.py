"""The planner: predicted posterior widths of candidate designs.

Given each body's nominal ``(m, rho, x)`` and the noise of a trial
(:class:`~inertiafit.planning.design.NoiseLevels`), :func:`plan` builds the model of each
design at its *expected* data (:func:`design_model`: evidence centred on the nominal values,
with the standard errors the design's trial counts give) and computes its exact posterior's
SDs and HDI widths by importance sampling
(:func:`inertiafit.inference.predict.posterior_widths`): tens of milliseconds per design. With
requested widths (``targets``) it searches, per design, the fewest fast trials per speed that
reach them and recommends the design that needs the fewest trials in all.
:func:`offset_scan` tabulates how much a weighing or a second mounting narrows one body's
intervals.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import pandas as pd

from inertiafit import physics
from inertiafit._checks import check_positive, check_probability, check_seed, check_whole
from inertiafit.errors import InputError
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.predict import DRAWS, posterior_widths
from inertiafit.inference.priors import Prior, load_prior
from inertiafit.mounting import Mounting
from inertiafit.physics import GRAVITY, PARAMETERS, REPORTED
from inertiafit.planning.design import Design, NoiseLevels, is_whole, nominal_values
from inertiafit.processing.living import PostureGeometry, design_statics, passive_basis

__all__ = [
    "PLAN_COLUMNS",
    "PlanResult",
    "design_model",
    "offset_scan",
    "plan",
    "reported_values",
]

#: Columns of ``plan.csv``.
PLAN_COLUMNS = [
    "design",
    "trials_per_speed",
    "n_trials",
    "body",
    "parameter",
    "nominal",
    "sd",
    "hdi_width",
    "relative_width",
    "target_width",
    "meets_target",
]


def reported_values(
    nominal: Mapping[str, Mapping[str, float]], gravity: float = GRAVITY
) -> dict[str, dict[str, float]]:
    """Every body's nominal parameters with its ``inertia`` and ``gravity_moment``."""
    return {
        name: {
            **v,
            "inertia": float(
                physics.inertia(v["mass"], v["radius_of_gyration"], v["com_distance"])
            ),
            "gravity_moment": float(physics.gravity_moment(v["mass"], v["com_distance"], gravity)),
        }
        for name, v in nominal.items()
    }


def _living_gravity_se(
    design: Design, moment: float, rigid_se: float, rotation_sd: float | None = None
) -> float | None:
    """A living condition's ``M_g`` SE, predicted without data (``None``: not measured).

    The joint fit of gravity and the passive curve that the design's sweeps, rest trials and
    postures would give (:func:`~inertiafit.processing.living.design_statics`; the gravity
    phase taken as 0), at the noise that gives one rigid sweep the SE ``rigid_se``. With one
    posture and a smooth passive curve the data do not measure ``M_g``
    (:attr:`~inertiafit.processing.living.LivingStatics.gravity_identified`).
    ``rotation_sd`` (rad): the rotations of :attr:`Design.rotation_postures` measured to it.
    """
    postures = design.postures or (PostureGeometry("reference"),)
    if rotation_sd is not None:
        measured = {p.name for p in design.rotation_postures}
        postures = tuple(
            dataclasses.replace(p, measured_sd=rotation_sd) if p.name in measured else p
            for p in postures
        )
    statics = design_statics(
        moment,
        postures,
        passive_basis(design.passive),
        rigid_se=rigid_se,
        sweeps=design.quasi_static_trials,
        rest_trials=design.rest_trials,
    )
    if not statics.gravity_identified:
        return None
    return statics.gravity_fit("living").gravity_moment_se


def _rotation_sd(
    design: Design, truth: Mapping[str, Mapping[str, float]], noise: NoiseLevels, gravity: float
) -> float | None:
    """The SD (rad) of a posture's rotation measured by the design's rigid sweeps.

    The difference of a rigid condition's gravity phases in two postures, one sweep each:
    ``sqrt(2)`` times one sweep's phase SE, ``gravity_se / M_g`` (the most precise rigid
    condition's). ``None`` without :attr:`Design.rotation_sweeps`.
    """
    if not design.rotation_postures:
        return None
    ses = []
    for mount in design.mountings:
        if design.holds_living(mount):
            continue
        moment = float(mount.totals(truth, gravity)[1])
        if moment > 0:
            ses.append(noise.gravity_se(mount) / moment)
    return math.sqrt(2.0) * min(ses) if ses else None


def design_model(
    bodies: Mapping[str, Mapping[str, float]],
    design: Design,
    priors: Mapping[str, Prior],
    *,
    noise: NoiseLevels | None = None,
    gravity: float = GRAVITY,
) -> Model:
    """The model of ``design`` at its expected data.

    Every condition's inertia is a Student-t centred on the true total (the moved body's
    ``I + 2 a d + m d^2``) with scale ``sd / sqrt(n)`` and ``n - 1`` degrees of freedom, ``n``
    its fast trials and ``sd`` the per-trial SD (:meth:`NoiseLevels.trial_sd`); its gravity
    moment a Gaussian of SE ``se / sqrt(q)`` (``q`` quasi-static trials); a weighed mass or a
    balance point a Gaussian of the given SD centred on the truth.
    """
    noise = noise or NoiseLevels()
    nominal = nominal_values(bodies)
    truth = reported_values(nominal, gravity)
    conditions = []
    rotation_sd = _rotation_sd(design, truth, noise, gravity)
    for mount in design.mountings:
        total_b, moment = (float(v) for v in mount.totals(truth, gravity))
        n = design.trials_per_speed * len(design.speeds)
        sd = noise.trial_sd(mount, total_b, design.speeds)
        obs_i = Observation(total_b, sd / math.sqrt(n), n - 1.0, n)
        se: float | None
        if design.holds_living(mount):
            se = _living_gravity_se(design, moment, noise.gravity_se(mount), rotation_sd)
        else:
            se = noise.gravity_se(mount) / math.sqrt(design.quasi_static_trials)
        obs_g = (
            None
            if se is None
            else Observation.from_mean_se(moment, se, where=f"{mount.label} M_g")
        )
        pilot = noise.pilot(mount)
        coupling = 0.0
        if pilot is not None:
            obs_i = obs_i.with_shared_error(pilot.shared_sd)
            coupling = pilot.coupling
        conditions.append(Condition(mount, obs_i, obs_g, coupling=coupling))
    measured = {
        body: {
            key: Observation.from_mean_se(nominal[body][key], sd, where=f"{body}.{key}")
            for key, sd in table.items()
        }
        for body, table in design.measured.items()
    }
    used = {b for m in design.mountings for b in m.bodies}
    model_priors = {b: priors[b] for b in nominal if b in used}
    for body, spec in design.priors.items():
        if body in model_priors:
            model_priors[body] = load_prior(spec, name=body)
    return Model(
        model_priors,
        conditions,
        gravity=gravity,
        torque_gain_sd=design.torque_gain_sd,
        measured=measured or None,
    )


def _targets(targets: Mapping[Any, float] | None, nominal) -> dict[tuple[str, str], float]:
    out = {}
    for key, width in (targets or {}).items():
        if isinstance(key, tuple) and len(key) == 2:
            body, parameter = (str(k) for k in key)
        else:
            body, _, parameter = str(key).partition(".")
        if body not in nominal or parameter not in REPORTED:
            raise InputError(
                f"targets: '{key}': expected 'body.parameter' with a body of the plan and a "
                f"parameter in {', '.join(REPORTED)}"
            )
        out[(body, parameter)] = check_positive(width, f"targets.{body}.{parameter}")
    return out


@dataclass
class PlanResult:
    """What :func:`plan` predicts.

    Attributes
    ----------
    table : pandas.DataFrame
        A row per design, body and parameter (:data:`PLAN_COLUMNS`): predicted posterior SD and
        HDI width (and width over the nominal value) at each design's own trials per speed.
    search : pandas.DataFrame
        With targets: a row per design with the fewest ``trials_per_speed`` that reach every
        target (``reached`` False when even ``max_trials_per_speed`` does not) and its
        ``n_trials``; empty without targets.
    recommended : str or None
        The design reaching the targets with the fewest trials (None: no targets, or none
        reaches them).
    hdi_prob : float
        Probability of the HDIs.
    seconds : float
        Time the predictions took.
    """

    table: pd.DataFrame
    search: pd.DataFrame
    recommended: str | None
    hdi_prob: float
    seconds: float
    targets: dict[tuple[str, str], float] = field(default_factory=dict)

    def text(self) -> str:
        """The table as text, with the recommendation."""
        t = self.table.copy()
        pct = round(100 * self.hdi_prob)
        t["nominal"] = t["nominal"].map(lambda v: f"{v:.4g}")
        t["sd"] = t["sd"].map(lambda v: f"{v:.3g}")
        t[f"{pct}% HDI width"] = t.pop("hdi_width").map(lambda v: f"{v:.3g}")
        t["relative"] = t.pop("relative_width").map(lambda v: f"{100 * v:.1f}%")
        t = t.drop(columns=["target_width", "meets_target"])
        lines = [t.to_string(index=False)]
        if len(self.search):
            lines += ["", "Fewest trials reaching the targets:"]
            lines.append(self.search.to_string(index=False))
            if self.recommended is None:
                lines.append("No design reaches every target.")
            else:
                row = self.search.set_index("design").loc[self.recommended]
                lines.append(
                    f"Recommended: '{self.recommended}' with {int(row['trials_per_speed'])} "
                    f"fast trials per speed ({int(row['n_trials'])} trials in all)."
                )
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.text()

    def figure(self, width="double"):
        """Predicted HDI width per parameter and design (see :func:`plot_plan`)."""
        from inertiafit.report.plots.plan import plot_plan

        return plot_plan(self.table, hdi_prob=self.hdi_prob, width=width)


def _rows(design, widths, nominal, targets, gravity) -> list[dict]:
    rows = []
    values = reported_values(nominal, gravity)
    for k, body in enumerate(widths.bodies):
        truth = values[body]
        for p in REPORTED:
            w = float(widths.hdi_width[p][k])
            target = targets.get((body, p), math.nan)
            rows.append(
                {
                    "design": design.name,
                    "trials_per_speed": design.trials_per_speed,
                    "n_trials": design.n_trials,
                    "body": body,
                    "parameter": p,
                    "nominal": truth[p],
                    "sd": float(widths.sd[p][k]),
                    "hdi_width": w,
                    "relative_width": math.nan,
                    "target_width": target,
                    "meets_target": (w <= target) if math.isfinite(target) else None,
                }
            )
    return rows


def plan(
    bodies: Mapping[str, Any],
    designs: Sequence[Design],
    *,
    priors: Mapping[str, Any] | None = None,
    noise: NoiseLevels | None = None,
    gravity: float = GRAVITY,
    hdi_prob: float = 0.95,
    targets: Mapping[Any, float] | None = None,
    max_trials_per_speed: int = 30,
    draws: int = DRAWS,
    seed: int = 0,
) -> PlanResult:
    """Predicted posterior SD and HDI width of every body's parameters for each design.

    Parameters
    ----------
    bodies : mapping
        Nominal values per body: ``{name: {"mass": .., "radius_of_gyration": ..,
        "com_distance": ..}}`` or ``{name: (mass, radius_of_gyration, com_distance)}`` (kg, m,
        m), the truth of the predictions.
    designs : sequence of Design
        Candidate designs (distinct names).
    priors : mapping of str to prior spec, optional
        Each body's prior (anything :func:`~inertiafit.inference.priors.load_prior` accepts);
        default a +-50 % box around its nominal values. A design's own ``priors`` override it.
    noise : NoiseLevels, optional
        Per-trial noise; default :class:`NoiseLevels` (the simulator's paper-like noise).
    gravity : float
        m/s^2.
    hdi_prob : float
        Probability of the HDIs.
    targets : mapping, optional
        Requested HDI widths (SI units) by ``"body.parameter"`` (or ``(body, parameter)``):
        each design is searched for the fewest fast trials per speed reaching all of them.
    max_trials_per_speed : int
        Upper end of that search.
    draws : int
        Importance draws per design (see :mod:`inertiafit.inference.predict`).
    seed : int
        Seed; every design uses the same random numbers.

    Returns
    -------
    PlanResult
    """
    t0 = time.perf_counter()
    check_probability(hdi_prob, "hdi_prob")
    check_seed(seed)
    check_whole(draws, "draws", 2)
    check_positive(gravity, "gravity", "m/s^2")
    nominal = nominal_values(bodies)
    names = [d.name for d in designs]
    if not designs:
        raise InputError("designs: expected at least one design")
    if len(set(names)) != len(names):
        raise InputError(f"designs: names repeat: {names}")
    if not (is_whole(max_trials_per_speed) and max_trials_per_speed >= 2):
        raise InputError(
            f"max_trials_per_speed: expected a whole number >= 2, got {max_trials_per_speed!r}"
        )
    resolved = {}
    for name, v in nominal.items():
        spec = (priors or {}).get(name)
        if spec is None:
            resolved[name] = Prior.box(
                name,
                mass=v["mass"],
                com_distance=v["com_distance"],
                radius_of_gyration=v["radius_of_gyration"],
            )
        else:
            try:
                resolved[name] = load_prior(spec, name=name)
            except InputError as exc:
                raise InputError(f"priors.{name}: {exc}") from None
    for d in designs:
        d.check_bodies(nominal)
    wanted = _targets(targets, nominal)

    cache: dict[tuple[str, int], Any] = {}

    def widths(design: Design):
        key = (design.name, design.trials_per_speed)
        if key not in cache:
            model = design_model(nominal, design, resolved, noise=noise, gravity=gravity)
            cache[key] = posterior_widths(model, hdi_prob=hdi_prob, draws=draws, rng=seed)
        return cache[key]

    rows = []
    for d in designs:
        rows += _rows(d, widths(d), nominal, wanted, gravity)
    table = pd.DataFrame(rows, columns=PLAN_COLUMNS)
    table["relative_width"] = table["hdi_width"] / table["nominal"]

    def meets(design: Design) -> bool:
        w = widths(design)
        index = {b: k for k, b in enumerate(w.bodies)}
        return all(
            body in index and w.hdi_width[p][index[body]] <= width
            for (body, p), width in wanted.items()
        )

    search_rows = []
    if wanted:
        for d in designs:
            lo = 1 if len(d.speeds) > 1 else 2
            hi = d.trials_per_speed  # predicted already
            if not meets(d):
                hi = max_trials_per_speed
                if not meets(replace(d, trials_per_speed=hi)):
                    search_rows.append(
                        {
                            "design": d.name,
                            "trials_per_speed": math.nan,
                            "n_trials": math.nan,
                            "reached": False,
                        }
                    )
                    continue
            while lo < hi:  # the widths fall with the trials: bisection
                mid = (lo + hi) // 2
                if meets(replace(d, trials_per_speed=mid)):
                    hi = mid
                else:
                    lo = mid + 1
            best = replace(d, trials_per_speed=hi)
            search_rows.append(
                {
                    "design": d.name,
                    "trials_per_speed": hi,
                    "n_trials": best.n_trials,
                    "reached": True,
                }
            )
    search = pd.DataFrame(
        search_rows, columns=["design", "trials_per_speed", "n_trials", "reached"]
    )
    recommended = None
    if len(search) and search["reached"].any():
        ok = search[search["reached"]]
        recommended = str(ok.sort_values("n_trials", kind="stable").iloc[0]["design"])
    return PlanResult(
        table, search, recommended, float(hdi_prob), time.perf_counter() - t0, wanted
    )


def offset_scan(
    bodies: Mapping[str, Any],
    base: Design,
    body: str,
    offsets: Sequence[float],
    *,
    weighed_sd: float | None = None,
    **kwargs: Any,
) -> pd.DataFrame:
    """How much a weighing or a second mounting narrows ``body``'s intervals, by offset.

    The second mounting repeats ``base``'s last condition that holds ``body`` with ``body``
    moved ``d`` along the lever, for each ``d`` in ``offsets``; with ``weighed_sd`` the
    weighed design is added as offset ``nan``. Returns a row per design and parameter of
    ``body``: ``offset`` (m), ``hdi_width``, and ``factor``, the box-alone (``base``) width
    over this one. Further keywords go to :func:`plan`.
    """
    holding = [m for m in base.mountings if body in m.bodies]
    if not holding:
        raise InputError(f"offset_scan: body '{body}' is in no condition of '{base.name}'")
    designs = [base]
    if weighed_sd is not None:
        designs.append(replace(base, name="weighed", weighed={**base.weighed, body: weighed_sd}))
    for d in offsets:
        moved = Mounting(holding[-1].bodies, body, float(d))
        designs.append(replace(base, name=f"offset {d:g} m", mountings=(*base.mountings, moved)))
    res = plan(bodies, designs, **kwargs)
    t = res.table[res.table["body"] == body]
    t = t[t["parameter"].isin(PARAMETERS)]
    box = t[t["design"] == base.name].set_index("parameter")["hdi_width"]
    out = []
    for des in designs:
        offset = math.nan
        if des.name.startswith("offset "):
            offset = des.mountings[-1].offset
        for _, r in t[t["design"] == des.name].iterrows():
            out.append(
                {
                    "design": des.name,
                    "offset": offset,
                    "parameter": r["parameter"],
                    "hdi_width": r["hdi_width"],
                    "factor": box[r["parameter"]] / r["hdi_width"],
                }
            )
    return pd.DataFrame(out)
