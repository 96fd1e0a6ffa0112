"""The processing's faster paths give the numbers of the plain library calls they replace.

Each fast path does the same arithmetic with its set-up done once (a filter's steady state per
design, a sampling step per trial); these tests hold them to the plain call to the last bit on
this machine (the same process, the same NumPy kernels), so a change that moves a number is
seen here and not as a shifted digit in a study's tables.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from inertiafit.processing.filtering import (
    derivative,
    even_step,
    lowpass_rows,
    spectral_derivative,
)


@pytest.mark.parametrize("shape", [(400,), (4, 900), (2, 1500), (3, 2, 300)])
@pytest.mark.parametrize(("rate", "cutoff", "order"), [(1000.0, 20.0, 2), (100.0, 10.0, 4)])
def test_lowpass_rows_is_sosfiltfilt_to_the_bit(shape, rate, cutoff, order):
    x = np.random.default_rng(3).normal(size=shape).cumsum(axis=-1)
    sos = signal.butter(order, cutoff, btype="low", fs=rate, output="sos")
    padlen = 3 * (2 * len(sos) + 1)
    expected = signal.sosfiltfilt(sos, x, axis=-1, padlen=padlen)
    got = lowpass_rows(x, rate, cutoff=cutoff, order=order)
    assert np.array_equal(got, expected)
    # the same layout too (a reversed view): a product over it takes the same BLAS path
    assert got.strides == expected.strides


def test_derivative_is_spectral_on_even_steps_and_gradient_otherwise():
    t = 0.25 + 1e-3 * np.arange(600)
    x = np.sin(2 * np.pi * 3.0 * t) + 0.1 * t
    step = even_step(t)
    assert step == float(np.median(np.diff(t)))
    assert np.array_equal(spectral_derivative(x, step), derivative(x, t))
    # spectral: near exact away from the ends, where a central difference is off by
    # (2 pi f dt)^2 / 6 of the slope (1e-3 here)
    inner = slice(100, 500)
    exact = 2 * np.pi * 3.0 * np.cos(2 * np.pi * 3.0 * t) + 0.1
    assert np.max(np.abs(derivative(x, t)[inner] - exact[inner])) < 1e-5
    assert np.max(np.abs(np.gradient(x, t)[inner] - exact[inner])) > 5e-4
    uneven = t.copy()
    uneven[300:] += 0.5e-3  # one step 50 % long
    assert even_step(uneven) is None
    assert np.array_equal(derivative(x, uneven), np.gradient(x, uneven))
    assert even_step(t[:3]) is None
