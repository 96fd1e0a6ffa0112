import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inertiafit.errors import InputError
from inertiafit.inference.model import (
    Condition,
    Model,
    box_meets,
    draw_angles,
    feasible_angles,
    feasible_measure,
)
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior
from inertiafit.physics import inertia, parameters_from_identified


@pytest.mark.parametrize("name", ["biodex-elbow-attachment", "disk-3kg"])
def test_measure_of_the_feasible_angles_is_the_prior_density_of_a_and_I(name):
    """|Psi(a, b)| / (V a) must be the density of (m x, I) under the uniform box: check it
    against a histogram of 2 million box draws (independent of the closed form)."""
    p = load_prior(name)
    rng = np.random.default_rng(1)
    d = p.sample(2_000_000, rng)
    a = d["mass"] * d["com_distance"]
    b = inertia(d["mass"], d["radius_of_gyration"], d["com_distance"])
    nb, sub = 20, 32  # fine sub-grid: the density has square-root edges
    hist, ae, be = np.histogram2d(a, b, bins=nb)
    vol = np.prod(p.bounds[:, 1] - p.bounds[:, 0])
    af = np.linspace(ae[0], ae[-1], nb * sub + 1)
    bf = np.linspace(be[0], be[-1], nb * sub + 1)
    aa, bb = np.meshgrid((af[1:] + af[:-1]) / 2, (bf[1:] + bf[:-1]) / 2, indexing="ij")
    dens = (feasible_measure(aa, bb, p) / (vol * aa)).reshape(nb, sub, nb, sub).mean((1, 3))
    cell = np.diff(ae)[0] * np.diff(be)[0]
    assert dens.sum() * cell == pytest.approx(1.0, abs=2e-3)
    expected = dens * cell * len(a)
    ok = expected > 2000
    z = (hist[ok] - expected[ok]) / np.sqrt(expected[ok])
    assert np.abs(z).max() < 5.5  # Poisson noise only (a few hundred cells)
    # A wrong measure (forgetting the 1/a of the Jacobian) is far off.
    wrong = (feasible_measure(aa, bb, p) / vol).reshape(nb, sub, nb, sub).mean((1, 3))
    wrong *= cell * len(a) / (wrong.sum() * cell)
    assert np.abs((hist[ok] - wrong[ok]) / np.sqrt(wrong[ok])).max() > 10


def test_angle_draws_stay_in_the_box_and_cover_it():
    p = load_prior("biodex-elbow-attachment")
    rng = np.random.default_rng(2)
    a = np.full(50_000, 0.756)
    b = np.full(50_000, 0.216)
    psi = draw_angles(a, b, p, rng)
    m, x, rho = parameters_from_identified(a, b, psi)
    assert p.contains(m, x, rho).all()
    np.testing.assert_allclose(m * x, a)
    np.testing.assert_allclose(inertia(m, rho, x), b)
    lo1, hi1, lo2, hi2 = (float(v) for v in feasible_angles(0.756, 0.216, p))
    # the draws fill the feasible angles uniformly
    lengths = max(hi1 - lo1, 0) + max(hi2 - lo2, 0)
    assert np.ptp(psi) == pytest.approx(lengths, rel=1e-3)
    # the paper's own answer lies on this curve, at the edge rho = 0.5 rho_0 of the box
    assert m.min() == pytest.approx(2.81, abs=0.03)


def test_log_prob_is_minus_infinity_outside_and_finite_inside():
    p = load_prior("disk-3kg")
    model = Model(
        {"disk": p},
        [
            Condition(
                ("disk",),
                Observation.from_mean_se(0.594, 0.01),
                Observation.from_mean_se(12.8, 0.05),
            )
        ],
    )
    inside = np.log([[12.8 / 9.81, 0.594]])
    outside = np.log([[12.8 / 9.81, 5.0]])  # an inertia no body in the box can have
    assert np.isfinite(model.log_prob(inside)).all()
    assert np.isneginf(model.log_prob(outside)).all()


def test_infeasible_box_is_reported_with_the_mass_bound():
    p = load_prior("disk-3kg")  # mass at most 4.38 kg
    model = Model(
        {"disk": p},
        [
            Condition(
                ("disk",),
                Observation.from_mean_se(0.30, 0.003),
                Observation.from_mean_se(12.8, 0.05),
            )
        ],
    )
    with pytest.raises(
        InputError, match=r"mass upper bound 4\.38 kg is below \(M_g/g\)\^2/I = 5\.67"
    ):
        model.check_feasible()


def test_two_trial_values_are_feasible():
    # Two trials give a Student-t with one degree of freedom, whose 1e-4 quantiles span orders
    # of magnitude, and the old 61 x 61 grid over them missed the thin feasible curve; a feasible
    # point (m 3.3, x 0.229, rho 0.112) lies inside the box.
    p = load_prior("biodex-elbow-attachment")
    model = Model(
        {"att": p},
        [
            Condition(
                ("att",),
                Observation.from_values([0.21, 0.22]),
                Observation.from_mean_se(7.415, 0.05),
            )
        ],
    )
    model.check_feasible()
    assert pytest.approx(7.415, rel=0.01) == 3.3 * 0.229 * 9.81
    assert inertia(3.3, 0.112, 0.229) == pytest.approx(0.215, rel=0.01)


class _Bounds:
    def __init__(self, lower, upper):
        self.lower, self.upper = lower, upper


KEYS = ("mass", "com_distance", "radius_of_gyration")


@settings(max_examples=200, deadline=None)
@given(
    centre=st.tuples(*(st.floats(0.05, 5.0) for _ in KEYS)),
    half=st.floats(0.05, 0.6),
    pick=st.tuples(*(st.floats(0.0, 1.0) for _ in KEYS)),
    widths=st.tuples(st.floats(1e-4, 3.0), st.floats(1e-4, 3.0)),
    skew=st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0)),
)
def test_box_meets_finds_every_point_of_the_box(centre, half, pick, widths, skew):
    # Any (m, x, rho) of the box gives an (a, I); a rectangle around it, however thin or wide,
    # must be found feasible.
    box = _Bounds(
        {k: c * (1 - half) for k, c in zip(KEYS, centre, strict=True)},
        {k: c * (1 + half) for k, c in zip(KEYS, centre, strict=True)},
    )
    m, x, rho = (
        box.lower[k] + f * (box.upper[k] - box.lower[k]) for k, f in zip(KEYS, pick, strict=True)
    )
    a, b = m * x, float(inertia(m, rho, x))
    a_range = (
        a * (1 - widths[0] * skew[0] / (1 + widths[0])),
        a * (1 + widths[0] * (1 - skew[0])),
    )
    b_range = (
        b * (1 - widths[1] * skew[1] / (1 + widths[1])),
        b * (1 + widths[1] * (1 - skew[1])),
    )
    assert box_meets(a_range, b_range, box)


def test_box_meets_refuses_what_no_point_of_the_box_reaches():
    box = _Bounds(
        {"mass": 1.0, "com_distance": 0.1, "radius_of_gyration": 0.05},
        {"mass": 2.0, "com_distance": 0.2, "radius_of_gyration": 0.1},
    )
    # the smallest inertia of the box is 1 * (0.05^2 + 0.1^2) = 0.0125; the largest a is 0.4
    assert not box_meets((0.05, 0.4), (1e-4, 0.0124), box)
    assert box_meets((0.05, 0.4), (1e-4, 0.0126), box)
    assert not box_meets((0.41, 1.0), (0.01, 1.0), box)
    # a = 0.1 needs I >= a^2/m + m rho_lo^2, least at m = a/rho_lo... within the box 0.0125 at m=1
    assert not box_meets((0.1, 0.1), (0.0, 0.0124), box)


def test_conditions_name_known_bodies():
    p = load_prior("disk-3kg")
    with pytest.raises(InputError, match="unknown body 'arm'"):
        Model({"disk": p}, [Condition(("arm",), Observation.from_mean_se(1, 0.1))])
    with pytest.raises(InputError, match="body 'disk' is in no condition"):
        Model({"disk": p, "att": p}, [Condition(("att",), Observation.from_mean_se(1, 0.1))])


def test_a_gravity_moment_no_body_of_the_box_has_is_reported_as_a_data_problem():
    # A flat quasi-static torque gives M_g near 0: the trials are at fault, not the prior, and
    # the message says so first (it used to blame the prior box).
    p = load_prior("disk-3kg")
    model = Model(
        {"disk": p},
        [
            Condition(
                ("disk",),
                Observation.from_mean_se(0.594, 0.0105),
                Observation.from_mean_se(0.0063, 0.002),
            )
        ],
    )
    with pytest.raises(
        InputError,
        match=r"^condition 'disk': its quasi-static trials give M_g = 0\.0063 ± 0\.002 N m, "
        r"outside the [\d.]+ to [\d.]+ N m that the prior 'disk-3kg' of body 'disk' allows: "
        r"check those trials \(a flat, clipped or wrongly scaled torque, too short a sweep\?\) "
        r"before the prior$",
    ):
        model.check_feasible()


def test_a_weighed_mass_in_grams_is_named_as_such():
    p = load_prior("disk-3kg")
    model = Model(
        {"disk": p},
        [
            Condition(
                ("disk",),
                Observation.from_mean_se(0.594, 0.0105),
                Observation.from_mean_se(12.8, 0.05),
            )
        ],
        measured={"disk": {"mass": Observation.from_mean_se(2920.0, 5.0)}},
    )
    with pytest.raises(
        InputError,
        match=r"^body 'disk': the weighed mass 2920 kg lies outside what its prior 'disk-3kg' "
        r"allows \([\d.]+ to 4\.38 kg\) \(grams entered as kg\?\); check the reading",
    ):
        model.check_feasible()
