"""A single fast trial's standard errors: calibrated against simulated trials with known truth.

``benchmarks/trial_se.py`` prints the same numbers over 60 trials per speed and kind; these
tests run it seeded. Under calibrated SEs the z-scores ``(estimate - truth) / SE`` are unit
Normal: over ``n`` trials ``(n - 1) s^2`` is chi-square with ``n - 1`` degrees of freedom, so
the sample SD ``s`` lies in the band :func:`trial_se.sd_band` with probability 99.9 % (for 60
trials 0.71-1.31: the SD of an SD over 60 draws is 9 %). The SEs computed before the noise
model (the window's residuals and their autocorrelation time) fail four of the six checks
on these trials: SDs 1.91 and 1.64 (rigid I at 180 and 240 deg/s), 1.43 and 1.88 (living
I); the living b's, 1.08 and 1.25, passed (the estimated lag takes up part of its error).
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from inertiafit.processing.gravity import GravityFit, TorqueNoise, fit_gravity
from inertiafit.processing.inertia import estimate_inertia
from inertiafit.simulate.signals import Noise, simulate_trial

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import trial_se

SEED = 20261126
CALIBRATED = ("rigid I", "living I", "living b")


@pytest.fixture(scope="module")
def default_noise():
    """z-scores of 60 rigid and 60 living trials per speed, the simulator's default noise.

    Without the white-only controls, which no test here reads at the default noise (the
    strong-drift test computes its own): the scores are the same without them.
    """
    return {s: trial_se.scores(s, 60, SEED, white_only=False) for s in trial_se.SPEEDS}


@pytest.mark.slow
@pytest.mark.parametrize("speed", trial_se.SPEEDS)
@pytest.mark.parametrize("estimate", CALIBRATED)
def test_error_over_se_has_unit_sd(default_noise, speed, estimate):
    z = default_noise[speed][estimate]
    lo, hi = trial_se.sd_band(z.size)
    assert lo <= np.std(z, ddof=1) <= hi
    assert abs(np.mean(z)) < 3.3 / math.sqrt(z.size)  # unbiased at the 0.1 % level


@pytest.mark.slow
def test_simulation_based_calibration_of_the_living_fast_trial(default_noise):
    # Truths from the prior (b from the elbow's damping prior, the passive curve's and the
    # hysteresis' coefficients from theirs, I uniform over 0.05-0.6 kg m^2), data from the
    # simulator: the ranks Phi(z) of I and b are uniform (KS at the 0.1 % level), over both
    # speeds. The negative control, the rigid estimate of the same trials (the damping read
    # as inertia), fails by far.
    for estimate in ("living I", "living b"):
        z = np.concatenate([default_noise[s][estimate] for s in trial_se.SPEEDS])
        assert stats.kstest(stats.norm.cdf(z), "uniform").pvalue > 1e-3
    control = np.concatenate(
        [default_noise[s]["living I, rigid estimate"] for s in trial_se.SPEEDS]
    )
    assert stats.kstest(stats.norm.cdf(control), "uniform").pvalue < 1e-6


@pytest.mark.slow
def test_a_strong_drift_is_carried_and_white_noise_alone_misses_it():
    # A drift of 0.1 N m (the default's three times): the SEs with the drift measured on the
    # sweeps stay calibrated; computed from the white noise alone, the rigid inertia's error
    # is more than twice its SE.
    z = trial_se.scores(180.0, 40, SEED, noise=Noise(drift_sd=0.1))
    lo, hi = trial_se.sd_band(40)
    for estimate in CALIBRATED:
        assert lo <= np.std(z[estimate], ddof=1) <= hi, estimate
    assert np.std(z["rigid I, white only"], ddof=1) > hi


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_sweep_measures_the_drift_a_fast_trial_sees(seed):
    # The simulator's torque noise: white 0.4 N m, a drift of 0.03 N m with a 0.2 s
    # correlation time. The sweep's noise model finds them (the white level to 3 %, the drift
    # to 35 %, its time to a factor of 1.6: a 90 s sweep holds ~450 correlation times).
    sweep = simulate_trial(
        inertia=0.25, gravity_moment=2.2, kind="quasi-static", speed_deg_s=1.0, rng=seed
    )
    noise = fit_gravity(sweep).noise
    assert noise.white_sd == pytest.approx(0.4, rel=0.03)
    assert noise.drift_sd == pytest.approx(0.03, rel=0.35)
    assert 0.2 / 1.6 < noise.drift_time < 0.2 * 1.6


def test_the_standard_error_grows_with_the_drift_given():
    # The same trial and estimate; a drift in the noise model adds its variance, which the
    # window's least squares cannot see: a drift slow enough to be a constant d over the
    # trial moves the estimate sum(alpha d) / sum(alpha^2), exactly that.
    trial = simulate_trial(inertia=0.25, gravity_moment=2.2, speed_deg_s=180.0, rng=3)
    gravity = GravityFit(2.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1000, 1000.0, 1.5, 0.02)
    white = estimate_inertia(trial, gravity, noise=TorqueNoise(0.4), lag=0.0)
    slow = estimate_inertia(trial, gravity, noise=TorqueNoise(0.4, 0.1, 1000.0), lag=0.0)
    assert slow.inertia == white.inertia
    time = trial["time"].values
    alpha = slow.acceleration[(time >= slow.window_start) & (time <= slow.window_end)]
    assert alpha.size == slow.n_window
    shift = 0.1 * alpha.sum() / (alpha @ alpha)
    assert slow.inertia_se**2 - white.inertia_se**2 == pytest.approx(shift**2, rel=1e-3)
    # computed from the white level alone, 0.4 N m through the filter: the SE of a mean
    # over the window's ~4 independent stretches (a 20 Hz filter over 93 ms), ~0.04 N m
    assert 0.02 < white.inertia_se * (alpha @ alpha) / alpha.sum() < 0.06


def test_the_weights_through_the_filter_are_exact_inside_the_trial():
    # The SE is the white level times the norm of the weights the estimate puts on the raw
    # torque, F' laid (laid: the window's least-squares weights on the filtered torque).
    # The code filters them (F laid, F' = F inside the trial); against F' built sample by
    # sample, the SE agrees to 1e-6.
    from inertiafit.processing.filtering import lowpass_rows

    trial = simulate_trial(
        inertia=0.25,
        gravity_moment=2.2,
        speed_deg_s=240.0,
        rng=4,
        noise=Noise(velocity_sd=0.0, ripple=0.0),
    )
    gravity = GravityFit(2.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1000, 1000.0, 1.5, 0.02)
    est = estimate_inertia(trial, gravity, noise=TorqueNoise(0.4), lag=0.0)
    time = trial["time"].values
    inside = (time >= est.window_start) & (time <= est.window_end)
    alpha = est.acceleration[inside]
    laid = np.where(inside, 0.0, 0.0)
    laid[inside] = alpha / (alpha @ alpha)
    rate = 1.0 / (time[1] - time[0])
    f_transposed = lowpass_rows(np.eye(time.size), rate)  # row j: F e_j, column j of F
    exact = 0.4 * np.linalg.norm(f_transposed @ laid)
    assert est.inertia_se == pytest.approx(exact, rel=1e-6)
