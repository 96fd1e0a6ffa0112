"""Priors for a body's inertial parameters, read from small TOML files.

A prior file holds a ``description``, a ``source``, an optional top-level ``spread`` (default
0.5, the paper's +-50 % box) and one table per parameter::

    description = "Biodex elbow attachment as an ideal square tube"
    source = "Son et al., Table 2 (ideal row)"
    spread = 0.5
    [mass]
    nominal = 2.91
    unit = "kg"
    [radius_of_gyration]
    nominal = 0.130
    unit = "m"
    spread = 0.3            # this parameter's own spread, or
    [com_distance]
    nominal = 0.225
    unit = "m"
    lower = 0.15            # explicit bounds instead of a spread
    upper = 0.30

A parameter table may instead name another ``distribution`` (default ``"uniform"``, the box
above); its support is the box every model keeps using (:attr:`Prior.lower`, :attr:`Prior.upper`):

* ``"normal"``: ``mean``, ``sd`` (in ``unit``); support ``mean +- 4.753 sd`` (the 1e-6 and
  1 - 1e-6 quantiles), which must be positive;
* ``"lognormal"``: ``median`` (in ``unit``) and ``sd_log``, the SD of the natural logarithm
  (a geometric SD of ``exp(sd_log)``); support ``median * exp(+-4.753 sd_log)``;
* ``"truncated-normal"``: ``mean``, ``sd``, ``lower``, ``upper`` (the support).

The density outside the support is zero (the normal and lognormal lose 2e-6 of their mass).

An optional ``[reference]`` table carries published values to print beside the posterior
(``label``, ``mass``, ``com_distance``, ``radius_of_gyration``, ``inertia`` in SI units).
Files are parsed against this schema; nothing in them is executed.

A table may instead name a population written by ``inertiafit population``,
``population = "OUT/population.nc"`` with ``body`` and the new subject's covariates: a
lognormal prior per parameter from the population's predictive distribution
(:func:`inertiafit.inference.population.population_prior_table`).

A table (a file, or an inline manifest table) may instead name an anthropometric table,
``anthropometric = "de-leva-male"``, with ``segment``, ``body_mass`` and ``segment_length``:
a lognormal prior per parameter from the published fractions (:mod:`.anthropometric`,
:func:`anthropometric_prior`).
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import special

from inertiafit._checks import check_finite, check_positive
from inertiafit.errors import InputError
from inertiafit.inference import anthropometric, population
from inertiafit.io.shipped import shipped_dirs
from inertiafit.io.units import si_factors
from inertiafit.physics import PARAMETERS, UNITS

if TYPE_CHECKING:
    from inertiafit.posterior import Posterior

__all__ = [
    "DEFAULT_SPREAD",
    "DISTRIBUTIONS",
    "SUPPORT_QUANTILE",
    "Prior",
    "anthropometric_prior",
    "available_priors",
    "load_prior",
    "parse_prior",
    "priors_from_posterior",
]

DEFAULT_SPREAD = 0.5

#: Distributions a parameter's prior may have, and the keys each takes besides ``unit``,
#: ``label`` and ``distribution`` (required keys first; ``uniform`` needs ``nominal`` and
#: ``spread`` or ``lower``/``upper`` optionally).
DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "uniform": ("nominal", "spread", "lower", "upper"),
    "normal": ("mean", "sd"),
    "lognormal": ("median", "sd_log"),
    "truncated-normal": ("mean", "sd", "lower", "upper"),
}

#: Lower tail mass cut off at each end of the support of a normal or lognormal prior.
SUPPORT_QUANTILE = 1e-6
_Q = float(-special.ndtri(SUPPORT_QUANTILE))  # 4.753 SDs

# Each parameter's quantity in the unit table of inertiafit.io.units; a prior file's ``unit``
# must be one of its canonical spellings (kg, g; m, cm, mm), exactly as written.
_QUANTITY = {"mass": "mass", "com_distance": "length", "radius_of_gyration": "length"}
_TOP_KEYS = {"name", "description", "source", "spread", "reference", *PARAMETERS}
_PARAM_KEYS = {"distribution", "unit", "label", *(k for v in DISTRIBUTIONS.values() for k in v)}
_REFERENCE_KEYS = {"label", "inertia", "gravity_moment", *PARAMETERS}


@dataclass(frozen=True)
class Prior:
    """Prior on ``(mass, com_distance, radius_of_gyration)`` of one body: independent parameters.

    Each parameter is uniform on its bounds (the box, the default) or has one of the
    :data:`DISTRIBUTIONS`, whose support the bounds are.

    Attributes
    ----------
    name : str
        Short name (the file stem for shipped priors); used as the body label.
    nominal : dict[str, float]
        Nominal value per parameter in SI units (kg, m, m).
    lower, upper : dict[str, float]
        Bounds of the box per parameter in SI units; ``0 < lower < upper``.
    description, source : str
        What the body is and where the numbers come from.
    reference : dict[str, Any]
        Optional published values (SI units) to show beside the posterior.
    path : pathlib.Path or None
        The file it was read from.
    distribution : dict[str, dict[str, Any]]
        Per parameter that is not uniform: ``{"kind": "normal", "mean": .., "sd": ..}``,
        ``{"kind": "lognormal", "median": .., "sd_log": ..}`` or
        ``{"kind": "truncated-normal", "mean": .., "sd": ..}`` (SI units; the truncation bounds
        are ``lower``/``upper``). A parameter missing here is uniform on its bounds.
    anthropometric : dict[str, str]
        For a prior from an anthropometric table: its ``table``, ``sex`` and ``segment`` as
        given (``inertiafit export`` reads the segment's other radii of gyration from them);
        empty otherwise.
    """

    name: str
    nominal: dict[str, float]
    lower: dict[str, float]
    upper: dict[str, float]
    description: str = ""
    source: str = ""
    reference: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None
    distribution: dict[str, dict[str, Any]] = field(default_factory=dict)
    anthropometric: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # Built directly (not by parse_prior): a missing key would fail later as a KeyError.
        where = f"Prior {self.name!r}"
        for attr in ("nominal", "lower", "upper"):
            table = getattr(self, attr)
            if not isinstance(table, dict):
                raise InputError(f"{where}: {attr}: expected a dict by parameter, got {table!r}")
            for p in PARAMETERS:
                if p not in table:
                    raise InputError(
                        f"{where}: {attr}: missing {p!r} (expected {', '.join(PARAMETERS)})"
                    )
                check_positive(table[p], f"{where}: {attr}.{p}")
        for p in PARAMETERS:
            if not self.lower[p] < self.upper[p]:
                raise InputError(
                    f"{where}: {p}: expected lower < upper, got {self.lower[p]!r} and "
                    f"{self.upper[p]!r}"
                )
        for p, d in self.distribution.items():
            kind = d.get("kind") if isinstance(d, dict) else None  # type: ignore[redundant-expr]
            if p not in PARAMETERS or kind not in DISTRIBUTIONS:
                raise InputError(
                    f"{where}: distribution.{p}: expected a parameter ({', '.join(PARAMETERS)}) "
                    f"with a kind ({', '.join(DISTRIBUTIONS)}), got {d!r}"
                )
            for key in ("median", "sd_log") if kind == "lognormal" else ("mean", "sd"):
                if kind != "uniform" and key not in d:
                    raise InputError(f"{where}: distribution.{p}: missing {key!r} ({kind})")

    def kind(self, parameter: str) -> str:
        """The parameter's distribution: ``uniform``, ``normal``, ``lognormal`` or ..."""
        return str(self.distribution.get(parameter, {}).get("kind", "uniform"))

    @property
    def is_box(self) -> bool:
        """Whether every parameter is uniform (the closed-form box)."""
        return all(self.kind(p) == "uniform" for p in PARAMETERS)

    def log_density(
        self, mass, com_distance, radius_of_gyration, *, check_support: bool = True
    ) -> np.ndarray:
        """Log prior density of ``(m, x, rho)`` up to a constant; ``-inf`` outside the bounds.

        The constant is the same everywhere (each parameter's truncation mass is left out).
        ``check_support=False`` skips the bounds (for points known to lie inside them); a
        uniform parameter's values are then not read and may be ``None``.
        """
        values = (mass, com_distance, radius_of_gyration)
        out = self._log_density_inside(values)
        if not check_support:  # the samplers' path
            return out
        # Every NaN of a shape term comes from a value outside its own bounds (a lognormal's
        # v <= 0, a NaN), which the bounds set to -inf here.
        for p, raw in zip(PARAMETERS, values, strict=True):
            if raw is None:
                raise ValueError(f"log_density: {p} is needed to check the bounds")
            v = np.asarray(raw, dtype=float)
            with np.errstate(invalid="ignore"):
                out[~((v >= self.lower[p]) & (v <= self.upper[p]))] = -np.inf
        return out

    def _log_density_inside(self, values) -> np.ndarray:
        """:meth:`log_density` without the bounds, from the constants of :attr:`_shapes`."""
        log_scale, shapes = self._shapes
        shape = np.broadcast(*(v for v in values if v is not None)).shape
        out = np.full(shape, -log_scale)
        with np.errstate(divide="ignore", invalid="ignore"):
            for i, p, lognormal, center, scale in shapes:
                raw = values[i]
                if raw is None:
                    raise ValueError(f"log_density: {p} is needed (not uniform)")
                v = np.asarray(raw, dtype=float)
                if lognormal:
                    log_v = np.log(v)
                    z = (log_v - center) / scale
                    out -= 0.5 * z * z + log_v
                else:
                    z = (v - center) / scale
                    out -= 0.5 * z * z
        return out

    @cached_property
    def _shapes(self) -> tuple[float, tuple[tuple[int, str, bool, float, float], ...]]:
        """The constants of :meth:`log_density`, computed once (a prior is not changed once made).

        :attr:`_log_scale` and, per parameter that is not uniform, its index, name, whether it
        is lognormal and the centre and scale of its ``z``.
        """
        shapes = []
        for i, p in enumerate(PARAMETERS):
            d = self.distribution.get(p, {})
            kind = d.get("kind", "uniform")
            if kind == "lognormal":
                shapes.append((i, p, True, math.log(d["median"]), d["sd_log"]))
            elif kind != "uniform":  # normal, truncated-normal
                shapes.append((i, p, False, d["mean"], d["sd"]))
        return self._log_scale, tuple(shapes)

    @property
    def _log_scale(self) -> float:
        """Constant part of ``-log_density``: each parameter's ``log(width)`` or ``log(sd)``."""
        total = 0.0
        for p in PARAMETERS:
            d = self.distribution.get(p, {})
            kind = d.get("kind", "uniform")
            if kind == "uniform":
                total += math.log(self.upper[p] - self.lower[p])
            else:
                total += math.log(d["sd_log" if kind == "lognormal" else "sd"])
        return total

    @classmethod
    def box(
        cls,
        name: str,
        *,
        mass: float,
        com_distance: float,
        radius_of_gyration: float,
        spread: float = DEFAULT_SPREAD,
        description: str = "",
        source: str = "",
    ) -> Prior:
        """Build the box ``nominal x (1 +- spread)`` around nominal values in SI units."""
        table = {
            "mass": mass,
            "com_distance": com_distance,
            "radius_of_gyration": radius_of_gyration,
            "spread": spread,
            "description": description,
            "source": source,
        }
        return parse_prior(table, name=name, where=f"prior '{name}'")

    @property
    def bounds(self) -> np.ndarray:
        """Array ``(3, 2)`` of ``[lower, upper]`` in the order of :data:`PARAMETERS`."""
        return np.array([[self.lower[p], self.upper[p]] for p in PARAMETERS])

    def contains(self, mass, com_distance, radius_of_gyration) -> np.ndarray:
        """Boolean mask of points inside the box (arrays broadcast)."""
        inside = np.ones(np.broadcast(mass, com_distance, radius_of_gyration).shape, bool)
        for p, v in zip(PARAMETERS, (mass, com_distance, radius_of_gyration), strict=True):
            inside &= (np.asarray(v) >= self.lower[p]) & (np.asarray(v) <= self.upper[p])
        return inside

    def sample(self, size: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Independent draws from the prior, a dict of arrays of length ``size`` (SI units).

        A uniform parameter takes ``rng.uniform(lower, upper, size)`` (so a box's draws are those
        of earlier versions); the others one uniform each, through the inverse CDF.
        """
        out = {}
        for p in PARAMETERS:
            lo, hi = self.lower[p], self.upper[p]
            d = self.distribution.get(p, {})
            kind = d.get("kind", "uniform")
            if kind == "uniform":
                out[p] = rng.uniform(lo, hi, size)
                continue
            if kind == "lognormal":
                mu, sd, lo, hi = math.log(d["median"]), d["sd_log"], math.log(lo), math.log(hi)
            else:
                mu, sd = d["mean"], d["sd"]
            out[p] = _truncated_normal_quantile(rng.uniform(size=size), mu, sd, lo, hi)
            if kind == "lognormal":
                out[p] = np.exp(out[p])
        return out

    def describe(self) -> str:
        """One line per parameter: its distribution and bounds with units."""
        lines = [f"prior '{self.name}': {self.description}".rstrip(": ")]
        for p in PARAMETERS:
            d = self.distribution.get(p, {})
            kind = d.get("kind", "uniform")
            u = UNITS[p]
            if kind == "uniform":
                what = f"nominal {self.nominal[p]:.4g} {u}, uniform"
            elif kind == "lognormal":
                what = f"lognormal, median {d['median']:.4g} {u}, sd of log {d['sd_log']:.4g}"
            else:
                what = f"{kind}, mean {d['mean']:.4g} {u}, sd {d['sd']:.4g} {u}"
            lines.append(f"  {p:<19} {what} on [{self.lower[p]:.4g}, {self.upper[p]:.4g}]")
        if self.source:
            lines.append(f"  source: {self.source}")
        return "\n".join(lines)


def _truncated_normal_quantile(u, mean: float, sd: float, lower: float, upper: float):
    """The quantile ``u`` (in ``[0, 1)``) of ``N(mean, sd^2)`` truncated to ``[lower, upper]``.

    Computed in the tail nearer the mean (the upper tail is mirrored), so bounds far out on one
    side lose no precision.
    """
    alpha, beta = (lower - mean) / sd, (upper - mean) / sd
    if alpha > 0:  # both bounds above the mean: mirror
        return mean - sd * special.ndtri(
            special.ndtr(-alpha) - np.asarray(u) * (special.ndtr(-alpha) - special.ndtr(-beta))
        )
    c0, c1 = special.ndtr(alpha), special.ndtr(beta)
    return np.clip(mean + sd * special.ndtri(c0 + np.asarray(u) * (c1 - c0)), lower, upper)


def parse_prior(
    table: dict[str, Any], *, name: str, where: str, path: Path | None = None
) -> Prior:
    """Validate a prior table (from a TOML file or an inline manifest table).

    Parameters may be tables (``nominal``, ``unit``, ``spread`` or ``lower``/``upper``) or
    plain numbers (a nominal in SI units), as in a manifest's inline
    ``prior = { mass = 2.92, radius_of_gyration = 0.035, com_distance = 0.45 }``.

    Raises
    ------
    InputError
        On unknown keys, a missing parameter or nominal, non-positive values, a bad unit,
        ``lower >= upper`` or a nominal outside its bounds; the message names ``where`` and
        the field.
    """
    if not isinstance(table, dict):
        raise InputError(f"{where}: expected a table of prior parameters, got {table!r}")
    segment: dict[str, str] = {}
    if "population" in table:
        table = population.population_prior_table(table, where=where, body=name)
    if "anthropometric" in table:
        segment = {k: str(table[k]) for k in ("anthropometric", "sex", "segment") if k in table}
        table = anthropometric.prior_table(table, where=where)
    unknown = sorted(set(table) - _TOP_KEYS)
    if unknown:
        raise InputError(
            f"{where}: unknown key '{unknown[0]}' (allowed: {', '.join(sorted(_TOP_KEYS))})"
        )
    spread = check_finite(table.get("spread", DEFAULT_SPREAD), where, field="spread")
    if not 0 < spread < 1:
        raise InputError(f"{where}: 'spread' must lie in (0, 1), got {spread}")
    nominal, lower, upper, distribution = {}, {}, {}, {}
    for p in PARAMETERS:
        if p not in table:
            raise InputError(f"{where}: missing parameter table '[{p}]' (with 'nominal')")
        entry = table[p]
        if not isinstance(entry, dict):
            entry = {"nominal": entry}
        bad = sorted(set(entry) - _PARAM_KEYS)
        if bad:
            raise InputError(
                f"{where}: unknown key '{p}.{bad[0]}' (allowed: {', '.join(sorted(_PARAM_KEYS))})"
            )
        kind = entry.get("distribution", "uniform")
        if kind not in DISTRIBUTIONS:
            raise InputError(
                f"{where}: '{p}.distribution' is {kind!r}; expected one of "
                f"{', '.join(DISTRIBUTIONS)}"
            )
        allowed = {"distribution", "unit", "label", *DISTRIBUTIONS[kind]}
        bad = sorted(set(entry) - allowed)
        if bad:
            raise InputError(
                f"{where}: '{p}.{bad[0]}' is not a parameter of a {kind} prior "
                f"(allowed: {', '.join(sorted(allowed - {'distribution', 'label'}))})"
            )
        unit = entry.get("unit", UNITS[p])
        factors = si_factors(_QUANTITY[p])
        if unit not in factors:
            raise InputError(
                f"{where}: '{p}.unit' is {unit!r}; expected one of {', '.join(factors)}"
            )
        scale = factors[unit]
        if kind == "uniform":
            nom, lo, hi = _uniform_bounds(entry, p, spread, scale, where)
        else:
            nom, lo, hi, distribution[p] = _shaped_bounds(entry, p, kind, scale, where)
        if lo < 0 or (lo == 0 and p == "mass"):
            raise InputError(f"{where}: '{p}.lower' must be positive, got {lo / scale:g}")
        if lo >= hi:
            raise InputError(
                f"{where}: '{p}.lower' ({lo / scale:g}) must be below '{p}.upper' ({hi / scale:g})"
            )
        if kind == "uniform" and not lo <= nom <= hi:
            raise InputError(
                f"{where}: '{p}.nominal' ({nom / scale:g}) lies outside "
                f"[{lo / scale:g}, {hi / scale:g}]"
            )
        nominal[p], lower[p], upper[p] = nom, lo, hi
    reference = table.get("reference", {})
    if not isinstance(reference, dict):
        raise InputError(f"{where}: 'reference' must be a table")
    bad = sorted(set(reference) - _REFERENCE_KEYS)
    if bad:
        raise InputError(f"{where}: unknown key 'reference.{bad[0]}'")
    ref = {
        k: (v if k == "label" else check_finite(v, where, field=f"reference.{k}"))
        for k, v in reference.items()
    }
    for key in ("description", "source"):
        if not isinstance(table.get(key, ""), str):
            raise InputError(f"{where}: '{key}' must be a string")
    return Prior(
        name=str(table.get("name", name)),
        nominal=nominal,
        lower=lower,
        upper=upper,
        description=table.get("description", ""),
        source=table.get("source", ""),
        reference=ref,
        path=path,
        distribution=distribution,
        anthropometric=segment,
    )


def anthropometric_prior(
    table: str,
    segment: str,
    body_mass: float,
    segment_length: float | None = None,
    *,
    sex: str | None = None,
    segment_lengths: dict[str, float] | None = None,
    name: str | None = None,
) -> Prior:
    """A segment's prior from a published anthropometric table (lognormal per parameter).

    Medians are the table's values for this subject (``m = fraction x body_mass``,
    ``x = CoM fraction x segment_length`` from the proximal joint, ``rho = radius fraction x
    segment_length`` about the CoM); each ``sd_log`` is the table file's population spread.

    Parameters
    ----------
    table : str
        ``"de-leva-female"``, ``"de-leva-male"`` or ``"dempster"`` (also ``"dempster-winter"``,
        or ``"de-leva"`` with ``sex``).
    segment : str
        ``forearm``, ``hand``, ``forearm+hand``, ``upper-arm``, ``shank``, ``foot``,
        ``shank+foot`` or ``thigh`` (de Leva has no foot nor shank + foot about a joint axis).
    body_mass : float
        kg.
    segment_length : float
        m; for ``forearm+hand`` and ``shank+foot`` the forearm's or the shank's length.
    sex : str, optional
        ``"female"`` or ``"male"`` when ``table`` names none.
    segment_lengths : dict, optional
        de Leva's forearm + hand: ``{"forearm": .., "hand": ..}`` (m) instead of
        ``segment_length`` and the mean hand/forearm ratio.
    name : str, optional
        The body's name (default: the segment's).

    Raises
    ------
    InputError
        Unknown table or segment, a missing or absurd mass or length (one line).
    """
    spec: dict[str, Any] = {
        "anthropometric": table,
        "segment": segment,
        "body_mass": body_mass,
    }
    for key, value in (
        ("segment_length", segment_length),
        ("segment_lengths", segment_lengths),
        ("sex", sex),
    ):
        if value is not None:
            spec[key] = value
    label = name or str(segment)
    return parse_prior(spec, name=label, where=f"prior of '{label}'")


def _uniform_bounds(entry: dict, p: str, spread: float, scale: float, where: str):
    """``(nominal, lower, upper)`` of a uniform parameter (SI units)."""
    if "nominal" not in entry:
        raise InputError(f"{where}: '{p}.nominal' is missing (a positive number)")
    nom = check_finite(entry["nominal"], where, field=f"{p}.nominal") * scale
    if nom <= 0:
        raise InputError(f"{where}: '{p}.nominal' must be positive, got {entry['nominal']}")
    own_spread = check_finite(entry.get("spread", spread), where, field=f"{p}.spread")
    if not 0 < own_spread < 1:
        raise InputError(f"{where}: '{p}.spread' must lie in (0, 1), got {own_spread}")
    if ("lower" in entry) != ("upper" in entry):
        raise InputError(f"{where}: give both '{p}.lower' and '{p}.upper', or neither")
    if "lower" in entry:
        if "spread" in entry:
            raise InputError(f"{where}: give '{p}.spread' or '{p}.lower'/'upper', not both")
        lo = check_finite(entry["lower"], where, field=f"{p}.lower") * scale
        hi = check_finite(entry["upper"], where, field=f"{p}.upper") * scale
    else:
        lo, hi = nom * (1 - own_spread), nom * (1 + own_spread)
    return nom, lo, hi


def _shaped_bounds(entry: dict, p: str, kind: str, scale: float, where: str):
    """``(nominal, lower, upper, distribution)`` of a normal, lognormal or truncated normal."""
    for key in DISTRIBUTIONS[kind]:
        if key not in entry:
            raise InputError(f"{where}: '{p}.{key}' is missing (a {kind} prior needs it)")
    values = {k: check_finite(entry[k], where, field=f"{p}.{k}") for k in DISTRIBUTIONS[kind]}
    spread_key = "sd_log" if kind == "lognormal" else "sd"
    if values[spread_key] <= 0:
        raise InputError(f"{where}: '{p}.{spread_key}' must be positive, got {entry[spread_key]}")
    if kind == "lognormal":
        median, sd_log = values["median"] * scale, values["sd_log"]
        if median <= 0:
            raise InputError(f"{where}: '{p}.median' must be positive, got {entry['median']}")
        return (
            median,
            median * math.exp(-_Q * sd_log),
            median * math.exp(_Q * sd_log),
            {"kind": kind, "median": median, "sd_log": sd_log},
        )
    mean, sd = values["mean"] * scale, values["sd"] * scale
    if kind == "normal":
        lo, hi = mean - _Q * sd, mean + _Q * sd
        if lo <= 0:
            raise InputError(
                f"{where}: '{p}' normal prior reaches zero (mean - {_Q:.3f} sd = {lo / scale:g}); "
                "use a lognormal or a truncated-normal prior"
            )
    else:
        lo, hi = values["lower"] * scale, values["upper"] * scale
    return mean, lo, hi, {"kind": kind, "mean": mean, "sd": sd}


def available_priors() -> dict[str, Path]:
    """Shipped prior files by name (file stem)."""
    found: dict[str, Path] = {}
    for d in shipped_dirs():  # the folder's own files: priors/passive/ etc. are not bodies'
        for f in sorted(d.glob("*.toml")):
            found.setdefault(f.stem, f)
    return found


def load_prior(
    spec: str | Path | dict | Prior, *, base_dir: Path | None = None, name=None
) -> Prior:
    """Find and read a prior: a shipped name, a path to a TOML file, or an inline table.

    Parameters
    ----------
    spec : str, pathlib.Path, dict or Prior
        ``"biodex-elbow-attachment"`` (a file in ``priors/``), a path (relative paths are taken
        relative to ``base_dir``), or an inline table as accepted by :func:`parse_prior`.
    base_dir : pathlib.Path, optional
        Folder that relative paths are resolved against (the manifest's folder).
    name : str, optional
        Body name for an inline table (defaults to ``"body"``).

    Raises
    ------
    InputError
        Unknown name, unreadable or malformed file.
    """
    if isinstance(spec, Prior):
        return spec
    if isinstance(spec, dict):
        if "population" in spec and base_dir is not None:
            spec = population.population_prior_table(
                spec, where=f"prior of '{name or 'body'}'", base_dir=base_dir, body=name
            )
        return parse_prior(spec, name=name or "body", where=f"prior of '{name or 'body'}'")
    text = str(spec)
    shipped = available_priors()
    path = Path(text)
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    if text in shipped and not path.is_file():
        path = shipped[text]
    elif not path.is_file():
        if path.suffix == "" and not any(c in text for c in "/\\"):
            raise InputError(
                f"prior '{text}': no such shipped prior and no such file "
                f"(shipped: {', '.join(shipped) or 'none'})"
            )
        raise InputError(f"{path}: prior file not found")
    try:
        table = tomllib.loads(path.read_text(encoding="utf-8-sig"))  # a BOM is not TOML
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read prior file ({exc})") from None
    return parse_prior(table, name=name or path.stem, where=str(path), path=path)


def priors_from_posterior(post: Posterior) -> dict[str, Prior]:
    """The priors stored in a posterior.

    Boxes from ``constant_data``; each prior file's description, source, published
    reference and the distributions of parameters that are not uniform from the ``priors``
    attribute.
    """
    about = json.loads(post.attrs.get("priors", "{}") or "{}")
    return {
        body: Prior(
            name=body,
            nominal=post.prior_values(body, "nominal"),
            lower=post.prior_values(body, "lower"),
            upper=post.prior_values(body, "upper"),
            description=str(about.get(body, {}).get("description", "")),
            source=str(about.get(body, {}).get("source", "")),
            reference=dict(about.get(body, {}).get("reference", {})),
            distribution=dict(about.get(body, {}).get("distribution", {})),
            anthropometric=dict(about.get(body, {}).get("anthropometric", {})),
        )
        for body in post.bodies
    }
