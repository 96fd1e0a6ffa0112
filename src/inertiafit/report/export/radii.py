"""The radii of gyration the dynamometer does not measure: about the long and the cross axis.

A dynamometer turns a body about one axis, so the posterior knows its radius of gyration
``rho`` about that axis only. The other two come from the body's declaration
(:class:`OtherRadii`): the ratios of an anthropometric table's radii (de Leva's sagittal and
longitudinal radius over his transverse one, the one the dynamometer measures for a rotation in
the sagittal plane) times the posterior's ``rho``, or radii the user declares in metres; or,
undeclared, from the body's de Leva prior (:func:`other_radii`). With an uncertainty
(``sd_log``) each draw of a model takes a lognormal draw of each ratio or radius, redrawn where
the three moments would break the triangle inequality (``I_a <= I_b + I_c``, a physical mass
distribution; :func:`radii_for`).
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from inertiafit._checks import check_positive
from inertiafit.errors import InputError
from inertiafit.inference import anthropometric
from inertiafit.inference.priors import Prior
from inertiafit.posterior import Posterior

__all__ = [
    "TRIANGLE_TOLERANCE",
    "OtherRadii",
    "declared_radii",
    "load_declarations",
    "other_radii",
    "radii_for",
]

#: Relative slack of the triangle inequality ``I_a <= (1 + tol) (I_b + I_c)``.
TRIANGLE_TOLERANCE = 1e-3
_DECLARATION_KEYS = {
    "radius_long",
    "radius_cross",
    "ratio_long",
    "ratio_cross",
    "segment",
    "table",
    "sex",
    "sd_log",
}


def _number(value: float) -> str:
    return np.format_float_positional(float(value), unique=True, trim="-")


@dataclass(frozen=True)
class OtherRadii:
    """How a body's radii of gyration about its long and cross axis are known.

    Attributes
    ----------
    kind : str
        ``"ratio"`` (multiples of the measured radius, from an anthropometric table) or
        ``"radius"`` (declared in metres).
    long, cross : float
        The ratios or radii (m) about the long and the cross axis.
    sd_log : float
        SD of the natural log of each, for the draws (0: exact).
    source : str
        Where they come from, one line.
    """

    kind: str
    long: float
    cross: float
    sd_log: float = 0.0
    source: str = ""


def declared_radii(body: str, entry: Mapping[str, Any], *, where: str) -> OtherRadii:
    """One body's declaration (a TOML table or the command line's) as :class:`OtherRadii`.

    ``radius_long`` and ``radius_cross`` (m); or ``ratio_long`` and ``ratio_cross``
    (multiples of the measured radius ``rho``); or ``segment`` with ``table`` (an
    anthropometric table with the other radii: ``de-leva-female``, ``de-leva-male``) and
    optionally ``sex``; ``sd_log`` optional (default 0, the table's spread for a segment).
    """
    here = f"{where}: bodies.{body}"
    if not isinstance(entry, Mapping):
        raise InputError(f"{here}: expected a table (radius_long and radius_cross, or segment)")
    bad = sorted(set(entry) - _DECLARATION_KEYS)
    if bad:
        raise InputError(
            f"{here}: unknown key '{bad[0]}' (allowed: {', '.join(sorted(_DECLARATION_KEYS))})"
        )
    sd_log = entry.get("sd_log")
    if "segment" in entry:
        if "radius_long" in entry or "radius_cross" in entry:
            raise InputError(f"{here}: give 'segment' or the radii, not both")
        if "table" not in entry:
            raise InputError(f"{here}: 'table' is missing (de-leva-female or de-leva-male)")
        return _table_radii(entry["table"], entry["segment"], entry.get("sex"), sd_log, here)
    sd = 0.0 if sd_log is None else _sd_log(sd_log, here)
    for kind, unit in (("ratio", "times rho"), ("radius", "m")):
        keys = (f"{kind}_long", f"{kind}_cross")
        if not any(k in entry for k in keys):
            continue
        others = {"radius_long", "radius_cross", "ratio_long", "ratio_cross"} - set(keys)
        if any(k not in entry for k in keys) or others & set(entry):
            raise InputError(
                f"{here}: give radius_long and radius_cross (m), or ratio_long and ratio_cross, "
                "or segment and table"
            )
        long = check_positive(entry[keys[0]], here, field=keys[0])
        cross = check_positive(entry[keys[1]], here, field=keys[1])
        return OtherRadii(
            kind, long, cross, sd, f"declared ({where}): long {long:g}, cross {cross:g} {unit}"
        )
    raise InputError(
        f"{here}: give radius_long and radius_cross (m), or ratio_long and ratio_cross, "
        "or segment and table"
    )


def _sd_log(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 <= value < 1:
        raise InputError(f"{where}: 'sd_log' must be a number in [0, 1), got {value!r}")
    return float(value)


def _table_radii(table: Any, segment: Any, sex: Any, sd_log: Any, where: str) -> OtherRadii:
    sag, long, values = anthropometric.principal_radius_ratios(table, segment, sex, where=where)
    sd = values.sd_log["radius_of_gyration"] if sd_log is None else _sd_log(sd_log, where)
    who = values.description.split(", body mass")[0]
    return OtherRadii(
        "ratio",
        long,
        sag,
        sd,
        f"{who}: longitudinal and sagittal radius over the transverse one "
        f"({long:.4g}, {sag:.4g}), sd_log {sd:g}; {values.source.split(';')[0]}",
    )


def load_declarations(path: str | Path) -> dict[str, OtherRadii]:
    """A declarations file: ``[bodies.<name>]`` tables as :func:`declared_radii` reads them."""
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read declarations ({exc})") from None
    bad = sorted(set(raw) - {"bodies"})
    if bad:
        raise InputError(f"{path}: unknown key '{bad[0]}' (expected [bodies.<name>] tables)")
    if not isinstance(raw.get("bodies"), dict) or not raw["bodies"]:
        raise InputError(f"{path}: no [bodies.<name>] table")
    return {
        str(body): declared_radii(str(body), entry, where=str(path))
        for body, entry in raw["bodies"].items()
    }


def other_radii(
    posterior: Posterior,
    priors: Mapping[str, Prior],
    declared: Mapping[str, OtherRadii] | None = None,
) -> dict[str, OtherRadii]:
    """Each body's other two radii: declared, else from its anthropometric prior's table.

    Raises
    ------
    InputError
        A declaration names no body of the posterior, or a body has no way to get them (one
        line naming the body and what to declare).
    """
    declared = dict(declared or {})
    unknown = sorted(set(declared) - set(posterior.bodies))
    if unknown:
        raise InputError(
            f"declarations: no body '{unknown[0]}' in the posterior "
            f"(bodies: {', '.join(posterior.bodies)})"
        )
    out = {}
    for body in posterior.bodies:
        if body in declared:
            out[body] = declared[body]
            continue
        spec = priors[body].anthropometric if body in priors else {}
        how = (
            f"declare them: --radii {body}=LONG,CROSS (m), or --segment {body}=TABLE:SEGMENT "
            "(e.g. de-leva-male:forearm), or a [bodies." + body + "] table in --declare FILE"
        )
        if not spec:
            raise InputError(
                f"body '{body}': the dynamometer measures one radius of gyration and its prior "
                f"names no anthropometric segment for the other two; {how}"
            )
        try:
            out[body] = _table_radii(
                spec.get("anthropometric"),
                spec.get("segment"),
                spec.get("sex"),
                None,
                f"body '{body}' (its prior)",
            )
        except InputError as exc:
            raise InputError(f"{exc}; {how}") from None
    return out


def _consistent(joint: np.ndarray, long: np.ndarray, cross: np.ndarray) -> np.ndarray:
    """Whether squared radii satisfy the triangle inequality of principal moments.

    Within :data:`TRIANGLE_TOLERANCE`: a thin plate is on the boundary (``I_a = I_b + I_c``),
    and its declared radii, rounded, may fall just outside.
    """
    a, b, c = joint**2, long**2, cross**2
    tol = 1 + TRIANGLE_TOLERANCE
    return (a <= tol * (b + c)) & (b <= tol * (a + c)) & (c <= tol * (a + b))


def radii_for(
    rho: np.ndarray, spec: OtherRadii, rng: np.random.Generator | None, body: str
) -> tuple[np.ndarray, np.ndarray]:
    """Long and cross radii (m) for each ``rho``: the declared values, or lognormal draws.

    Without ``rng`` (the median model) or without an uncertainty, radii that break the
    triangle inequality are an error naming ``body``; with them, a draw that breaks it is
    drawn again (the ratios' distribution truncated to physical tensors).
    """
    base = rho if spec.kind == "ratio" else np.ones_like(rho)
    long = base * spec.long
    cross = base * spec.cross
    if rng is None or spec.sd_log == 0:
        bad = ~_consistent(rho, long, cross)
        if bad.any():
            i = int(np.argmax(bad))
            which = "its radii" if rho.size == 1 else f"{int(bad.sum())} of {rho.size} draws"
            raise InputError(
                f"body '{body}': {which} break the triangle inequality of a rigid body's "
                f"moments (radii about the joint, long and cross axis {_number(rho.flat[i])}, "
                f"{_number(long.flat[i])}, {_number(cross.flat[i])} m); check the declaration, "
                "or declare ratio_long and ratio_cross (multiples of the measured radius)"
            )
        return long, cross
    out_long, out_cross = long.copy(), cross.copy()
    todo = np.ones(rho.shape, dtype=bool)
    for _ in range(200):
        n = int(todo.sum())
        if n == 0:
            break
        z = rng.normal(0.0, spec.sd_log, size=(2, n))
        out_long[todo] = long[todo] * np.exp(z[0])
        out_cross[todo] = cross[todo] * np.exp(z[1])
        todo = ~_consistent(rho, out_long, out_cross)
    if todo.any():
        raise InputError(
            f"body '{body}': its declared radii cannot make a physical inertia tensor with the "
            "posterior's radius; check the declaration"
        )
    return out_long, out_cross
