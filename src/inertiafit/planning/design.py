"""What a session would measure: designs, their conditions and the noise of a trial.

A :class:`Design` names the conditions measured (a :class:`~inertiafit.mounting.Mounting`
each: bodies mounted together, one of them maybe moved along the lever), the fast trials per speed, the quasi-static trials,
the bodies weighed or balanced, per-body priors and the torque gain's SD. :class:`NoiseLevels`
is the noise of one trial (nominal levels, or a pilot's per condition,
:class:`ConditionNoise`). :func:`nominal_values` reads each body's nominal ``(m, x, rho)``;
:func:`design_variants` derives the variants ``inertiafit plan`` compares.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from inertiafit._checks import check_number, check_positive
from inertiafit.errors import InputError
from inertiafit.measured import MEASURED_QUANTITIES, MeasuredQuantity
from inertiafit.mounting import Mounting
from inertiafit.physics import PARAMETERS

__all__ = [
    "DEFAULT_SPEEDS",
    "PAPER_GRAVITY_MOMENT_SE",
    "PAPER_INERTIA_SD",
    "ConditionNoise",
    "Design",
    "NoiseLevels",
    "design_variants",
    "is_whole",
    "nominal_values",
]

#: The paper's fast speeds (deg/s).
DEFAULT_SPEEDS = (240.0, 270.0, 300.0)

#: Per-trial SD of a fast trial's inertia (kg m^2) under the simulator's ``Noise.paper()``:
#: root mean square 0.014-0.021 per condition and speed over six simulated paper studies
#: (``paper_study``, seeds 10-15), the same whatever is mounted (its per-trial torque shift is
#: in N m, not relative), like the paper's 0.017 for the attachment.
PAPER_INERTIA_SD = 0.017

#: SE of one quasi-static trial's gravity moment (N m) under ``Noise.paper()`` at 1 deg/s over
#: 90 deg: root mean square 0.022 (attachment) and 0.024 (attachment + disk) in those studies.
PAPER_GRAVITY_MOMENT_SE = 0.023


def is_whole(value: Any) -> bool:
    """Whether ``value`` is a whole number (not a bool)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool)


@dataclass(frozen=True)
class Design:
    """A candidate session.

    Attributes
    ----------
    name : str
        Shown in tables and figures.
    mountings : tuple of Mounting
        The conditions measured.
    trials_per_speed : int
        Fast trials per speed and condition.
    speeds : tuple of float
        Preset speeds of the fast trials (deg/s).
    quasi_static_trials : int
        Quasi-static trials per condition (their gravity moments are combined).
    priors : mapping of str to prior spec
        Per body, a prior overriding the plan's (anything :func:`load_prior` accepts).
    weighed : mapping of str to float
        Bodies weighed on a scale, with the scale's SD (kg).
    balanced : mapping of str to float
        Bodies whose centre of mass is found on a balance, with its SD (m).
    torque_gain_sd : float
        Relative SD of the torque gain carried in the posterior (0: none).
    living : str
        The living body (``""``: none). Its conditions' gravity moment comes from the joint
        fit of gravity and the passive curve (:func:`~inertiafit.processing.living.
        design_statics`): ``quasi_static_trials`` sweeps (alternating up and down) and
        ``rest_trials`` quiet holds in each of ``postures``. It can be neither weighed,
        balanced nor moved along the lever.
    passive : PassivePrior or None
        The living joint's ``[passive]`` prior (:func:`inertiafit.io.manifest.read_passive`).
    postures : tuple of PostureGeometry
        The postures the living conditions are measured in (the first the reference);
        default one posture.
    rest_trials : int
        Quiet holds per posture of each living condition.
    rotation_sweeps : bool
        Sweep the rigid conditions also in each posture after the first (axis horizontal):
        each such sweep measures that posture's gravity rotation, which two postures need to
        tell ``M_g`` from a passive curve of any smooth shape.
    """

    name: str
    mountings: tuple[Mounting, ...]
    trials_per_speed: int = 10
    speeds: tuple[float, ...] = DEFAULT_SPEEDS
    quasi_static_trials: int = 1
    priors: Mapping[str, Any] = field(default_factory=dict)
    weighed: Mapping[str, float] = field(default_factory=dict)
    balanced: Mapping[str, float] = field(default_factory=dict)
    torque_gain_sd: float = 0.0
    living: str = ""
    passive: Any = None
    postures: tuple[Any, ...] = ()
    rest_trials: int = 0
    rotation_sweeps: bool = False

    def __post_init__(self):
        where = f"design '{self.name}'"
        self._check_living(where)
        if not self.mountings:
            raise InputError(f"{where}: conditions: expected at least one condition")
        n = self.trials_per_speed
        if not is_whole(n) or n < 1:
            raise InputError(f"{where}: trials_per_speed: expected a whole number >= 1, got {n!r}")
        if n * len(self.speeds) < 2:
            raise InputError(f"{where}: trials_per_speed: one speed needs at least 2 trials")
        q = self.quasi_static_trials
        if not is_whole(q) or q < 1:
            raise InputError(
                f"{where}: quasi_static_trials: expected a whole number >= 1, got {q!r}"
            )
        if not self.speeds:
            raise InputError(f"{where}: speeds: expected at least one speed")
        for s in self.speeds:
            check_positive(s, f"{where}: speeds", "deg/s")
        for quantity, table in self._measured_tables():
            for body, sd in table.items():
                check_positive(sd, f"{where}: {quantity.design_field}.{body}", quantity.unit)

    def _check_living(self, where: str) -> None:
        body = self.living
        if not body:
            if self.passive is not None or self.postures or self.rest_trials:
                raise InputError(
                    f"{where}: passive, postures and rest_trials are for a living body; mark "
                    "it with living = true"
                )
            if self.rotation_sweeps:
                raise InputError(f"{where}: rotation_sweeps: for a living body's postures")
            return
        if not any(body in m.bodies for m in self.mountings):
            raise InputError(f"{where}: living body '{body}' is in no condition")
        if self.passive is None:
            raise InputError(f"{where}: living body '{body}' needs the [passive] table")
        if any(body in table for _, table in self._measured_tables()):
            raise InputError(
                f"{where}: '{body}' is living: it cannot be weighed or balanced apart from the "
                "subject"
            )
        if any(m.offset_body == body for m in self.mountings):
            raise InputError(
                f"{where}: '{body}' is living: it cannot be moved along the lever (remounted)"
            )
        if not is_whole(self.rest_trials) or self.rest_trials < 0:
            raise InputError(
                f"{where}: rest_trials: expected a whole number >= 0, got {self.rest_trials!r}"
            )
        if self.rotation_sweeps and not any(not self.holds_living(m) for m in self.mountings):
            raise InputError(
                f"{where}: rotation_sweeps: no rigid condition to sweep in the other postures"
            )

    @property
    def rotation_postures(self) -> tuple[Any, ...]:
        """The postures after the first whose rotation the rigid sweeps measure."""
        if not self.rotation_sweeps:
            return ()
        return tuple(p for p in self.postures[1:] if p.tilt == 0.0)

    def holds_living(self, mounting: Mounting) -> bool:
        """Whether ``mounting`` holds the living body."""
        return bool(self.living) and self.living in mounting.bodies

    @property
    def n_trials(self) -> int:
        """Dynamometer trials of the session: fast and quasi-static (and rest), every condition.

        A condition that holds the living body is measured in each posture.
        """
        per = self.trials_per_speed * len(self.speeds) + self.quasi_static_trials
        total = 0
        for m in self.mountings:
            if self.holds_living(m):
                total += (per + self.rest_trials) * max(len(self.postures), 1)
            else:
                total += per + len(self.rotation_postures)
        return total

    def _measured_tables(self) -> list[tuple[MeasuredQuantity, Mapping[str, float]]]:
        """Each registered quantity with its table of body -> SD (its ``design_field``)."""
        return [(q, getattr(self, q.design_field)) for q in MEASURED_QUANTITIES.values()]

    @property
    def measured(self) -> dict[str, dict[str, float]]:
        """Body -> {measured quantity: SD} of the bodies measured directly.

        Each quantity of :data:`inertiafit.measured.MEASURED_QUANTITIES` by its name, read
        from its :attr:`~inertiafit.measured.MeasuredQuantity.design_field` (``weighed`` is
        ``mass``, ``balanced`` is ``com_distance``).
        """
        out: dict[str, dict[str, float]] = {}
        for q, table in self._measured_tables():
            for body, sd in table.items():
                out.setdefault(body, {})[q.name] = float(sd)
        return out

    def bodies(self) -> set[str]:
        """Every body the design names."""
        out = {b for m in self.mountings for b in m.bodies}
        return out | set(self.priors) | set(self.measured)

    def check_bodies(self, nominal: Mapping[str, Any]) -> None:
        """An :class:`InputError` when the design names a body ``nominal`` does not have."""
        unknown = sorted(self.bodies() - set(nominal))
        if unknown:
            raise InputError(
                f"design '{self.name}': unknown body '{unknown[0]}' (bodies: {', '.join(nominal)})"
            )


@dataclass(frozen=True)
class ConditionNoise:
    """Noise of one set of mounted bodies measured in a pilot.

    Attributes
    ----------
    inertia_sd : dict of float to float
        Per-trial SD of the inertia (kg m^2) per speed (deg/s).
    gravity_moment_se : float
        SE of one quasi-static trial's gravity moment (N m): the pilot's SE times the square
        root of its number of quasi-static trials.
    coupling, shared_sd : float
        The gravity model's error in the mean inertia (see
        :func:`~inertiafit.inference.evidence.shared_gravity_error`).
    """

    inertia_sd: dict[float, float]
    gravity_moment_se: float
    coupling: float = 0.0
    shared_sd: float = 0.0

    def sd_at(self, speed: float) -> float:
        """Per-trial SD at ``speed``: interpolated between the pilot's speeds, held outside."""
        speeds = sorted(self.inertia_sd)
        return float(np.interp(speed, speeds, [self.inertia_sd[s] for s in speeds]))


@dataclass(frozen=True)
class NoiseLevels:
    """Noise of a trial: the per-trial SD of the inertia and the SE of the gravity moment.

    The per-trial SD of a condition's inertia is ``hypot(inertia_sd, inertia_relative_sd *
    I)``; a condition measured in a pilot (``conditions``, by its set of bodies, not moved)
    uses the pilot's numbers instead.

    Attributes
    ----------
    inertia_sd : float
        Absolute per-trial SD (kg m^2); default :data:`PAPER_INERTIA_SD`.
    inertia_relative_sd : float
        Relative per-trial SD (0.02 = 2 % of the condition's inertia); default 0.
    gravity_moment_se : float
        SE of one quasi-static trial's gravity moment (N m); default
        :data:`PAPER_GRAVITY_MOMENT_SE`.
    conditions : dict of frozenset to ConditionNoise
        Pilot measurements by set of bodies.
    """

    inertia_sd: float = PAPER_INERTIA_SD
    inertia_relative_sd: float = 0.0
    gravity_moment_se: float = PAPER_GRAVITY_MOMENT_SE
    conditions: Mapping[frozenset[str], ConditionNoise] = field(default_factory=dict)

    def __post_init__(self):
        check_positive(self.gravity_moment_se, "noise.gravity_moment_se", "N m")
        for key in ("inertia_sd", "inertia_relative_sd"):
            value = check_number(getattr(self, key), f"noise.{key}")
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"noise.{key}: expected a finite number >= 0, got {value!r}")
        if self.inertia_sd == 0 and self.inertia_relative_sd == 0:
            raise InputError("noise.inertia_sd: expected inertia_sd or inertia_relative_sd > 0")

    def pilot(self, mounting: Mounting) -> ConditionNoise | None:
        """The pilot's noise of this set of bodies (none for a moved body)."""
        if mounting.offset_body:
            return None
        return self.conditions.get(frozenset(mounting.bodies))

    def trial_sd(self, mounting: Mounting, inertia: float, speeds: Sequence[float]) -> float:
        """Per-trial SD of the inertia pooled over ``speeds`` (root mean square)."""
        pilot = self.pilot(mounting)
        if pilot is not None:
            sds = [pilot.sd_at(s) for s in speeds]
        else:
            sds = [math.hypot(self.inertia_sd, self.inertia_relative_sd * inertia)] * len(speeds)
        return float(np.sqrt(np.mean(np.square(sds))))

    def gravity_se(self, mounting: Mounting) -> float:
        """SE of one quasi-static trial's gravity moment."""
        pilot = self.pilot(mounting)
        return pilot.gravity_moment_se if pilot is not None else self.gravity_moment_se


def nominal_values(bodies: Mapping[str, Any]) -> dict[str, dict[str, float]]:
    """Bodies as ``{name: {mass, radius_of_gyration, com_distance}}`` (SI units)."""
    out = {}
    for name, value in bodies.items():
        if isinstance(value, Mapping):
            table = {p: value.get(p) for p in PARAMETERS}
        else:
            seq = list(value)
            if len(seq) != 3:
                raise InputError(
                    f"bodies.{name}: expected (mass, radius_of_gyration, com_distance), "
                    f"got {value!r}"
                )
            table = dict(zip(("mass", "radius_of_gyration", "com_distance"), seq, strict=True))
        unit = {"mass": "kg", "com_distance": "m", "radius_of_gyration": "m"}
        out[name] = {
            p: check_positive(table[p], f"bodies.{name}.{p}", unit[p]) for p in PARAMETERS
        }
    if not out:
        raise InputError("bodies: expected at least one body")
    return out


def design_variants(
    base: Design,
    trials_per_speed: Sequence[int],
    weigh: Mapping[str, float],
    offsets: Mapping[str, Sequence[float]],
) -> list[Design]:
    """Variants of ``base``: other trial counts, a weighed body, a body's second mounting."""
    out = []
    for n in trials_per_speed:
        out.append(replace(base, name=f"{base.name}, {n} per speed", trials_per_speed=int(n)))
    for body, sd in weigh.items():
        if body == base.living:
            raise InputError(
                f"weigh: '{body}' is living: it cannot be weighed apart from the subject"
            )
        out.append(
            replace(base, name=f"{base.name}, {body} weighed", weighed={**base.weighed, body: sd})
        )
    for body, ds in offsets.items():
        if body == base.living:
            raise InputError(f"offsets: '{body}' is living: it cannot be remounted")
        holding = [m for m in base.mountings if body in m.bodies and not m.offset_body]
        if not holding:
            raise InputError(f"offsets: body '{body}' is in no condition of '{base.name}'")
        for d in ds:
            moved = Mounting(holding[-1].bodies, body, float(d))
            out.append(
                replace(
                    base,
                    name=f"{base.name}, {body} also at +{d:g} m",
                    mountings=(*base.mountings, moved),
                )
            )
    return out
