"""One verdict of who decides each quantity (issue 34): every output reads it, seeds agree.

The case: the demo's attachment (its box, I = 0.2042 kg m^2 from 30 trials, M_g = 6.693 N m),
where the old labels disagreed (the SD ratio said ``data + prior`` for m, the prior's share
``prior``) and the share's 0.7 split flipped x between seeds (its share 0.67-0.76). The
verdict's margin keeps it the same for every seed, and identification.csv, the printed table,
the what-pins-what line and the identification figure's title all say it. And advice fits
the body: a living segment is never told to weigh or remount it.
"""

import math
import warnings

import pandas as pd
import pytest
import xarray as xr

from inertiafit.inference.fit import fit_body
from inertiafit.inference.priors import Prior
from inertiafit.physics import PARAMETERS, REPORTED
from inertiafit.posterior import Posterior, pins

DEMO_ATTACHMENT = {
    "inertia": 0.2042,
    "inertia_sd": 0.01985,
    "inertia_n": 30,
    "gravity_moment": 6.693,
    "gravity_moment_se": 0.0222,
}
SEEDS = range(5)


def attachment_prior() -> Prior:
    return Prior.box("attachment", mass=2.91, com_distance=0.225, radius_of_gyration=0.13)


def test_the_rule_names_both_within_its_margin_of_a_split():
    assert pins.verdict(0.24) == "data"
    assert pins.verdict(0.26) == pins.verdict(0.34) == "data + prior"
    assert pins.verdict(0.36) == pins.verdict(0.74) == "data + prior"
    assert pins.verdict(0.76) == "prior"
    # a Monte Carlo SE of 0.03 widens the band to 3 SEs: 0.78 is not clearly past 0.7
    assert pins.verdict(0.78, 0.03) == "data + prior"
    assert pins.verdict(0.80, 0.03) == "prior"
    assert pins.verdict(math.nan) == "data"
    # the sources and the calibration prior's part, from the same verdicts
    assert pins.pinned_by("prior", ["data"]) == "prior"
    assert pins.pinned_by("data + prior", ["data", "weighed mass"]) == (
        "data + weighed mass + prior"
    )
    assert pins.pinned_by("data", ["data"], "prior") == "calibration prior"
    assert pins.pinned_by("data", ["data"], "data + prior") == "data + calibration prior"


def test_batch_means_give_the_monte_carlo_error_of_a_mean():
    import numpy as np

    rng = np.random.default_rng(3)
    draws = rng.standard_normal((32, 8000))  # independent: SE of the mean 1/sqrt(256 000)
    ses = [pins.batch_se(np.mean, [rng.standard_normal((32, 8000))]) for _ in range(40)]
    assert np.mean(ses) == pytest.approx(1 / math.sqrt(draws.size), rel=0.1)
    assert math.isnan(pins.batch_se(np.mean, [draws[:, :10]]))  # fewer than 2 per batch


@pytest.fixture(scope="module")
def runs():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # and no prior-data conflict: the data are the prior's
        return [fit_body(attachment_prior(), seed=s, **DEMO_ATTACHMENT) for s in SEEDS]


def _old_labels(row) -> tuple[str, str]:
    """What the two old labels said: the SD ratio's and the share's plain 0.3/0.7 splits."""

    def split(v):
        return "data" if v < 0.3 else "prior" if v > 0.7 else "data + prior"

    share = row["prior_share"]
    by_share = "prior" if share >= 0.7 else "data + prior" if share > 0.3 else "data"
    return split(row["sd_ratio"]), by_share


@pytest.mark.slow
def test_the_same_data_give_the_same_verdict_for_every_seed(runs):
    tables = [post.identification().set_index("parameter") for post in runs]
    for p in REPORTED:
        said = {(t.loc[p, "identified_by"], t.loc[p, "pinned_by"]) for t in tables}
        assert len(said) == 1, (p, said)
    assert tables[0]["identified_by"].tolist() == ["data + prior"] * 3 + ["data"] * 2
    # negative control: the old labels disagreed with each other and flipped between seeds
    old = {p: [_old_labels(t.loc[p]) for t in tables] for p in PARAMETERS}
    assert {by_share for _, by_share in old["com_distance"]} == {"data + prior", "prior"}
    assert all(by_ratio != by_share for by_ratio, by_share in old["mass"])
    # the margin holds them: every ratio is more than 3 of its SEs inside the band
    for t in tables:
        rows = t.loc[list(PARAMETERS)]
        inside = (rows["sd_ratio"] + 3 * rows["sd_ratio_se"] < 0.75) & (rows["sd_ratio"] > 0.35)
        assert inside.all()


def _printed_verdicts(text: str) -> dict[str, str]:
    """The printed table's 'identified by' column: parameter -> verdict."""
    out = {}
    for line in text.splitlines():
        for p in REPORTED:
            if line.startswith("attachment") and f" {p} [" in line:
                out[p] = line.rsplit(" (", 1)[0].split("  ")[-1].strip()
    return out


def test_identification_csv_text_and_figure_titles_agree(tmp_path, capsys, no_figures):
    from inertiafit.cli import main
    from inertiafit.posterior import open_posterior
    from inertiafit.report.plots import plot_identification_curve
    from inertiafit.report.plots.identification import curve_verdict

    prior = tmp_path / "attachment.toml"
    prior.write_text(
        'name = "attachment"\nmass = 2.91\ncom_distance = 0.225\nradius_of_gyration = 0.13\n',
        encoding="utf-8",
    )
    args = ["fit", "--prior", str(prior), "--inertia", "0.2042", "--inertia-sd", "0.01985"]
    args += ["--inertia-n", "30", "--gravity-moment", "6.693", "--gravity-moment-se", "0.0222"]
    out = tmp_path / "out"
    assert main([*args, "--out", str(out), "--seed", "1"]) == 0
    printed = capsys.readouterr().out
    csv = pd.read_csv(out / "identification.csv").set_index("parameter")
    # the printed table's column
    assert _printed_verdicts(printed) == csv["identified_by"].to_dict()
    # pinned_by is the same verdict with its sources
    for p in REPORTED:
        who, pinned = csv.loc[p, "identified_by"], csv.loc[p, "pinned_by"]
        assert pinned == {"data": "data", "data + prior": "data + prior", "prior": "prior"}[who]
    # the what-pins-what line groups the parameters by it
    assert "attachment: m, x and rho by the data and the prior together" in printed
    assert "I and M_g pinned by the data" in printed
    # the figure's title says it too
    post = open_posterior(out / "posterior.nc")
    title = plot_identification_curve(post, "attachment")._suptitle.get_text()
    assert title.endswith("on the curve, data and prior box together set $m$, $x$ and $\\rho$")
    assert curve_verdict(post, "attachment") in title
    pd.testing.assert_series_equal(
        post.identification().set_index("parameter")["identified_by"], csv["identified_by"]
    )


# -- advice fits the body ----------------------------------------------------------------------
def _with_living(post: Posterior, body: str) -> Posterior:
    """The posterior with a study's ``living`` group naming ``body`` as its living body."""
    tree = post.tree.copy()
    tree["living/parameters"] = xr.DataTree(
        xr.Dataset({"body": ("row", [body]), "parameter": ("row", ["stiffness"])})
    )
    return Posterior(tree)


def test_a_living_segment_is_not_told_to_weigh_it():
    post = fit_body(attachment_prior(), seed=0, **DEMO_ATTACHMENT)
    rigid = post.what_pins_what()["attachment"]
    assert "weigh it, find its balance point or mount it at a second distance" in rigid
    assert pins.living_bodies(post.tree) == set()
    living = _with_living(post, "attachment")
    assert pins.living_bodies(living.tree) == {"attachment"}
    line = living.what_pins_what()["attachment"]
    assert "weigh it" not in line
    assert "balance point" not in line
    assert "second distance" not in line
    assert "a living segment can be neither weighed nor remounted" in line
    # the rest of the line is the rigid body's
    assert line.split(" - ")[0] == rigid.split(" - ")[0]


def test_the_example_design_file_weighs_only_what_can_be_weighed(tmp_path):
    from pathlib import Path

    from inertiafit.errors import InputError
    from inertiafit.planning.files import load_plan_file

    example = Path(__file__).resolve().parents[1] / "examples" / "plan-session.toml"
    text = example.read_text(encoding="utf-8")
    kwargs = load_plan_file(example)
    weighed = {b for d in kwargs["designs"] for b in d.weighed}
    moved = {m.offset_body for d in kwargs["designs"] for m in d.mountings if m.offset_body}
    assert weighed == moved == {"forearm"}
    assert not any(d.living for d in kwargs["designs"])  # the segment it weighs is not living
    assert "phantom" in text.split("[bodies.forearm]")[1].split("\n")[0]
    # the same file with the forearm marked living: the planner refuses to weigh it
    living = text.replace("[bodies.forearm]", "[bodies.forearm]\nliving = true", 1)
    living += '\n[passive]\njoint = "elbow"\njoint_angle_at_zero = 30\n'
    copy = tmp_path / "living.toml"
    copy.write_text(living, encoding="utf-8")
    with pytest.raises(InputError, match="'forearm' is living: it cannot be weighed"):
        load_plan_file(copy)
