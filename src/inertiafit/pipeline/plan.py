"""Planning a session: predicted posterior widths of candidate designs (``inertiafit plan``).

A *design* is what a session would measure: which bodies are mounted together (and a body
moved ``d`` along the lever in a second mounting), how many fast trials at which speeds, how
many quasi-static trials, whether a body is weighed or balanced, each body's prior, the torque
gain's SD. Given each body's nominal ``(m, rho, x)`` and the noise of a trial
(:class:`NoiseLevels`), :func:`plan` builds the model of each design at its *expected* data —
evidence centred on the nominal values, with the standard errors the design's trial counts
give — and computes its exact posterior's SDs and HDI widths by importance sampling
(:func:`inertiafit.inference.predict.posterior_widths`): tens of milliseconds per design.
With requested widths (``targets``) it searches, per design, the fewest fast trials per speed
that reach them and recommends the design that needs the fewest trials in all.

The noise comes from nominal levels (defaults measured with the simulator's
:meth:`~inertiafit.simulate.Noise.paper`) or from a pilot study (:func:`pilot_inputs`: the
per-trial scatter of ``trials.csv`` and the gravity moments' standard errors and gravity-model
coupling stored in ``posterior.nc``). :func:`load_plan_file` reads a design file (TOML) and
:func:`run_plan` writes ``plan.csv``, ``plan-search.csv`` and ``plan.pdf``/``.png``.
docs/tutorials/planning.md is the tutorial; the predictions are validated against full
simulated studies in docs/validation.md.
"""

from __future__ import annotations

import json
import math
import time
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from inertiafit._checks import (
    check_number,
    check_positive,
    check_probability,
    check_seed,
    check_whole,
)
from inertiafit.errors import InputError
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.predict import DRAWS, posterior_widths
from inertiafit.inference.priors import Prior, load_prior
from inertiafit.physics import GRAVITY, PARAMETERS, REPORTED, moved_moments

__all__ = [
    "DEFAULT_SPEEDS",
    "PAPER_GRAVITY_MOMENT_SE",
    "PAPER_INERTIA_SD",
    "PLAN_COLUMNS",
    "ConditionNoise",
    "Design",
    "Mounting",
    "NoiseLevels",
    "PlanResult",
    "design_model",
    "load_plan_file",
    "offset_scan",
    "pilot_inputs",
    "plan",
    "run_plan",
    "simulated_widths",
]

#: The paper's fast speeds (deg/s).
DEFAULT_SPEEDS = (240.0, 270.0, 300.0)

#: Per-trial SD of a fast trial's inertia (kg m^2) under the simulator's ``Noise.paper()``:
#: root mean square 0.014-0.021 per condition and speed over six simulated paper studies
#: (``paper_study``, seeds 10-15), the same whatever is mounted (its per-trial torque shift is
#: in N m, not relative), like the paper's 0.017 for the attachment.
PAPER_INERTIA_SD = 0.017

#: SE of one quasi-static trial's gravity moment (N m) under ``Noise.paper()`` at 1 deg/s over
#: 90 deg: root mean square 0.022 (attachment) and 0.024 (attachment + disk) in those studies.
PAPER_GRAVITY_MOMENT_SE = 0.023

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

_FROZEN = frozenset


def _whole(value: Any) -> bool:
    """Whether ``value`` is a whole number (not a bool)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


@dataclass(frozen=True)
class Mounting:
    """One condition of a design: bodies mounted together, one of them maybe moved.

    Attributes
    ----------
    bodies : tuple of str
        The mounted bodies.
    offset_body, offset : str, float
        A second mounting: this body sits ``offset`` m further out along the lever (``""``:
        none), as :class:`~inertiafit.inference.model.Condition`.
    """

    bodies: tuple[str, ...]
    offset_body: str = ""
    offset: float = 0.0

    @property
    def label(self) -> str:
        """``attachment+forearm`` (``@forearm+0.05m`` when moved)."""
        text = "+".join(self.bodies)
        if self.offset_body:
            text += f"@{self.offset_body}{self.offset:+g}m"
        return text


@dataclass(frozen=True)
class Design:
    """A candidate session.

    Attributes
    ----------
    name : str
        Shown in tables and figures.
    mountings : tuple of Mounting
        The conditions measured.
    trials_per_speed : int
        Fast trials per speed and condition.
    speeds : tuple of float
        Preset speeds of the fast trials (deg/s).
    quasi_static_trials : int
        Quasi-static trials per condition (their gravity moments are combined).
    priors : mapping of str to prior spec
        Per body, a prior overriding the plan's (anything :func:`load_prior` accepts).
    weighed : mapping of str to float
        Bodies weighed on a scale, with the scale's SD (kg).
    balanced : mapping of str to float
        Bodies whose centre of mass is found on a balance, with its SD (m).
    torque_gain_sd : float
        Relative SD of the torque gain carried in the posterior (0: none).
    """

    name: str
    mountings: tuple[Mounting, ...]
    trials_per_speed: int = 10
    speeds: tuple[float, ...] = DEFAULT_SPEEDS
    quasi_static_trials: int = 1
    priors: Mapping[str, Any] = field(default_factory=dict)
    weighed: Mapping[str, float] = field(default_factory=dict)
    balanced: Mapping[str, float] = field(default_factory=dict)
    torque_gain_sd: float = 0.0

    def __post_init__(self):
        where = f"design '{self.name}'"
        if not self.mountings:
            raise InputError(f"{where}: conditions: expected at least one condition")
        n = self.trials_per_speed
        if not _whole(n) or n < 1:
            raise InputError(f"{where}: trials_per_speed: expected a whole number >= 1, got {n!r}")
        if n * len(self.speeds) < 2:
            raise InputError(f"{where}: trials_per_speed: one speed needs at least 2 trials")
        q = self.quasi_static_trials
        if not _whole(q) or q < 1:
            raise InputError(
                f"{where}: quasi_static_trials: expected a whole number >= 1, got {q!r}"
            )
        if not self.speeds:
            raise InputError(f"{where}: speeds: expected at least one speed")
        for s in self.speeds:
            check_positive(s, f"{where}: speeds", "deg/s")
        for key, table, unit in (
            ("weighed", self.weighed, "kg"),
            ("balanced", self.balanced, "m"),
        ):
            for body, sd in table.items():
                check_positive(sd, f"{where}: {key}.{body}", unit)

    @property
    def n_trials(self) -> int:
        """Dynamometer trials of the session: fast and quasi-static, every condition."""
        per = self.trials_per_speed * len(self.speeds) + self.quasi_static_trials
        return per * len(self.mountings)

    def bodies(self) -> set[str]:
        """Every body the design names."""
        out = {b for m in self.mountings for b in m.bodies}
        return out | set(self.priors) | set(self.weighed) | set(self.balanced)


@dataclass(frozen=True)
class ConditionNoise:
    """Noise of one set of mounted bodies measured in a pilot.

    Attributes
    ----------
    inertia_sd : dict of float to float
        Per-trial SD of the inertia (kg m^2) per speed (deg/s).
    gravity_moment_se : float
        SE of one quasi-static trial's gravity moment (N m): the pilot's SE times the square
        root of its number of quasi-static trials.
    coupling, shared_sd : float
        The gravity model's error in the mean inertia (see
        :func:`~inertiafit.inference.evidence.shared_gravity_error`).
    """

    inertia_sd: dict[float, float]
    gravity_moment_se: float
    coupling: float = 0.0
    shared_sd: float = 0.0

    def sd_at(self, speed: float) -> float:
        """Per-trial SD at ``speed``: interpolated between the pilot's speeds, held outside."""
        speeds = sorted(self.inertia_sd)
        return float(np.interp(speed, speeds, [self.inertia_sd[s] for s in speeds]))


@dataclass(frozen=True)
class NoiseLevels:
    """Noise of a trial: the per-trial SD of the inertia and the SE of the gravity moment.

    The per-trial SD of a condition's inertia is ``hypot(inertia_sd, inertia_relative_sd *
    I)``; a condition measured in a pilot (``conditions``, by its set of bodies, not moved)
    uses the pilot's numbers instead.

    Attributes
    ----------
    inertia_sd : float
        Absolute per-trial SD (kg m^2); default :data:`PAPER_INERTIA_SD`.
    inertia_relative_sd : float
        Relative per-trial SD (0.02 = 2 % of the condition's inertia); default 0.
    gravity_moment_se : float
        SE of one quasi-static trial's gravity moment (N m); default
        :data:`PAPER_GRAVITY_MOMENT_SE`.
    conditions : dict of frozenset to ConditionNoise
        Pilot measurements by set of bodies.
    """

    inertia_sd: float = PAPER_INERTIA_SD
    inertia_relative_sd: float = 0.0
    gravity_moment_se: float = PAPER_GRAVITY_MOMENT_SE
    conditions: Mapping[frozenset[str], ConditionNoise] = field(default_factory=dict)

    def __post_init__(self):
        check_positive(self.gravity_moment_se, "noise.gravity_moment_se", "N m")
        for key in ("inertia_sd", "inertia_relative_sd"):
            value = check_number(getattr(self, key), f"noise.{key}")
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"noise.{key}: expected a finite number >= 0, got {value!r}")
        if self.inertia_sd == 0 and self.inertia_relative_sd == 0:
            raise InputError("noise.inertia_sd: expected inertia_sd or inertia_relative_sd > 0")

    def pilot(self, mounting: Mounting) -> ConditionNoise | None:
        """The pilot's noise of this set of bodies (none for a moved body)."""
        if mounting.offset_body:
            return None
        return self.conditions.get(_FROZEN(mounting.bodies))

    def trial_sd(self, mounting: Mounting, inertia: float, speeds: Sequence[float]) -> float:
        """Per-trial SD of the inertia pooled over ``speeds`` (root mean square)."""
        pilot = self.pilot(mounting)
        if pilot is not None:
            sds = [pilot.sd_at(s) for s in speeds]
        else:
            sds = [math.hypot(self.inertia_sd, self.inertia_relative_sd * inertia)] * len(speeds)
        return float(np.sqrt(np.mean(np.square(sds))))

    def gravity_se(self, mounting: Mounting) -> float:
        """SE of one quasi-static trial's gravity moment."""
        pilot = self.pilot(mounting)
        return pilot.gravity_moment_se if pilot is not None else self.gravity_moment_se


def _nominal(bodies: Mapping[str, Any]) -> dict[str, dict[str, float]]:
    """Bodies as ``{name: {mass, radius_of_gyration, com_distance}}`` (SI units)."""
    out = {}
    for name, value in bodies.items():
        if isinstance(value, Mapping):
            table = {p: value.get(p) for p in PARAMETERS}
        else:
            seq = list(value)
            if len(seq) != 3:
                raise InputError(
                    f"bodies.{name}: expected (mass, radius_of_gyration, com_distance), "
                    f"got {value!r}"
                )
            table = dict(zip(("mass", "radius_of_gyration", "com_distance"), seq, strict=True))
        unit = {"mass": "kg", "com_distance": "m", "radius_of_gyration": "m"}
        out[name] = {
            p: check_positive(table[p], f"bodies.{name}.{p}", unit[p]) for p in PARAMETERS
        }
    if not out:
        raise InputError("bodies: expected at least one body")
    return out


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
    nominal = _nominal(bodies)
    conditions = []
    for mount in design.mountings:
        total_a = total_b = 0.0
        for b in mount.bodies:
            v = nominal[b]
            a = v["mass"] * v["com_distance"]
            i = v["mass"] * (v["radius_of_gyration"] ** 2 + v["com_distance"] ** 2)
            if b == mount.offset_body:
                a, i = (float(t) for t in moved_moments(a, i, v["mass"], mount.offset))
            total_a += a
            total_b += i
        n = design.trials_per_speed * len(design.speeds)
        sd = noise.trial_sd(mount, total_b, design.speeds)
        obs_i = Observation(total_b, sd / math.sqrt(n), n - 1.0, n)
        se = noise.gravity_se(mount) / math.sqrt(design.quasi_static_trials)
        obs_g = Observation.from_mean_se(gravity * total_a, se, where=f"{mount.label} M_g")
        pilot = noise.pilot(mount)
        coupling = 0.0
        if pilot is not None:
            obs_i = obs_i.with_shared_error(pilot.shared_sd)
            coupling = pilot.coupling
        conditions.append(
            Condition(
                tuple(mount.bodies),
                obs_i,
                obs_g,
                label=mount.label,
                coupling=coupling,
                offset_body=mount.offset_body,
                offset=mount.offset,
            )
        )
    measured: dict[str, dict[str, Observation]] = {}
    for body, sd in design.weighed.items():
        measured.setdefault(body, {})["mass"] = Observation.from_mean_se(
            nominal[body]["mass"], sd, where=f"weighed.{body}"
        )
    for body, sd in design.balanced.items():
        measured.setdefault(body, {})["com_distance"] = Observation.from_mean_se(
            nominal[body]["com_distance"], sd, where=f"balanced.{body}"
        )
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


def _check_design(design: Design, nominal: Mapping[str, Any]) -> None:
    unknown = sorted(design.bodies() - set(nominal))
    if unknown:
        raise InputError(
            f"design '{design.name}': unknown body '{unknown[0]}' (bodies: {', '.join(nominal)})"
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
    for k, body in enumerate(widths.bodies):
        v = nominal[body]
        truth = {
            **v,
            "inertia": v["mass"] * (v["radius_of_gyration"] ** 2 + v["com_distance"] ** 2),
            "gravity_moment": gravity * v["mass"] * v["com_distance"],
        }
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
    nominal = _nominal(bodies)
    names = [d.name for d in designs]
    if not designs:
        raise InputError("designs: expected at least one design")
    if len(set(names)) != len(names):
        raise InputError(f"designs: names repeat: {names}")
    if not (_whole(max_trials_per_speed) and max_trials_per_speed >= 2):
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
        _check_design(d, nominal)
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


# -- inputs: a design file, a pilot ---------------------------------------------------------

_FILE_KEYS = {"name", "gravity", "hdi_prob", "bodies", "noise", "targets", "defaults", "designs",
              "max_trials_per_speed", "seed"}  # fmt: skip
_DESIGN_KEYS = {"name", "conditions", "trials_per_speed", "speeds", "quasi_static_trials",
                "priors", "weigh", "balance", "torque_gain_sd"}  # fmt: skip
_BODY_KEYS = {*PARAMETERS, "prior"}
_NOISE_KEYS = {"inertia_sd", "inertia_relative_sd", "gravity_moment_se"}


def _table(value: Any, where: str, keys: set[str] | None = None) -> dict:
    if not isinstance(value, Mapping):
        raise InputError(f"{where}: expected a table, got {value!r}")
    if keys is not None:
        unknown = sorted(set(value) - keys)
        if unknown:
            raise InputError(
                f"{where}: unknown key '{unknown[0]}' (expected {', '.join(sorted(keys))})"
            )
    return dict(value)


def _mountings(value: Any, where: str) -> tuple[Mounting, ...]:
    if not isinstance(value, list) or not value:
        raise InputError(f"{where}: expected a list of conditions (lists of bodies or tables)")
    out = []
    for i, item in enumerate(value):
        here = f"{where}[{i}]"
        if isinstance(item, list) and item and all(isinstance(b, str) for b in item):
            out.append(Mounting(tuple(item)))
            continue
        table = _table(item, here, {"bodies", "offset"})
        bodies = table.get("bodies")
        if not (isinstance(bodies, list) and bodies and all(isinstance(b, str) for b in bodies)):
            raise InputError(f"{here}.bodies: expected a list of body names")
        offset = _table(table.get("offset", {}), f"{here}.offset")
        if len(offset) > 1:
            raise InputError(f"{here}.offset: expected one body moved, got {offset!r}")
        if offset:
            body, d = next(iter(offset.items()))
            d = check_number(d, f"{here}.offset.{body}")
            if body not in bodies or not math.isfinite(d) or d == 0:
                raise InputError(
                    f"{here}.offset: expected a mounted body and a non-zero distance in m, "
                    f"got {offset!r}"
                )
            out.append(Mounting(tuple(bodies), str(body), float(d)))
        else:
            out.append(Mounting(tuple(bodies)))
    return tuple(out)


def _design(spec: Mapping[str, Any], defaults: Mapping[str, Any], where: str) -> Design:
    table = {**defaults, **_table(spec, where, _DESIGN_KEYS)}
    if "conditions" not in table:
        raise InputError(f"{where}: conditions: missing (here or in [defaults])")
    name = table.get("name", where)
    kwargs: dict[str, Any] = {
        "name": str(name),
        "mountings": _mountings(table["conditions"], f"{where}.conditions"),
    }
    for key in ("trials_per_speed", "quasi_static_trials"):
        if key in table:
            v = table[key]
            if isinstance(v, bool) or not isinstance(v, int):
                raise InputError(f"{where}.{key}: expected a whole number, got {v!r}")
            kwargs[key] = v
    if "speeds" in table:
        sp = table["speeds"]
        if not isinstance(sp, list) or not sp:
            raise InputError(f"{where}.speeds: expected a list of speeds in deg/s")
        kwargs["speeds"] = tuple(check_positive(s, f"{where}.speeds", "deg/s") for s in sp)
    if "torque_gain_sd" in table:
        kwargs["torque_gain_sd"] = check_number(table["torque_gain_sd"], f"{where}.torque_gain_sd")
    if "priors" in table:
        kwargs["priors"] = _table(table["priors"], f"{where}.priors")
    for key, attr in (("weigh", "weighed"), ("balance", "balanced")):
        if key in table:
            kwargs[attr] = {
                b: check_positive(sd, f"{where}.{key}.{b}")
                for b, sd in _table(table[key], f"{where}.{key}").items()
            }
    return Design(**kwargs)


def load_plan_file(path: str | Path) -> dict[str, Any]:
    """Read a design file (TOML): the keyword arguments of :func:`plan`.

    See docs/tutorials/planning.md for the format (``[bodies.<name>]`` nominal values and
    ``prior``, ``[noise]``, ``[targets]``, ``[defaults]``, ``[[designs]]``). Errors name the
    file and the key.
    """
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: design file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read design file ({exc})") from None
    try:
        return _plan_kwargs(doc, path)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None


def _plan_kwargs(doc: Mapping[str, Any], path: Path) -> dict[str, Any]:
    _table(doc, "design file", _FILE_KEYS)
    bodies = _table(doc.get("bodies"), "bodies")
    if not bodies:
        raise InputError("bodies: expected at least one [bodies.<name>] table")
    nominal, priors = {}, {}
    for name, spec in bodies.items():
        t = _table(spec, f"bodies.{name}", _BODY_KEYS)
        missing = [p for p in PARAMETERS if p not in t]
        if missing:
            raise InputError(f"bodies.{name}.{missing[0]}: missing (nominal value in SI units)")
        nominal[name] = {p: t[p] for p in PARAMETERS}
        if "prior" in t:
            prior = t["prior"]
            if (
                isinstance(prior, str)
                and not Path(prior).is_absolute()
                and (path.parent / prior).is_file()
            ):
                prior = str(path.parent / prior)
            try:
                priors[name] = load_prior(prior, name=name)
            except InputError as exc:
                raise InputError(f"bodies.{name}.prior: {exc}") from None
    noise_t = _table(doc.get("noise", {}), "noise", _NOISE_KEYS)
    levels: dict[str, Any] = {k: check_number(v, f"noise.{k}") for k, v in noise_t.items()}
    noise = NoiseLevels(**levels)
    defaults = _table(doc.get("defaults", {}), "defaults", _DESIGN_KEYS - {"name"})
    specs = doc.get("designs")
    if not isinstance(specs, list) or not specs:
        raise InputError("designs: expected at least one [[designs]] table")
    designs = [_design(s, defaults, f"designs[{i}]") for i, s in enumerate(specs)]
    out: dict[str, Any] = {
        "bodies": nominal,
        "designs": designs,
        "priors": priors,
        "noise": noise,
        "targets": {str(k): v for k, v in _table(doc.get("targets", {}), "targets").items()},
    }
    if "gravity" in doc:
        out["gravity"] = check_positive(doc["gravity"], "gravity", "m/s^2")
    if "hdi_prob" in doc:
        out["hdi_prob"] = check_probability(doc["hdi_prob"], "hdi_prob")
    if "max_trials_per_speed" in doc:
        out["max_trials_per_speed"] = doc["max_trials_per_speed"]
    return out


def pilot_inputs(folder: str | Path) -> dict[str, Any]:
    """What a pilot study's outputs say for planning: nominal values, priors, noise, conditions.

    Reads ``posterior.nc`` (posterior means as the nominal values, the priors, each
    condition's gravity-moment SE and gravity-model coupling) and ``trials.csv`` (the
    per-trial SD of the inertia per condition and speed; skipped trials left out) of a folder
    written by ``inertiafit run``.

    Returns
    -------
    dict
        ``bodies``, ``priors``, ``noise`` (keywords of :func:`plan`) and ``design``: the
        pilot's own design (its conditions, speeds, trials per speed, quasi-static trials).
    """
    from inertiafit.pipeline.redraw import priors_from_posterior
    from inertiafit.posterior import open_posterior

    folder = Path(folder)
    post_path, trials_path = folder / "posterior.nc", folder / "trials.csv"
    for p in (post_path, trials_path):
        if not p.is_file():
            raise InputError(f"{p}: not found (a pilot is the --out folder of 'inertiafit run')")
    post = open_posterior(post_path)
    try:
        trials = pd.read_csv(trials_path)
    except (pd.errors.ParserError, UnicodeDecodeError, pd.errors.EmptyDataError) as exc:
        raise InputError(f"{trials_path}: cannot read ({exc})") from None
    need = ["condition", "kind", "speed", "inertia"]
    missing = [c for c in need if c not in trials.columns]
    if missing:
        raise InputError(
            f"{trials_path}: column '{missing[0]}' missing (expected {', '.join(need)})"
        )
    if "status" in trials.columns:
        trials = trials[trials["status"].fillna("ok") != "skipped"]
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    conditions = {k: tuple(v) for k, v in inputs.get("conditions", {}).items()}
    if not conditions:
        raise InputError(f"{post_path}: no conditions stored (not written by 'inertiafit run')")
    cd = post.tree["constant_data"]
    labels = [str(c) for c in np.asarray(cd["condition"])]
    noise_by = {}
    tps, speeds_all, n_qs = [], set(), []
    for label, bodies in conditions.items():
        fast = trials[(trials["condition"] == label) & (trials["kind"] == "fast")]
        qs = trials[(trials["condition"] == label) & (trials["kind"] == "quasi-static")]
        by_speed = fast.groupby("speed")["inertia"]
        sds = {float(s): float(g.std(ddof=1)) for s, g in by_speed if len(g) >= 2}
        if not sds:
            raise InputError(
                f"{trials_path}: condition {label}: expected at least 2 fast trials at a speed"
            )
        tps.append(int(by_speed.size().max()))
        speeds_all |= set(sds)
        n_qs.append(max(len(qs), 1))
        if label not in labels:
            raise InputError(f"{post_path}: condition {label} has no stored evidence")
        sel = cd.sel(condition=label)
        se = float(sel["gravity_moment_scale"]) * math.sqrt(max(len(qs), 1))
        noise_by[_FROZEN(bodies)] = ConditionNoise(
            sds,
            se,
            coupling=float(sel["coupling"]) if "coupling" in sel else 0.0,
            shared_sd=float(sel["inertia_shared_sd"]) if "inertia_shared_sd" in sel else 0.0,
        )
    pooled = [sd for c in noise_by.values() for sd in c.inertia_sd.values()]
    noise = NoiseLevels(
        inertia_sd=float(np.sqrt(np.mean(np.square(pooled)))),
        gravity_moment_se=float(np.median([c.gravity_moment_se for c in noise_by.values()])),
        conditions=noise_by,
    )
    nominal = {b: {p: float(post.draws(b, p).mean()) for p in PARAMETERS} for b in post.bodies}
    gain_sd = float(cd["torque_gain_sd"]) if "torque_gain_sd" in cd else 0.0
    design = Design(
        "pilot",
        tuple(Mounting(tuple(v)) for v in conditions.values()),
        trials_per_speed=max(tps),
        speeds=tuple(sorted(speeds_all)),
        quasi_static_trials=max(n_qs),
        torque_gain_sd=gain_sd,
    )
    return {
        "bodies": nominal,
        "priors": priors_from_posterior(post),
        "noise": noise,
        "gravity": float(cd["gravity"]),
        "design": design,
    }


def run_plan(
    design_file: str | Path | None = None,
    *,
    pilot: str | Path | None = None,
    out: str | Path,
    trials_per_speed: Sequence[int] = (),
    weigh: Mapping[str, float] | None = None,
    offsets: Mapping[str, Sequence[float]] | None = None,
    targets: Mapping[str, float] | None = None,
    hdi_prob: float | None = None,
    seed: int = 0,
    formats: tuple[str, ...] = ("pdf", "png"),
    echo: Callable[[str], None] = print,
) -> PlanResult:
    """``inertiafit plan``: predictions of a design file or of a pilot's variants, written.

    With ``design_file`` its designs; with ``pilot`` (a folder written by ``inertiafit run``)
    the pilot's own design and its variants: every count of ``trials_per_speed``, each body of
    ``weigh`` weighed with that SD (kg), each body of ``offsets`` moved in a second mounting at
    each offset (m). ``targets`` and ``hdi_prob`` override the file's. Writes ``plan.csv``,
    ``plan-search.csv`` (with targets) and ``plan.pdf``/``.png`` into ``out`` (replaced whole)
    and echoes the table.
    """
    from inertiafit.io.outputs import output_folder, write_csv
    from inertiafit.plotting.style import save_figure

    check_seed(seed)
    if (design_file is None) == (pilot is None):
        raise InputError("plan: give a design file or a pilot folder (one of them)")
    if design_file is not None:
        kwargs = load_plan_file(design_file)
        if trials_per_speed or weigh or offsets:
            extra = []
            for d in kwargs["designs"]:
                extra += _variants(d, trials_per_speed, weigh or {}, offsets or {})
            kwargs["designs"] = kwargs["designs"] + extra
    else:
        info = pilot_inputs(pilot)  # type: ignore[arg-type]
        base = info.pop("design")
        kwargs = {
            **info,
            "designs": [base, *_variants(base, trials_per_speed, weigh or {}, offsets or {})],
        }
    if targets:
        kwargs["targets"] = {**kwargs.get("targets", {}), **targets}
    if hdi_prob is not None:
        kwargs["hdi_prob"] = check_probability(hdi_prob, "hdi_prob")
    result = plan(**kwargs, seed=seed)
    with output_folder(out) as folder:
        write_csv(result.table, folder / "plan.csv")
        if len(result.search):
            write_csv(result.search, folder / "plan-search.csv")
        save_figure(result.figure(), folder / "plan", formats)
    echo(result.text())
    echo(f"({len(result.table['design'].unique())} designs predicted in {result.seconds:.1f} s)")
    return result


def _variants(
    base: Design,
    trials_per_speed: Sequence[int],
    weigh: Mapping[str, float],
    offsets: Mapping[str, Sequence[float]],
) -> list[Design]:
    """Variants of ``base``: other trial counts, a weighed body, a body's second mounting."""
    out = []
    for n in trials_per_speed:
        out.append(replace(base, name=f"{base.name}, {n} per speed", trials_per_speed=int(n)))
    for body, sd in weigh.items():
        out.append(
            replace(base, name=f"{base.name}, {body} weighed", weighed={**base.weighed, body: sd})
        )
    for body, ds in offsets.items():
        holding = [m for m in base.mountings if body in m.bodies and not m.offset_body]
        if not holding:
            raise InputError(f"offsets: body '{body}' is in no condition of '{base.name}'")
        for d in ds:
            moved = Mounting(holding[-1].bodies, body, float(d))
            out.append(
                replace(
                    base,
                    name=f"{base.name}, {body} also at +{d:g} m",
                    mountings=(*base.mountings, moved),
                )
            )
    return out


def simulated_widths(
    bodies: Mapping[str, Any],
    design: Design,
    *,
    priors: Mapping[str, Any] | None = None,
    replicates: int = 4,
    seed: int = 0,
    hdi_prob: float = 0.95,
    folder: str | Path,
    noise: Any = None,
) -> pd.DataFrame:
    """What :func:`plan` predicts, measured: full simulated studies of ``design``.

    ``replicates`` studies are simulated (:func:`~inertiafit.simulate.simulate_study`, trial
    files at 1 kHz with ``noise``, default :meth:`~inertiafit.simulate.Noise.paper`) with the
    nominal values as the truth, and each runs through
    :func:`~inertiafit.pipeline.study.analyse_study`. A second mounting is a condition with
    its body moved (``offset``); a weighed body or a balance point is written into the
    manifest with the design's SD, its reading drawn from the truth with that SD (a fresh
    draw per study, as a real scale's would be), where :func:`plan` centres it on the truth.
    Returns a row per body and parameter: the mean over the replicates of the posterior
    ``sd`` and HDI width (``hdi_width``), and the SDs of both over replicates (``sd_sd``,
    ``hdi_width_sd``: the Monte Carlo SE of the means is these over ``sqrt(replicates)``).
    Written under ``folder``. Designs with one quasi-static trial per condition and no
    torque-gain SD only (the simulator writes one quasi-static trial and no calibration).
    """
    from inertiafit.pipeline.study import analyse_study
    from inertiafit.simulate import Noise, simulate_study

    if design.quasi_static_trials != 1:
        raise InputError("simulated_widths: the simulator writes one quasi-static trial")
    if design.torque_gain_sd:
        raise InputError("simulated_widths: torque_gain_sd: the simulator writes no calibration")
    if not (_whole(replicates) and replicates >= 2):
        raise InputError(f"simulated_widths: replicates: expected >= 2, got {replicates!r}")
    nominal = _nominal(bodies)
    _check_design(design, nominal)
    used = [b for b in nominal if any(b in m.bodies for m in design.mountings)]
    specs: dict[str, Any] = {}
    for b in used:
        spec = {**(priors or {}), **design.priors}.get(b)
        if spec is not None:
            if isinstance(spec, Prior):
                raise InputError(f"simulated_widths: prior of '{b}': give a name or a table")
            specs[b] = spec
    conditions: list[Any] = [
        {"bodies": m.bodies, "offset": {m.offset_body: m.offset}} if m.offset_body else m.bodies
        for m in design.mountings
    ]
    measured: dict[str, dict[str, float]] = {}
    for b, sd in design.weighed.items():
        measured.setdefault(b, {})["mass"] = float(sd)
    for b, sd in design.balanced.items():
        measured.setdefault(b, {})["com_distance"] = float(sd)
    rows = []
    for r in range(replicates):
        manifest = simulate_study(
            Path(folder) / f"{design.name}-{r}".replace(" ", "_").replace("/", "_"),
            bodies={
                b: (
                    nominal[b]["mass"],
                    nominal[b]["radius_of_gyration"],
                    nominal[b]["com_distance"],
                )
                for b in used
            },
            conditions=conditions,
            speeds=design.speeds,
            trials_per_speed=design.trials_per_speed,
            seed=seed + r,
            noise=Noise.paper() if noise is None else noise,
            priors=specs,
            measured={b: m for b, m in measured.items() if b in used} or None,
        )
        result = analyse_study(manifest, seed=seed + r, hdi_prob=hdi_prob)
        s = result.posterior.summary(hdi_prob)
        s["hdi_width"] = s["hdi_upper"] - s["hdi_lower"]
        s["replicate"] = r
        rows.append(s[["replicate", "body", "parameter", "sd", "hdi_width"]])
    all_rows = pd.concat(rows)
    out = all_rows.groupby(["body", "parameter"], sort=False).agg(
        sd=("sd", "mean"),
        hdi_width=("hdi_width", "mean"),
        sd_sd=("sd", "std"),
        hdi_width_sd=("hdi_width", "std"),
    )
    return out.reset_index()
