import pandas as pd

from inertiafit.report.tables import (
    comparison_display,
    fmt,
    summary_display,
    to_latex,
    to_markdown,
    trial_tables,
    tukey_display,
    write_table,
)

FRAME = pd.DataFrame(
    {"body": ["arm_1", "disk"], "mass [kg]": [2.8867123, float("nan")], "n": [30, 10]}
)


def test_numbers_have_four_significant_figures_and_nan_is_blank():
    assert fmt(2.8867123) == "2.887"
    assert fmt(0.000123456) == "0.0001235"
    assert fmt(float("nan")) == ""
    assert fmt(True) == "yes"


def test_markdown_table():
    md = to_markdown(FRAME)
    lines = md.splitlines()
    assert lines[0] == "| body | mass [kg] | n |"
    assert lines[1] == "|:---|---:|---:|"
    assert lines[2] == "| arm_1 | 2.887 | 30 |"
    assert lines[3] == "| disk |  | 10 |"


def test_latex_table_uses_booktabs_and_escapes():
    tex = to_latex(FRAME, caption="Mass & more: 50% box", label="tab:x")
    assert r"\toprule" in tex
    assert r"\midrule" in tex
    assert r"\bottomrule" in tex
    assert r"\begin{tabular}{lrr}" in tex
    assert r"arm\_1 & 2.887 & 30 \\" in tex
    assert r"\caption{Mass \& more: 50\% box}" in tex
    assert r"\label{tab:x}" in tex


def test_write_table_writes_three_files_and_keeps_full_precision(tmp_path):
    paths = write_table(FRAME, tmp_path, "t")
    assert [p.name for p in paths] == ["t.csv", "t.md", "t.tex"]
    assert "2.8867123" in paths[0].read_text(encoding="utf-8")
    assert "2.887" in paths[1].read_text(encoding="utf-8")


def test_display_frames_format_intervals():
    summary = pd.DataFrame(
        {
            "body": ["d"],
            "parameter": ["mass"],
            "mean": [2.9],
            "sd": [0.05],
            "median": [2.89],
            "hdi_lower": [2.8],
            "hdi_upper": [3.0],
            "hdi_prob": [0.9],
            "ess_bulk": [1234.6],
            "ess_tail": [1000.0],
            "r_hat": [1.0012],
        }
    )
    d = summary_display(summary)
    assert d.loc[0, "median [90% HDI]"] == "2.89 [2.8, 3]"
    assert d.loc[0, "parameter"] == "mass [kg]"
    assert d.loc[0, "ESS bulk"] == 1235
    comp = pd.DataFrame(
        {
            "body": ["d"],
            "parameter": ["mass"],
            "unit": ["kg"],
            "ideal": [2.92],
            "posterior_median": [2.89],
            "hdi_lower": [2.8],
            "hdi_upper": [3.0],
            "baseline": [2.87],
            "posterior_vs_ideal": [-0.0103],
            "baseline_vs_ideal": [float("nan")],
            "ideal_in_hdi": [True],
            "sd_ratio": [0.07],
            "identified_by": ["data"],
        }
    )
    c = comparison_display(comp)
    assert c.loc[0, "posterior vs ideal"] == "-1.0 %"
    assert c.loc[0, "baseline vs ideal"] == ""
    assert c.loc[0, "identified by (post/prior SD)"] == "data (0.07)"


def test_trial_tables_split_by_condition_with_units():
    nan = float("nan")
    trials = pd.DataFrame(
        {
            "file": ["a_qs.csv", "a_240.csv", "b_240.csv", "b_bad.csv"],
            "condition": ["A", "A", "B", "B"],
            "kind": ["quasi-static", "fast", "fast", "fast"],
            "speed": [nan, 240.0, 240.0, 240.0],
            "inertia": [nan, 0.21234, 0.8, nan],
            "inertia_se": [nan, 0.0012, 0.002, nan],
            "gravity_moment": [6.69, nan, nan, nan],
            "gravity_moment_se": [0.022, nan, nan, nan],
            "window_start": [nan, 0.199, 0.2, nan],
            "window_end": [nan, 0.32, 0.33, nan],
            "lag": [nan, 0.0002, -0.0001, nan],
            "lag_se": [nan, 0.00014, 0.0001, nan],
            "flags": ["", "", "", "skipped: unreadable"],
            "status": ["ok", "ok", "ok", "skipped"],
        }
    )
    tables = dict(trial_tables(trials))
    assert list(tables) == ["A: quasi-static trials", "A: fast trials", "B: fast trials"]
    fast = tables["A: fast trials"].iloc[0]
    assert fast["I [kg m²] ± SE"] == "0.2123 ± 0.0012"
    assert fast["window [s]"] == "0.199–0.320"
    assert fast["lag [ms] ± SE"] == "0.2 ± 0.14"
    assert tables["A: quasi-static trials"].iloc[0]["M_g [N m] ± SE"] == "6.69 ± 0.022"
    bad = tables["B: fast trials"].iloc[1]
    assert (bad["I [kg m²] ± SE"], bad["flags"]) == ("", "skipped: unreadable")
    assert "kind" not in tables["A: fast trials"].columns  # one kind per table
    assert "posture" not in tables["A: fast trials"].columns  # only for a living body
    living = dict(trial_tables(trials.assign(posture="p1", damping=0.4, damping_se=0.1)))
    assert living["A: fast trials"].iloc[0]["b [N m s/rad] ± SE"] == "0.4 ± 0.1"


def test_tukey_pairs_are_formatted_not_dumped():
    effect = pd.DataFrame(
        {
            "condition": ["A", "A", "A"],
            "row": ["speed", "speed", "pair"],
            "speed": [240.0, 300.0, 240.0],
            "speed_b": [float("nan"), float("nan"), 300.0],
            "mean_difference": [float("nan"), float("nan"), -0.0042476],
            "p_tukey": [float("nan"), float("nan"), 0.888733],
            "ci_lower": [float("nan"), float("nan"), -0.026961],
            "ci_upper": [float("nan"), float("nan"), 0.0184658],
        }
    )
    pairs = tukey_display(effect)
    assert pairs.to_dict("records") == [
        {
            "condition": "A",
            "speeds [°/s]": "240 vs 300",
            "difference of means [kg m²]": "-0.00425",
            "95% CI [kg m²]": "[-0.027, 0.0185]",
            "p (Tukey HSD)": "0.889",
        }
    ]
