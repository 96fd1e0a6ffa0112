import math

import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.io.units import (
    FT_LBF,
    IN_LBF,
    SI_UNITS,
    canonical_unit,
    to_si,
    unit_factor,
)


def test_foot_pound_force_is_the_exact_product_of_foot_and_pound_force():
    # 0.3048 m x 4.4482216152605 N = 1.35581794833140040 N m exactly (decimal arithmetic).
    assert FT_LBF == 1.3558179483314004
    assert math.isclose(FT_LBF, 0.3048 * 4.4482216152605, rel_tol=1e-15)
    assert math.isclose(IN_LBF, FT_LBF / 12, rel_tol=1e-15)


@pytest.mark.parametrize("spelling", ["ft*lbf", "ft-lb", "ft*lb", "ft-lbf", "ft-lbs", "FT-LBS"])
def test_ten_foot_pounds_in_newton_metres(spelling):
    value = to_si([10.0], "torque", spelling, where="f.csv: units.torque")
    assert value[0] == pytest.approx(13.558179483314004, rel=1e-15)


@pytest.mark.parametrize("spelling", ["N*m", "N m", "Nm", "N·m", "n-m", "Newton-Meters"])
def test_newton_metre_spellings_are_identity(spelling):
    assert unit_factor("torque", spelling, where="x") == 1.0


def test_inch_pounds():
    assert to_si([12.0], "torque", "in*lbf", where="x")[0] == pytest.approx(FT_LBF, rel=1e-15)


def test_angles_and_velocities_to_radians():
    assert to_si([90.0], "angle", "deg", where="x")[0] == pytest.approx(math.pi / 2, rel=1e-15)
    assert to_si([1.0], "angle", "rad", where="x")[0] == 1.0
    assert to_si([240.0], "velocity", "deg/s", where="x")[0] == pytest.approx(
        4 * math.pi / 3, rel=1e-15
    )
    assert to_si([-180.0], "velocity", "°/s", where="x")[0] == pytest.approx(-math.pi)
    assert to_si([2.0], "velocity", "rad / s", where="x")[0] == 2.0


def test_milliseconds_to_seconds():
    out = to_si(np.array([0, 10, 1500]), "time", "ms", where="x")
    assert out.dtype == np.float64
    np.testing.assert_allclose(out, [0.0, 0.01, 1.5], rtol=0, atol=1e-15)


def test_canonical_spellings_and_si_labels():
    assert canonical_unit("torque", " ft-lb ", where="x") == "ft*lbf"
    assert canonical_unit("velocity", "d/s", where="x") == "deg/s"
    assert SI_UNITS == {"time": "s", "angle": "rad", "velocity": "rad/s", "torque": "N m"}


def test_unknown_unit_names_where_and_lists_accepted():
    with pytest.raises(
        InputError, match=r"^f\.csv: units\.torque: unknown torque unit 'kgf\*m' \(accepted: "
    ) as info:
        unit_factor("torque", "kgf*m", where="f.csv: units.torque")
    assert "N*m, ft*lbf, in*lbf" in str(info.value)
    with pytest.raises(
        InputError, match=r"units\.time: unknown time unit 'min' \(accepted: s, ms"
    ):
        unit_factor("time", "min", where="f.csv: units.time")


def test_unit_must_be_a_string():
    with pytest.raises(InputError, match=r"f: units\.angle: angle unit must be a string, got 3"):
        unit_factor("angle", 3, where="f: units.angle")
