"""The per-trial inertia has no processing bias worth the name, at 1 kHz and at 100 Hz.

The gravity model is the true one (built from the simulated ``M_g``, ``phi`` and offset) and
no lag is removed, so only the fast trial's processing is measured: filter, derivative,
window, least squares. Without noise the simulated torque is exactly ``I alpha + G(theta)``;
the ramp's corners fall anywhere between two samples (a random sub-sample start).
``docs/processing.md`` ("Processing bias") has the measured table with the default noise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import inertiafit.processing.filtering as filtering_module
from inertiafit.processing.filtering import derivative, lowpass_array
from inertiafit.processing.gravity import GravityFit
from inertiafit.processing.inertia import estimate_inertia
from inertiafit.simulate import PAPER_TRUTH, Motion, Noise, simulate_trial

ATTACHMENT = PAPER_TRUTH["attachment"]
INERTIA, MOMENT, PHI, OFFSET = ATTACHMENT.inertia, ATTACHMENT.gravity_moment(), 0.2, 1.5
TRUE_GRAVITY = GravityFit(MOMENT, 0.0, PHI, 0.0, OFFSET, 0.0, 0.0, 1, 1.0, math.pi / 2, 0.0)


def relative_errors(rate, trials_per_speed):
    errors = []
    for speed in (240, 270, 300):
        for k in range(trials_per_speed):
            rng = np.random.default_rng([k, speed, int(rate)])
            trial = simulate_trial(
                inertia=INERTIA,
                gravity_moment=MOMENT,
                phi=PHI,
                offset=OFFSET,
                speed_deg_s=speed,
                rng=rng,
                rate=rate,
                noise=Noise.none(),
                motion=Motion(rest=0.2 + rng.uniform(0.0, 1.0) / rate),
                sampling="average" if rate < 1000 else "instant",
            )
            errors.append(estimate_inertia(trial, TRUE_GRAVITY, lag=0.0).inertia / INERTIA - 1)
    return np.array(errors)


def test_noise_free_inertia_is_unbiased_at_1_khz_and_at_100_hz():
    fine = relative_errors(1000.0, 3)
    assert abs(fine.mean()) < 0.0002  # measured +0.002 %; the target is 0.05 %
    coarse = relative_errors(100.0, 12)
    # at 100 Hz the error of one trial depends on where the corners fall between samples
    # (SD 0.25 %); the mean over 36 positions is within 0.1 % (measured +0.04 %)
    assert abs(coarse.mean()) < 0.001
    assert coarse.std() < 0.006


def test_a_central_difference_puts_a_bias_of_about_one_percent_into_100_hz_trials(monkeypatch):
    # negative control: the acceleration as numpy.gradient of the filtered velocity averages
    # the derivative over two sample periods, which the torque is not
    def with_gradient(velocity_f, step):
        return np.gradient(velocity_f, step)

    monkeypatch.setattr(filtering_module, "spectral_derivative", with_gradient)
    coarse = relative_errors(100.0, 4)
    assert coarse.mean() > 0.006  # measured +0.92 %


def test_spectral_derivative_is_exact_in_the_pass_band_where_the_central_difference_is_not():
    rate = 100.0
    t = np.arange(400) / rate
    for f in (2.0, 10.0, 20.0):
        w = 2 * math.pi * f
        x = np.sin(w * t)
        core = slice(50, 350)
        assert np.allclose(derivative(x, t)[core], w * np.cos(w * t)[core], atol=1e-3 * w)
        # numpy.gradient multiplies the frequency by sin(w dt) / (w dt): 0.76 at 20 Hz
        gain = np.max(np.abs(np.gradient(x, t)[core])) / w
        assert gain == pytest.approx(math.sin(w / rate) / (w / rate), rel=1e-3)
    # a low-passed ramp that does not end at rest: no ringing from the ends
    v = lowpass_array(np.clip(t - 1.0, 0.0, None) * 3.0, rate)
    a = derivative(v, t)
    assert a[-50:] == pytest.approx(3.0, rel=1e-3)
    assert a[:50] == pytest.approx(0.0, abs=1e-3)
    # uneven samples: numpy.gradient on the times
    uneven = t + 0.002 * np.sin(t)
    assert np.array_equal(derivative(v, uneven), np.gradient(v, uneven))
