"""A small living study's results folder, built in about 2 s for the export and propagate tests.

The pipeline's own path (``inertiafit run`` on a simulated living study) takes 20 s; here its
two halves are run on their own and put together as ``pipeline.study`` does: the joint fit of
gravity and the passive curve (``processing.living.fit_statics``) on sweeps built from the
living model with a known truth, in two postures 45 deg apart, and the body's posterior
(``fit_body``) on the fit's gravity moment and a measured inertia; the fit is stored in the
posterior's ``living`` group with its tables (``living_datatree``), and the conditions in its
``inputs``, as a study's ``posterior.nc`` holds them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from inertiafit import SamplerSettings, fit_body
from inertiafit.inference.priors import load_prior
from inertiafit.passive import passive_moment
from inertiafit.processing.living import (
    LIVING_GROUP,
    PassiveBasis,
    PostureGeometry,
    StaticRecord,
    fit_statics,
    living_datatree,
    living_tables,
)

#: The truth: a forearm of 1.5 kg, CoM 0.15 m, rho 0.08 m on a shaft whose phase is PHI.
MASS, COM, RHO, PHI, G = 1.5, 0.15, 0.08, 0.3, 9.81
GRAVITY_MOMENT = MASS * G * COM
INERTIA = MASS * (RHO**2 + COM**2)
#: The damping the fast trials would have measured (N m s/rad): mean and SD.
DAMPING = (0.12, 0.01)
ZERO = math.radians(60.0)  # the elbow's angle at the device's 0
BASIS = PassiveBasis(
    joint="elbow",
    zero=ZERO,
    stiffness=(1.1, 0.45),
    stop_moment=(0.0, 2.0),
    width=math.radians(10.0),
    range_low=math.radians(30.0),
    range_high=math.radians(150.0),
    hysteresis=(0.05, 0.1),
    damping=(0.1, 0.1),
)
POSTURES = {
    "seated": PostureGeometry("seated"),
    "tilted": PostureGeometry("tilted", math.radians(45.0)),
}


def _passive(theta: np.ndarray) -> np.ndarray:
    return passive_moment(
        ZERO + theta,
        stiffness=0.9,
        relaxed=math.radians(100.0),
        stop_low=0.2,
        stop_high=0.3,
        range_low=BASIS.range_low,
        range_high=BASIS.range_high,
        width=math.radians(9.0),
    )


def _records(rng: np.random.Generator) -> list[StaticRecord]:
    records = []
    for name, posture in POSTURES.items():
        for direction in (1, -1):
            theta = np.linspace(0.0, math.radians(90.0), 4000)[::direction]
            torque = (
                GRAVITY_MOMENT * np.sin(theta + PHI + posture.rotation)
                + 0.1
                + _passive(theta)
                + 0.04 * direction
                + rng.normal(0.0, 0.05, theta.size)
            )
            records.append(
                StaticRecord(theta, torque, "forearm", name, "quasi-static", f"{name}{direction}")
            )
    return records


def living_results(folder: Path, seed: int = 5) -> Path:
    """Write ``folder/posterior.nc``: a living forearm's study as ``inertiafit run`` keeps it."""
    rng = np.random.default_rng(seed)
    statics = fit_statics(_records(rng), POSTURES, BASIS)
    gravity = statics.gravity_fit("forearm")
    prior = load_prior(
        {"mass": MASS, "com_distance": COM, "radius_of_gyration": RHO, "spread": 0.5},
        name="forearm",
    )
    post = fit_body(
        prior,
        inertia=INERTIA,
        inertia_se=0.01 * INERTIA,
        gravity_moment=gravity.gravity_moment,
        gravity_moment_se=gravity.gravity_moment_se,
        seed=seed,
        settings=SamplerSettings(ess_min=200, chunk=100),
    )
    post.tree[LIVING_GROUP] = living_datatree(
        living_tables(statics, DAMPING, body="forearm"), statics
    )
    inputs = json.loads(post.tree.attrs.get("inputs", "{}") or "{}")
    inputs["conditions"] = {"forearm": ["forearm"]}
    post.tree.attrs["inputs"] = json.dumps(inputs)
    folder.mkdir(parents=True, exist_ok=True)
    post.save(folder / "posterior.nc")
    return folder
