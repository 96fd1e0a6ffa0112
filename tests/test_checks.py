"""The validators of ``inertiafit._checks``: one function per rule, one line per failure."""

import math

import numpy as np
import pytest

from inertiafit._checks import (
    SEED_MAX,
    check_finite,
    check_interval,
    check_non_negative,
    check_number,
    check_positive,
    check_probability,
    check_seed,
    check_whole,
)
from inertiafit.errors import InputError


@pytest.mark.parametrize(
    ("call", "value"),
    [
        (lambda: check_number(2.5, "x"), 2.5),
        (lambda: check_number(math.inf, "x"), math.inf),
        (lambda: check_finite(np.float64(0.1), "x"), 0.1),
        (lambda: check_finite(-3, "x", "m"), -3.0),
        (lambda: check_positive(np.int64(2), "x"), 2.0),
        (lambda: check_non_negative(0, "x"), 0.0),
        (lambda: check_interval(500, "w", 0, 500, "kg", upper_closed=True), 500.0),
        (lambda: check_probability(0.9), 0.9),
        (lambda: check_whole(3.0, "n", 2), 3),
        (lambda: check_seed(np.uint32(SEED_MAX)), SEED_MAX),
    ],
)
def test_valid_values_come_back_as_numbers(call, value):
    got = call()
    assert got == value
    assert type(got) is type(value)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: check_number(True, "x"), "x: expected a number, got True"),
        # text is no number, for check_number as for check_finite (issue 35 item 4)
        (lambda: check_number("2.5", "x"), "x: expected a number, got '2.5'"),
        (lambda: check_probability("0.9"), "hdi_prob: expected a number, got '0.9'"),
        (lambda: check_finite("1", "x", "m"), "x: expected a number (m), got '1'"),
        (lambda: check_finite(math.nan, "x"), "x: expected a finite number, got nan"),
        (lambda: check_finite(None, "w", field="a.b"), "w: 'a.b' must be a number, got None"),
        (lambda: check_finite(math.inf, "w", field="a.b"), "w: 'a.b' must be finite, got inf"),
        (lambda: check_positive("0.3", "c", "m"), "c: expected a positive number (m), got '0.3'"),
        (lambda: check_positive(math.inf, "g"), "g: expected a positive finite number, got inf"),
        (
            lambda: check_positive(-240, "speed", "deg/s"),
            "speed: must be positive (deg/s), got -240",
        ),
        (lambda: check_positive(0, "w", field="sd"), "w: 'sd' must be positive, got 0"),
        (lambda: check_non_negative(-1, "x", "m"), "x: must not be negative (m), got -1"),
        (
            lambda: check_interval(725, "w", 0, 500, "kg", field="body_mass", upper_closed=True),
            "w: 'body_mass' must lie in (0, 500] kg, got 725",
        ),
        (
            lambda: check_interval("72", "w", 0, 500, "kg", field="body_mass", upper_closed=True),
            "w: 'body_mass' must be a number in kg, got '72'",
        ),
        (lambda: check_interval(1, "s", 0, 1), "s: expected a number in (0, 1), got 1"),
        (
            lambda: check_probability(math.nan),
            "hdi_prob: expected a probability in (0, 1), got nan",
        ),
        (lambda: check_whole(1.5, "n"), "n: expected a whole number >= 1, got 1.5"),
        (lambda: check_whole(1, "n", 2), "n: expected a whole number >= 2, got 1"),
        (lambda: check_seed(-1), f"seed: expected a whole number from 0 to {SEED_MAX}, got -1"),
        (lambda: check_seed(SEED_MAX + 1), f"seed: expected a whole number from 0 to {SEED_MAX}"),
        (lambda: check_seed(2.0**32), f"seed: expected a whole number from 0 to {SEED_MAX}"),
        (lambda: check_seed("3"), f"seed: expected a whole number from 0 to {SEED_MAX}, got '3'"),
        (lambda: check_seed(True), f"seed: expected a whole number from 0 to {SEED_MAX}"),
    ],
)
def test_invalid_values_are_one_line_naming_where(call, message):
    with pytest.raises(InputError) as info:
        call()
    assert str(info.value).startswith(message), str(info.value)
    assert "\n" not in str(info.value)
