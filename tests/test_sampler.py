"""The sampler against the exact quadrature posterior (the emcee proposal-test idea):
fixed seeds, tolerances from Monte Carlo error, and a negative control that must fail."""

import numpy as np
import pytest

from inertiafit.inference.fit import fit, fit_body
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior, load_prior
from inertiafit.inference.reference import reference_posterior
from inertiafit.inference.sampler import SamplerSettings

# The sampler tests: CI runs them a second time with NumPy's newest CPU features disabled.
pytestmark = pytest.mark.reproducibility

QUANTITIES = ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment")
TRIALS = np.random.default_rng(11).normal(0.2157, 0.0167, 10)

CASES = {
    # the paper's attachment: m, x, rho partly identified, partly prior
    "attachment": (
        "biodex-elbow-attachment",
        Observation.from_mean_sd(0.216, 0.017, 30),
        Observation.from_mean_se(7.415, 0.05),
    ),
    # the paper's disk: m pinned by the data, rho decided by the prior
    "disk": (
        "disk-3kg",
        Observation.from_mean_se(0.594, 0.0105),
        Observation.from_mean_se(12.80, 0.05),
    ),
    # a wide box (+-80 %) with ten raw trial values: a long curved ridge
    "wide": (
        Prior.box("wide", mass=2.91, com_distance=0.225, radius_of_gyration=0.13, spread=0.8),
        Observation.from_values(TRIALS),
        Observation.from_mean_se(7.415, 0.15),
    ),
}


def agreement(post, ref, body) -> tuple[float, float]:
    """``ref.agreement`` of one body's draws of the five quantities."""
    return ref.agreement({q: post.draws(body, q) for q in QUANTITIES})


def run(case, seed, scale_inflation=1.0):
    prior, obs_i, obs_g = CASES[case]
    prior = load_prior(prior)
    wrong = Observation(obs_i.center, obs_i.scale * scale_inflation, obs_i.df, obs_i.n)
    model = Model({case: prior}, [Condition((case,), wrong, obs_g)])
    post = fit(model, seed=seed)
    ref = reference_posterior(prior, obs_i, obs_g)
    return post, ref


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("seed", [1, 2])
def test_sampler_matches_the_quadrature_posterior(case, seed):
    post, ref = run(case, seed)
    assert post.converged
    # ESS >= 1000 gives a Monte Carlo SE of the mean <= 0.032 SD and of the SD <= ~2.5 %:
    # 0.1 SD and 10 % are > 3 standard errors.
    assert post.summary()["ess_bulk"].min() >= 1000
    worst_mean, worst_sd = agreement(post, ref, case)
    assert worst_mean < 0.1
    assert worst_sd < 0.10


@pytest.mark.slow
@pytest.mark.parametrize("case", ["attachment", "disk"])
def test_negative_control_a_wrong_likelihood_fails_the_same_test(case):
    # The inertia evidence 30 % too wide: a plausible bug (e.g. SD/sqrt(n-1) mix-ups are
    # smaller; forgetting sqrt(n) is far larger). The same tolerances must catch it.
    post, ref = run(case, 1, scale_inflation=1.3)
    worst_mean, worst_sd = agreement(post, ref, case)
    assert worst_mean >= 0.1 or worst_sd >= 0.10


def test_plain_stretch_move_samples_the_same_posterior():
    prior, obs_i, obs_g = CASES["disk"]
    prior = load_prior(prior)
    model = Model({"disk": prior}, [Condition(("disk",), obs_i, obs_g)])
    post = fit(model, seed=3, settings=SamplerSettings(moves="stretch"))
    worst_mean, worst_sd = agreement(post, reference_posterior(prior, obs_i, obs_g), "disk")
    assert worst_mean < 0.1
    assert worst_sd < 0.1
    assert post.attrs["tau_max"] > 10  # the stretch move mixes several times slower


def test_same_seed_same_draws_other_seed_other_draws():
    kw = {
        "inertia": 0.594,
        "inertia_se": 0.0105,
        "gravity_moment": 12.8,
        "gravity_moment_se": 0.05,
    }
    a = fit_body("disk-3kg", seed=5, **kw)
    b = fit_body("disk-3kg", seed=5, **kw)
    c = fit_body("disk-3kg", seed=6, **kw)
    np.testing.assert_array_equal(a.draws("disk-3kg", "mass"), b.draws("disk-3kg", "mass"))
    assert not np.array_equal(
        a.draws("disk-3kg", "mass")[:, :50], c.draws("disk-3kg", "mass")[:, :50]
    )


def test_identifiability_disk_mass_pinned_radius_of_gyration_from_the_prior():
    post = fit_body(
        "disk-3kg",
        inertia=0.594,
        inertia_se=0.0105,
        gravity_moment=12.8,
        gravity_moment_se=0.05,
        seed=0,
    )
    ident = post.identification().set_index("parameter")
    assert ident.loc["mass", "identified_by"] == "data"
    assert ident.loc["mass", "sd_ratio"] < 0.1
    assert ident.loc["radius_of_gyration", "identified_by"] == "prior"
    assert ident.loc["radius_of_gyration", "sd_ratio"] > 0.9
    # m >= (M_g/g)^2 / I = (12.8/9.81)^2 / 0.594 = 2.866 kg
    assert ident.loc["mass", "minimum_mass"] == pytest.approx(2.866, abs=0.02)


def test_identifiability_attachment_is_shared_between_data_and_prior():
    post = fit_body(
        "biodex-elbow-attachment",
        inertia=0.216,
        inertia_sd=0.017,
        inertia_n=30,
        gravity_moment=7.415,
        gravity_moment_se=0.05,
        seed=0,
    )
    ident = post.identification().set_index("parameter")
    for p in ("mass", "com_distance", "radius_of_gyration"):
        assert ident.loc[p, "identified_by"] == "data + prior"
    for p in ("inertia", "gravity_moment"):
        assert ident.loc[p, "identified_by"] == "data"
    # every draw respects physical consistency, m >= (M_g/g)^2 / I
    d = {q: post.draws("biodex-elbow-attachment", q) for q in QUANTITIES}
    assert (d["mass"] >= (d["gravity_moment"] / 9.81) ** 2 / d["inertia"] * (1 - 1e-12)).all()


def test_a_convergence_check_stops_at_the_first_failing_quantity_and_decides_as_the_full_one():
    from arviz_stats.base import array_stats

    from inertiafit.inference.sampler import convergence_check

    rng = np.random.default_rng(8)
    good = rng.standard_normal((16, 400, 2))  # (walkers, draws, bodies): mixed, independent
    stuck = good.copy()
    stuck[:8] += 3.0  # half the walkers elsewhere: R-hat far above 1.01
    params = {"mass": good, "inertia": stuck, "torque_gain": good[..., 0]}
    full = np.concatenate(
        [np.moveaxis(v, -1, 0) if v.ndim == 3 else v[None] for v in params.values()]
    )
    ess = array_stats.ess(full, chain_axis=-2, draw_axis=-1, method="bulk")
    rhat = array_stats.rhat(full, chain_axis=-2, draw_axis=-1)
    assert rhat[2] > 1.5
    assert rhat[[0, 1, 4]].max() < 1.01
    # from quantity 0: the first that fails is the inertia of body 0 (row 2), with its numbers
    assert convergence_check(params, 1000.0, 1.01) == pytest.approx((ess[2], rhat[2], 2))
    # started from the last culprit, it is the first looked at
    assert convergence_check(params, 1000.0, 1.01, first=3)[2] == 3
    # all pass (no bounds): the minimum and maximum over every quantity, as one full pass gives
    low, high, culprit = convergence_check(params, -np.inf, np.inf)
    assert culprit is None
    assert (low, high) == pytest.approx((ess.min(), rhat.max()))
    # not early (the last check, for the record): every quantity, and still the culprit
    assert convergence_check(params, 1000.0, 1.01, early=False) == pytest.approx(
        (ess.min(), rhat.max(), 2)
    )
    # negative control: without the stuck walkers nothing fails
    assert convergence_check({"mass": good}, 1000.0, 1.01)[2] is None


def test_nested_r_hat_over_groups_of_walkers_passes_a_mixed_ensemble_and_fails_a_split_one():
    """Nested R-hat (``superchains``) compares groups of walkers, not every walker: a mixed
    ensemble at bulk ESS ~600 passes 1.01 where R-hat with each of 32 walkers a chain (its
    expected excess about 64 half-walkers / (2 ESS) = 0.05) fails it; a group of walkers
    half an SD off still fails the nested one."""
    from inertiafit.inference.sampler import convergence_check

    rng = np.random.default_rng(21)
    phi = 0.9  # AR(1) walkers: tau = (1 + phi) / (1 - phi) = 19 steps
    walkers, steps = 32, 400
    eps = rng.standard_normal((walkers, steps + 100))
    x = np.empty_like(eps)
    x[:, 0] = eps[:, 0]
    for t in range(1, eps.shape[1]):
        x[:, t] = phi * x[:, t - 1] + np.sqrt(1 - phi * phi) * eps[:, t]
    mixed = x[:, 100:, None]  # (walkers, draws, one body)
    ess, plain, culprit = convergence_check({"m": mixed}, 400.0, 1.01, early=False)
    assert 400 < ess < 1000
    assert plain > 1.02
    assert culprit == 0
    ess_n, nested, culprit_n = convergence_check({"m": mixed}, 400.0, 1.01, superchains=4)
    assert ess_n == ess
    assert nested < 1.01
    assert culprit_n is None
    # negative control: the walkers of one group (w % 4 == 0) half an SD off
    split = mixed.copy()
    split[::4] += 0.5
    assert convergence_check({"m": split}, 400.0, 1.01, superchains=4)[2] == 0
