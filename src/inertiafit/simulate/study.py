"""A simulated study on disk: one CSV per trial, a ``study.toml`` manifest and ``truth.toml``.

Besides sets of bodies, a condition may be a second mounting (a body moved along the lever) or
carry known added masses, and bodies may be weighed or balanced (``measured``): the extra
information of :mod:`inertiafit.io.manifest`, written into the manifest as a lab would.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from inertiafit.measured import MEASURED_QUANTITIES
from inertiafit.mounting import Mounting
from inertiafit.physics import GRAVITY
from inertiafit.simulate.emg import EmgSimulation, Reflex, trial_emg
from inertiafit.simulate.emg import truth_lines as emg_truth_lines
from inertiafit.simulate.files import VELOCITY_UNITS, check_units, toml_value, write_trial_csv
from inertiafit.simulate.signals import Body, Motion, Noise, simulate_trial

__all__ = [
    "PlannedTrial",
    "TrialWriter",
    "condition_totals",
    "emg_manifest_lines",
    "emg_plan",
    "manifest_head",
    "simulate_study",
    "trial_entry",
    "truth_lines",
]


#: Keys of a condition given as a mapping.
_CONDITION_KEYS = ("bodies", "offset", "added_mass")
#: Keys of one added mass.
_ADDED_KEYS = ("mass", "com_distance", "radius_of_gyration")


def _condition_labels(n: int) -> list[str]:
    return [chr(ord("A") + i) if i < 26 else f"C{i}" for i in range(n)]


def _manifest_lines(mounting: Mounting) -> list[str]:
    """``offset`` and ``added_mass`` of a ``[[trials]]`` entry (none for a plain one)."""
    lines = []
    if mounting.offset_body:
        lines.append(f"offset = {toml_value({mounting.offset_body: mounting.offset})}")
    if mounting.added:
        added = [dict(zip(_ADDED_KEYS, mass, strict=True)) for mass in mounting.added]
        lines.append(f"added_mass = {toml_value(added)}")
    return lines


def condition_totals(
    mounting: Mounting, truth: Mapping[str, Body], gravity: float
) -> tuple[float, float]:
    """The condition's true ``I`` (kg m^2) and ``M_g`` (N m), moved body and added masses included."""
    values = {
        b: {
            "mass": body.mass,
            "inertia": body.inertia,
            "gravity_moment": body.gravity_moment(gravity),
        }
        for b, body in truth.items()
    }
    inertia, moment = mounting.totals(values, gravity)
    return float(inertia), float(moment)


def _mounting(
    condition: Sequence[str] | Mapping[str, Any] | Mounting, truth: Mapping[str, Body]
) -> Mounting:
    """Check one entry of ``conditions``: a Mounting, a sequence of body names or a mapping."""
    if isinstance(condition, Mounting):
        mounting = condition
    elif not isinstance(condition, Mapping):
        mounting = Mounting(tuple(condition))
    else:
        unknown = [k for k in condition if k not in _CONDITION_KEYS]
        if unknown or "bodies" not in condition:
            msg = (
                f"condition {dict(condition)!r}: expected keys {', '.join(_CONDITION_KEYS)} "
                "(bodies required)"
            )
            raise ValueError(msg)
        bodies = tuple(condition["bodies"])
        offset = dict(condition.get("offset") or {})
        if len(offset) > 1:
            msg = f"condition {bodies}: offset moves exactly one body, got {offset!r}"
            raise ValueError(msg)
        offset_body, d = next(iter(offset.items())) if offset else ("", 0.0)
        if offset_body and (offset_body not in bodies or not np.isfinite(d) or d == 0):
            msg = f"condition {bodies}: offset {offset!r} must move a mounted body a non-zero d"
            raise ValueError(msg)
        raw = condition.get("added_mass") or ()
        added = []
        for mass in [raw] if isinstance(raw, Mapping) else raw:
            if any(k not in _ADDED_KEYS for k in mass) or not {"mass", "com_distance"} <= set(
                mass
            ):
                msg = f"condition {bodies}: added mass {dict(mass)!r}: keys {_ADDED_KEYS}"
                raise ValueError(msg)
            added.append(
                (
                    float(mass["mass"]),
                    float(mass["com_distance"]),
                    float(mass.get("radius_of_gyration", 0.0)),
                )
            )
        mounting = Mounting(bodies, str(offset_body), float(d), tuple(added))
    for b in mounting.bodies:
        if b not in truth:
            msg = f"condition {mounting.bodies} names unknown body {b!r}"
            raise ValueError(msg)
    return mounting


def _readings(
    measured: Mapping[str, Mapping[str, float | Sequence[float]]],
    truth: Mapping[str, Body],
    seed: np.random.SeedSequence,
) -> dict[str, dict[str, dict[str, float]]]:
    """Weighings and balance points to write: drawn from the truth, or as given.

    A number is the measurement's SD: the reading is the true value plus a Gaussian error of
    that SD (seeded), as a real scale's would be. A pair ``(value, sd)`` is written as given.
    """
    rng = np.random.default_rng(seed)
    out: dict[str, dict[str, dict[str, float]]] = {}
    for b, table in measured.items():
        if b not in truth:
            msg = f"measured: unknown body {b!r}"
            raise ValueError(msg)
        out[b] = {}
        for key, spec in table.items():
            if key not in MEASURED_QUANTITIES:
                msg = f"measured.{b}: unknown quantity {key!r} ({', '.join(MEASURED_QUANTITIES)})"
                raise ValueError(msg)
            if isinstance(spec, int | float):
                true = getattr(truth[b], key)
                sd = float(spec)
                value = float(true + sd * rng.standard_normal())
            else:
                value, sd = map(float, spec)
            if not (sd > 0 and value > 0 and np.isfinite(value + sd)):
                msg = f"measured.{b}.{key}: need a positive value and SD, got {value!r}, {sd!r}"
                raise ValueError(msg)
            out[b][key] = {"value": value, "sd": sd}
    return out


def manifest_head(
    *,
    name: str,
    gravity: float,
    truth: Mapping[str, Body],
    priors: Mapping[str, str | Mapping[str, Any]],
    readings: Mapping[str, Mapping[str, Mapping[str, float]]],
    angle_unit: str,
    torque_unit: str,
    time_unit: str,
    living: str = "",
) -> list[str]:
    """The manifest's lines before its ``[[trials]]``: name, gravity, bodies and defaults.

    Each body's prior is ``priors[body]``, or an inline table of its true values (the prior
    loader's default spread, +-50 %); ``readings`` are its weighings and balance points; the
    body named ``living`` gets ``living = true``.
    """
    lines = [f"name = {toml_value(name)}", f"gravity = {toml_value(gravity)}", ""]
    for b, body in truth.items():
        spec = priors.get(b) or {
            "mass": body.mass,
            "radius_of_gyration": body.radius_of_gyration,
            "com_distance": body.com_distance,
        }
        lines += [f"[bodies.{b}]", f"prior = {toml_value(spec)}"]
        if b == living:
            lines.append("living = true")
        lines += [f"{key} = {toml_value(v)}" for key, v in readings.get(b, {}).items()]
        lines.append("")
    lines += [
        "[defaults]",
        'columns = { time = "time", angle = "angle", velocity = "velocity", torque = "torque" }',
        "units = "
        + toml_value(
            {
                "time": time_unit,
                "angle": angle_unit,
                "velocity": VELOCITY_UNITS[angle_unit],
                "torque": torque_unit,
            }
        ),
        "",
    ]
    return lines


def trial_entry(
    filename: str,
    bodies: Sequence[str],
    kind: str,
    speed: float | None = None,
    *,
    extra: Sequence[str] = (),
) -> list[str]:
    """One ``[[trials]]`` entry of the manifest (file under ``data/``), then a blank line.

    ``speed`` (deg/s) is written when given; ``extra`` are further ``key = value`` lines.
    """
    lines = [
        "[[trials]]",
        f"file = {toml_value('data/' + filename)}",
        f"bodies = {toml_value(list(bodies))}",
        f"kind = {toml_value(kind)}",
    ]
    if speed is not None:
        lines.append(f"speed = {toml_value(speed)}")
    return [*lines, *extra, ""]


#: A trial to simulate: its kind, preset speed (deg/s; ``None`` for a rest hold), motion
#: (``None``: :class:`Motion`'s default) and file name under ``data/``.
PlannedTrial = tuple[str, float | None, Motion | None, str]


@dataclass(frozen=True)
class TrialWriter:
    """How a simulated study records its trials: where, in which units, on which device.

    ``offset`` (N m), ``rate`` (Hz) and ``sampling`` are :func:`simulate_trial`'s; ``noise``
    is every trial's noise but a quasi-static sweep's or a rest hold's, which take
    ``quasi_static_noise`` when given. :meth:`write` writes a condition's trials;
    :func:`simulate_study` and :func:`~inertiafit.simulate.living.simulate_living_study` both
    record through it.
    """

    data: Path
    angle_unit: str = "deg"
    torque_unit: str = "N*m"
    time_unit: str = "s"
    offset: float = 0.0
    rate: float = 1000.0
    noise: Noise | None = None
    quasi_static_noise: Noise | None = None
    sampling: str = "instant"

    def write(
        self,
        plan: Sequence[PlannedTrial],
        seed: np.random.SeedSequence,
        *,
        bodies: Sequence[str],
        inertia: float,
        gravity_moment: float,
        phi: float,
        emg: EmgSimulation | None = None,
        extra_torque: Any = None,
        entry: Sequence[str] = (),
        emg_per_trial: bool = False,
    ) -> tuple[list[str], dict[str, Reflex]]:
        """One condition's trials written to :attr:`data`, in ``plan``'s order.

        Each trial's seed is spawned from ``seed``; the condition's true ``inertia`` (kg m^2)
        and ``gravity_moment`` (N m), the device phase ``phi`` (rad) and ``extra_torque`` (a
        joint's own moment, or ``None``) make its torque; ``emg`` adds its EMG channels.
        Returns the manifest's ``[[trials]]`` entries (each with the lines ``entry``, and its
        ``emg`` channels when ``emg_per_trial``) and the stretch reflexes simulated, by file.
        """
        lines: list[str] = []
        reflexes: dict[str, Reflex] = {}
        for (kind, speed, motion, filename), tseed in zip(
            plan, seed.spawn(len(plan)), strict=True
        ):
            noise = (
                self.quasi_static_noise
                if kind != "fast" and self.quasi_static_noise
                else self.noise
            )
            channels, extra, reflex = emg_plan(
                emg, tseed, filename, kind, motion, self.rate, noise, extra_torque
            )
            if reflex is not None:
                reflexes[filename] = reflex
            trial = simulate_trial(
                inertia=inertia,
                gravity_moment=gravity_moment,
                kind=kind,
                speed_deg_s=speed,
                phi=phi,
                offset=self.offset,
                rng=np.random.default_rng(tseed),
                rate=self.rate,
                noise=noise,
                motion=motion,
                source=filename,
                sampling=self.sampling,
                extra_torque=extra,
            )
            write_trial_csv(
                self.data / filename,
                trial,
                angle_unit=self.angle_unit,
                torque_unit=self.torque_unit,
                time_unit=self.time_unit,
                emg=channels(trial["time"].values) if channels is not None else None,
            )
            own = []
            if emg_per_trial and emg is not None and channels is not None:
                own = [f"emg = {toml_value(list(emg.muscles))}"]
            lines += trial_entry(
                filename,
                bodies,
                kind,
                speed if kind == "fast" else None,
                extra=[*entry, *own],
            )
        return lines, reflexes


def simulate_study(
    out_dir: str | Path,
    *,
    bodies: Mapping[str, Sequence[float]],
    conditions: Sequence[Sequence[str] | Mapping[str, Any] | Mounting],
    speeds: Sequence[float] = (240.0, 270.0, 300.0),
    trials_per_speed: int = 10,
    seed: int | None = 0,
    angle_unit: str = "deg",
    torque_unit: str = "N*m",
    time_unit: str = "s",
    phi: float = 0.0,
    offset: float = 0.0,
    gravity: float = GRAVITY,
    rate: float = 1000.0,
    quasi_static_speed: float = 1.0,
    noise: Noise | None = None,
    quasi_static_noise: Noise | None = None,
    motion: Motion | None = None,
    sampling: str = "instant",
    priors: Mapping[str, str | Mapping[str, Any]] | None = None,
    name: str = "Simulated study",
    measured: Mapping[str, Mapping[str, float | Sequence[float]]] | None = None,
    emg: EmgSimulation | None = None,
    subject: Mapping[str, Any] | None = None,
    segment_lengths: Mapping[str, float] | None = None,
) -> Path:
    """Write a simulated study: one CSV per trial and a ``study.toml`` manifest.

    For each condition (a tuple of mounted bodies) one quasi-static trial and
    ``trials_per_speed`` fast trials at every speed are written to ``out_dir/data``; the
    condition's inertia and gravity moment are the sums over its bodies. The true parameters
    are written to ``out_dir/truth.toml`` (not read by the pipeline), with the torque
    channel's ``lag`` and ``torque_gain`` (:class:`Noise`), which a study-wide ``noise``
    gives every trial.

    Parameters
    ----------
    out_dir : str or Path
        Folder to write into (created; files of the same names are replaced).
    bodies : mapping of str to (mass, radius_of_gyration, com_distance)
        True parameters of each body (kg, m, m).
    conditions : sequence of (sequence of str, mapping or Mounting)
        The bodies mounted in each condition, e.g. ``[("attachment",), ("attachment",
        "weight")]``; conditions are labelled A, B, ... in file names. A mapping
        ``{"bodies": (...), "offset": {"weight": 0.05}, "added_mass": [{"mass": 0.5,
        "com_distance": 0.3, "radius_of_gyration": 0.0}]}`` is a second mounting (the named
        body's centre of mass ``d`` metres further out along the lever) and/or known added
        masses (``radius_of_gyration`` optional, default 0); the trials see the moved body and
        the added masses, and the manifest's ``[[trials]]`` carry ``offset`` and
        ``added_mass``. A :class:`~inertiafit.mounting.Mounting` says the same.
    speeds : sequence of float
        Preset speeds of the fast trials (deg/s).
    trials_per_speed : int
        Fast trials per speed and condition.
    seed : int, optional
        Seed of the whole study.
    angle_unit : {"deg", "rad"}
        Unit of the angle (and, per second, the velocity) columns.
    torque_unit : {"N*m", "ft*lbf"}
        Unit of the torque column.
    time_unit : {"s", "ms"}
        Unit of the time column.
    phi, offset : float
        Device phase (rad) and torque offset (N m), the same in every trial.
    gravity : float
        Gravitational acceleration (m/s^2), also written to the manifest.
    rate : float
        Sampling rate (Hz).
    quasi_static_speed : float
        Speed of the quasi-static trials (deg/s).
    noise, motion : Noise, Motion, optional
        Passed to :func:`simulate_trial`.
    quasi_static_noise : Noise, optional
        Noise of the quasi-static trials instead of ``noise`` (a servo ripple sized for the
        fast ramps is several times a 1 deg/s move's speed; keep the same ``lag`` and
        ``torque_gain``: one recording chain). ``truth.toml`` records ``noise``.
    sampling : {"instant", "average"}
        Passed to :func:`simulate_trial`; ``"average"`` below 1 kHz.
    priors : mapping of str to (str or mapping), optional
        Prior spec written for each named body instead of the default inline table centred
        on the body's values: a prior name or path (str) or an inline table.
    name : str
        The manifest's ``name``.
    measured : mapping of str to mapping of str to (float or (float, float)), optional
        Weighings and balance points written into the manifest (``[bodies.<name>] mass`` and
        ``com_distance`` with their ``sd``), e.g. ``{"weight": {"mass": 0.005}}``. A number is
        the measurement's SD, and the reading written is the true value plus a seeded Gaussian
        error of that SD (a simulated scale is as honest as a real one); a pair ``(value,
        sd)`` is written exactly as given. ``truth.toml`` keeps the true values.
    emg : EmgSimulation, optional
        EMG channels in every trial (:mod:`inertiafit.simulate.emg`): rest noise, and a
        stretch reflex (burst and torque) in the fast trials it chooses. The manifest gets an
        ``[emg]`` table (``columns``, ``unit = "V"``), ``truth.toml`` an ``[emg]`` table with
        every reflex. Default None: no EMG, the files exactly as without the option.
    subject : mapping, optional
        The manifest's ``[subject]`` table (``id``, ``body_mass``, ...), written as given.
    segment_lengths : mapping of str to float, optional
        Each named body's ``segment_length`` (m), written into its ``[bodies.<name>]``.

    Returns
    -------
    Path
        Path of the written ``study.toml``.

    Raises
    ------
    ValueError
        On an unknown unit, a condition naming an unknown body, a bad offset, added mass or
        measurement, or no conditions.
    """
    check_units(angle_unit=angle_unit, torque_unit=torque_unit, time_unit=time_unit)
    if not conditions:
        msg = "no conditions"
        raise ValueError(msg)
    truth = {b: Body(*map(float, values)) for b, values in bodies.items()}
    mountings = [_mounting(condition, truth) for condition in conditions]
    priors = dict(priors or {})

    out = Path(out_dir)
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    labels = _condition_labels(len(conditions))
    root = np.random.SeedSequence(seed)
    condition_seeds = root.spawn(len(conditions))
    # Spawned after the conditions' seeds, so that measuring leaves every trial's bytes alone.
    readings: dict[str, dict[str, Any]] = {
        b: dict(r)
        for b, r in (_readings(measured, truth, root.spawn(1)[0]) if measured else {}).items()
    }
    for b, length in (segment_lengths or {}).items():
        if b not in truth:
            raise ValueError(f"segment_lengths: {b!r} is not a body ({', '.join(truth)})")
        readings.setdefault(b, {})["segment_length"] = float(length)

    lines = manifest_head(
        name=name,
        gravity=gravity,
        truth=truth,
        priors=priors,
        readings=readings,
        angle_unit=angle_unit,
        torque_unit=torque_unit,
        time_unit=time_unit,
    )
    if emg is not None:
        lines += emg_manifest_lines(emg.muscles)
    if subject is not None:
        lines += ["[subject]", *(f"{k} = {toml_value(v)}" for k, v in subject.items()), ""]
    reflexes: dict[str, Reflex] = {}
    writer = TrialWriter(
        data,
        angle_unit=angle_unit,
        torque_unit=torque_unit,
        time_unit=time_unit,
        offset=offset,
        rate=rate,
        noise=noise,
        quasi_static_noise=quasi_static_noise,
        sampling=sampling,
    )

    for label, mounting, cseed in zip(labels, mountings, condition_seeds, strict=True):
        i_total, mg_total = condition_totals(mounting, truth, gravity)
        plan: list[PlannedTrial] = [
            ("quasi-static", quasi_static_speed, motion, f"{label}_quasistatic.csv")
        ]
        plan += [
            ("fast", float(speed), motion, f"{label}_{speed:g}_{k + 1:02d}.csv")
            for speed in speeds
            for k in range(trials_per_speed)
        ]
        written, condition_reflexes = writer.write(
            plan,
            cseed,
            bodies=mounting.bodies,
            inertia=i_total,
            gravity_moment=mg_total,
            phi=phi,
            emg=emg,
            entry=_manifest_lines(mounting),
        )
        lines += written
        reflexes.update(condition_reflexes)

    manifest = out / "study.toml"
    manifest.write_text("\n".join(lines), encoding="utf-8")
    truth_text = truth_lines(truth, mountings, labels, gravity, phi, offset, noise or Noise())
    if emg is not None:
        truth_text += emg_truth_lines(emg, reflexes)
    (out / "truth.toml").write_text("\n".join(truth_text), encoding="utf-8")
    return manifest


def emg_manifest_lines(columns: Sequence[str] = ()) -> list[str]:
    """The manifest's ``[emg]`` table of a simulated study, in volts.

    ``columns`` when every trial has the channels; else each trial names its own.
    """
    lines = ["[emg]"]
    if columns:
        lines.append(f"columns = {toml_value(list(columns))}")
    return [*lines, 'unit = "V"', ""]


def emg_plan(
    emg: EmgSimulation | None,
    seed: np.random.SeedSequence,
    filename: str,
    kind: str,
    motion: Motion | None,
    rate: float,
    noise: Noise | None,
    extra: Any,
) -> tuple[Any, Any, Reflex | None]:
    """:func:`~inertiafit.simulate.emg.trial_emg` of a trial, or no EMG (``emg`` None)."""
    if emg is None:
        return None, extra, None
    motion = Motion() if motion is None else motion
    return trial_emg(
        emg,
        seed,
        filename,
        kind=kind,
        start=motion.start,
        end=motion.end,
        rest=motion.rest,
        rate=rate,
        lag=(noise or Noise()).lag,
        extra_torque=extra,
    )


def truth_lines(
    truth: Mapping[str, Body],
    conditions: Sequence[Mounting],
    labels: Sequence[str],
    gravity: float,
    phi: float,
    offset: float,
    noise: Noise,
) -> list[str]:
    """The lines of ``truth.toml``: the true parameters of every body and condition (SI units).

    ``lag`` (s) and ``torque_gain`` are the torque channel's (``Noise.lag``,
    ``Noise.torque_gain``); the inertias and moments are the bodies' own, before the gain.
    A condition's totals include its moved body and added masses, written with it.
    """
    lines = [
        "# True parameters of the simulated study (not read by the pipeline).",
        f"gravity = {gravity!r}",
        f"phi = {float(phi)!r}",
        f"offset = {float(offset)!r}",
        f"lag = {float(noise.lag)!r}",
        f"torque_gain = {float(noise.torque_gain)!r}",
        "",
    ]
    for b, body in truth.items():
        lines += [
            f"[bodies.{b}]",
            f"mass = {body.mass!r}",
            f"radius_of_gyration = {body.radius_of_gyration!r}",
            f"com_distance = {body.com_distance!r}",
            f"inertia = {body.inertia!r}",
            f"gravity_moment = {body.gravity_moment(gravity)!r}",
            "",
        ]
    for label, mounting in zip(labels, conditions, strict=True):
        i_total, mg_total = condition_totals(mounting, truth, gravity)
        lines += [
            f"[conditions.{label}]",
            f"bodies = {toml_value(list(mounting.bodies))}",
            *_manifest_lines(mounting),
            f"inertia = {i_total!r}",
            f"gravity_moment = {mg_total!r}",
            "",
        ]
    return lines
