"""The planner's inputs from files: a design file (TOML) and a pilot study's outputs.

:func:`load_plan_file` reads a design file into the keyword arguments of
:func:`~inertiafit.planning.planner.plan` (docs/tutorials/planning.md gives the format);
:func:`pilot_inputs` reads what a pilot study written by ``inertiafit run`` says for planning:
the per-trial scatter of ``trials.csv`` and the gravity moments' standard errors and
gravity-model coupling stored in ``posterior.nc``.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from inertiafit._checks import check_number, check_positive, check_probability
from inertiafit.errors import InputError
from inertiafit.inference.priors import load_prior, priors_from_posterior
from inertiafit.io.manifest import read_passive, read_postures
from inertiafit.measured import MEASURED_QUANTITIES
from inertiafit.mounting import Mounting
from inertiafit.physics import PARAMETERS
from inertiafit.planning.design import ConditionNoise, Design, NoiseLevels
from inertiafit.processing.living import PostureGeometry, posture_geometry

__all__ = ["load_plan_file", "pilot_inputs"]

_FILE_KEYS = {"name", "gravity", "hdi_prob", "bodies", "noise", "targets", "defaults", "designs",
              "max_trials_per_speed", "seed", "passive", "postures"}  # fmt: skip
_DESIGN_KEYS = {"name", "conditions", "trials_per_speed", "speeds", "quasi_static_trials",
                "priors", "torque_gain_sd", "postures", "rest_trials", "rotation_sweeps",
                *(q.plan_key for q in MEASURED_QUANTITIES.values())}  # fmt: skip
_BODY_KEYS = {*PARAMETERS, "prior", "living"}
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
            out.append(_mounting(here, tuple(item)))
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
            out.append(_mounting(here, tuple(bodies), str(body), float(d)))
        else:
            out.append(_mounting(here, tuple(bodies)))
    return tuple(out)


def _mounting(where: str, *args: Any) -> Mounting:
    """A :class:`Mounting`, its refusal (a body listed twice, ...) naming the file and entry."""
    try:
        return Mounting(*args)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


@dataclass(frozen=True)
class _Living:
    """A design file's living body, its ``[passive]`` prior and its ``[postures]``."""

    body: str = ""
    passive: Any = None
    postures: Mapping[str, PostureGeometry] = field(default_factory=dict)

    def design_kwargs(self, table: Mapping[str, Any], where: str) -> dict[str, Any]:
        if not self.body:
            for key in ("postures", "rest_trials", "rotation_sweeps"):
                if key in table:
                    raise InputError(f"{where}.{key}: for a living body (living = true)")
            return {}
        names = table.get("postures", list(self.postures)[:1])
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise InputError(f"{where}.postures: expected a list of posture names")
        unknown = [n for n in names if n not in self.postures]
        if unknown:
            raise InputError(
                f"{where}.postures: unknown posture '{unknown[0]}' (defined: "
                f"{', '.join(self.postures) or 'none; add [postures.<name>] tables'})"
            )
        out: dict[str, Any] = {
            "living": self.body,
            "passive": self.passive,
            "postures": tuple(self.postures[n] for n in names),
        }
        if "rest_trials" in table:
            v = table["rest_trials"]
            if isinstance(v, bool) or not isinstance(v, int):
                raise InputError(f"{where}.rest_trials: expected a whole number, got {v!r}")
            out["rest_trials"] = v
        if "rotation_sweeps" in table:
            v = table["rotation_sweeps"]
            if not isinstance(v, bool):
                raise InputError(f"{where}.rotation_sweeps: expected true or false, got {v!r}")
            out["rotation_sweeps"] = v
        return out


def _living(doc: Mapping[str, Any], bodies: Mapping[str, Any]) -> _Living:
    """The design file's living body (``living = true``, at most one) and its joint."""
    living = []
    for name, spec in bodies.items():
        flag = spec.get("living", False) if isinstance(spec, Mapping) else False
        if not isinstance(flag, bool):
            raise InputError(f"bodies.{name}.living: expected true or false, got {flag!r}")
        if flag:
            living.append(name)
    if len(living) > 1:
        raise InputError(
            f"bodies: {' and '.join(living)} are both living; one living body per study"
        )
    body = living[0] if living else ""
    passive = read_passive(doc.get("passive"), living=body, where="design file")
    postures = {
        n: posture_geometry(p)
        for n, p in read_postures(doc.get("postures", {}), where="design file").items()
    }
    return _Living(body, passive, postures)


def _design(
    spec: Mapping[str, Any], defaults: Mapping[str, Any], where: str, living: _Living
) -> Design:
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
    for q in MEASURED_QUANTITIES.values():
        if q.plan_key in table:
            kwargs[q.design_field] = {
                b: check_positive(sd, f"{where}.{q.plan_key}.{b}")
                for b, sd in _table(table[q.plan_key], f"{where}.{q.plan_key}").items()
            }
    kwargs.update(living.design_kwargs(table, where))
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
        t.pop("living", None)
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
    living = _living(doc, bodies)
    designs = [_design(s, defaults, f"designs[{i}]", living) for i, s in enumerate(specs)]
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
        trials = trials[trials["status"].fillna("ok") == "ok"]  # not skipped or excluded
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
        noise_by[frozenset(bodies)] = ConditionNoise(
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
