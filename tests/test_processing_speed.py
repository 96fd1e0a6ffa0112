"""Speed effect: per-speed summaries, one-way ANOVA and Tukey HSD."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from inertiafit.processing import speed_effect
from inertiafit.processing.speed import COLUMNS

SMALL = {"A": {240.0: [1.0, 2.0, 3.0], 270.0: [2.0, 3.0, 4.0], 300.0: [5.0, 6.0, 7.0]}}


def test_anova_matches_the_hand_computation():
    table = speed_effect(SMALL)
    assert list(table.columns) == list(COLUMNS)
    rows = table[table["row"] == "speed"]
    assert rows["n"].tolist() == [3, 3, 3]
    assert rows["mean"].tolist() == [2.0, 3.0, 6.0]
    assert rows["sd"].tolist() == [1.0, 1.0, 1.0]
    # Grand mean 11/3; SS_between = 3 (25/9 + 4/9 + 49/9) = 26 on 2 df; SS_within = 6 on 6 df.
    # F = 13 / 1; for F(2, d2) the tail is (1 + 2F/d2)^(-d2/2) = (16/3)^-3 = 27/4096.
    assert rows["F"].iloc[0] == pytest.approx(13.0)
    assert rows["p"].iloc[0] == pytest.approx(27 / 4096)


def test_tukey_pairs():
    pairs = speed_effect(SMALL).query("row == 'pair'").reset_index(drop=True)
    assert pairs[["speed", "speed_b"]].to_numpy().tolist() == [
        [240.0, 270.0],
        [240.0, 300.0],
        [270.0, 300.0],
    ]
    assert pairs["mean_difference"].tolist() == pytest.approx([-1.0, -4.0, -3.0])
    assert (pairs["ci_lower"] < pairs["mean_difference"]).all()
    assert (pairs["mean_difference"] < pairs["ci_upper"]).all()
    # The CIs are symmetric, of half-width q(0.95; 3, 6) sqrt(MSE / n) = 4.339 sqrt(1/3).
    half = (pairs["ci_upper"] - pairs["ci_lower"]) / 2
    assert half.tolist() == pytest.approx([4.339 / np.sqrt(3)] * 3, rel=1e-3)
    assert pairs["p_tukey"].iloc[0] > 0.05
    assert pairs["p_tukey"].iloc[1] < 0.05
    assert pairs["n"].isna().all()


def test_equal_means_at_three_speeds_are_not_significant_like_the_paper():
    # Section 3.1: 0.216 +- 0.017, 0.215 +- 0.016, 0.216 +- 0.017 kg m^2, ten trials each.
    rng = np.random.default_rng(31)
    rows = []
    for condition, (mean, sd) in {"A": (0.216, 0.017), "B": (0.823, 0.055)}.items():
        for speed in (240, 270, 300):
            rows += [
                {"condition": condition, "speed": speed, "inertia": v}
                for v in rng.normal(mean, sd, 10)
            ]
        rows.append({"condition": condition, "speed": np.nan, "inertia": np.nan})  # quasi
    table = speed_effect(pd.DataFrame(rows))
    assert len(table) == 2 * (3 + 3)
    speeds = table[table["row"] == "speed"]
    assert (speeds["n"] == 10).all()
    assert (speeds["p"] > 0.05).all()
    assert (table.query("row == 'pair'")["p_tukey"] > 0.05).all()


def test_a_real_speed_effect_is_found():
    rng = np.random.default_rng(3)
    data = {"A": {s: rng.normal(0.2 + 0.0005 * (s - 240), 0.005, 10) for s in (240, 270, 300)}}
    table = speed_effect(data)
    assert table["p"].iloc[0] < 1e-6
    pair = table.query("row == 'pair' and speed == 240 and speed_b == 300")
    assert pair["p_tukey"].iloc[0] < 0.001
    assert pair["mean_difference"].iloc[0] == pytest.approx(-0.03, abs=0.01)


def test_untestable_groups_give_nan_and_no_pairs():
    table = speed_effect(
        {"A": {240.0: [0.2, 0.21, 0.22]}, "B": {240.0: [0.8], 300.0: [0.8, 0.81]}}
    )
    assert table["row"].tolist() == ["speed", "speed", "speed"]
    assert table["F"].isna().all()
    assert np.isnan(table["sd"].iloc[1])


def test_a_table_without_the_columns_is_refused():
    with pytest.raises(KeyError, match="speed"):
        speed_effect(pd.DataFrame({"condition": ["A"], "inertia": [0.2]}))


def test_frame_mean_column_can_be_analysed():
    frame = pd.DataFrame(
        {
            "condition": ["A"] * 4,
            "speed": [240, 240, 300, 300],
            "inertia_frame_mean": [0.2, 0.21, 0.2, 0.22],
        }
    )
    table = speed_effect(frame, value="inertia_frame_mean")
    assert table.query("row == 'speed'")["mean"].tolist() == pytest.approx([0.205, 0.21])


@pytest.mark.parametrize("sizes", [(10, 10, 10), (4, 7, 5, 9), (2, 3)])
def test_tukey_pairs_are_scipys_tukey_hsd_numbers(sizes):
    # The pairs-only computation must give scipy.stats.tukey_hsd's numbers exactly.
    from scipy import stats

    from inertiafit.processing.speed import tukey_pairs

    rng = np.random.default_rng(len(sizes))
    samples = [rng.normal(0.2 + 0.01 * i, 0.02, n) for i, n in enumerate(sizes)]
    for confidence in (0.95, 0.9):
        ref = stats.tukey_hsd(*samples)
        ci = ref.confidence_interval(confidence_level=confidence)
        pairs, diffs, pvals, radii = tukey_pairs(samples, confidence)
        assert len(pairs) == len(sizes) * (len(sizes) - 1) // 2
        for (i, j), d, p, r in zip(pairs, diffs, pvals, radii, strict=True):
            assert d == ref.statistic[i, j]
            assert p == ref.pvalue[i, j]
            assert (d - r, d + r) == (ci.low[i, j], ci.high[i, j])
