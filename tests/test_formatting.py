"""The one number formatter (formatting.py): each kind of number reads one way everywhere."""

from __future__ import annotations

import math

from inertiafit.formatting import (
    correlation,
    ess,
    interval,
    mean_sd,
    r_hat,
    share,
    tail_probability,
)


def test_a_value_with_its_sd_or_se():
    assert mean_sd(0.15, 0.0018) == "0.15 ± 0.0018"
    assert mean_sd(1.00123, 0.0042, 3) == "1 ± 0.0042"
    assert mean_sd(184.6, 703.4) == "184.6 ± 703"  # a large SD whole, not 7e+02


def test_the_sampler_and_identification_numbers():
    assert (r_hat(1.00349), r_hat(math.nan)) == ("1.003", "")
    assert (ess(1234.4), ess(math.nan)) == ("1234", "")
    assert (share(0.374), share(-0.004), share(math.nan), share(math.inf)) == (
        "0.37",
        "0.00",
        "",
        "",
    )
    assert (correlation(0.934), correlation(-0.1)) == ("+0.93", "-0.10")
    assert [tail_probability(p) for p in (0.0123, 3e-7, math.nan)] == ["0.012", "< 1e-6", ""]
    assert interval(0.123456, 2.5) == "[0.1235, 2.5]"
