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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit._checks import (
    check_gravity,
    check_path,
)
from inertiafit.errors import InputError
from inertiafit.io.emg import EmgSettings
from inertiafit.io.sections import SECTIONS, SectionContext
from inertiafit.io.sections.base import fail as _fail
from inertiafit.io.sections.base import resolve_file
from inertiafit.io.sections.bodies import BODY_KEYS, MEASURED_KEYS, BodySpec
from inertiafit.io.sections.calibration import (
    CALIBRATION_KEYS,
    MAX_TORQUE_GAIN_SD,
    Calibration,
)
from inertiafit.io.sections.passive import PASSIVE_KEYS, PassivePrior, read_passive
from inertiafit.io.sections.postures import (
    DEFAULT_GRAVITY_ROTATION_SD,
    POSTURE_KEYS,
    Posture,
    read_postures,
)
from inertiafit.io.sections.subject import Subject
from inertiafit.io.sections.trials import (
    ADDED_MASS_KEYS,
    DEFAULT_KEYS,
    KINDS,
    TRIAL_KEYS,
    TrialSpec,
    read_trial_spec,
)
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

#: What a trial that cannot be read or processed does to the study: stop it (the default) or be
#: skipped, listed in ``trials.csv``, the warnings and ``report.html``.
ON_TRIAL_ERROR = ("stop", "skip")
#: The manifest's own keys; each registered section (:data:`inertiafit.io.sections.SECTIONS`)
#: adds its table's name (:func:`top_keys`).
_OWN_HEAD = ("name", "description", "gravity")
_OWN_TAIL = ("on_trial_error",)
#: Every top-level key, the sections' included (as at import: a section registered later counts
#: in :func:`top_keys`).
TOP_KEYS = (*_OWN_HEAD, *SECTIONS, *_OWN_TAIL)


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
    def subject(self) -> Subject | None:
        """The ``[subject]`` table (:class:`~inertiafit.io.sections.subject.Subject`), if any."""
        return self.sections.get("subject")

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
    path = resolve_file(str(check_path(path)), Path(), where="study manifest")
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
    # each section sees those read before it
    context = SectionContext(where=where, read=sections, base=path.parent, doc=doc)
    for table, section in SECTIONS.items():
        sections[table] = section.read(doc.get(table), context)
    bodies: dict[str, BodySpec] = sections["bodies"]
    trials: list[TrialSpec] = sections["trials"]
    calibration: Calibration = sections["calibration"]
    passive: PassivePrior | None = sections["passive"]
    postures: dict[str, Posture] = sections["postures"]
    emg: EmgSettings | None = sections["emg"]
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
