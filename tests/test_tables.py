import pandas as pd

from inertiafit.report.tables import (
    comparison_display,
    fmt,
    summary_display,
    to_latex,
    to_markdown,
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
    assert "2.8867123" in paths[0].read_text()
    assert "2.887" in paths[1].read_text()


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
