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

from inertiafit.processing.filtering import lowpass_rows


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
