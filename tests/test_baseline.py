"""The paper's multi-start estimator on the paper's two bodies, and its feasible-region rule."""

from __future__ import annotations

import json
from functools import cache

import numpy as np
import pytest

from inertiafit import paper, physics
from inertiafit.baseline import (
    BOUND_MARGIN,
    METHODS,
    BaselineResult,
    _objective,
    curve_mass_intervals,
    feasible_region,
    identification_curve,
    paper_baseline,
)
from inertiafit.errors import InputError

G = paper.GRAVITY
CASES = {
    # Table 2: I and the M_g implied by the estimated row; nominal = ideal row.
    "attachment": {
        "inertia": 0.216,
        "gravity_moment": 2.81 * G * 0.269,
        "nominal": [2.91, 0.225, 0.130],
    },
    # Table 3.
    "disk": {
        "inertia": 0.594,
        "gravity_moment": 2.90 * G * 0.45,
        "nominal": [2.92, 0.45, 0.035],
    },
}
SLOW = pytest.mark.slow  # trust-constr: ~3-4 s for 101 starts
METHOD_PARAMS = [
    pytest.param(m, marks=SLOW) if m == "trust-constr" else pytest.param(m) for m in METHODS
]


@cache
def run(case: str, method: str) -> BaselineResult:
    return paper_baseline(**CASES[case], method=method)


def _residuals(sol, case):
    m, x, rho = np.asarray(sol).T
    kw = CASES[case]
    return m * x - kw["gravity_moment"] / G, m * (rho**2 + x**2) - kw["inertia"]


# --- every start lands on the identification curve, inside the box ------------------------------


@pytest.mark.parametrize("method", METHOD_PARAMS)
@pytest.mark.parametrize("case", CASES)
def test_every_solution_solves_both_equations_inside_the_box(case, method):
    res = run(case, method)
    assert res.solutions.shape == (101, 3)
    assert res.success.all(), res.messages
    assert np.all(res.objective < 1e-10)
    first, second = _residuals(res.solutions, case)
    assert np.max(np.abs(first)) < 1e-5
    assert np.max(np.abs(second)) < 1e-5
    assert np.all(res.solutions >= res.lower)
    assert np.all(res.solutions <= res.upper)
    np.testing.assert_allclose(res.lower, 0.5 * np.array(CASES[case]["nominal"]))
    np.testing.assert_allclose(res.upper, 1.5 * np.array(CASES[case]["nominal"]))


@pytest.mark.parametrize("method", METHOD_PARAMS)
def test_disk_mass_and_com_are_pinned_by_the_data(method):
    res = run("disk", method)
    assert res.mass == pytest.approx(paper.TABLE3_ESTIMATED.mass, rel=0.02)
    assert res.com_distance == pytest.approx(paper.TABLE3_ESTIMATED.com_distance, rel=0.02)
    # The whole curve inside the box spans 2.871..2.906 kg; rho spans the box.
    assert 2.871 <= res.mass <= 2.907


@pytest.mark.parametrize("method", ["SLSQP", "L-BFGS-B"])
def test_attachment_gradient_methods_stop_on_the_rho_bound_like_the_paper(method):
    # Starts below nominal run down to the face rho = 0.5 * 0.130 = 0.065, where the curve
    # leaves the box: m = 2.798, x = 0.2701 (paper: 2.81, 0.269, 0.065).
    res = run("attachment", method)
    assert res.radius_of_gyration == pytest.approx(0.065, abs=1e-4)
    assert res.mass == pytest.approx(2.7984, abs=2e-3)
    assert res.com_distance == pytest.approx(0.2701, abs=2e-4)
    assert res.mass == pytest.approx(paper.TABLE2_ESTIMATED.mass, abs=0.015)
    assert res.com_distance == pytest.approx(paper.TABLE2_ESTIMATED.com_distance, abs=0.0015)
    assert res.starts[res.feasible][-1] == -5
    assert res.run_length >= 40


@SLOW
def test_attachment_interior_point_stops_mid_curve():
    # The barrier keeps trust-constr away from the bounds: m ~ 3.21, rho ~ 0.109, far from the
    # paper's 2.81 / 0.065, though both solve the equations exactly.
    res = run("attachment", "trust-constr")
    assert res.mass == pytest.approx(3.21, abs=0.02)
    assert res.radius_of_gyration == pytest.approx(0.109, abs=0.002)
    assert res.com_distance == pytest.approx(0.2355, abs=0.002)


@pytest.mark.parametrize("method", METHOD_PARAMS)
def test_attachment_baseline_lies_on_the_identification_curve(method):
    res = run("attachment", method)
    # A mean of points on a curve is (nearly) on it: both equations hold to 0.1 %.
    assert res.inertia == pytest.approx(0.216, rel=1e-3)
    assert res.gravity_moment == pytest.approx(CASES["attachment"]["gravity_moment"], rel=1e-3)
    ((m0, m1),) = curve_mass_intervals(
        inertia=0.216,
        gravity_moment=CASES["attachment"]["gravity_moment"],
        lower=res.lower,
        upper=res.upper,
    )
    assert m0 - 1e-6 <= res.mass <= m1
    assert res.mass >= physics.minimum_mass(0.216, CASES["attachment"]["gravity_moment"])


@SLOW
def test_methods_disagree_far_more_for_the_attachment_than_for_the_disk():
    def spread(case):
        masses = np.array([run(case, m).mass for m in METHODS])
        return (masses.max() - masses.min()) / masses.mean()

    # Measured: attachment 0.137 (2.798 .. 3.211 kg), disk 0.0045 (2.871 .. 2.884 kg).
    assert spread("attachment") > 0.10
    assert spread("disk") < 0.01
    assert spread("attachment") > 10 * spread("disk")


# --- the identification curve -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("case", "expected"),
    [("attachment", [(2.7984, 4.365)]), ("disk", [(2.8713, 2.9062)])],
)
def test_curve_mass_intervals(case, expected):
    kw = CASES[case]
    p0 = np.array(kw["nominal"])
    got = curve_mass_intervals(
        inertia=kw["inertia"], gravity_moment=kw["gravity_moment"], lower=0.5 * p0, upper=1.5 * p0
    )
    assert len(got) == len(expected)
    for (a, b), (ea, eb) in zip(got, expected, strict=True):
        assert a == pytest.approx(ea, abs=1e-4)
        assert b == pytest.approx(eb, abs=1e-4)
    curve = identification_curve(
        inertia=kw["inertia"], gravity_moment=kw["gravity_moment"], lower=0.5 * p0, upper=1.5 * p0
    )
    first, second = _residuals(curve, case)
    assert np.max(np.abs(first)) < 1e-12
    assert np.max(np.abs(second)) < 1e-12
    assert np.all(curve >= 0.5 * p0 * (1 - 1e-9))
    assert np.all(curve <= 1.5 * p0 * (1 + 1e-9))


def test_curve_can_split_into_two_intervals():
    # A rho ceiling below the curve's largest rho removes the middle of the curve.
    a, inertia = 1.0, 0.5
    got = curve_mass_intervals(
        inertia=inertia, gravity_moment=a * G, lower=[1.0, 0.1, 0.0], upper=[20.0, 1.0, 0.2]
    )
    assert len(got) == 2
    assert got[0][1] < got[1][0]
    pts = identification_curve(
        inertia=inertia, gravity_moment=a * G, lower=[1.0, 0.1, 0.0], upper=[20.0, 1.0, 0.2]
    )
    assert np.all(pts[:, 2] <= 0.2 + 1e-12)


# --- the feasible-region rule itself ------------------------------------------------------------


def _sequence(middle_rows):
    rng = np.random.default_rng(7)
    varying = lambda n: 1.0 + rng.uniform(0.1, 0.5, size=(n, 3)).cumsum(axis=0)
    return np.vstack([varying(10), middle_rows, 10 + varying(10)])


def test_feasible_region_picks_the_constant_run_in_the_middle():
    sol = _sequence(np.tile([2.0, 0.3, 0.1], (7, 1)))
    region = feasible_region(sol, [1.0, 1.0, 1.0], tolerance=0.01)
    assert region == slice(10, 17)


def test_feasible_region_tolerates_changes_below_tolerance_only():
    middle = np.tile([2.0, 0.3, 0.1], (7, 1))
    middle[3, 0] += 0.009  # 0.9 % of scale 1: still one run
    assert feasible_region(_sequence(middle), np.ones(3), tolerance=0.01) == slice(10, 17)
    middle[3, 0] += 0.003  # 1.2 %: splits the run into 3 + 1 + 3 (with its jump back)
    region = feasible_region(_sequence(middle), np.ones(3), tolerance=0.01)
    assert region.stop - region.start == 3


def test_feasible_region_tie_goes_to_the_run_nearest_k0():
    ks = np.arange(-5, 6)
    sol = np.array([[float(i), 0.0, 0.0] for i in range(11)])
    sol[0:3] = [100.0, 0, 0]  # k = -5..-3: run of 3
    sol[6:9] = [200.0, 0, 0]  # k = 1..3: run of 3, nearer k = 0
    assert feasible_region(sol, np.ones(3), ks=ks) == slice(6, 9)
    assert feasible_region(sol, np.ones(3), ks=ks + 4) == slice(0, 3)  # k = -1..1 holds 0
    assert feasible_region(sol, np.ones(3)) == slice(6, 9)  # default ks: centred on start 5


def test_feasible_region_skips_invalid_starts_and_can_be_empty():
    sol = np.zeros((6, 3))
    valid = np.array([True, True, False, True, True, True])
    assert feasible_region(sol, np.ones(3), valid=valid) == slice(3, 6)
    assert feasible_region(sol, np.ones(3), valid=np.zeros(6, bool)) == slice(0, 0)
    assert feasible_region(sol[:1], np.ones(3)) == slice(0, 1)


# --- starts, options and the result object ------------------------------------------------------


def test_starts_on_the_bounds_are_moved_inside():
    res = run("disk", "SLSQP")
    width = res.upper - res.lower
    np.testing.assert_allclose(res.initial[0], res.lower + BOUND_MARGIN * width)
    np.testing.assert_allclose(res.initial[-1], res.upper - BOUND_MARGIN * width)
    np.testing.assert_allclose(res.initial[50], res.nominal)
    np.testing.assert_allclose(res.initial[40], 0.9 * res.nominal)
    np.testing.assert_array_equal(res.starts, np.arange(-50, 51))


def test_per_parameter_start_grid_and_mapping_nominal():
    k = np.arange(-20, 21, 5.0)
    ks = np.column_stack([k, np.zeros_like(k), np.zeros_like(k)])
    kw = dict(CASES["disk"])
    kw["nominal"] = dict(zip(physics.PARAMETERS, kw["nominal"], strict=True))
    res = paper_baseline(**kw, ks=ks, method="SLSQP")
    np.testing.assert_allclose(res.initial[:, 1:], np.tile(res.nominal[1:], (len(k), 1)))
    np.testing.assert_allclose(res.initial[:, 0], res.nominal[0] * (1 + k / 100))
    assert np.all(res.objective < 1e-10)
    assert res.mass == pytest.approx(2.90, rel=0.02)


def test_narrower_box_confines_the_answer():
    kw = CASES["attachment"]
    res = paper_baseline(
        **kw, lower=[2.5, 0.2, 0.12], upper=[3.5, 0.3, 0.14], method="SLSQP", ks=range(-5, 6)
    )
    assert np.all(res.solutions[:, 2] >= 0.12)
    assert res.mass > 3.5 * 0.9  # rho >= 0.12 forces the heavy end of the curve


def test_analytic_gradient_and_hessian_match_finite_differences():
    fun, jac, hess = _objective(0.8, 0.3)
    p = np.array([2.7, 0.31, 0.09])
    h = 1e-6
    eye = np.eye(3)
    num_grad = np.array([(fun(p + h * e) - fun(p - h * e)) / (2 * h) for e in eye])
    num_hess = np.array([(jac(p + h * e) - jac(p - h * e)) / (2 * h) for e in eye])
    np.testing.assert_allclose(jac(p), num_grad, rtol=1e-6)
    np.testing.assert_allclose(hess(p), num_hess, rtol=1e-6, atol=1e-9)


def test_method_name_is_case_insensitive():
    assert run("disk", "SLSQP").method == "SLSQP"
    assert paper_baseline(**CASES["disk"], method="slsqp", ks=[0]).method == "SLSQP"


def test_result_reports():
    res = run("attachment", "SLSQP")
    assert res.feasible_mask.sum() == res.run_length
    assert res.feasible_mask[res.feasible].all()
    d = json.loads(json.dumps(res.to_dict()))
    assert d["method"] == "SLSQP"
    assert d["mass"] == res.mass
    assert d["nominal"] == {"mass": 2.91, "com_distance": 0.225, "radius_of_gyration": 0.13}
    assert d["feasible_k"] == [-50.0, -5.0]
    assert len(d["solutions"]) == 101
    text = str(res)
    assert "SLSQP" in text
    assert "k = -50..-5 %" in text
    assert "radius_of_gyration [m]" in text
    assert res.estimate["gravity_moment"] == pytest.approx(res.mass * G * res.com_distance)


# --- bad input: one line naming the field -------------------------------------------------------

_GOOD = {"inertia": 0.594, "gravity_moment": 12.8, "nominal": [2.92, 0.45, 0.035]}


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"inertia": 0.0}, "inertia"),
        ({"inertia": -0.2}, "inertia"),
        ({"inertia": float("nan")}, "inertia"),
        ({"gravity_moment": -12.8}, "gravity_moment"),
        ({"gravity_moment": "heavy"}, "gravity_moment"),
        ({"gravity": 0.0}, "gravity"),
        ({"nominal": [2.92, 0.45]}, "nominal"),
        ({"nominal": [[2.92, 0.45, 0.035]]}, "nominal"),
        ({"nominal": {"mass": 2.92, "com_distance": 0.45}}, "nominal"),
        ({"nominal": [2.92, 0.0, 0.035]}, "nominal"),
        ({"lower": [3.0, 0.2, 0.01], "upper": [3.0, 0.7, 0.05]}, "lower, upper"),
        ({"lower": [1.0, 0.2, 0.06], "upper": [4.0, 0.7, 0.05]}, "lower, upper"),
        ({"lower": [1.0, 0.2], "upper": [4.0, 0.7, 0.05]}, "lower"),
        ({"lower": [3.0, 0.2, 0.01]}, "nominal"),
        ({"method": "Nelder-Mead"}, "method"),
        ({"method": "fmincon"}, "method"),
        ({"ks": []}, "ks"),
        ({"ks": [[0, 0]]}, "ks"),
        ({"ks": [-100]}, "ks"),
        ({"tolerance": -0.01}, "tolerance"),
        ({"inertia": 0.3}, "inertia, gravity_moment"),  # needs m >= (M_g/g)²/I = 5.7 kg
    ],
)
def test_bad_input_raises_one_line_error_naming_the_field(change, field):
    with pytest.raises(InputError) as info:
        paper_baseline(**{"method": "SLSQP", "ks": [0], **_GOOD, **change})
    message = str(info.value)
    assert message.startswith(f"{field}:")
    assert "\n" not in message


def test_box_without_solution_names_the_minimum_mass():
    with pytest.raises(InputError, match=r"mass must be >= \(M_g/g\)\^2/I = 2\.867"):
        paper_baseline(
            inertia=0.594,
            gravity_moment=2.90 * G * 0.45,
            nominal=[2.7, 0.45, 0.035],
            lower=[1.46, 0.225, 0.0175],
            upper=[2.8, 0.675, 0.0525],
        )
