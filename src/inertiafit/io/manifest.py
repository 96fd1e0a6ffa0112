"""The study manifest: a TOML file naming the bodies, their priors and the trial files.

::

    name = "Elbow attachment with 3 kg disk"
    gravity = 9.81                      # optional (m/s^2, 9.7 to 9.9)
    on_trial_error = "stop"             # optional; "skip" drops a bad trial, loudly
    [bodies.attachment]
    prior = "biodex-elbow-attachment"   # a prior name, a path, or an inline table
    [bodies.weight]
    prior = { mass = 2.92, radius_of_gyration = 0.035, com_distance = 0.45, spread = 0.5 }
    mass = { value = 2.93, resolution = 0.01 }          # optional: weighed (kg; or sd = ...)
    com_distance = { value = 45.5, sd = 0.2, unit = "cm" }  # optional: a balance point
    [defaults]                          # optional; each [[trials]] entry may override
    format = "csv"
    columns = { time = "t", torque = "moment" }
    units = { time = "ms", torque = "ft*lbf" }
    [[trials]]
    file = "data/A_quasistatic.csv"     # relative to this file
    bodies = ["attachment"]             # what is mounted: defines the condition
    kind = "quasi-static"               # or "fast"
    [[trials]]
    file = "data/A_240_01.csv"
    bodies = ["attachment"]
    kind = "fast"
    speed = 240                         # nominal deg/s; required for fast trials
    window = [0.10, 0.22]               # optional manual acceleration window (s)
    torque_sign = -1                    # optional, +1 or -1 ("motion": see apply_torque_sign)
    lag = 0.003                         # optional (also in [defaults]): fixed torque lag (s)
    emg = ["biceps", "triceps"]         # optional (also in [defaults]): EMG columns to read
    [[trials]]                          # a second mounting: its own condition
    file = "data/C_quasistatic.csv"
    bodies = ["attachment", "weight"]
    kind = "quasi-static"
    offset = { weight = 0.05 }          # per trial only: this body sits 5 cm further out (m)
    added_mass = { mass = 0.5, com_distance = 0.30 }  # per trial only: a known mass (SI)
    [calibration]                       # optional; systematic errors of the instrument
    torque_gain_sd = 0.01               # relative SD of the torque gain (default 0)
    angle_offset_sd = 0.5               # deg (default 0; absorbed by the gravity phase)
    lag = "estimate"                    # or seconds, fixed for every trial
    lag_bounds = [-0.02, 0.02]          # s, search range of the estimated lag
    max_lag_spread = 0.001              # s, lags further from the study's median are flagged
    [emg]                               # optional; EMG of every trial and its activity check
    columns = ["biceps", "triceps"]     # (inertiafit.io.emg: unit, band, rms_window, ...)

:func:`load_study` checks all of it and returns a :class:`Study`; every problem is one
:class:`~inertiafit.errors.InputError` line naming the manifest and the key path, such as
``trials[3].bodies`` (``trials[0]`` is the first ``[[trials]]`` entry).

Extra information
-----------------
A body's ``mass`` (a scale) and ``com_distance`` (a balance point: the centre of mass's
distance from the joint axis in the body's own mounting) are tables ``{ value, sd | resolution,
unit }``; ``resolution`` is a reading rounded to that step, whose rounding error alone has the
SD ``resolution / sqrt(12)`` (a scale's stated accuracy, given as ``sd``, is usually larger).
They become :attr:`BodySpec.measured` (value, SD in kg and m). A trial's ``offset`` (one mounted
body moved that far along the lever, m or ``{ value, unit }``) and ``added_mass`` (known masses:
``mass`` kg, ``com_distance`` m, optional ``radius_of_gyration`` m about their own centre of
mass) are part of its condition: trials that differ in them are different conditions
(a :class:`~inertiafit.mounting.Mounting` each, :attr:`Study.mountings`), labelled by its
:attr:`~inertiafit.mounting.Mounting.label`.

Living segments
---------------
::

    [bodies.forearm]
    prior = "..."
    living = true                       # at most one body per study
    [passive]                           # required with a living body, refused without one
    joint = "elbow"                     # "elbow", "knee", "ankle" or "generic"
    joint_angle_at_zero = 90            # deg: joint angle = this + the device's angle
    stiffness = { mean = 1.1, sd = 0.45 }   # optional overrides of priors/passive/<joint>.toml
    range = [30.0, 150.0]
    [postures.seated]
    gravity_rotation = 0                # deg, required
    gravity_rotation_sd = 2             # deg (default 2), or "free"
    axis_tilt = 0                       # deg in [0, 90] (default 0)
    [[trials]]
    posture = "seated"                  # (or in [defaults]) on every trial when postures exist
    kind = "rest"                       # a quiet hold: only with the living body mounted
    [[trials]]
    kind = "mvc"                        # a maximal voluntary contraction with EMG: MVC levels

A living body (:attr:`BodySpec.living`) brings its joint's passive prior
(:class:`PassivePrior`, :attr:`Study.passive`): the shipped file
``priors/passive/<joint>.toml`` with the ``[passive]`` table's overrides merged in, each number's
source recorded. Postures (:class:`Posture`, :attr:`Study.postures`) do not split conditions:
a condition is what is mounted, and :attr:`TrialSpec.posture` says which setup a trial was
recorded in.
"""

from __future__ import annotations

import hashlib
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit._checks import (
    check_gravity,
    check_increasing_pair,
    check_path,
    check_positive,
)
from inertiafit.errors import InputError
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
from inertiafit.io.sections import SECTIONS, SectionContext
from inertiafit.io.sections.base import as_table as _table
from inertiafit.io.sections.base import fail as _fail
from inertiafit.io.sections.base import number as _number
from inertiafit.io.sections.bodies import BODY_KEYS, MEASURED_KEYS, BodySpec
from inertiafit.io.sections.calibration import (
    CALIBRATION_KEYS,
    MAX_TORQUE_GAIN_SD,
    Calibration,
)
from inertiafit.io.sections.calibration import read_lag as _lag
from inertiafit.io.sections.passive import PASSIVE_KEYS, PassivePrior, read_passive
from inertiafit.io.sections.postures import (
    DEFAULT_GRAVITY_ROTATION_SD,
    POSTURE_KEYS,
    Posture,
    read_postures,
)
from inertiafit.io.sections.postures import posture_name as _posture_name
from inertiafit.io.trial import apply_torque_sign
from inertiafit.io.units import unit_factor
from inertiafit.mounting import Mounting
from inertiafit.physics import GRAVITY

__all__ = [
    "ADDED_MASS_KEYS",
    "BODY_KEYS",
    "CALIBRATION_KEYS",
    "DEFAULT_GRAVITY_ROTATION_SD",
    "DEFAULT_KEYS",
    "KINDS",
    "MAX_TORQUE_GAIN_SD",
    "MEASURED_KEYS",
    "ON_TRIAL_ERROR",
    "PASSIVE_KEYS",
    "POSTURE_KEYS",
    "TOP_KEYS",
    "TRIAL_KEYS",
    "BodySpec",
    "Calibration",
    "PassivePrior",
    "Posture",
    "Study",
    "TrialSpec",
    "file_sha256",
    "load_study",
    "read_passive",
    "read_postures",
    "read_trial_spec",
]

#: Trial kinds: a slow sweep (gravity, and a living joint's passive moment), a fast isokinetic
#: move (inertia), a quiet hold at one angle of a living body (``"rest"``) and a maximal
#: voluntary contraction recorded for its EMG (``"mvc"``: the muscles' MVC levels, never
#: evidence).
KINDS = ("quasi-static", "fast", "rest", "mvc")
#: What a trial that cannot be read or processed does to the study: stop it (the default) or be
#: skipped, listed in ``trials.csv``, the warnings and ``report.html``.
ON_TRIAL_ERROR = ("stop", "skip")
#: The manifest's own keys; each registered section (:data:`inertiafit.io.sections.SECTIONS`)
#: adds its table's name (:func:`top_keys`).
_OWN_HEAD = ("name", "description", "gravity")
_OWN_TAIL = ("defaults", "trials", "on_trial_error")
#: Every top-level key, the sections' included (as at import: a section registered later counts
#: in :func:`top_keys`).
TOP_KEYS = (*_OWN_HEAD, *SECTIONS, *_OWN_TAIL)
#: Keys of one ``added_mass`` table of a trial (SI: kg, m, m).
ADDED_MASS_KEYS = ("mass", "com_distance", "radius_of_gyration")
#: Keys of a trial that describe its mounting; never in ``[defaults]``.
_MOUNTING_KEYS = ("offset", "added_mass")
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
TRIAL_KEYS = ("file", "bodies", "kind", "speed", "window", *_MOUNTING_KEYS, *DEFAULT_KEYS)


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
        Position of the entry in ``[[trials]]`` (0-based), as used in error messages.
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


@dataclass(frozen=True)
class Study:
    """A checked study manifest.

    Attributes
    ----------
    name : str
        The manifest's ``name`` (default: the file name without extension).
    path : Path
        Absolute path of the manifest.
    base_dir : Path
        Directory that relative trial paths are resolved against (the manifest's).
    gravity : float
        Gravitational acceleration (m/s^2), default 9.81; 9.7 to 9.9
        (:data:`~inertiafit._checks.GRAVITY_RANGE`).
    bodies : dict of str to BodySpec
        In manifest order.
    trials : list of TrialSpec
        In manifest order.
    description : str
        Free text, may be empty.
    on_trial_error : {"stop", "skip"}
        What a trial that cannot be read or processed does: stop the study (default), or be
        skipped and listed (see :func:`inertiafit.processing.study.process_study`).
    calibration : Calibration
        The ``[calibration]`` table (defaults when absent).
    passive : PassivePrior or None
        The ``[passive]`` table of the living body's joint; ``None`` in a rigid study.
    postures : dict of str to Posture
        The ``[postures]`` tables, in manifest order; empty when none (every trial then in one
        posture with no gravity rotation).
    emg : EmgSettings or None
        The ``[emg]`` table (:mod:`inertiafit.io.emg`); ``None`` when the manifest has none.
    sections : dict of str to object
        What every registered section's reader returned (:data:`inertiafit.io.sections.SECTIONS`),
        by its table's name: the tables above again, and any section added since.
    """

    name: str
    path: Path
    base_dir: Path
    gravity: float
    bodies: dict[str, BodySpec]
    trials: list[TrialSpec]
    description: str = ""
    on_trial_error: str = "stop"
    calibration: Calibration = field(default_factory=Calibration)
    passive: PassivePrior | None = None
    postures: dict[str, Posture] = field(default_factory=dict)
    emg: EmgSettings | None = None
    sections: dict[str, Any] = field(default_factory=dict)

    @property
    def living_body(self) -> str:
        """The name of the living body (``living = true``), ``""`` when every body is rigid."""
        return next((name for name, b in self.bodies.items() if b.living), "")

    @property
    def conditions(self) -> dict[str, tuple[str, ...]]:
        """Condition label -> mounted body names, in order of first appearance in trials."""
        out: dict[str, tuple[str, ...]] = {}
        for trial in self.trials:
            out.setdefault(trial.condition, trial.bodies)
        return out

    @property
    def mountings(self) -> dict[str, Mounting]:
        """Condition label -> what is mounted (bodies, offset, added masses), as ``conditions``."""
        out: dict[str, Mounting] = {}
        for t in self.trials:
            out.setdefault(t.condition, t.mounting)
        return out

    @property
    def measured(self) -> dict[str, dict[str, tuple[float, float]]]:
        """Body -> its direct measurements (``BodySpec.measured``), bodies with any only."""
        return {name: dict(b.measured) for name, b in self.bodies.items() if b.measured}

    def read(self, trial: TrialSpec | int) -> xr.Dataset:
        """Read one trial (a TrialSpec or its index) into a Trial dataset.

        See :func:`read_trial_spec`.
        """
        spec = self.trials[trial] if isinstance(trial, int) else trial
        return read_trial_spec(spec)


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


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes, as 64 hex digits (the provenance of an input file).

    Raises
    ------
    InputError
        The file cannot be read (names it).
    """
    digest = hashlib.sha256()
    try:
        with Path(path).open("rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
    except OSError as err:
        raise InputError(f"{path}: cannot read the file ({err.strerror or err})") from None
    return digest.hexdigest()


# --------------------------------------------------------------------------------------------


def _torque_sign(value: object, *, where: str) -> int | str:
    if value == "motion":
        return "motion"
    if isinstance(value, bool) or value not in (1, -1):
        raise _fail(
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
            raise _fail(
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
            _table(table["options"], where=f"{where}.options", what="reader option = value")
        )
    if "lag" in table:
        out["lag"] = _lag(table["lag"], where=f"{where}.lag")
    if "emg" in table:
        out["emg"] = check_emg(table["emg"], where=f"{where}.emg")
    return out


def load_study(path: str | Path) -> Study:
    """Read and check a study manifest.

    Parameters
    ----------
    path : str or Path
        The TOML manifest; trial paths in it are relative to its directory.

    Returns
    -------
    Study
        Bodies and trials in manifest order, defaults merged into every trial.

    Raises
    ------
    InputError
        One line naming the manifest and the key path: a TOML syntax error (with its line),
        an unknown key, a missing trial file, an unknown body, a body without prior, a bad
        ``kind``, ``speed``, ``window``, ``torque_sign``, ``lag`` or ``on_trial_error``, an
        unknown format, unit or option, a bad ``[calibration]`` value (unknown key, wrong
        type, not finite, a negative SD, ``lag_bounds`` not increasing), a bad measured
        ``mass`` or ``com_distance`` (no value, a value or SD not positive, both ``sd`` and
        ``resolution`` or neither, an unknown unit), a bad ``offset`` (not exactly one
        mounted body, zero or not finite) or ``added_mass``, either of those in
        ``[defaults]``, no trials, or a condition with fast trials but no quasi-static one.
        Of living segments: ``living`` not a bool, two living bodies, a living body without
        ``[passive]`` or ``[passive]`` without one, an unknown joint or key, a bad override
        (an SD not positive, a ``range`` not increasing, ``curve_scale`` of a joint without a
        literature curve), a bad posture (``gravity_rotation`` missing or outside (-360, 360)
        deg, ``gravity_rotation_sd`` not positive nor ``"free"``, ``axis_tilt`` outside
        [0, 90] deg), a trial's ``posture`` undefined, named without ``[postures]`` or missing
        with them, a rest trial without the living body or with a ``speed``, and a condition
        of the living body with rest trials but no quasi-static one.
    """
    path = check_path(path).expanduser().resolve()
    where = str(path)
    if not path.is_file():
        raise _fail(where, "study manifest not found")
    try:
        # utf-8-sig: a byte-order mark (which some Windows editors write) is not TOML
        with path.open(encoding="utf-8-sig", newline="") as handle:
            doc = tomllib.loads(handle.read())
    except tomllib.TOMLDecodeError as err:
        raise _fail(where, f"TOML syntax error: {err}") from None
    except UnicodeDecodeError as err:
        raise _fail(where, f"not a UTF-8 text file ({err.reason})") from None
    except OSError as err:
        raise _fail(where, f"cannot read the manifest ({err.strerror or err})") from None

    allowed = top_keys()
    for key in doc:
        if key not in allowed:
            raise _fail(
                f"{where}: {key}", f"unknown top-level key (allowed: {', '.join(allowed)})"
            )
    name = doc.get("name", path.stem)
    if not isinstance(name, str):
        raise _fail(f"{where}: name", f"expected a string, got {name!r}")
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise _fail(f"{where}: description", f"expected a string, got {description!r}")
    gravity = check_gravity(doc.get("gravity", GRAVITY), f"{where}: gravity")
    on_trial_error = doc.get("on_trial_error", "stop")
    if on_trial_error not in ON_TRIAL_ERROR:
        raise _fail(
            f"{where}: on_trial_error", f'expected "stop" or "skip", got {on_trial_error!r}'
        )

    sections: dict[str, Any] = {}
    context = SectionContext(where=where, read=sections)  # each sees those read before it
    for table, section in SECTIONS.items():
        sections[table] = section.read(doc.get(table), context)
    bodies: dict[str, BodySpec] = sections["bodies"]
    living = context.living
    calibration: Calibration = sections["calibration"]
    passive: PassivePrior | None = sections["passive"]
    postures: dict[str, Posture] = sections["postures"]
    emg: EmgSettings | None = sections["emg"]
    raw_defaults = _table(
        doc.get("defaults", {}), where=f"{where}: defaults", what="reader settings"
    )
    for key in raw_defaults:
        if key in _MOUNTING_KEYS:
            raise _fail(
                f"{where}: defaults.{key}",
                "per trial only: a mounting belongs to the trials recorded with it; put it in "
                "each [[trials]] entry of that mounting",
            )
        if key not in DEFAULT_KEYS:
            raise _fail(
                f"{where}: defaults.{key}", f"unknown key (allowed: {', '.join(DEFAULT_KEYS)})"
            )
    defaults = _settings(raw_defaults, where=f"{where}: defaults")
    if "posture" in raw_defaults:
        defaults["posture"] = _posture_name(
            raw_defaults["posture"], postures, where=f"{where}: defaults.posture"
        )

    raw_trials = doc.get("trials")
    if raw_trials is None or raw_trials == []:
        raise _fail(
            f"{where}: trials", "no trials; add [[trials]] entries with file, bodies, kind"
        )
    if not isinstance(raw_trials, list):
        raise _fail(f"{where}: trials", "expected [[trials]] entries (an array of tables)")
    order = list(bodies)
    if not isinstance(calibration.lag, str):  # a study-wide fixed lag
        defaults.setdefault("lag", calibration.lag)
    trials = [
        _trial(
            entry,
            i,
            defaults=defaults,
            order=order,
            base=path.parent,
            where=where,
            postures=postures,
            living=living,
            emg=emg,
        )
        for i, entry in enumerate(raw_trials)
    ]

    seen: dict[Path, int] = {}
    for trial in trials:
        if trial.file in seen:
            raise _fail(
                f"{where}: trials[{trial.index}].file",
                f"{trial.file} is already trials[{seen[trial.file]}]; each recording counts once",
            )
        seen[trial.file] = trial.index
    trials = _label_conditions(trials)
    for condition in dict.fromkeys(t.condition for t in trials):
        members = [t for t in trials if t.condition == condition]
        fast = [t.index for t in members if t.kind == "fast"]
        if fast and not any(t.kind == "quasi-static" for t in members):
            listed = ", ".join(f"trials[{i}]" for i in fast[:3]) + (
                ", ..." if len(fast) > 3 else ""
            )
            raise _fail(
                f"{where}: trials",
                f"condition '{condition}' has fast trials ({listed}) but no quasi-static trial; "
                'add one with kind = "quasi-static" (it gives the gravitational moment)',
            )
        rest = [t.index for t in members if t.kind == "rest"]
        mvc = [t.index for t in members if t.kind == "mvc"]
        if mvc and not any(t.kind == "quasi-static" for t in members):
            raise _fail(
                f"{where}: trials[{mvc[0]}].bodies",
                f"an mvc trial is recorded in a mounting the study measures, but condition "
                f"'{condition}' has no quasi-static trial; give it the bodies of the trials it "
                "was recorded with",
            )
        if rest and not any(t.kind == "quasi-static" for t in members):
            raise _fail(
                f"{where}: trials[{rest[0]}].kind",
                f"condition '{condition}' holds the living body '{living}' but has no "
                "quasi-static trial; rest trials alone do not do: add one with kind = "
                '"quasi-static" (it gives the gravity and passive curve)',
            )
    _check_mvc(trials, doc.get("emg"), where=where)
    return Study(
        name=name,
        path=path,
        base_dir=path.parent,
        gravity=gravity,
        bodies=bodies,
        trials=trials,
        description=description,
        on_trial_error=on_trial_error,
        calibration=calibration,
        passive=passive,
        postures=postures,
        emg=emg,
        sections=sections,
    )


def top_keys() -> tuple[str, ...]:
    """The manifest's top-level keys: its own and every registered section's table."""
    return (*_OWN_HEAD, *SECTIONS, *_OWN_TAIL)


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
            raise _fail(
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
            listed = ", ".join(f"trials[{x.index}]" for x in mvc[:3])
            raise _fail(
                f"{where}: trials[{mvc[0].index}].emg",
                f"no mvc trial ({listed}) records EMG channel {missing[0]!r}, which "
                f"trials[{t.index}] records; record every checked muscle in an mvc trial",
            )


def _offset(value: object, *, where: str, bodies: tuple[str, ...]) -> tuple[str, float]:
    """A trial's ``offset = { <body> = d }``: the one body moved and ``d`` in metres."""
    table = _table(value, where=where, what="{ <body> = distance in m }")
    if len(table) != 1:
        raise _fail(
            where,
            f"expected exactly one body moved along the lever ({{ <body> = distance in m }}), "
            f"got {value!r}",
        )
    ((body, raw),) = table.items()
    if body not in bodies:
        raise _fail(
            f"{where}.{body}",
            f"body {body!r} is not mounted in this trial (bodies: {', '.join(bodies)})",
        )
    here = f"{where}.{body}"
    factor, unit = 1.0, "m"
    if isinstance(raw, dict):
        for k in raw:
            if k not in ("value", "unit"):
                raise _fail(f"{here}.{k}", "unknown key (allowed: value, unit)")
        if "value" not in raw:
            raise _fail(f"{here}.value", "missing; the distance the body is moved")
        unit = raw.get("unit", "m")
        factor = unit_factor("length", unit, where=f"{here}.unit")
        raw = raw["value"]
    distance = _number(raw, where=here, what=f"a distance along the lever ({unit})")
    if distance == 0:
        raise _fail(here, "expected a non-zero distance (a second mounting moves the body)")
    return body, distance * factor


def _added_masses(value: object, *, where: str) -> tuple[tuple[float, float, float], ...]:
    """A trial's ``added_mass``: one table or a list of them, as sorted (m, x, rho) in SI."""
    entries = [value] if isinstance(value, dict) else value
    if not isinstance(entries, list) or not entries:
        raise _fail(
            where,
            "expected { mass = kg, com_distance = m, radius_of_gyration = m } or a list of "
            f"such tables, got {value!r}",
        )
    out = []
    for j, raw in enumerate(entries):
        here = f"{where}[{j}]" if isinstance(value, list) else where
        table = _table(raw, where=here, what="mass = kg, com_distance = m, ...")
        for k in table:
            if k not in ADDED_MASS_KEYS:
                raise _fail(f"{here}.{k}", f"unknown key (allowed: {', '.join(ADDED_MASS_KEYS)})")
        for k in ("mass", "com_distance"):
            if k not in table:
                raise _fail(f"{here}.{k}", f"missing ({'kg' if k == 'mass' else 'm'})")
        mass = check_positive(table["mass"], f"{here}.mass", "kg")
        distance = _number(
            table["com_distance"],
            where=f"{here}.com_distance",
            what="a distance from the joint axis in m (negative: across the axis)",
        )
        radius = _number(
            table.get("radius_of_gyration", 0.0),
            where=f"{here}.radius_of_gyration",
            what="a radius of gyration >= 0 in m",
        )
        if radius < 0:
            raise _fail(
                f"{here}.radius_of_gyration", f"expected a radius >= 0 (m), got {radius!r}"
            )
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
) -> TrialSpec:
    here = f"{where}: trials[{i}]"
    entry = _table(entry, where=here, what="file, bodies, kind, ...")
    for key in entry:
        if key not in TRIAL_KEYS:
            raise _fail(f"{here}.{key}", f"unknown key (allowed: {', '.join(TRIAL_KEYS)})")

    if "file" not in entry:
        raise _fail(f"{here}.file", "missing (the trial file, relative to the manifest)")
    if not isinstance(entry["file"], str) or not entry["file"].strip():
        raise _fail(f"{here}.file", f"expected a path (a string), got {entry['file']!r}")
    if "\x00" in entry["file"]:
        raise _fail(f"{here}.file", f"a path cannot hold a NUL character, got {entry['file']!r}")
    file = (base / Path(entry["file"]).expanduser()).resolve()
    if not file.is_file():
        raise _fail(f"{here}.file", f"file not found: {file}")

    names = entry.get("bodies")
    if names is None:
        raise _fail(f"{here}.bodies", "missing (the list of mounted bodies)")
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise _fail(f"{here}.bodies", f"expected a non-empty list of body names, got {names!r}")
    for n in names:
        if n not in order:
            raise _fail(f"{here}.bodies", f"unknown body {n!r} (bodies: {', '.join(order)})")
    if len(set(names)) != len(names):
        raise _fail(f"{here}.bodies", f"a body is listed twice: {names!r}")
    bodies = tuple(b for b in order if b in names)

    kind = entry.get("kind")
    if kind not in KINDS:
        raise _fail(
            f"{here}.kind", f'expected "quasi-static", "fast", "rest" or "mvc", got {kind!r}'
        )
    if kind == "rest" and (not living or living not in bodies):
        held = f"the living body '{living}'" if living else "a living body (none is)"
        raise _fail(
            f"{here}.kind",
            f'"rest" (a quiet hold of a living joint) needs {held} mounted, got bodies '
            f"{', '.join(bodies)}",
        )
    speed = entry.get("speed")
    if speed is not None and kind == "rest":
        raise _fail(f"{here}.speed", "a rest trial holds one angle: remove its speed")
    if speed is not None and kind == "mvc":
        raise _fail(f"{here}.speed", "an mvc trial is a contraction, not a move: remove its speed")
    if speed is None and kind == "fast":
        raise _fail(f"{here}.speed", "missing; a fast trial needs its nominal speed in deg/s")
    if speed is not None:
        speed = check_positive(speed, f"{here}.speed", "deg/s")
    window = _window(entry["window"], where=f"{here}.window") if "window" in entry else None
    if window is not None and kind != "fast":
        raise _fail(
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
        posture = _posture_name(entry["posture"], postures, where=f"{here}.posture")
    else:
        posture = defaults.get("posture", "")
    if postures and not posture:
        raise _fail(
            f"{here}.posture",
            f"missing; with [postures] every trial names its posture, here or in [defaults] "
            f"(postures: {', '.join(postures)})",
        )
    fmt = own.get("format", defaults.get("format")) or recognised_format(file) or "csv"
    merged: dict[str, dict[str, Any]] = {}
    for key in ("columns", "units", "calibration", "options"):
        merged[key] = {**defaults.get(key, {}), **own.get(key, {})}
    if fmt == "analog":
        for channel in ("angle", "velocity", "torque"):
            if channel not in merged["calibration"]:
                raise _fail(
                    f"{here}.calibration.{channel}",
                    "missing; the analog format needs { scale, offset, unit } per channel "
                    "(value = scale x volts + offset)",
                )
    muscles, emg_from = _trial_emg(own, defaults, emg, here=here, where=where)
    if kind == "mvc" and not muscles:
        raise _fail(
            f"{here}.emg",
            "no EMG channels; an mvc trial is read for its EMG (each muscle's MVC level): give it "
            "emg = [...] (or [defaults] emg, or [emg] columns)",
        )
    if muscles and not carries_emg(fmt):
        raise _fail(
            emg_from,
            f"format '{fmt}' has no EMG channels (formats with EMG: "
            f"{', '.join(f for f in available_formats() if carries_emg(f))}); remove emg for "
            "this trial (emg = [])",
        )
    allowed = reader_options(fmt)
    for option in merged["options"]:
        if option not in allowed:
            listed = ", ".join(allowed) if allowed else "none"
            raise _fail(
                f"{here}.options.{option}",
                f"unknown option for format '{fmt}' (options: {listed})",
            )
    return TrialSpec(
        file=file,
        mounting=Mounting(bodies, offset_body, offset, added),
        kind=kind,
        speed=speed,
        format=fmt,
        columns=merged["columns"],
        units=merged["units"],
        calibration=merged["calibration"],
        window=window,
        torque_sign=own.get("torque_sign", defaults.get("torque_sign", 1)),
        condition="+".join(bodies),
        options=merged["options"],
        index=i,
        lag=own.get("lag", defaults.get("lag")),
        posture=posture,
        emg=muscles,
        emg_unit=emg.unit if emg is not None and muscles else None,
    )


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
