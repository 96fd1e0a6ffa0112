"""The passive elastic moment of a living joint (inertiafit.passive)."""

import numpy as np
import pytest

from inertiafit.passive import literature_curve, passive_moment, riener_edrich_knee


def test_knee_curve_matches_the_published_seated_values():
    # DOMAIN.md, from Riener & Edrich 1999 with the hip at 90 deg: 47 N m at full extension,
    # 17 at 20 deg, 0.2 at 60 deg, -3.5 at 90 deg of flexion
    got = riener_edrich_knee([0.0, 20.0, 60.0, 90.0])
    np.testing.assert_allclose(got, [47.0, 16.7, 0.225, -3.54], atol=0.05)


@pytest.mark.parametrize("joint", ["knee", "ankle"])
def test_device_moment_rises_with_the_joint_angle(joint):
    # the device pushes against the tissues: its moment grows toward either end of the range
    theta = np.radians(np.linspace(0.0, 90.0 if joint == "knee" else 30.0, 50))
    assert np.all(np.diff(literature_curve(joint, theta)) > 0)


def test_spring_with_stops():
    theta = np.radians([60.0, 107.0, 140.0])
    got = passive_moment(
        theta,
        stiffness=1.0,
        relaxed=np.radians(107.0),
        stop_low=0.5,
        stop_high=0.25,
        range_low=np.radians(60.0),
        range_high=np.radians(140.0),
        width=np.radians(10.0),
    )
    spring = theta - np.radians(107.0)
    high = 0.25 * np.exp((theta - np.radians(140.0)) / np.radians(10.0))
    low = 0.5 * np.exp((np.radians(60.0) - theta) / np.radians(10.0))
    np.testing.assert_allclose(got, spring + high - low)
    assert got[2] == pytest.approx(spring[2] + 0.25, rel=1e-3)  # the stop's moment at its end


def test_unknown_joint_refused():
    with pytest.raises(ValueError, match="joint must be one of"):
        literature_curve("hip", [0.0])
