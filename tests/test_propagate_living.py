"""``propagate`` of a living body: its joint's passive moment, damping and hysteresis (issue 34).

The posterior is ``living_cases``' forearm (the joint fit stored as a study stores it). Along a
motion inside the swept range, the moment is the dynamometer's whole equation
``I alpha + M_g sin(theta + phi) + P(theta) + b omega + h(theta) sgn(omega)``; the rigid part is
``joint=False``'s, and the joint's parts are checked against the study's own numbers: the
passive curve table (``living/curve``) and the damping's mean and SD.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from living_cases import DAMPING, living_results

from inertiafit import InputError, propagate
from inertiafit.posterior import open_posterior
from inertiafit.processing.living import living_tables_from_tree
from inertiafit.report.export import data_phase

TIME = np.linspace(0.0, 1.0, 501)
ANGLE = 0.8 + 0.6 * np.sin(2 * np.pi * TIME)  # rad: inside the swept 0 to 90 deg
VELOCITY = 0.6 * 2 * np.pi * np.cos(2 * np.pi * TIME)
ACCELERATION = -0.6 * (2 * np.pi) ** 2 * np.sin(2 * np.pi * TIME)
MOTION = {"time": TIME, "angle": ANGLE, "velocity": VELOCITY, "acceleration": ACCELERATION}


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    return living_results(tmp_path_factory.mktemp("living") / "results")


def test_the_joint_adds_to_the_rigid_moment(results):
    post = open_posterior(results / "posterior.nc")
    phase, _ = data_phase(post)
    full = propagate(post, MOTION, phase="data", seed=2, draws=4000)
    rigid = propagate(post, MOTION, phase="data", seed=2, draws=4000, joint=False)
    assert full.phase == phase
    assert set(full.parts) == {"passive", "damping", "hysteresis"}
    assert not rigid.parts
    np.testing.assert_allclose(full.moments - rigid.moments, sum(full.parts.values()), atol=1e-12)
    # b omega: one b per draw, drawn from the fast trials' Gaussian
    b = full.parts["damping"][:, 100] / VELOCITY[100]
    np.testing.assert_allclose(full.parts["damping"], b[:, None] * VELOCITY[None, :], rtol=1e-12)
    n = b.size
    assert b.mean() == pytest.approx(DAMPING[0], abs=4 * DAMPING[1] / n**0.5)
    assert b.std() == pytest.approx(DAMPING[1], rel=0.1)
    # h(theta) sgn(omega): the study's hysteresis, its sign the motion's direction
    table = living_tables_from_tree(post.tree)["passive_curve"]
    theta = np.radians(table["device_angle"])
    h = full.parts["hysteresis"] * np.sign(VELOCITY)
    h_band = np.interp(ANGLE, theta, table["hysteresis_upper"] - table["hysteresis_lower"])
    assert np.all(np.abs(np.median(h, axis=0) - np.interp(ANGLE, theta, table["hysteresis"]))
                  < 0.15 * h_band)  # fmt: skip
    # P(theta): the draws centre on the study's fitted curve (0 at the middle of the range)
    curve = np.interp(ANGLE, theta, table["median"])
    band = np.interp(ANGLE, theta, table["upper"] - table["lower"])
    centre = np.median(full.parts["passive"], axis=0)
    assert np.all(np.abs(centre - curve) < 0.15 * band)
    # the exact split still adds to one with the joint's variance and covariances
    shares = full.shares()
    exact = shares[["share_inertia", "share_gravity_moment", "share_covariance", "share_joint",
                    "share_joint_covariance"]].sum(axis=1)  # fmt: skip
    np.testing.assert_allclose(exact, 1.0, atol=1e-9)
    assert list(rigid.shares().columns)[-1] == "share_covariance"  # a rigid body's as before


def test_a_motion_without_velocity_is_differentiated_and_bad_ones_refused(results):
    post = open_posterior(results / "posterior.nc")
    given = propagate(post, MOTION, draws=50, seed=1)
    derived = propagate(post, {k: MOTION[k] for k in ("time", "angle", "acceleration")},
                        draws=50, seed=1)  # fmt: skip
    assert derived.velocity is not None
    np.testing.assert_allclose(derived.velocity[5:-5], VELOCITY[5:-5], rtol=0, atol=1e-6)
    np.testing.assert_allclose(derived.parts["passive"], given.parts["passive"], atol=1e-12)
    uneven = np.sort(np.r_[TIME, 0.5011])
    with pytest.raises(InputError, match="damping needs the velocity") as err:
        propagate(post, (uneven, np.interp(uneven, TIME, ANGLE), np.zeros(uneven.size)))
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="phase: 'data' needs a posterior"):
        propagate({"mass": 1.0, "com_distance": 0.1, "radius_of_gyration": 0.05},
                  (TIME, ANGLE), phase="data")  # fmt: skip
    assert math.isfinite(propagate(post, MOTION, phase="data", draws=10).phase)
