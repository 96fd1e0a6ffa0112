"""Anthropometric priors: a segment's parameters from published tables, body mass and length.

The tables are data files in ``priors/anthropometric/`` (one per source: ``de-leva.toml`` with
both sexes, ``dempster-winter.toml``), parsed against a fixed schema. For a segment of length
``L`` of a subject of body mass ``M`` a table gives

* ``m = mass fraction x M``,
* ``x = CoM fraction x L``, measured from the segment's PROXIMAL endpoint (the joint on the
  dynamometer's axis),
* ``rho = radius fraction x L``, the radius of gyration about the CoM for rotation in the
  sagittal plane (de Leva's "transverse" radius, Dempster's only one);

a composite segment that a table gives only as parts (de Leva's forearm + hand) is combined:
masses add, the CoM is the mass-weighted mean of the parts' CoMs (the distal part in line,
starting at the proximal part's distal end) and the moment about the proximal joint is the sum
of each part's ``m (rho^2 + x^2)`` (parallel axes).

Each parameter gets a lognormal prior with its median at the table's value and the table's
``sd_log`` (the population spread, with its source in the file). :func:`prior_table` turns an
inline specification (``anthropometric = "de-leva-male"``, ``segment``, ``body_mass``,
``segment_length``) into an ordinary prior table for
:func:`inertiafit.inference.priors.parse_prior`, which calls it; the public entry point that
returns a :class:`~inertiafit.inference.priors.Prior` is
:func:`inertiafit.inference.priors.anthropometric_prior`.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

from inertiafit._checks import check_interval
from inertiafit.errors import InputError
from inertiafit.io.shipped import shipped_dirs
from inertiafit.physics import PARAMETERS

__all__ = [
    "MAX_BODY_MASS",
    "MAX_SEGMENT_LENGTH",
    "SPEC_KEYS",
    "Segment",
    "SegmentValues",
    "Table",
    "available_tables",
    "load_table",
    "principal_radius_ratios",
    "prior_table",
    "resolve_table",
    "segment_values",
    "table_dirs",
]

#: Largest body mass (kg) and segment length (m) accepted: beyond them an input is a typo.
MAX_BODY_MASS = 500.0
MAX_SEGMENT_LENGTH = 2.5

#: Keys of an inline anthropometric prior (``anthropometric``, ``segment`` and ``body_mass``
#: required; ``segment_length`` or ``segment_lengths``; ``sex`` for a table with sexes).
SPEC_KEYS = (
    "anthropometric",
    "segment",
    "body_mass",
    "segment_length",
    "segment_lengths",
    "sex",
    "name",
    "description",
)

_FILE_KEYS = {"title", "citation", "aliases", "sexes", "radius", "notes", "spread", "segments"}
_SEGMENT_KEYS = {
    "endpoints",
    "length",
    "mean_length_mm",
    "mass",
    "com",
    "radius",
    "rg_proximal",
    "rg_distal",
    "radius_sagittal",
    "radius_longitudinal",
    "parts",
    "spread",
    "unsupported",
}
_FRACTIONS = ("mass", "com", "radius")
#: Optional fractions of a row: the parallel-axis check's radii, and the other two radii about
#: the CoM (de Leva's), read only by :func:`principal_radius_ratios`.
_OPTIONAL = ("rg_proximal", "rg_distal", "radius_sagittal", "radius_longitudinal")
_SEGMENT_ALIASES = {
    "leg": "shank",
    "lowerleg": "shank",
    "leg+foot": "shank+foot",
    "lowerleg+foot": "shank+foot",
    "arm": "upper-arm",
}


def _key(text: str) -> str:
    """A name as compared: lower case, ``and`` as ``+``, without spaces, ``-`` and ``_``."""
    text = re.sub(r"\s+and\s+", "+", text.strip().lower())
    return re.sub(r"[\s_\-]", "", text)


@dataclass(frozen=True)
class Segment:
    """One row of a table: fractions per sex (``""`` for a table without sexes), or parts.

    Attributes
    ----------
    name : str
        Canonical name (``forearm+hand``).
    endpoints : tuple of str
        Proximal and distal landmark.
    length : str
        What the user measures as ``segment_length``.
    fractions : dict
        ``fractions[sex][key]`` for ``mass``, ``com``, ``radius`` (and ``rg_proximal``,
        ``rg_distal`` where given); empty for a composite.
    parts : tuple of str
        For a composite the table gives only as parts: its proximal and distal part.
    mean_length_mm : dict
        Mean segment length per sex (mm), for the distal part of a composite.
    spread : dict
        This segment's own ``sd_log`` per parameter, overriding the table's.
    unsupported : str
        Why the table cannot give this segment (empty when it can).
    """

    name: str
    endpoints: tuple[str, ...] = ()
    length: str = ""
    fractions: dict[str, dict[str, float]] = field(default_factory=dict)
    parts: tuple[str, ...] = ()
    mean_length_mm: dict[str, float] = field(default_factory=dict)
    spread: dict[str, float] = field(default_factory=dict)
    unsupported: str = ""


@dataclass(frozen=True)
class Table:
    """One anthropometric table file.

    Attributes
    ----------
    name : str
        File stem (``de-leva``).
    title, citation, notes : str
    aliases : tuple of str
        Other names it answers to (``dempster``).
    sexes : tuple of str
        ``("female", "male")`` or empty (not sex-specific).
    radius : str
        Which radius of gyration the table's ``radius`` column is (``transverse``).
    spread : dict
        ``sd_log`` per parameter (``mass``, ``com_distance``, ``radius_of_gyration``).
    spread_source : str
    segments : dict of str to Segment
    path : pathlib.Path
    """

    name: str
    title: str
    citation: str
    notes: str
    aliases: tuple[str, ...]
    sexes: tuple[str, ...]
    radius: str
    spread: dict[str, float]
    spread_source: str
    segments: dict[str, Segment]
    path: Path

    def names(self) -> list[str]:
        """The names a manifest may give: ``de-leva-female``, ... or ``dempster-winter``, ..."""
        stems = [self.name, *self.aliases]
        if self.sexes:
            return [f"{s}-{sex}" for s in stems for sex in self.sexes]
        return stems


@dataclass(frozen=True)
class SegmentValues:
    """A segment's point values for one subject (SI units) and where they come from."""

    mass: float
    com_distance: float
    radius_of_gyration: float
    sd_log: dict[str, float]
    description: str
    source: str

    @property
    def inertia(self) -> float:
        """Moment of inertia about the proximal joint, ``m (rho^2 + x^2)`` (kg m^2)."""
        return self.mass * (self.radius_of_gyration**2 + self.com_distance**2)


def table_dirs() -> list[Path]:
    """Folders holding the table files: inside the wheel, or the source tree's priors/."""
    return shipped_dirs("anthropometric")


def available_tables() -> dict[str, Path]:
    """Shipped table files by name (file stem)."""
    found: dict[str, Path] = {}
    for d in table_dirs():
        for f in sorted(d.glob("*.toml")):
            found.setdefault(f.stem, f)
    return found


def _fraction(value: Any, where: str, sexes: tuple[str, ...]) -> dict[str, float]:
    """A number (``{"": v}``) or a table by sex, each in (0, 2)."""
    if isinstance(value, dict):
        if sorted(value) != sorted(sexes) or not sexes:
            raise InputError(f"{where}: expected one number per sex ({', '.join(sexes)})")
        return {s: _fraction(value[s], f"{where}.{s}", ())[""] for s in sexes}
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where}: expected a number, got {value!r}")
    if not 0 < value < 2:
        raise InputError(f"{where}: expected a fraction in (0, 2), got {value}")
    if sexes:
        return dict.fromkeys(sexes, float(value))
    return {"": float(value)}


def _spread(value: Any, where: str) -> dict[str, float]:
    if not isinstance(value, dict):
        raise InputError(f"{where}: expected a table of sd_log per parameter")
    out = {}
    for k, v in value.items():
        if k == "source":
            continue
        if k not in PARAMETERS:
            raise InputError(f"{where}: unknown key '{k}' (allowed: {', '.join(PARAMETERS)})")
        if isinstance(v, bool) or not isinstance(v, int | float) or not 0 < v < 1:
            raise InputError(f"{where}.{k}: expected an sd_log in (0, 1), got {v!r}")
        out[k] = float(v)
    return out


@cache
def load_table(path: Path) -> Table:
    """Read and check one table file (cached; the files are data shipped with the package)."""
    where = str(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"{where}: cannot read anthropometric table ({exc})") from None
    bad = sorted(set(raw) - _FILE_KEYS)
    if bad:
        raise InputError(f"{where}: unknown key '{bad[0]}'")
    sexes = tuple(raw.get("sexes", ()))
    spread = _spread(raw.get("spread", {}), f"{where}: spread")
    if set(spread) != set(PARAMETERS):
        raise InputError(f"{where}: spread needs an sd_log for each of {', '.join(PARAMETERS)}")
    segments = {}
    for name, row in raw.get("segments", {}).items():
        here = f"{where}: segments.{name}"
        bad = sorted(set(row) - _SEGMENT_KEYS)
        if bad:
            raise InputError(f"{here}: unknown key '{bad[0]}'")
        fractions: dict[str, dict[str, float]] = {}
        if not row.get("parts") and not row.get("unsupported"):
            for key in (*_FRACTIONS, *_OPTIONAL):
                if key in row:
                    for sex, v in _fraction(row[key], f"{here}.{key}", sexes).items():
                        fractions.setdefault(sex, {})[key] = v
                elif key in _FRACTIONS:
                    raise InputError(f"{here}: '{key}' is missing")
        mean_length = {}
        if "mean_length_mm" in row:
            mean_length = _fraction(
                {k: v / 1000 for k, v in row["mean_length_mm"].items()},
                f"{here}.mean_length_mm",
                sexes,
            )
        segments[name] = Segment(
            name=name,
            endpoints=tuple(row.get("endpoints", ())),
            length=str(row.get("length", "")),
            fractions=fractions,
            parts=tuple(row.get("parts", ())),
            mean_length_mm={k: 1000 * v for k, v in mean_length.items()},
            spread=_spread(row.get("spread", {}), f"{here}.spread"),
            unsupported=str(row.get("unsupported", "")),
        )
    for seg in segments.values():
        for part in seg.parts:
            if part not in segments or segments[part].parts or not segments[part].fractions:
                raise InputError(f"{where}: segments.{seg.name}: part '{part}' is not a row")
    return Table(
        name=path.stem,
        title=str(raw.get("title", path.stem)),
        citation=str(raw.get("citation", "")),
        notes=str(raw.get("notes", "")),
        aliases=tuple(raw.get("aliases", ())),
        sexes=sexes,
        radius=str(raw.get("radius", "")),
        spread=spread,
        spread_source=str(raw.get("spread", {}).get("source", "")),
        segments=segments,
        path=path,
    )


def _all_tables() -> list[Table]:
    return [load_table(p) for p in available_tables().values()]


def resolve_table(name: str, sex: str | None = None, *, where: str = "anthropometric"):
    """``(table, sex)`` for a name as a user would type it (``"de Leva male"``, ``"dempster"``).

    ``sex`` may be given separately for a table with sexes; ``sex`` is ``""`` for a table
    without. Raises :class:`InputError` naming every valid name.
    """
    tables = _all_tables()
    valid = [n for t in tables for n in t.names()]
    if not isinstance(name, str):
        raise InputError(f"{where}: expected a table name ({', '.join(valid)}), got {name!r}")
    want = _key(name)
    if sex is not None and not isinstance(sex, str):
        raise InputError(f"{where}: 'sex' must be 'female' or 'male', got {sex!r}")
    for table in tables:
        for stem in (table.name, *table.aliases):
            if table.sexes:
                for s in table.sexes:
                    if want == _key(f"{stem}-{s}"):
                        if sex is not None and _key(sex) != s:
                            raise InputError(
                                f"{where}: table '{name}' is for sex '{s}' but sex = '{sex}'"
                            )
                        return table, s
                if want == _key(stem) and sex is not None and _key(sex) in table.sexes:
                    return table, _key(sex)
                if want == _key(stem):
                    raise InputError(
                        f"{where}: table '{name}' needs a sex; use one of "
                        f"{', '.join(table.names())} or give sex = 'female' / 'male'"
                    )
            elif want == _key(stem):
                if sex is not None:
                    raise InputError(
                        f"{where}: table '{name}' is not sex-specific; leave out 'sex'"
                    )
                return table, ""
    raise InputError(f"{where}: unknown anthropometric table {name!r}; expected one of "
                     f"{', '.join(valid)}")  # fmt: skip


def _segment(table: Table, name: Any, where: str) -> Segment:
    valid = ", ".join(table.segments)
    if not isinstance(name, str):
        raise InputError(f"{where}: 'segment' must be one of {valid}, got {name!r}")
    want = _key(name)
    want = _key(_SEGMENT_ALIASES.get(want, want))
    for seg in table.segments.values():
        if _key(seg.name) == want:
            if seg.unsupported:
                raise InputError(f"{where}: segment '{seg.name}': {seg.unsupported}")
            return seg
    raise InputError(f"{where}: unknown segment {name!r}; expected one of {valid}")


def segment_values(
    table: str,
    segment: str,
    body_mass: float,
    segment_length: float | None = None,
    *,
    sex: str | None = None,
    segment_lengths: Any = None,
    where: str = "anthropometric",
) -> SegmentValues:
    """The table's values for one subject's segment (SI units), and their spreads.

    Parameters
    ----------
    table : str
        ``"de-leva-female"``, ``"de-leva-male"``, ``"dempster"`` (``"dempster-winter"``);
        spelling is forgiving (case, spaces, ``_``), or ``"de-leva"`` with ``sex``.
    segment : str
        ``forearm``, ``hand``, ``forearm+hand``, ``upper-arm``, ``shank``, ``foot``,
        ``shank+foot``, ``thigh`` (``leg`` is ``shank``).
    body_mass : float
        kg, in (0, 500].
    segment_length : float
        m, in (0, 2.5]: the length the table's row names (for a composite, the PROXIMAL part's:
        forearm for forearm + hand, shank for shank + foot).
    sex : str, optional
        ``"female"`` or ``"male"``, for a table with sexes named without one.
    segment_lengths : dict, optional
        For a composite the table gives as parts: each part's length (m), e.g.
        ``{"forearm": 0.27, "hand": 0.085}``, instead of ``segment_length`` and the table's
        mean length ratio.
    where : str
        Prefix of error messages (the file or manifest field).
    """
    tab, sex_key = resolve_table(table, sex, where=where)
    seg = _segment(tab, segment, where)
    mass_total = check_interval(
        body_mass, where, 0, MAX_BODY_MASS, "kg", field="body_mass", upper_closed=True
    )
    lengths: dict[str, float] = {}
    if segment_lengths is not None:
        if segment_length is not None:
            raise InputError(f"{where}: give 'segment_length' or 'segment_lengths', not both")
        if not seg.parts:
            raise InputError(
                f"{where}: 'segment_lengths' is for a segment made of parts; "
                f"give segment_length (m) for '{seg.name}'"
            )
        if not isinstance(segment_lengths, dict) or sorted(segment_lengths) != sorted(seg.parts):
            raise InputError(
                f"{where}: 'segment_lengths' must name exactly {', '.join(seg.parts)} (m), "
                f"got {segment_lengths!r}"
            )
        for part in seg.parts:
            lengths[part] = check_interval(
                segment_lengths[part],
                where,
                0,
                MAX_SEGMENT_LENGTH,
                "m",
                field=f"segment_lengths.{part}",
                upper_closed=True,
            )
    else:
        if segment_length is None:
            raise InputError(f"{where}: 'segment_length' is missing ({seg.length}, in m)")
        length = check_interval(
            segment_length,
            where,
            0,
            MAX_SEGMENT_LENGTH,
            "m",
            field="segment_length",
            upper_closed=True,
        )
        if seg.parts:
            first, *rest = seg.parts
            lengths[first] = length
            for part in rest:
                ratio = (
                    tab.segments[part].mean_length_mm[sex_key]
                    / tab.segments[first].mean_length_mm[sex_key]
                )
                lengths[part] = length * ratio
        else:
            lengths[seg.name] = length
    m, mx, moment = 0.0, 0.0, 0.0
    offset = 0.0  # each part starts where the previous one ends
    for part in seg.parts or (seg.name,):
        f = tab.segments[part].fractions[sex_key]
        length = lengths[part]
        m_i = f["mass"] * mass_total
        x_i = offset + f["com"] * length
        rho_i = f["radius"] * length
        m += m_i
        mx += m_i * x_i
        moment += m_i * (rho_i**2 + x_i**2)
        offset += length
    x = mx / m
    rho = math.sqrt(moment / m - x * x)
    sd_log = {**tab.spread, **seg.spread}
    who = f"{tab.title.split(',')[0]}{f' {sex_key}' if sex_key else ''} {seg.name}"
    sizes = ", ".join(f"{p} length {lengths[p]:.4g} m" for p in lengths)
    if not seg.parts:
        sizes = f"segment length {lengths[seg.name]:.4g} m"
    elif segment_lengths is None:
        first = seg.parts[0]
        sizes = (
            f"segment length {lengths[first]:.4g} m ({first}; "
            + ", ".join(f"{p} {lengths[p]:.4g} m from the mean ratio" for p in seg.parts[1:])
            + ")"
        )
    description = f"{who}, body mass {mass_total:g} kg, {sizes}"
    source = f"{tab.citation}; spread (sd_log) {_fmt_spread(sd_log)}: {tab.spread_source}"
    return SegmentValues(m, x, rho, sd_log, description, source)


def principal_radius_ratios(
    table: str, segment: str, sex: str | None = None, *, where: str = "anthropometric"
) -> tuple[float, float, SegmentValues]:
    """The other two radii of gyration about the CoM as multiples of the measured one.

    The measured radius is the table's ``radius`` (de Leva's transverse one: rotation in the
    sagittal plane about the medio-lateral axis). Returns ``(sagittal / transverse,
    longitudinal / transverse, values)``: the radius about the antero-posterior axis and
    about the segment's long axis over the transverse radius, and the segment's values for a
    unit body mass and segment length (for its description and spreads). A composite (de
    Leva's forearm + hand) is combined as :func:`segment_values` combines it, its parts in
    line at the table's mean length ratio: about the composite CoM, the transverse and
    sagittal moments add each part's ``m (r^2 + (x_i - x)^2)``, the longitudinal ones each
    part's ``m r^2`` (every part's CoM lies on the long axis). The ratios do not depend on
    body mass or segment length.

    Raises
    ------
    InputError
        The table gives no sagittal and longitudinal radii for this segment (Dempster's give
        one radius only), or an unknown table or segment.
    """
    values = segment_values(table, segment, 1.0, 1.0, sex=sex, where=where)
    tab, sex_key = resolve_table(table, sex, where=where)
    seg = _segment(tab, segment, where)
    parts = seg.parts or (seg.name,)
    for part in parts:
        if not {"radius_sagittal", "radius_longitudinal"} <= set(
            tab.segments[part].fractions[sex_key]
        ):
            raise InputError(
                f"{where}: {tab.title.split(',')[0]} gives one radius of gyration for "
                f"'{part}', not the sagittal and longitudinal ones; declare the other two radii"
            )
    lengths = {parts[0]: 1.0}
    for part in parts[1:]:
        lengths[part] = (
            tab.segments[part].mean_length_mm[sex_key]
            / tab.segments[parts[0]].mean_length_mm[sex_key]
        )
    rows, offset = [], 0.0
    for part in parts:
        f = tab.segments[part].fractions[sex_key]
        length = lengths[part]
        rows.append(
            (
                f["mass"],
                offset + f["com"] * length,
                f["radius"] * length,
                f["radius_sagittal"] * length,
                f["radius_longitudinal"] * length,
            )
        )
        offset += length
    m = sum(r[0] for r in rows)
    x = sum(r[0] * r[1] for r in rows) / m
    trans = sum(r[0] * (r[2] ** 2 + (r[1] - x) ** 2) for r in rows)
    sag = sum(r[0] * (r[3] ** 2 + (r[1] - x) ** 2) for r in rows)
    long = sum(r[0] * r[4] ** 2 for r in rows)
    return math.sqrt(sag / trans), math.sqrt(long / trans), values


def _fmt_spread(sd_log: dict[str, float]) -> str:
    return ", ".join(f"{p} {sd_log[p]:g}" for p in PARAMETERS)


def prior_table(spec: dict[str, Any], *, where: str) -> dict[str, Any]:
    """An inline anthropometric specification as an ordinary prior table (lognormal each).

    ``spec`` has the keys of :data:`SPEC_KEYS`; the result is accepted by
    :func:`inertiafit.inference.priors.parse_prior`, with a ``[reference]`` table holding the
    table's point values (labelled with the table and segment).
    """
    bad = sorted(set(spec) - set(SPEC_KEYS))
    if bad:
        raise InputError(
            f"{where}: unknown key '{bad[0]}' for an anthropometric prior "
            f"(allowed: {', '.join(SPEC_KEYS)})"
        )
    for key in ("segment", "body_mass"):
        if key not in spec:
            raise InputError(f"{where}: '{key}' is missing (an anthropometric prior needs it)")
    values = segment_values(
        spec["anthropometric"],
        spec["segment"],
        spec["body_mass"],
        spec.get("segment_length"),
        sex=spec.get("sex"),
        segment_lengths=spec.get("segment_lengths"),
        where=where,
    )
    table: dict[str, Any] = {
        "description": str(spec.get("description", values.description)),
        "source": values.source,
        "reference": {
            "label": f"{values.description} (table value)",
            "mass": values.mass,
            "com_distance": values.com_distance,
            "radius_of_gyration": values.radius_of_gyration,
            "inertia": values.inertia,
        },
    }
    if "name" in spec:
        table["name"] = spec["name"]
    for p in PARAMETERS:
        table[p] = {
            "distribution": "lognormal",
            "median": getattr(values, p),
            "sd_log": values.sd_log[p],
        }
    return table
