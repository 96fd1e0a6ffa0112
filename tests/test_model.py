import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.inference.model import (
    Condition,
    Model,
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


def test_conditions_name_known_bodies():
    p = load_prior("disk-3kg")
    with pytest.raises(InputError, match="unknown body 'arm'"):
        Model({"disk": p}, [Condition(("arm",), Observation.from_mean_se(1, 0.1))])
    with pytest.raises(InputError, match="body 'disk' is in no condition"):
        Model({"disk": p, "att": p}, [Condition(("att",), Observation.from_mean_se(1, 0.1))])
