"""The blocked sampler for an attachment with K segments: which models it takes, and its draws
against the exact star-model quadrature (and the joint sampler against the same yardstick)."""

import math
import warnings

import emcee
import numpy as np
import pytest

from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.inference import moves
from inertiafit.inference.blocked import BlockedGibbs
from inertiafit.inference.fit import fit
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.moves import laplace_fit, proposal_df
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior
from inertiafit.inference.reference import reference_posterior, star_reference
from inertiafit.inference.sampler import SamplerSettings, resolve_moves, sample
from inertiafit.inference.star import star_structure
from inertiafit.physics import inertia

# The sampler tests: CI runs them a second time with NumPy's newest CPU features disabled.
pytestmark = pytest.mark.reproducibility

G = 9.81


def segments_model(k, *, seed=0, n_trials=10, inflate=None):
    """An attachment measured alone and with each of ``k`` segments: 10 inertia trials per
    condition (Student-t, 9 d.o.f.) and a gravity moment with a 1 % SE. Prior boxes (+-50 %)
    are centred up to 15 % off the truth. ``inflate`` widens the evidence of one condition
    (a negative control)."""
    rng = np.random.default_rng([seed, k])
    truth = {"attachment": (2.85, 0.12, 0.24)}
    for j in range(1, k + 1):
        truth[f"seg{j:02d}"] = (rng.uniform(1, 4), rng.uniform(0.04, 0.1), rng.uniform(0.1, 0.3))
    priors = {}
    for name, (m, rho, x) in truth.items():
        f = rng.uniform(0.85, 1.15, 3)
        priors[name] = Prior.box(
            name, mass=m * f[0], radius_of_gyration=rho * f[1], com_distance=x * f[2]
        )
    ab = {n: (m * x, float(inertia(m, rho, x))) for n, (m, rho, x) in truth.items()}
    conditions = []
    for names in [("attachment",)] + [("attachment", n) for n in list(truth)[1:]]:
        a = sum(ab[n][0] for n in names)
        b = sum(ab[n][1] for n in names)
        obs_i = Observation.from_values(b * (1 + 0.03 * rng.standard_normal(n_trials)))
        obs_g = Observation.from_mean_se(G * a * (1 + 0.01 * rng.standard_normal()), 0.01 * G * a)
        if inflate == names[-1]:
            obs_i = Observation(obs_i.center, 1.3 * obs_i.scale, obs_i.df, obs_i.n)
        conditions.append(Condition(names, obs_i, obs_g))
    return Model(priors, conditions, gravity=G)


def agreement(post, ref):
    """Largest ``ref[body].agreement`` over all bodies (mean error in SDs, SD error)."""
    worst = [r.agreement({q: post.draws(body, q) for q in r.values}) for body, r in ref.items()]
    return max(w[0] for w in worst), max(w[1] for w in worst)


# ------------------------------------------------------------------------------- structure


def obs(center, scale=0.01):
    return Observation.from_mean_se(center, scale)


def box(name):
    return Prior.box(name, mass=2.0, com_distance=0.2, radius_of_gyration=0.1)


def model_of(conditions):
    bodies = sorted({b for names, *_ in conditions for b in names})
    return Model(
        {b: box(b) for b in bodies},
        [Condition(tuple(names), i, g) for names, i, g in conditions],
    )


def test_attachment_with_segments_is_a_star():
    m = model_of(
        [
            (("a",), obs(0.1), obs(4.0)),
            (("a", "b"), obs(0.2), obs(8.0)),
            (("a", "c"), obs(0.2), obs(8.0)),
        ]
    )
    star = star_structure(m)
    assert star.shared == (0,)
    assert star.leaves == (1, 2)
    assert star.leaf_conditions == (1, 2)
    assert star.shared_conditions == (0,)
    np.testing.assert_array_equal(star.weights, [[1.0], [1.0]])
    assert resolve_moves(m, "auto") == "blocked"


def test_nested_conditions_leave_only_the_outermost_body_a_leaf():
    m = model_of(
        [
            (("a",), obs(0.1), obs(4.0)),
            (("a", "b"), obs(0.2), obs(8.0)),
            (("a", "b", "c"), obs(0.3), obs(12.0)),
        ]
    )
    star = star_structure(m)
    assert star.shared == (0, 1)
    assert star.leaves == (2,)
    np.testing.assert_array_equal(star.weights, [[1.0, 1.0]])


def test_models_the_blocked_sampler_cannot_take():
    # the attachment is never measured alone: nothing anchors the shared proposal
    never_alone = model_of([(("a", "b"), obs(0.2), obs(8.0)), (("a", "c"), obs(0.2), obs(8.0))])
    assert star_structure(never_alone) is None
    # the segment's condition has no gravity moment: its total cannot be proposed from evidence
    no_gravity = model_of([(("a",), obs(0.1), obs(4.0)), (("a", "b"), obs(0.2), None)])
    assert star_structure(no_gravity) is None
    # the attachment alone without its gravity moment: nothing pins its shared proposal
    alone_no_gravity = model_of([(("a",), obs(0.1), None), (("a", "b"), obs(0.2), obs(8.0))])
    assert star_structure(alone_no_gravity) is None
    for m in (never_alone, no_gravity, alone_no_gravity):
        assert resolve_moves(m, "auto") == "independent"
        with pytest.raises(InputError, match="moves 'blocked' needs"):
            resolve_moves(m, "blocked")
    one_body = model_of([(("a",), obs(0.1), obs(4.0))])
    assert resolve_moves(one_body, "auto") == "independent"
    with pytest.raises(InputError, match="unknown moves 'gibbs'"):
        resolve_moves(one_body, "gibbs")


# -------------------------------------------------------------------------------- reference


def test_star_reference_without_segments_is_the_single_body_quadrature():
    m = segments_model(0)
    cond = m.conditions[0]
    star = star_reference(m, n_angle=40)["attachment"]
    single = reference_posterior(m.priors["attachment"], cond.inertia, cond.gravity_moment)
    for q in ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment"):
        assert star.mean(q) == pytest.approx(single.mean(q), rel=2e-4)
        assert star.sd(q) == pytest.approx(single.sd(q), rel=2e-3)


def test_star_reference_rejects_models_without_one_measured_attachment():
    m = model_of([(("a", "b"), obs(0.2), obs(8.0)), (("a", "c"), obs(0.2), obs(8.0))])
    with pytest.raises(ValueError, match="one shared body"):
        star_reference(m)


# ---------------------------------------------------------------------------------- sampler


@pytest.mark.slow
@pytest.mark.parametrize(("k", "seed"), [(1, 1), (3, 2), (20, 3)])
def test_blocked_sampler_matches_the_exact_posterior(k, seed):
    model = segments_model(k)
    post = fit(model, seed=seed, settings=SamplerSettings(progress=False))
    assert post.attrs["moves"] == "blocked"
    assert post.converged
    # ESS >= 1000 per quantity: Monte Carlo SE of a mean <= 0.032 SD, of an SD <= ~2.5 %;
    # over 5 (k + 1) quantities the largest of them stays below 0.1 SD and 10 %.
    assert post.summary()["ess_bulk"].min() >= 1000
    worst_mean, worst_sd = agreement(post, star_reference(model, n_angle=24))
    assert worst_mean < 0.1
    assert worst_sd < 0.10


@pytest.mark.slow
@pytest.mark.parametrize("k", [1, 2])
def test_joint_sampler_gives_the_same_posterior_at_small_k(k):
    # The joint emcee sampler (all bodies' coordinates at once) against the same yardstick:
    # the blocked decomposition changes how the posterior is explored, not what it is.
    model = segments_model(k)
    post = fit(model, seed=4, settings=SamplerSettings(moves="independent", progress=False))
    assert post.attrs["moves"] == "independent"
    worst_mean, worst_sd = agreement(post, star_reference(model, n_angle=24))
    assert worst_mean < 0.1
    assert worst_sd < 0.10


@pytest.mark.slow
def test_negative_control_a_wrong_likelihood_fails_the_same_test():
    # One segment's inertia evidence 30 % too wide; the yardstick is the right model's.
    model = segments_model(3)
    wrong = segments_model(3, inflate="seg02")
    post = fit(wrong, seed=2, settings=SamplerSettings(progress=False))
    worst_mean, worst_sd = agreement(post, star_reference(model))
    assert worst_mean >= 0.1 or worst_sd >= 0.10


def test_same_seed_same_draws():
    model = segments_model(2)
    s = SamplerSettings(progress=False, max_steps=300)
    a = fit(model, seed=7, settings=s).draws("seg01", "mass")
    b = fit(model, seed=7, settings=s).draws("seg01", "mass")
    c = fit(model, seed=8, settings=s).draws("seg01", "mass")
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a[:, :50], c[:, :50])


def far_tail_chains(model, joint_step: bool, sweeps: int = 60):
    """Chains started with the attachment's inertia 8 SDs out; where are they after a while?"""
    star = star_structure(model)
    shared = BlockedGibbs.shared_submodel(model, star)
    mode, cov = laplace_fit(shared, np.random.default_rng(0))
    gibbs = BlockedGibbs(model, star, mode, cov, proposal_df(shared))
    if not joint_step:
        gibbs._shared_step_leaves_fixed = lambda s, ta, tb, random: (s, ta, tb)
    random = np.random.default_rng(1)
    s_log, ta, tb = gibbs.start(32, random)
    sd = np.sqrt(cov[1, 1])
    s_log[:, 1] = mode[1] + 8 * sd
    # leaf totals that fit the far-out attachment (as a chain that wandered there would hold)
    ta, tb = gibbs.fit_leaves(s_log, ta, tb, random)
    for _ in range(sweeps):
        s_log, ta, tb = gibbs.sweep(s_log, ta, tb, random)
    return np.abs(s_log[:, 1] - mode[1]) / sd


def test_a_chain_in_a_far_tail_comes_back():
    # Three trials per condition: Student-t evidence with 2 d.o.f., chains do visit far tails.
    model = segments_model(2, n_trials=3)
    assert np.all(far_tail_chains(model, joint_step=True) < 6)
    # negative control: with only the two conditional updates, the attachment and the leaf
    # totals hold each other in place (each segment's box ties its total to the attachment)
    assert np.sum(far_tail_chains(model, joint_step=False) > 6) >= 2


# ----------------------------------------------- a small segment on a heavy, noisy attachment (issue 12)


def trials(mean, se, n=10):
    """A mean of ``n`` trials reported with its SE: the Student-t of those trials."""
    return Observation.from_mean_sd(mean, se * math.sqrt(n), n)


def two_segments(inertias, gravity_moments):
    """An attachment alone and with each of two segments; boxes +-50 % around (m, x, rho)."""
    priors = {
        "attachment": Prior.box(
            "attachment", mass=2.9, com_distance=0.225, radius_of_gyration=0.13
        ),
        "segment0": Prior.box("segment0", mass=1.6, com_distance=0.16, radius_of_gyration=0.08),
        "segment1": Prior.box("segment1", mass=1.6, com_distance=0.16, radius_of_gyration=0.08),
    }
    names = [("attachment",), ("attachment", "segment0"), ("attachment", "segment1")]
    conditions = [
        Condition(n, trials(*i), Observation.from_mean_se(*g))
        for n, i, g in zip(names, inertias, gravity_moments, strict=True)
    ]
    return Model(priors, conditions, gravity=G)


def small_segment_model():
    """Issue 12's case, which stopped with ``cannot convert float NaN to integer``: segment 1's
    total is measured tightly (SE 0.0019) and its box needs I >= ~0.019 kg m^2, so the
    attachment's inertia is bounded near 0.29, while measured alone it reads 0.300 +- 0.010."""
    return two_segments(
        [(0.30011, 0.0101), (0.30674, 0.00789), (0.30873, 0.00191)],
        [(8.7542, 0.035), (10.683, 0.0425), (10.602, 0.0424)],
    )


def kink_model():
    """A scan case whose attachment has its posterior mode on a kink of its prior density;
    20 000 steps left it unconverged (tau ~1500) before its Laplace fit was re-measured."""
    return two_segments(
        [(0.12790, 0.0029141), (0.16111, 0.0031022), (0.17057, 0.00070774)],
        [(3.1745, 0.0096240), (5.5153, 0.021447), (5.6826, 0.039646)],
    )


def blocked_sampler(model, seed=0):
    star = star_structure(model)
    shared = BlockedGibbs.shared_submodel(model, star)
    mode, cov = laplace_fit(shared, np.random.default_rng(seed))
    return BlockedGibbs(model, star, mode, cov, proposal_df(shared))


def test_every_chain_starts_inside_the_support():
    model = small_segment_model()
    gibbs = blocked_sampler(model)
    for seed in range(3):
        random = np.random.default_rng(seed)
        state = gibbs.start(32, random)
        assert gibbs.in_support(*state).all()
        assert np.isfinite(model.log_prob(gibbs.joint_coordinates(*state))).all()
    # negative control: shared draws from the attachment's own evidence with leaves redrawn
    # for them (the start before the fix) leave chains with no room for segment 1
    _, ta, tb = state
    s_new = gibbs.proposal.draw(32, random)
    ta, tb = gibbs.fit_leaves(s_new, ta, tb, random)
    outside = ~gibbs.in_support(s_new, ta, tb)
    assert outside.sum() >= 5
    assert np.isnan(gibbs.joint_coordinates(s_new, ta, tb)[outside]).any()


def test_the_start_falls_back_on_the_whole_models_laplace_fit():
    # The attachment alone says I = 0.3000 +- 0.0006; with segment 1 (whose box needs at least
    # ~0.019) the total says 0.3070 +- 0.0002: the attachment lies 6 SD out, where its own
    # proposal hardly ever goes.
    model = two_segments(
        [(0.30011, 0.0006), (0.33, 0.005), (0.30711, 0.0002)],
        [(8.7542, 0.035), (10.683, 0.0425), (10.683, 0.0425)],
    )
    gibbs = blocked_sampler(model)
    fallback = gibbs._laplace_draws
    calls = []
    gibbs._laplace_draws = lambda n, random: calls.append(n) or fallback(n, random)
    state = gibbs.start(32, np.random.default_rng(1))
    assert calls
    assert calls[0] > 0
    assert gibbs.in_support(*state).all()


def test_laplace_fit_measures_the_curvature_across_a_kink():
    model = kink_model()
    shared = BlockedGibbs.shared_submodel(model, star_structure(model))
    # the shared posterior's SD of log I, on a grid (0.0242)
    mode, cov = laplace_fit(shared, np.random.default_rng(0))
    la, lb = np.meshgrid(
        np.linspace(mode[0] - 0.05, mode[0] + 0.05, 201),
        np.linspace(mode[1] - 0.2, mode[1] + 0.2, 401),
        indexing="ij",
    )
    w = np.exp(shared.log_prob(np.stack([la.ravel(), lb.ravel()], -1)))
    sd_grid = math.sqrt(np.cov(lb.ravel(), aweights=w))
    assert 0.6 < math.sqrt(cov[1, 1]) / sd_grid < 1.2
    # smooth posterior: the curvature over one SD agrees, the fit is exactly the old one
    smooth = BlockedGibbs.shared_submodel(segments_model(3), star_structure(segments_model(3)))
    kept = laplace_fit(smooth, np.random.default_rng(0))[1]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(moves, "KINK_RATIO", math.inf)  # no re-measuring
        np.testing.assert_array_equal(laplace_fit(smooth, np.random.default_rng(0))[1], kept)
        # negative control: the curvature at the kink itself is 8 times too narrow
        narrow = laplace_fit(shared, np.random.default_rng(0))[1]
    assert math.sqrt(narrow[1, 1]) / sd_grid < 0.2


@pytest.fixture(scope="module")
def small_segment_reference():
    return star_reference(small_segment_model(), n_angle=24)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_a_small_segment_on_a_heavy_noisy_attachment(seed, small_segment_reference):
    post = fit(small_segment_model(), seed=seed, settings=SamplerSettings(progress=False))
    assert post.attrs["moves"] == "blocked"
    assert post.converged
    worst_mean, worst_sd = agreement(post, small_segment_reference)
    assert worst_mean < 0.1
    assert worst_sd < 0.10


@pytest.mark.slow
def test_a_mode_on_a_kink_of_the_prior():
    model = kink_model()
    post = fit(model, seed=43, settings=SamplerSettings(progress=False))
    assert post.converged
    assert post.attrs["n_steps"] <= 500
    worst_mean, worst_sd = agreement(post, star_reference(model, n_angle=24))
    assert worst_mean < 0.1
    assert worst_sd < 0.10


@pytest.mark.parametrize("moves_", ["blocked", "independent"])
def test_a_tau_that_cannot_be_estimated_never_raises(moves_, monkeypatch):
    # emcee's tau is nan for a coordinate that never moved; the sampler must carry on to
    # max_steps, dropping the first half, and warn (it used to raise on math.ceil(nan)).
    model = segments_model(1)
    settings = SamplerSettings(progress=False, moves=moves_, chunk=50, max_steps=100)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        honest = sample(model, seed=1, settings=settings)
    real = emcee.autocorr.integrated_time

    def nan_tau(chain, **kwargs):
        tau = real(chain, **kwargs)
        tau[1] = np.nan
        return tau

    monkeypatch.setattr(emcee.autocorr, "integrated_time", nan_tau)
    with pytest.warns(ConvergenceWarning, match="tau not estimable"):
        run = sample(model, seed=1, settings=settings)
    assert not run.converged
    assert run.n_steps == 100
    assert run.burn == 50
    assert run.chain.shape[1] == 50
    assert np.isfinite(run.parameters["mass"]).all()
    # negative control: with tau estimated, the burn-in is 3 tau, well under half
    assert honest.burn < 20
