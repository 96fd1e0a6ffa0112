import numpy as np
import pytest

from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior
from inertiafit.inference.reference import reference_posterior
from inertiafit.physics import inertia

ATTACHMENT = (
    "biodex-elbow-attachment",
    Observation.from_mean_sd(0.216, 0.017, 30),
    Observation.from_mean_se(7.415, 0.05),
)


def brute_force(prior, obs_i, obs_g, n=150, gravity=9.81):
    """Posterior means on a plain grid over the (m, x, rho) box: slow but independent."""
    axes = [np.linspace(*prior.bounds[k], n) for k in range(3)]
    m, x, rho = np.meshgrid(*axes, indexing="ij")
    log_l = obs_i.logpdf(inertia(m, rho, x)) + obs_g.logpdf(gravity * m * x)
    w = np.exp(log_l - log_l.max())
    w /= w.sum()
    return {
        "mass": (w * m).sum(),
        "com_distance": (w * x).sum(),
        "radius_of_gyration": (w * rho).sum(),
    }


def test_reference_agrees_with_a_brute_force_grid_in_the_original_box():
    # Wide evidence, so a plain 150^3 grid over the box resolves the ridge.
    prior = load_prior("biodex-elbow-attachment")
    obs_i = Observation.from_mean_se(0.216, 0.02)
    obs_g = Observation.from_mean_se(7.415, 0.4)
    ref = reference_posterior(prior, obs_i, obs_g)
    bf = brute_force(prior, obs_i, obs_g)
    for k, v in bf.items():
        assert ref.mean(k) == pytest.approx(v, abs=0.02 * ref.sd(k))


def test_reference_is_converged_in_its_grid():
    coarse = reference_posterior(*ATTACHMENT[1:], n_identified=60, n_mass=200) if False else None
    prior = load_prior(ATTACHMENT[0])
    coarse = reference_posterior(prior, *ATTACHMENT[1:], n_identified=60, n_mass=200)
    fine = reference_posterior(prior, *ATTACHMENT[1:], n_identified=160, n_mass=600)
    for k in fine.values:
        assert coarse.mean(k) == pytest.approx(fine.mean(k), abs=0.01 * fine.sd(k))
        assert coarse.sd(k) == pytest.approx(fine.sd(k), rel=0.01)


def test_reference_matches_the_physics_of_the_papers_attachment():
    prior = load_prior(ATTACHMENT[0])
    ref = reference_posterior(prior, *ATTACHMENT[1:])
    # The data fix I and M_g: their posteriors are the evidence (SE 0.017/sqrt(30) and 0.05).
    assert ref.mean("inertia") == pytest.approx(0.216, abs=2e-4)
    assert ref.sd("inertia") == pytest.approx(0.017 / np.sqrt(30), rel=0.05)
    assert ref.sd("gravity_moment") == pytest.approx(0.05, rel=0.02)
    # Mass is bounded below by (M_g/g)^2 / I = 2.645 kg and above by the box (4.365 kg).
    lo, hi = ref.quantile("mass", [0.0005, 0.9995])
    assert lo > 2.6
    assert hi <= 4.365 + 1e-9
