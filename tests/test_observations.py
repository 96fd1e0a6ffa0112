import math

import numpy as np
import pytest
from scipy import stats

from inertiafit.errors import InputError
from inertiafit.inference.observations import Observation
from inertiafit.stats import student_t_draws, student_t_logpdf


def test_repeated_values_give_the_marginal_student_t():
    y = np.array([0.21, 0.23, 0.22, 0.20, 0.215])
    obs = Observation.from_values(y)
    mu = np.linspace(0.19, 0.24, 7)
    expect = stats.t.logpdf(mu, df=4, loc=y.mean(), scale=y.std(ddof=1) / math.sqrt(5))
    np.testing.assert_allclose(obs.logpdf(mu), expect, rtol=1e-12)
    # The same Student-t follows from integrating sigma out under p(sigma) ~ 1/sigma:
    # prod_k N(y_k | mu, sigma) / sigma, integrated numerically over sigma.
    from scipy.integrate import quad

    def marginal(m):
        f = lambda s: np.prod(stats.norm.pdf(y, m, s)) / s
        return quad(f, 1e-4, 1.0, limit=200)[0]

    num = np.array([marginal(m) for m in mu])
    np.testing.assert_allclose(np.log(num) - np.log(num[3]), expect - expect[3], atol=1e-6)


def test_mean_sd_n_equals_the_values_it_summarises():
    y = np.random.default_rng(3).normal(0.216, 0.017, 30)
    a = Observation.from_values(y)
    b = Observation.from_mean_sd(y.mean(), y.std(ddof=1), 30)
    mu = np.linspace(0.2, 0.23, 5)
    np.testing.assert_allclose(a.logpdf(mu), b.logpdf(mu), rtol=1e-12)


def test_single_value_with_se_is_gaussian():
    obs = Observation.from_mean_se(7.4, 0.05)
    np.testing.assert_allclose(obs.logpdf([7.3, 7.45]), stats.norm.logpdf([7.3, 7.45], 7.4, 0.05))


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: Observation.from_values([0.2]), "one value needs its standard error"),
        (lambda: Observation.from_values([0.2, -0.1]), r"values\[1\].*positive"),
        (lambda: Observation.from_values(["abc"]), r"values\[0\].*expected a positive number"),
        (lambda: Observation.from_values([0.2, 0.2]), "identical"),
        (lambda: Observation.from_mean_se(0.2, 0), "standard error.*positive"),
        (lambda: Observation.from_mean_sd(0.2, 0.01, 1), "n must be an integer >= 2"),
        (lambda: Observation.from_values([float("nan"), 0.2]), "finite"),
    ],
)
def test_bad_observations(call, match):
    with pytest.raises(InputError, match=match):
        call()


def test_student_t_logpdf_evaluates_many_distributions_at_once():
    # Column i of x under distribution i; a Gaussian where df is infinite.
    center = np.array([0.2, 7.4, 1.0])
    scale = np.array([0.01, 0.05, 0.3])
    df = np.array([4.0, math.inf, 29.0])
    x = center + scale * np.random.default_rng(5).normal(0, 2, (6, 3))
    got = student_t_logpdf(x, center, scale, df)
    expect = np.column_stack(
        [
            stats.t.logpdf(x[:, 0], 4, center[0], scale[0]),
            stats.norm.logpdf(x[:, 1], center[1], scale[1]),
            stats.t.logpdf(x[:, 2], 29, center[2], scale[2]),
        ]
    )
    np.testing.assert_allclose(got, expect, rtol=1e-12)
    # Unnormalised: the same up to one constant per column.
    kernel = student_t_logpdf(x, center, scale, df, normalised=False)
    np.testing.assert_allclose(np.ptp(got - kernel, axis=0), 0, atol=1e-12)
    # An Observation's likelihood is the same density, digit for digit.
    for i in range(3):
        obs = Observation(center[i], scale[i], df[i], 5)
        np.testing.assert_array_equal(obs.logpdf(x[:, i]), got[:, i])


def test_student_t_draws_follow_their_distributions():
    center, scale, df = np.array([0.2, 7.4]), np.array([0.01, 0.05]), np.array([3.0, math.inf])
    x = student_t_draws(center, scale, df, (20_000,), np.random.default_rng(6))
    assert x.shape == (20_000, 2)
    assert stats.kstest(x[:, 0], stats.t(3, center[0], scale[0]).cdf).pvalue > 1e-3
    assert stats.kstest(x[:, 1], stats.norm(center[1], scale[1]).cdf).pvalue > 1e-3
