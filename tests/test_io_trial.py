import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.io.trial import MIN_SAMPLES, make_trial


def channels(n=50, rate=1000.0, start=0.25):
    t = start + np.arange(n) / rate
    return t, 0.1 * t, np.full(n, 0.1), 2.0 + t


def test_trial_contract():
    t, a, v, m = channels()
    trial = make_trial(t, a, v, m, source="data/A_240_01.csv", format="csv")
    assert list(trial.data_vars) == ["angle", "velocity", "torque"]
    assert trial.time.dtype == np.float64
    assert trial.time.attrs["units"] == "s"
    assert float(trial.time[0]) == 0.25  # starts wherever the file starts
    assert {k: trial[k].attrs["units"] for k in trial.data_vars} == {
        "angle": "rad",
        "velocity": "rad/s",
        "torque": "N m",
    }
    for name in trial.data_vars:
        assert trial[name].dtype == np.float64
        assert trial[name].dims == ("time",)
    assert trial.attrs["source"] == "data/A_240_01.csv"
    assert trial.attrs["format"] == "csv"
    assert trial.attrs["sampling_rate"] == 1000.0
    np.testing.assert_array_equal(trial.torque.values, m)


def test_sampling_rate_from_median_step_ignores_jitter():
    t, a, v, m = channels(n=21, rate=100.0)
    t[5] += 0.002  # one late sample: the median step is still 10 ms
    trial = make_trial(t, a, v, m, source="x")
    assert trial.attrs["sampling_rate"] == 100.0


def test_extra_attrs_are_kept():
    trial = make_trial(*channels(), source="x", format="biodex", attrs={"angle_column": "POS"})
    assert trial.attrs["angle_column"] == "POS"
    assert trial.attrs["format"] == "biodex"


def test_nan_names_file_column_and_first_bad_line():
    t, a, v, m = channels()
    m[7] = np.nan
    m[9] = np.nan
    lines = np.arange(t.size) + 2
    with pytest.raises(
        InputError,
        match=r"^A\.csv: column 'tau' has a missing or non-finite value \(nan\) at line 9 "
        r"\(and 1 more\)",
    ):
        make_trial(t, a, v, m, source="A.csv", columns={"torque": "tau"}, lines=lines)


def test_infinity_is_rejected_with_sample_number_when_lines_unknown():
    t, a, v, m = channels()
    a[0] = np.inf
    with pytest.raises(InputError, match=r"^B\.csv: column 'angle' .*\(inf\) at sample 1;"):
        make_trial(t, a, v, m, source="B.csv")


def test_time_not_increasing_names_the_row():
    t, a, v, m = channels()
    t[12] = t[11]
    with pytest.raises(
        InputError, match=r"^C\.csv: column 'time' does not increase at sample 13 "
    ):
        make_trial(t, a, v, m, source="C.csv")


def test_gap_names_the_time():
    t, a, v, m = channels(n=40, rate=100.0, start=0.0)
    t[20:] += 0.03  # three samples lost after t = 0.19 s
    with pytest.raises(
        InputError,
        match=r"^D\.csv: gap in column 'time' at sample 21: 0\.04 s between t = 0\.19 s and "
        r"t = 0\.23 s, more than 1\.5 x the median step 0\.01 s",
    ):
        make_trial(t, a, v, m, source="D.csv")


def test_too_short():
    t, a, v, m = channels(n=MIN_SAMPLES - 1)
    with pytest.raises(InputError, match=r"^E\.csv: only 9 samples; a trial needs at least 10"):
        make_trial(t, a, v, m, source="E.csv")


def test_channel_length_mismatch():
    t, a, v, m = channels()
    with pytest.raises(InputError, match=r"^F\.csv: column 'velocity' has 49 values but 'time'"):
        make_trial(t, a, v[:-1], m, source="F.csv")


def test_two_dimensional_channel():
    t, a, v, m = channels()
    with pytest.raises(InputError, match=r"column 'angle' must be one-dimensional"):
        make_trial(t, np.c_[a, a], v, m, source="G.csv")
