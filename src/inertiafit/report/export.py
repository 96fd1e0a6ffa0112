"""A posterior as segments of a musculoskeletal model: ``.bioMod``, ``.osim`` or JSON.

Each body becomes a segment (biorbd) or a body (OpenSim) with its mass, its centre of mass and
its full inertia tensor about the centre of mass, in a body frame whose origin is the joint on
the dynamometer's axis (:class:`Frame`):

* the centre of mass lies on the *long axis* (``+x`` by default) at ``x`` from the joint;
* the *joint axis* (``z`` by default) is the dynamometer's axis, about which the posterior's
  radius of gyration ``rho`` was measured: ``I = m rho^2`` about the centre of mass;
* about the long axis and the *cross axis* (normal to both) the radii of gyration come from
  the body's declaration (:class:`OtherRadii`): the ratios of an anthropometric table's radii
  (de Leva's sagittal and longitudinal radius over his transverse one, the one the dynamometer
  measures for a rotation in the sagittal plane) times the posterior's ``rho``, or radii the
  user declares in metres. The axes are the tensor's principal axes (no products of inertia).

The *median* model takes the posterior medians of ``m``, ``x`` and ``rho`` (``summary.csv``'s
``median`` column) and the declared ratios or radii. A *draw* takes one joint posterior draw
of every body (the same draw index for all: their correlations are kept) and, with an
uncertainty (``sd_log``), a lognormal draw of each ratio or radius around its declared value,
redrawn where the three moments would break the triangle inequality
(``I_a <= I_b + I_c``, a physical mass distribution). :func:`write_model` writes one model
file in each format; docs/export.md documents the formats and the frame.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

import numpy as np

from inertiafit._checks import check_positive
from inertiafit.errors import InputError
from inertiafit.inference import anthropometric
from inertiafit.inference.priors import Prior
from inertiafit.posterior import Posterior

__all__ = [
    "EXPORT_COLUMNS",
    "FORMATS",
    "SUFFIXES",
    "TRIANGLE_TOLERANCE",
    "BodyInertia",
    "Frame",
    "OtherRadii",
    "declared_radii",
    "exported_bodies",
    "load_declarations",
    "model_text",
    "other_radii",
    "write_model",
]

#: Export formats and their file suffixes.
FORMATS = ("biomod", "osim", "json")
SUFFIXES = {"biomod": ".bioMod", "osim": ".osim", "json": ".json"}
#: Columns of ``export.csv``: a row per model (``median`` or draw number) and body.
EXPORT_COLUMNS = [
    "model",
    "body",
    "mass",
    "com_x",
    "com_y",
    "com_z",
    "inertia_xx",
    "inertia_yy",
    "inertia_zz",
    "radius_joint",
    "radius_long",
    "radius_cross",
    "posterior_draw",
]
#: Relative slack of the triangle inequality ``I_a <= (1 + tol) (I_b + I_c)``.
TRIANGLE_TOLERANCE = 1e-3
_AXES = ("x", "y", "z")
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
    """A float as the shortest decimal that reads back to the same bits, never in e-notation."""
    return np.format_float_positional(float(value), unique=True, trim="-")


@dataclass(frozen=True)
class Frame:
    """Where the body frame's axes point.

    Attributes
    ----------
    long_axis : str
        The direction from the joint to the centre of mass: ``+x`` (default), ``-y``, ...
    joint_axis : str
        The dynamometer's axis: ``x``, ``y`` or ``z`` (default); not the long axis.
    """

    long_axis: str = "+x"
    joint_axis: str = "z"

    def __post_init__(self) -> None:
        long = self.long_axis.strip().lower()
        if long in _AXES:
            long = "+" + long
        if len(long) != 2 or long[0] not in "+-" or long[1] not in _AXES:
            raise InputError(
                f"long_axis: expected one of +x, -x, +y, -y, +z, -z, got {self.long_axis!r}"
            )
        joint = self.joint_axis.strip().lower().lstrip("+-")
        if joint not in _AXES:
            raise InputError(f"joint_axis: expected x, y or z, got {self.joint_axis!r}")
        if joint == long[1]:
            raise InputError(
                f"joint_axis: the dynamometer axis ({joint}) cannot be the long axis "
                f"({long}); choose another"
            )
        object.__setattr__(self, "long_axis", long)
        object.__setattr__(self, "joint_axis", joint)

    @property
    def cross_axis(self) -> str:
        """The third axis, normal to the long and the joint axis."""
        return next(a for a in _AXES if a not in (self.long_axis[1], self.joint_axis))

    def describe(self) -> dict[str, str]:
        """The frame in words (the JSON file's ``frame``)."""
        return {
            "origin": "the joint centre on the dynamometer axis",
            "long_axis": f"{self.long_axis} (joint to centre of mass)",
            "joint_axis": f"{self.joint_axis} (the dynamometer axis; the measured radius)",
            "cross_axis": f"{self.cross_axis} (normal to both)",
        }


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


@dataclass(frozen=True)
class BodyInertia:
    """One body as a model segment: mass, centre of mass and inertia tensor (SI units).

    ``com`` is in the body frame (origin at the joint); ``inertia`` is 3 x 3 about the centre
    of mass in the body frame; ``radii`` are the radii of gyration about the centre of mass
    (``joint``, ``long``, ``cross``); ``extra["other_radii"]`` how the long and cross radii
    were declared (``kind``, ``long``, ``cross``, ``sd_log``: the uncertainty the draws carry).
    """

    name: str
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[tuple[float, float, float], ...]
    radii: dict[str, float]
    source: str = ""
    draw: int = -1
    extra: dict[str, Any] = field(default_factory=dict)


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


def _radii(
    rho: np.ndarray, spec: OtherRadii, rng: np.random.Generator | None, body: str
) -> tuple[np.ndarray, np.ndarray]:
    """Long and cross radii for each ``rho``: the declared values, or lognormal draws."""
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


def _body(
    name: str,
    m: float,
    x: float,
    rho: float,
    long: float,
    cross: float,
    frame: Frame,
    spec: OtherRadii,
    draw: int,
) -> BodyInertia:
    sign = 1.0 if frame.long_axis[0] == "+" else -1.0
    com = [0.0, 0.0, 0.0]
    com[_AXES.index(frame.long_axis[1])] = sign * x
    diag = [0.0, 0.0, 0.0]
    diag[_AXES.index(frame.long_axis[1])] = m * long * long
    diag[_AXES.index(frame.joint_axis)] = m * rho * rho
    diag[_AXES.index(frame.cross_axis)] = m * cross * cross
    tensor = ((diag[0], 0.0, 0.0), (0.0, diag[1], 0.0), (0.0, 0.0, diag[2]))
    return BodyInertia(
        name=name,
        mass=m,
        com=(com[0], com[1], com[2]),
        inertia=tensor,
        radii={"joint": rho, "long": long, "cross": cross},
        source=spec.source,
        draw=draw,
        extra={
            "other_radii": {
                "kind": spec.kind,
                "long": spec.long,
                "cross": spec.cross,
                "sd_log": spec.sd_log,
            }
        },
    )


def exported_bodies(
    posterior: Posterior,
    radii: Mapping[str, OtherRadii],
    *,
    frame: Frame | None = None,
    draws: int = 0,
    seed: int = 0,
) -> tuple[list[BodyInertia], list[list[BodyInertia]]]:
    """The median model's bodies and ``draws`` models' bodies sampled from the posterior.

    Parameters
    ----------
    posterior : Posterior
    radii : mapping
        Each body's :class:`OtherRadii` (:func:`other_radii`).
    frame : Frame, optional
        Default ``Frame()``: long axis ``+x``, joint axis ``z``.
    draws : int
        How many models sampled from the posterior (0: the median model only). Posterior
        draws are taken without replacement while there are enough.
    seed : int
        Seeds the choice of draws and the draws of uncertain radii.
    """
    frame = frame or Frame()
    rng = np.random.default_rng(seed)
    values = {
        b: {
            p: posterior.draws(b, p).reshape(-1)
            for p in ("mass", "com_distance", "radius_of_gyration")
        }
        for b in posterior.bodies
    }
    total = next(iter(values.values()))["mass"].size
    median = []
    for b in posterior.bodies:
        m, x, rho = (float(np.median(values[b][p])) for p in values[b])
        long, cross = _radii(np.array([rho]), radii[b], None, b)
        median.append(_body(b, m, x, rho, float(long[0]), float(cross[0]), frame, radii[b], -1))
    sampled: list[list[BodyInertia]] = []
    if draws:
        index = rng.choice(total, size=draws, replace=draws > total)
        per_body = {}
        for b in posterior.bodies:
            per_body[b] = _radii(values[b]["radius_of_gyration"][index], radii[b], rng, b)
        for k, i in enumerate(index):
            sampled.append(
                [
                    _body(
                        b,
                        float(values[b]["mass"][i]),
                        float(values[b]["com_distance"][i]),
                        float(values[b]["radius_of_gyration"][i]),
                        float(per_body[b][0][k]),
                        float(per_body[b][1][k]),
                        frame,
                        radii[b],
                        int(i),
                    )
                    for b in posterior.bodies
                ]
            )
    return median, sampled


def _biomod(bodies: Sequence[BodyInertia], frame: Frame, title: str) -> str:
    lines = [
        "version 4",
        "",
        f"// {title}",
        "// Written by inertiafit export: one segment per body, its frame's origin at the joint",
        f"// on the dynamometer axis ({frame.joint_axis}); centre of mass on {frame.long_axis};",
        "// inertia about the centre of mass (kg m^2), mass kg, lengths m.",
        "",
    ]
    for body in bodies:
        if not body.name or any(c.isspace() for c in body.name):
            raise InputError(f"body '{body.name}': a bioMod segment name cannot hold spaces")
        lines += [
            f"// {body.name}: other radii: {body.source}",
            f"segment {body.name}",
            f"    rotations {frame.joint_axis}",
            f"    mass {_number(body.mass)}",
            "    com " + " ".join(_number(v) for v in body.com),
            "    inertia",
            *("        " + " ".join(_number(v) for v in row) for row in body.inertia),
            "endsegment",
            "",
        ]
    return "\n".join(lines)


def _unit(axis: str) -> str:
    return " ".join("1" if a == axis else "0" for a in _AXES)


def _transform(spatial: ET.Element, name: str, axis: str, coordinate: str) -> None:
    """One TransformAxis of a CustomJoint: turned by ``coordinate``, or held at 0."""
    element = ET.SubElement(spatial, "TransformAxis", name=name)
    ET.SubElement(element, "coordinates").text = coordinate
    ET.SubElement(element, "axis").text = _unit(axis)
    if coordinate:
        function = ET.SubElement(element, "LinearFunction", name="function")
        ET.SubElement(function, "coefficients").text = "1 0"
    else:
        function = ET.SubElement(element, "Constant", name="function")
        ET.SubElement(function, "value").text = "0"


def _osim(bodies: Sequence[BodyInertia], frame: Frame, title: str, gravity: float) -> str:
    doc = ET.Element("OpenSimDocument", Version="40000")
    model = ET.SubElement(doc, "Model", name="inertiafit")
    ET.SubElement(model, "credits").text = title
    ET.SubElement(model, "gravity").text = f"0 {_number(-gravity)} 0"
    ET.SubElement(model, "length_units").text = "meters"
    ET.SubElement(model, "force_units").text = "N"
    ground = ET.SubElement(model, "Ground", name="ground")
    geometry = ET.SubElement(ground, "FrameGeometry", name="frame_geometry")
    ET.SubElement(geometry, "socket_frame").text = ".."
    ET.SubElement(geometry, "scale_factors").text = "0.2 0.2 0.2"
    objects = ET.SubElement(ET.SubElement(model, "BodySet", name="bodyset"), "objects")
    joints = ET.SubElement(ET.SubElement(model, "JointSet", name="jointset"), "objects")
    for body in bodies:
        element = ET.SubElement(objects, "Body", name=body.name)
        ET.SubElement(element, "mass").text = _number(body.mass)
        ET.SubElement(element, "mass_center").text = " ".join(_number(v) for v in body.com)
        tensor = body.inertia
        ET.SubElement(element, "inertia").text = " ".join(
            _number(v)
            for v in (
                tensor[0][0],
                tensor[1][1],
                tensor[2][2],
                tensor[0][1],
                tensor[0][2],
                tensor[1][2],
            )
        )
        # A CustomJoint (biobuddy reads no PinJoint): one rotation about the dynamometer axis.
        joint = ET.SubElement(joints, "CustomJoint", name=f"{body.name}_joint")
        ET.SubElement(joint, "socket_parent_frame").text = "ground_offset"
        ET.SubElement(joint, "socket_child_frame").text = f"{body.name}_offset"
        coords = ET.SubElement(joint, "coordinates")
        coord = ET.SubElement(coords, "Coordinate", name=f"{body.name}_angle")
        ET.SubElement(coord, "default_value").text = "0"
        ET.SubElement(coord, "range").text = f"{_number(-math.pi)} {_number(math.pi)}"
        ET.SubElement(coord, "clamped").text = "false"
        ET.SubElement(coord, "locked").text = "false"
        frames = ET.SubElement(joint, "frames")
        for name, parent in (
            ("ground_offset", "/ground"),
            (f"{body.name}_offset", f"/bodyset/{body.name}"),
        ):
            offset = ET.SubElement(frames, "PhysicalOffsetFrame", name=name)
            ET.SubElement(offset, "socket_parent").text = parent
            ET.SubElement(offset, "translation").text = "0 0 0"
            ET.SubElement(offset, "orientation").text = "0 0 0"
        spatial = ET.SubElement(joint, "SpatialTransform")
        others = [a for a in _AXES if a != frame.joint_axis]
        _transform(spatial, "rotation1", frame.joint_axis, f"{body.name}_angle")
        _transform(spatial, "rotation2", others[0], "")
        _transform(spatial, "rotation3", others[1], "")
        for k, axis in enumerate(_AXES, start=1):
            _transform(spatial, f"translation{k}", axis, "")
    ET.indent(doc)
    return (
        '<?xml version="1.0" encoding="UTF-8" ?>\n' + ET.tostring(doc, encoding="unicode") + "\n"
    )


def _json(bodies: Sequence[BodyInertia], frame: Frame, title: str, gravity: float) -> str:
    data = {
        "format": "inertiafit-export",
        "version": 1,
        "title": title,
        "units": {"mass": "kg", "com": "m", "inertia": "kg m^2 about the centre of mass"},
        "gravity": gravity,
        "frame": frame.describe(),
        "bodies": {
            b.name: {
                "mass": b.mass,
                "com": list(b.com),
                "inertia": [list(row) for row in b.inertia],
                "radii_of_gyration": b.radii,
                "other_radii": {**b.extra.get("other_radii", {}), "source": b.source},
                **({"posterior_draw": b.draw} if b.draw >= 0 else {}),
            }
            for b in bodies
        },
    }
    return json.dumps(data, indent=2) + "\n"


def model_text(
    bodies: Sequence[BodyInertia],
    fmt: str,
    *,
    frame: Frame | None = None,
    title: str = "",
    gravity: float = 9.81,
) -> str:
    """One model's file text in ``fmt`` (``biomod``, ``osim`` or ``json``)."""
    frame = frame or Frame()
    if fmt == "biomod":
        return _biomod(bodies, frame, title)
    if fmt == "osim":
        return _osim(bodies, frame, title, gravity)
    if fmt == "json":
        return _json(bodies, frame, title, gravity)
    raise InputError(f"format: expected one of {', '.join(FORMATS)}, got {fmt!r}")


def write_model(
    path: str | Path,
    bodies: Sequence[BodyInertia],
    fmt: str,
    *,
    frame: Frame | None = None,
    title: str = "",
    gravity: float = 9.81,
) -> Path:
    """Write one model file (into a staging folder: see ``pipeline.export``)."""
    path = Path(path)
    path.write_text(
        model_text(bodies, fmt, frame=frame, title=title, gravity=gravity), encoding="utf-8"
    )
    return path
