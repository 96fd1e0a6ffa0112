"""A simulated study on disk: one CSV per trial, a ``study.toml`` manifest and ``truth.toml``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from inertiafit.physics import GRAVITY
from inertiafit.simulate.files import VELOCITY_UNITS, check_units, toml_value, write_trial_csv
from inertiafit.simulate.signals import Body, Motion, Noise, simulate_trial

__all__ = ["simulate_study"]


def _condition_labels(n: int) -> list[str]:
    return [chr(ord("A") + i) if i < 26 else f"C{i}" for i in range(n)]


def simulate_study(
    out_dir: str | Path,
    *,
    bodies: Mapping[str, Sequence[float]],
    conditions: Sequence[Sequence[str]],
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
    conditions : sequence of sequence of str
        The bodies mounted in each condition, e.g. ``[("attachment",), ("attachment",
        "weight")]``; conditions are labelled A, B, ... in file names.
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

    Returns
    -------
    Path
        Path of the written ``study.toml``.

    Raises
    ------
    ValueError
        On an unknown unit, a condition naming an unknown body, or no conditions.
    """
    check_units(angle_unit=angle_unit, torque_unit=torque_unit, time_unit=time_unit)
    if not conditions:
        msg = "no conditions"
        raise ValueError(msg)
    truth = {b: Body(*map(float, values)) for b, values in bodies.items()}
    for condition in conditions:
        for b in condition:
            if b not in truth:
                msg = f"condition {tuple(condition)} names unknown body {b!r}"
                raise ValueError(msg)
    priors = dict(priors or {})

    out = Path(out_dir)
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    labels = _condition_labels(len(conditions))
    root = np.random.SeedSequence(seed)
    condition_seeds = root.spawn(len(conditions))

    lines = [f"name = {toml_value(name)}", f"gravity = {toml_value(gravity)}", ""]
    for b, body in truth.items():
        spec = priors.get(b) or {
            "mass": body.mass,
            "radius_of_gyration": body.radius_of_gyration,
            "com_distance": body.com_distance,
        }
        lines += [f"[bodies.{b}]", f"prior = {toml_value(spec)}", ""]
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

    for label, condition, cseed in zip(labels, conditions, condition_seeds, strict=True):
        mounted = [truth[b] for b in condition]
        i_total = sum(body.inertia for body in mounted)
        mg_total = sum(body.gravity_moment(gravity) for body in mounted)
        plan = [("quasi-static", quasi_static_speed, f"{label}_quasistatic.csv")]
        plan += [
            ("fast", float(speed), f"{label}_{speed:g}_{k + 1:02d}.csv")
            for speed in speeds
            for k in range(trials_per_speed)
        ]
        for (kind, speed, filename), tseed in zip(plan, cseed.spawn(len(plan)), strict=True):
            trial = simulate_trial(
                inertia=i_total,
                gravity_moment=mg_total,
                kind=kind,
                speed_deg_s=speed,
                phi=phi,
                offset=offset,
                rng=np.random.default_rng(tseed),
                rate=rate,
                noise=quasi_static_noise
                if kind == "quasi-static" and quasi_static_noise
                else noise,
                motion=motion,
                source=filename,
                sampling=sampling,
            )
            write_trial_csv(
                data / filename,
                trial,
                angle_unit=angle_unit,
                torque_unit=torque_unit,
                time_unit=time_unit,
            )
            lines += [
                "[[trials]]",
                f"file = {toml_value('data/' + filename)}",
                f"bodies = {toml_value(list(condition))}",
                f"kind = {toml_value(kind)}",
            ]
            if kind == "fast":
                lines.append(f"speed = {toml_value(speed)}")
            lines.append("")

    manifest = out / "study.toml"
    manifest.write_text("\n".join(lines), encoding="utf-8")
    _write_truth(
        out / "truth.toml", truth, conditions, labels, gravity, phi, offset, noise or Noise()
    )
    return manifest


def _write_truth(
    path: Path,
    truth: Mapping[str, Body],
    conditions: Sequence[Sequence[str]],
    labels: Sequence[str],
    gravity: float,
    phi: float,
    offset: float,
    noise: Noise,
) -> None:
    """Write ``truth.toml``: the true parameters of every body and condition (SI units).

    ``lag`` (s) and ``torque_gain`` are the torque channel's (``Noise.lag``,
    ``Noise.torque_gain``); the inertias and moments are the bodies' own, before the gain.
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
    for label, condition in zip(labels, conditions, strict=True):
        mounted = [truth[b] for b in condition]
        lines += [
            f"[conditions.{label}]",
            f"bodies = {toml_value(list(condition))}",
            f"inertia = {sum(b.inertia for b in mounted)!r}",
            f"gravity_moment = {sum(b.gravity_moment(gravity) for b in mounted)!r}",
            "",
        ]
    path.write_text("\n".join(lines), encoding="utf-8")
