"""The ``[defaults]`` table and the ``[[trials]]`` entries: each trial and its condition.

:class:`TrialSpec` is one trial as the manifest states it; :func:`read_trial_spec` reads its
file. The trials are read last (they name the bodies, the postures and the EMG channels the
other sections declare), labelled by condition (what is mounted) and checked together. An
entry names one file (``file``) or a glob pattern (``files``): a pattern becomes a trial per
matched file, in sorted order, each with the entry's other keys (:func:`match_files`).
"""

from __future__ import annotations

import glob
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit._checks import (
    check_increasing_pair,
    check_positive,
)
from inertiafit.io.emg import EmgSettings
from inertiafit.io.readers import (
    available_formats,
    check_calibration,
    check_columns,
    check_units,
    read_trial,
    reader_options,
)
from inertiafit.io.readers.registry import carries_emg, recognised_format
from inertiafit.io.readers.validation import check_emg
from inertiafit.io.sections.base import (
    Section,
    SectionContext,
    as_table,
    check_keys,
    expand_user,
    fail,
    number,
    register_section,
    resolve_file,
)
from inertiafit.io.sections.calibration import read_lag
from inertiafit.io.sections.postures import Posture, posture_name
from inertiafit.io.trial import apply_torque_sign
from inertiafit.io.units import unit_factor
from inertiafit.mounting import Mounting

__all__ = [
    "ADDED_MASS_KEYS",
    "DEFAULT_KEYS",
    "KINDS",
    "MOUNTING_KEYS",
    "TRIAL_KEYS",
    "TrialSpec",
    "match_files",
    "read_defaults",
    "read_trial_spec",
    "read_trials",
]

#: Trial kinds: a slow sweep (gravity, and a living joint's passive moment), a fast isokinetic
#: move (inertia), a quiet hold at one angle of a living body (``"rest"``) and a maximal
#: voluntary contraction recorded for its EMG (``"mvc"``: the muscles' MVC levels, never
#: evidence).
KINDS = ("quasi-static", "fast", "rest", "mvc")
#: Keys of one ``added_mass`` table of a trial (SI: kg, m, m).
ADDED_MASS_KEYS = ("mass", "com_distance", "radius_of_gyration")
#: Keys of a trial that describe its mounting; never in ``[defaults]``.
MOUNTING_KEYS = ("offset", "added_mass")
DEFAULT_KEYS = (
    "format",
    "columns",
    "units",
    "calibration",
    "torque_sign",
    "options",
    "lag",
    "posture",
    "emg",
)
TRIAL_KEYS = ("file", "bodies", "kind", "speed", "window", *MOUNTING_KEYS, *DEFAULT_KEYS, "files")


@dataclass(frozen=True)
class TrialSpec:
    """One ``[[trials]]`` entry with the ``[defaults]`` merged in.

    Attributes
    ----------
    file : Path
        Absolute path of the trial file (resolved relative to the manifest).
    mounting : Mounting
        What is mounted: the bodies (also :attr:`bodies`, in the manifest's ``[bodies]``
        order), a body moved along the lever (``offset``) and known added masses
        (``added_mass``, sorted).
    kind : {"quasi-static", "fast", "rest", "mvc"}
        Slow passive move (gives ``M_g``), fast isokinetic move (gives ``I``), a quiet hold
        of a living body at one angle (the gravity and passive elastic moment there), or a
        maximal voluntary contraction (its EMG gives each muscle's MVC level for the activity
        check; its torque is not used).
    speed : float or None
        Nominal speed (deg/s); always set for fast trials, never for rest trials.
    format : str
        Reader name (see :func:`inertiafit.io.available_formats`).
    columns, units : dict of str to str
        Channel -> column name / unit; the reader fills in its defaults for channels absent.
    calibration : dict
        Channel -> ``{"scale", "offset", "unit"}`` for the ``analog`` format.
    window : tuple of float or None
        Manual acceleration window ``(start, end)`` in seconds of the file's time, if given.
    torque_sign : {1, -1, "motion"}
        Multiplies the torque when the trial is read (a device that reports the opposite
        sign); ``"motion"`` signs a torque written as a magnitude by the direction of motion
        (fast trials; :func:`inertiafit.io.trial.apply_torque_sign`).
    condition : str
        The condition's label: :attr:`Mounting.label <inertiafit.mounting.Mounting.label>`,
        made unique in the study.
    options : dict
        Keyword options passed to the reader.
    index : int
        Position of the trial in :attr:`Study.trials <inertiafit.io.Study.trials>` (0-based),
        a key unique in the study; the position of its ``[[trials]]`` entry while no entry
        before it has ``files``.
    lag : float or None
        The torque channel's lag (s) the manifest fixes for this trial: its own ``lag``, else
        ``[defaults] lag``, else a number in ``[calibration] lag``; ``None`` when the lag is
        to be estimated (fast trials).
    posture : str
        The trial's posture (a key of :attr:`Study.postures`), its own ``posture`` or
        ``[defaults] posture``; ``""`` when the manifest defines no postures. Postures do not
        split conditions: a condition is what is mounted.
    emg : tuple of str
        EMG columns (or analog labels) read with the trial: its own ``emg``, else
        ``[defaults] emg``, else ``[emg] columns``; empty when none.
    emg_unit : str or None
        ``[emg] unit`` (``V``, ``mV``, ``µV``), where the file does not say; ``None``: volts.
    entry : int
        Position of the ``[[trials]]`` entry the trial comes from (0-based): ``trials[entry]``
        in error messages.
    pattern : str
        The entry's ``files`` glob pattern that matched :attr:`file`, as written; ``""`` for an
        entry with ``file``.
    """

    file: Path
    mounting: Mounting
    kind: str
    speed: float | None
    format: str
    columns: dict[str, str]
    units: dict[str, str]
    calibration: dict[str, dict[str, Any]]
    window: tuple[float, float] | None
    torque_sign: int | str
    condition: str
    options: dict[str, Any] = field(default_factory=dict)
    index: int = 0
    lag: float | None = None
    posture: str = ""
    emg: tuple[str, ...] = ()
    emg_unit: str | None = None
    entry: int = 0
    pattern: str = ""

    @property
    def key(self) -> str:
        """The manifest key that names this trial's file: ``trials[3].file`` or ``.files``."""
        return f"trials[{self.entry}].{'files' if self.pattern else 'file'}"

    @property
    def bodies(self) -> tuple[str, ...]:
        """The mounted bodies, in the manifest's ``[bodies]`` order."""
        return self.mounting.bodies

    def read(self) -> xr.Dataset:
        """Read this trial; see :func:`read_trial_spec`."""
        return read_trial_spec(self)

    def reader_settings(self) -> dict[str, Any]:
        """The settings this trial is read with, for provenance (plain JSON-able values).

        ``format``, ``columns``, ``units``, ``calibration``, ``options`` (defaults merged in),
        ``torque_sign`` and ``window`` (``None`` when the window is detected); ``emg`` and
        ``emg_unit`` only when the trial has EMG channels (a trial without keeps the settings
        it always had).
        """
        settings: dict[str, Any] = {
            "format": self.format,
            "columns": dict(self.columns),
            "units": dict(self.units),
            "calibration": {k: dict(v) for k, v in self.calibration.items()},
            "options": dict(self.options),
            "torque_sign": self.torque_sign,
            "window": list(self.window) if self.window is not None else None,
        }
        if self.emg:
            settings["emg"] = list(self.emg)
            settings["emg_unit"] = self.emg_unit or "V"
        return settings


def read_trial_spec(spec: TrialSpec) -> xr.Dataset:
    """Read the trial a :class:`TrialSpec` describes, with its torque sign applied.

    Parameters
    ----------
    spec : TrialSpec
        From :func:`load_study`.

    Returns
    -------
    xarray.Dataset
        The Trial of :func:`inertiafit.io.read_trial`, torque signed by
        ``spec.torque_sign`` (:func:`inertiafit.io.trial.apply_torque_sign`), with extra attrs
        ``condition``, ``kind``, ``torque_sign`` and, when set, ``speed`` (deg/s),
        ``window`` (s, two numbers), ``lag`` (s, the torque channel's fixed lag) and
        ``posture`` (its name); with ``spec.emg``, the variable ``emg`` (V).

    Raises
    ------
    InputError
        Every problem with the file (see :func:`inertiafit.io.read_trial`), and a torque
        sign that does not fit the torque (see :func:`inertiafit.io.trial.apply_torque_sign`).
    """
    trial = read_trial(
        spec.file,
        format=spec.format,
        columns=spec.columns or None,
        units=spec.units or None,
        calibration=spec.calibration or None,
        **_emg_arguments(spec),
        **spec.options,
    )
    trial = apply_torque_sign(trial, spec.torque_sign, kind=spec.kind)
    trial.attrs.update(condition=spec.condition, kind=spec.kind, torque_sign=spec.torque_sign)
    if spec.speed is not None:
        trial.attrs["speed"] = spec.speed
    if spec.window is not None:
        trial.attrs["window"] = list(spec.window)
    if spec.lag is not None:
        trial.attrs["lag"] = spec.lag
    if spec.posture:
        trial.attrs["posture"] = spec.posture
    return trial


def _emg_arguments(spec: TrialSpec) -> dict[str, Any]:
    """``emg`` and ``emg_unit`` for :func:`read_trial`, or nothing for a trial without EMG."""
    return {"emg": list(spec.emg), "emg_unit": spec.emg_unit} if spec.emg else {}


def _torque_sign(value: object, *, where: str) -> int | str:
    if value == "motion":
        return "motion"
    if isinstance(value, bool) or value not in (1, -1):
        raise fail(
            where,
            f'must be 1 or -1, got {value!r} (or "motion": a torque written as a magnitude, '
            "signed by the direction of motion, for fast trials)",
        )
    return int(value)


def _window(value: object, *, where: str) -> tuple[float, float]:
    return check_increasing_pair(value, where, "numbers [start, end] in s")


def _settings(table: Mapping[str, Any], *, where: str) -> dict[str, Any]:
    """Check the reader settings shared by [defaults] and [[trials]] (keys present only)."""
    out: dict[str, Any] = {}
    if "format" in table:
        fmt = table["format"]
        if fmt not in available_formats():
            raise fail(
                f"{where}.format",
                f"unknown trial format {fmt!r} (formats: {', '.join(available_formats())})",
            )
        out["format"] = fmt
    if "columns" in table:
        out["columns"] = check_columns(table["columns"], where=f"{where}.columns")
    if "units" in table:
        out["units"] = check_units(table["units"], where=f"{where}.units")
    if "calibration" in table:
        check_calibration(table["calibration"], where=f"{where}.calibration")
        out["calibration"] = {k: dict(v) for k, v in table["calibration"].items()}
    if "torque_sign" in table:
        out["torque_sign"] = _torque_sign(table["torque_sign"], where=f"{where}.torque_sign")
    if "options" in table:
        out["options"] = dict(
            as_table(table["options"], where=f"{where}.options", what="reader option = value")
        )
    if "lag" in table:
        out["lag"] = read_lag(table["lag"], where=f"{where}.lag")
    if "emg" in table:
        out["emg"] = check_emg(table["emg"], where=f"{where}.emg")
    return out


def _check_mvc(trials: list[TrialSpec], emg_table: object, *, where: str) -> None:
    """MVC trials record every muscle the study checks; ``mvc_fraction`` needs one.

    A muscle may have its MVC in any of the ``kind = "mvc"`` trials (one contraction per
    muscle, or repeated attempts): its level is its largest peak over those that record it.
    ``[emg] mvc_fraction`` without an MVC trial is refused rather than ignored: the threshold
    it asks for cannot be made.
    """
    mvc = [t for t in trials if t.kind == "mvc"]
    if not mvc:
        if isinstance(emg_table, Mapping) and "mvc_fraction" in emg_table:
            raise fail(
                f"{where}: emg.mvc_fraction",
                'set, but no trial has kind = "mvc"; add the maximal voluntary contractions '
                "(with EMG) it is a fraction of, or remove mvc_fraction",
            )
        return
    recorded = {m for t in mvc for m in t.emg}
    for t in trials:
        if t.kind == "mvc":
            continue
        missing = [m for m in t.emg if m not in recorded]
        if missing:
            listed = ", ".join(
                f"trials[{e}]" for e in list(dict.fromkeys(x.entry for x in mvc))[:3]
            )
            raise fail(
                f"{where}: trials[{mvc[0].entry}].emg",
                f"no mvc trial ({listed}) records EMG channel {missing[0]!r}, which "
                f"trials[{t.entry}] records; record every checked muscle in an mvc trial",
            )


def _offset(value: object, *, where: str, bodies: tuple[str, ...]) -> tuple[str, float]:
    """A trial's ``offset = { <body> = d }``: the one body moved and ``d`` in metres."""
    table = as_table(value, where=where, what="{ <body> = distance in m }")
    if len(table) != 1:
        raise fail(
            where,
            f"expected exactly one body moved along the lever ({{ <body> = distance in m }}), "
            f"got {value!r}",
        )
    ((body, raw),) = table.items()
    if body not in bodies:
        raise fail(
            f"{where}.{body}",
            f"body {body!r} is not mounted in this trial (bodies: {', '.join(bodies)})",
        )
    here = f"{where}.{body}"
    factor, unit = 1.0, "m"
    if isinstance(raw, dict):
        check_keys(raw, ("value", "unit"), where=here)
        if "value" not in raw:
            raise fail(f"{here}.value", "missing; the distance the body is moved")
        unit = raw.get("unit", "m")
        factor = unit_factor("length", unit, where=f"{here}.unit")
        raw = raw["value"]
    distance = number(raw, where=here, what=f"a distance along the lever ({unit})")
    if distance == 0:
        raise fail(here, "expected a non-zero distance (a second mounting moves the body)")
    return body, distance * factor


def _added_masses(value: object, *, where: str) -> tuple[tuple[float, float, float], ...]:
    """A trial's ``added_mass``: one table or a list of them, as sorted (m, x, rho) in SI."""
    entries = [value] if isinstance(value, dict) else value
    if not isinstance(entries, list) or not entries:
        raise fail(
            where,
            "expected { mass = kg, com_distance = m, radius_of_gyration = m } or a list of "
            f"such tables, got {value!r}",
        )
    out = []
    for j, raw in enumerate(entries):
        here = f"{where}[{j}]" if isinstance(value, list) else where
        table = as_table(raw, where=here, what="mass = kg, com_distance = m, ...")
        check_keys(table, ADDED_MASS_KEYS, where=here)
        for k in ("mass", "com_distance"):
            if k not in table:
                raise fail(f"{here}.{k}", f"missing ({'kg' if k == 'mass' else 'm'})")
        mass = check_positive(table["mass"], f"{here}.mass", "kg")
        distance = number(
            table["com_distance"],
            where=f"{here}.com_distance",
            what="a distance from the joint axis in m (negative: across the axis)",
        )
        radius = number(
            table.get("radius_of_gyration", 0.0),
            where=f"{here}.radius_of_gyration",
            what="a radius of gyration >= 0 in m",
        )
        if radius < 0:
            raise fail(f"{here}.radius_of_gyration", f"expected a radius >= 0 (m), got {radius!r}")
        out.append((mass, distance, radius))
    return tuple(sorted(out))


def _condition_key(trial: TrialSpec) -> tuple[Any, ...]:
    """What makes two trials the same condition (distances compared to the nanometre)."""
    m = trial.mounting
    return (
        m.bodies,
        m.offset_body,
        round(m.offset, 9),
        tuple(tuple(round(v, 9) for v in added) for added in m.added),
    )


def _label_conditions(trials: list[TrialSpec]) -> list[TrialSpec]:
    """Give every trial its condition's unique label (:attr:`Mounting.label`).

    A trial without offset or added mass keeps the label it has (its bodies joined by ``+``).
    """
    labels: dict[tuple[Any, ...], str] = {}
    taken: set[str] = set()
    for trial in trials:
        key = _condition_key(trial)
        if key in labels:
            continue
        label = trial.mounting.label
        stem, n = label, 1
        while label in taken:
            n += 1
            label = f"{stem}_{n}"
        labels[key] = label
        taken.add(label)
    return [replace(t, condition=labels[_condition_key(t)]) for t in trials]


def match_files(pattern: object, base: Path, *, where: str) -> list[tuple[Path, str]]:
    """The files a ``files`` glob pattern matches, relative to ``base``, sorted.

    ``*``, ``?`` and ``[...]`` match within a folder name, ``**`` any number of folders; a
    name starting with ``.`` is matched only by a pattern that starts it with ``.`` (as in a
    shell). Folders matched are left out. The order is the sorted order of the matched paths
    as written relative to ``base`` (code points: ``B_240_10`` before ``B_240_2``; number
    files with leading zeros). Returns ``(absolute path, path as matched)`` pairs.

    Raises
    ------
    InputError
        ``<where>: ...`` naming the pattern, when it is not a non-empty string or matches no
        file.
    """
    if not isinstance(pattern, str) or not pattern.strip():
        raise fail(
            where,
            f'expected a glob pattern (a string such as "data/B_240_*.csv"), got {pattern!r}',
        )
    if "\x00" in pattern:
        raise fail(where, f"a pattern cannot hold a NUL character, got {pattern!r}")
    expanded = str(expand_user(pattern, where=where))
    found = sorted(glob.glob(expanded, root_dir=base, recursive=True))
    out = [(path, shown) for shown in found if (path := (base / shown).resolve()).is_file()]
    if not out:
        folders = f" ({len(found)} folders do)" if found else ""
        raise fail(where, f"no file matches {pattern!r} (relative to {base}){folders}")
    return out


def _entry_files(entry: Mapping[str, Any], *, here: str, base: Path) -> list[tuple[Path, str]]:
    """The files of one ``[[trials]]`` entry: its ``file``, or every match of its ``files``."""
    if "file" in entry and "files" in entry:
        raise fail(
            here,
            f"both file = {entry['file']!r} and files = {entry['files']!r}; expected one: file "
            "for one trial, files for a glob pattern whose every match is a trial",
        )
    if "files" in entry:
        return match_files(entry["files"], base, where=f"{here}.files")
    if "file" not in entry:
        raise fail(
            f"{here}.file",
            "missing (the trial file, relative to the manifest; or files = a glob pattern)",
        )
    if not isinstance(entry["file"], str) or not entry["file"].strip():
        raise fail(f"{here}.file", f"expected a path (a string), got {entry['file']!r}")
    if "\x00" in entry["file"]:
        raise fail(f"{here}.file", f"a path cannot hold a NUL character, got {entry['file']!r}")
    file = resolve_file(entry["file"], base, where=f"{here}.file")
    if not file.is_file():
        raise fail(f"{here}.file", f"file not found: {file}")
    return [(file, entry["file"])]


def _trial(
    entry: object,
    i: int,
    *,
    defaults: Mapping[str, Any],
    order: list[str],
    base: Path,
    where: str,
    postures: Mapping[str, Posture],
    living: str,
    emg: EmgSettings | None = None,
    start: int = 0,
) -> list[TrialSpec]:
    """The trials of ``[[trials]]`` entry ``i``: one for ``file``, one per match of ``files``.

    Every key but the file is the entry's, checked once; what depends on the file (the
    format it is recognised as, and the options and channels that format takes) is checked
    per file, its messages naming the file. ``start`` is the first trial's :attr:`index`.
    """
    here = f"{where}: trials[{i}]"
    entry = as_table(entry, where=here, what="file, bodies, kind, ...")
    check_keys(entry, TRIAL_KEYS, where=here)
    files = _entry_files(entry, here=here, base=base)
    pattern = entry.get("files", "")

    names = entry.get("bodies")
    if names is None:
        raise fail(f"{here}.bodies", "missing (the list of mounted bodies)")
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise fail(f"{here}.bodies", f"expected a non-empty list of body names, got {names!r}")
    for n in names:
        if n not in order:
            raise fail(f"{here}.bodies", f"unknown body {n!r} (bodies: {', '.join(order)})")
    if len(set(names)) != len(names):
        raise fail(f"{here}.bodies", f"a body is listed twice: {names!r}")
    bodies = tuple(b for b in order if b in names)

    kind = entry.get("kind")
    if kind not in KINDS:
        *most, last = (f'"{k}"' for k in KINDS)  # every kind, one added included
        raise fail(f"{here}.kind", f"expected {', '.join(most)} or {last}, got {kind!r}")
    if kind == "rest" and (not living or living not in bodies):
        held = f"the living body '{living}'" if living else "a living body (none is)"
        raise fail(
            f"{here}.kind",
            f'"rest" (a quiet hold of a living joint) needs {held} mounted, got bodies '
            f"{', '.join(bodies)}",
        )
    speed = entry.get("speed")
    if speed is not None and kind == "rest":
        raise fail(f"{here}.speed", "a rest trial holds one angle: remove its speed")
    if speed is not None and kind == "mvc":
        raise fail(f"{here}.speed", "an mvc trial is a contraction, not a move: remove its speed")
    if speed is None and kind == "fast":
        raise fail(f"{here}.speed", "missing; a fast trial needs its nominal speed in deg/s")
    if speed is not None:
        speed = check_positive(speed, f"{here}.speed", "deg/s")
    window = _window(entry["window"], where=f"{here}.window") if "window" in entry else None
    if window is not None and kind != "fast":
        raise fail(
            f"{here}.window",
            f"{'an' if kind == 'mvc' else 'a'} {kind} trial has no acceleration window (its gravity fit uses the whole "
            'sweep); remove it, or set kind = "fast" if this trial is one',
        )
    offset_body, offset = (
        _offset(entry["offset"], where=f"{here}.offset", bodies=bodies)
        if "offset" in entry
        else ("", 0.0)
    )
    added = (
        _added_masses(entry["added_mass"], where=f"{here}.added_mass")
        if "added_mass" in entry
        else ()
    )

    own = _settings(entry, where=here)
    if "posture" in entry:
        posture = posture_name(entry["posture"], postures, where=f"{here}.posture")
    else:
        posture = defaults.get("posture", "")
    if postures and not posture:
        raise fail(
            f"{here}.posture",
            f"missing; with [postures] every trial names its posture, here or in [defaults] "
            f"(postures: {', '.join(postures)})",
        )
    merged: dict[str, dict[str, Any]] = {}
    for key in ("columns", "units", "calibration", "options"):
        merged[key] = {**defaults.get(key, {}), **own.get(key, {})}
    muscles, emg_from = _trial_emg(own, defaults, emg, here=here, where=where)
    if kind == "mvc" and not muscles:
        raise fail(
            f"{here}.emg",
            "no EMG channels; an mvc trial is read for its EMG (each muscle's MVC level): give it "
            "emg = [...] (or [defaults] emg, or [emg] columns)",
        )
    out = []
    for k, (file, shown) in enumerate(files):
        # a matched file's messages name it: its format may be its own (a C3D file among CSVs)
        at = f"{here} ({shown})" if pattern else here
        fmt = _format(
            own, defaults, file, merged, muscles, emg_from, here=at, shown=at if pattern else ""
        )
        out.append(
            TrialSpec(
                file=file,
                mounting=Mounting(bodies, offset_body, offset, added),
                kind=kind,
                speed=speed,
                format=fmt,
                columns=dict(merged["columns"]),
                units=dict(merged["units"]),
                calibration={c: dict(v) for c, v in merged["calibration"].items()},
                window=window,
                torque_sign=own.get("torque_sign", defaults.get("torque_sign", 1)),
                condition="+".join(bodies),
                options=dict(merged["options"]),
                index=start + k,
                lag=own.get("lag", defaults.get("lag")),
                posture=posture,
                emg=muscles,
                emg_unit=emg.unit if emg is not None and muscles else None,
                entry=i,
                pattern=pattern,
            )
        )
    return out


def _format(
    own: Mapping[str, Any],
    defaults: Mapping[str, Any],
    file: Path,
    merged: Mapping[str, Mapping[str, Any]],
    muscles: tuple[str, ...],
    emg_from: str,
    *,
    here: str,
    shown: str = "",
) -> str:
    """The format ``file`` is read with, checked against the settings that depend on it.

    ``here`` starts the messages of the entry's own keys; ``shown`` names a matched file (the
    entry and the file) in a message whose key was set elsewhere (``[defaults] emg``).
    """
    fmt = own.get("format", defaults.get("format")) or recognised_format(file) or "csv"
    if fmt == "analog":
        for channel in ("angle", "velocity", "torque"):
            if channel not in merged["calibration"]:
                raise fail(
                    f"{here}.calibration.{channel}",
                    "missing; the analog format needs { scale, offset, unit } per channel "
                    "(value = scale x volts + offset)",
                )
    if muscles and not carries_emg(fmt):
        raise fail(
            emg_from,
            f"format '{fmt}' has no EMG channels (formats with EMG: "
            f"{', '.join(f for f in available_formats() if carries_emg(f))}); remove emg for "
            f"this trial (emg = []){f' ({shown.rpartition(": ")[2]})' if shown else ''}",
        )
    allowed = reader_options(fmt)
    for option in merged["options"]:
        if option not in allowed:
            listed = ", ".join(allowed) if allowed else "none"
            raise fail(
                f"{here}.options.{option}",
                f"unknown option for format '{fmt}' (options: {listed})",
            )
    return fmt


def _trial_emg(
    own: Mapping[str, Any],
    defaults: Mapping[str, Any],
    emg: EmgSettings | None,
    *,
    here: str,
    where: str,
) -> tuple[tuple[str, ...], str]:
    """A trial's EMG columns (its own, ``[defaults]``'s, ``[emg]``'s) and where they were set."""
    if "emg" in own:
        return own["emg"], f"{here}.emg"
    if "emg" in defaults:
        return defaults["emg"], f"{where}: defaults.emg"
    if emg is not None:
        return emg.columns, f"{where}: emg.columns"
    return (), ""


def read_defaults(value: object, ctx: SectionContext) -> dict[str, Any]:
    """The ``[defaults]`` table: reader settings (and a posture) every trial starts from.

    A study-wide fixed lag (``[calibration] lag``) joins them unless they set their own.
    """
    where = ctx.where
    raw = as_table(
        {} if value is None else value, where=f"{where}: defaults", what="reader settings"
    )
    for key in raw:
        if key in MOUNTING_KEYS:
            raise fail(
                f"{where}: defaults.{key}",
                "per trial only: a mounting belongs to the trials recorded with it; put it in "
                "each [[trials]] entry of that mounting",
            )
        if key not in DEFAULT_KEYS:
            raise fail(
                f"{where}: defaults.{key}", f"unknown key (allowed: {', '.join(DEFAULT_KEYS)})"
            )
    defaults = _settings(raw, where=f"{where}: defaults")
    if "posture" in raw:
        defaults["posture"] = posture_name(
            raw["posture"], ctx.read.get("postures", {}), where=f"{where}: defaults.posture"
        )
    calibration = ctx.read.get("calibration")
    if calibration is not None and not isinstance(calibration.lag, str):  # a study-wide lag
        defaults.setdefault("lag", calibration.lag)
    return defaults


def read_trials(value: object, ctx: SectionContext) -> list[TrialSpec]:
    """The ``[[trials]]`` entries, labelled by condition and checked together.

    Each recording once; a condition with fast, rest or mvc trials has a quasi-static one;
    MVC trials record every muscle the study checks.
    """
    where = ctx.where
    if value is None or value == []:
        raise fail(f"{where}: trials", "no trials; add [[trials]] entries with file, bodies, kind")
    if not isinstance(value, list):
        raise fail(f"{where}: trials", "expected [[trials]] entries (an array of tables)")
    living = ctx.living
    assert ctx.base is not None
    trials: list[TrialSpec] = []
    for i, entry in enumerate(value):
        trials += _trial(
            entry,
            i,
            defaults=ctx.read.get("defaults", {}),
            order=list(ctx.read.get("bodies", {})),
            base=ctx.base,
            where=where,
            postures=ctx.read.get("postures", {}),
            living=living,
            emg=ctx.read.get("emg"),
            start=len(trials),
        )
    seen: dict[Path, TrialSpec] = {}
    for trial in trials:
        if trial.file in seen:
            first = seen[trial.file]
            matched = f" (files = {first.pattern!r})" if first.pattern else ""
            raise fail(
                f"{where}: {trial.key}",
                f"{trial.file} is already trials[{first.entry}]{matched}; each recording "
                "counts once",
            )
        seen[trial.file] = trial
    trials = _label_conditions(trials)
    for condition in dict.fromkeys(t.condition for t in trials):
        members = [t for t in trials if t.condition == condition]
        fast = list(dict.fromkeys(t.entry for t in members if t.kind == "fast"))
        if fast and not any(t.kind == "quasi-static" for t in members):
            listed = ", ".join(f"trials[{i}]" for i in fast[:3]) + (
                ", ..." if len(fast) > 3 else ""
            )
            raise fail(
                f"{where}: trials",
                f"condition '{condition}' has fast trials ({listed}) but no quasi-static trial; "
                'add one with kind = "quasi-static" (it gives the gravitational moment)',
            )
        rest = [t.entry for t in members if t.kind == "rest"]
        mvc = [t.entry for t in members if t.kind == "mvc"]
        if mvc and not any(t.kind == "quasi-static" for t in members):
            raise fail(
                f"{where}: trials[{mvc[0]}].bodies",
                f"an mvc trial is recorded in a mounting the study measures, but condition "
                f"'{condition}' has no quasi-static trial; give it the bodies of the trials it "
                "was recorded with",
            )
        if rest and not any(t.kind == "quasi-static" for t in members):
            raise fail(
                f"{where}: trials[{rest[0]}].kind",
                f"condition '{condition}' holds the living body '{living}' but has no "
                "quasi-static trial; rest trials alone do not do: add one with kind = "
                '"quasi-static" (it gives the gravity and passive curve)',
            )
    _check_mvc(trials, ctx.doc.get("emg"), where=where)
    return trials


register_section(Section("defaults", read_defaults, "", 60))
register_section(Section("trials", read_trials, "trials", 70))
