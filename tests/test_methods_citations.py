"""Every work cited by key where it is used, every entry complete, the living terms described.

Three results: the rigid study of conftest's ``study_out``, a body fitted from numbers with
de Leva's prior, and a living knee (two postures, rest holds, EMG, a de Leva prior) simulated
inside its own output folder while it is staged, as ``inertiafit demo`` does: the same run
shows that no output names the staging folder.
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from inertiafit.inference.fit import fit_body
from inertiafit.inference.priors import anthropometric_prior, load_prior
from inertiafit.io.outputs import output_folder
from inertiafit.io.shipped import load_passive_prior
from inertiafit.pipeline.fit import fit_result
from inertiafit.pipeline.study import analyse_study
from inertiafit.report import outputs as outputs_module
from inertiafit.report.figures import figure_records
from inertiafit.report.methods import methods_html, methods_markdown, references_of
from inertiafit.report.references import REFERENCES, bibtex, citations, cite
from inertiafit.simulate import simulate_living_study
from inertiafit.simulate.emg import EmgSimulation

DE_LEVA = {
    "anthropometric": "de-leva-male",
    "segment": "forearm+hand",
    "body_mass": 72.5,
    "segment_length": 0.27,
}
#: The fields every entry has; the method paper's copy states no year (its note says so).
REQUIRED = ("author", "title", "year")


def bib_entries(text: str) -> dict[str, dict[str, str]]:
    """``references.bib`` as ``{key: {field: value}}`` (one field per line, as written)."""
    out = {}
    for key, body in re.findall(
        r"^@\w+\{([^,\n]+),\n(.*?)\n\}", text, flags=re.MULTILINE | re.DOTALL
    ):
        out[key] = dict(re.findall(r"^\s+(\w+)\s*=\s*\{(.*)\},?$", body, flags=re.MULTILINE))
    return out


def body_citations(md: str) -> set[str]:
    """Keys cited in the text of methods.md, its reference list left out."""
    text = md[: md.index("## References")]
    return {
        k for group in re.findall(r"\[(@[^\]]+)\]", text) for k in re.findall(r"@(\w+)", group)
    }


def check_cited_both_ways(md: str, bib: str) -> dict[str, dict[str, str]]:
    entries = bib_entries(bib)
    assert entries, "references.bib has no entries"
    assert body_citations(md) == set(entries)
    for key, fields in entries.items():
        missing = [f for f in REQUIRED if not fields.get(f)]
        if key == "son_dynamometer":  # the copy it was built from gives no year or venue
            assert missing == ["year"]
            assert "states no journal, volume, year" in fields["note"]
        else:
            assert missing == [], (key, missing)
    return entries


@pytest.fixture(scope="module")
def living_staged(tmp_path_factory):
    """A living knee simulated inside the output folder while it is staged, analysed and
    written there (the living fast trials' figure only): ``(out, result, staging name)``."""
    out = tmp_path_factory.mktemp("staged") / "out"
    seen = {}
    every = figure_records
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(
            outputs_module,
            "figure_records",
            lambda res: [r for r in every(res) if r.stem == "fast-trials-attachment+forearm"],
        )
        with output_folder(out) as folder:
            seen["staging"] = folder.name
            manifest = simulate_living_study(
                folder / "study",
                seed=3,
                joint="knee",
                postures="two",
                trials_per_speed=1,
                rate=500.0,
                quasi_static_speed=5.0,
                emg=EmgSimulation(),
                priors={"forearm": DE_LEVA},
            )
            result = analyse_study(manifest, seed=1, hdi_prob=0.95, echo=lambda _: None)
            outputs_module.write_outputs(folder, result)
    return out, result, seen["staging"]


# -- references.bib and the citations of methods.md ---------------------------------------


def test_every_shipped_entry_is_complete_where_the_facts_are_known():
    for key, ref in REFERENCES.items():
        missing = [f for f in REQUIRED if not ref.fields.get(f)]
        assert missing == ([] if key != "son_dynamometer" else ["year"]), key
        venue = {
            "article": ("journal", "volume", "pages"),
            "book": ("publisher",),
            "techreport": ("institution", "number"),
            "phdthesis": ("school",),
        }[ref.kind]
        if key != "son_dynamometer":
            assert set(venue) <= set(ref.fields), key


def test_a_rigid_study_cites_what_its_bib_holds(study_out):
    md = (study_out / "methods.md").read_text(encoding="utf-8")
    bib = (study_out / "references.bib").read_text(encoding="utf-8")
    assert set(check_cited_both_ways(md, bib)) == {
        "son_dynamometer",
        "foreman_mackey_emcee_2013",
        "kumar_arviz_2019",
        "vehtari_rhat_2021",
        "foreman_mackey_corner_2016",
    }
    assert "## Living joint" not in md


def test_a_de_leva_prior_is_cited_where_its_source_is_quoted(tmp_path):
    prior = load_prior("disk-3kg")
    post = fit_body(
        prior, inertia=0.594, inertia_se=0.0105, gravity_moment=12.8, gravity_moment_se=0.05
    )
    disk = fit_result(post, prior, inertia=0.594, gravity_moment=12.8, gravity=9.81, hdi_prob=0.95)
    leva = anthropometric_prior("de-leva-male", "forearm", 70, 0.27)
    result = dataclasses.replace(disk, priors={"disk-3kg": leva})
    md = methods_markdown(result)
    entries = check_cited_both_ways(md, bibtex(references_of(result)))
    # the table and the three studies guiding its spread, cited on the line that quotes them
    (source,) = [line for line in md.splitlines() if line.startswith("Source: de Leva P.")]
    assert source.endswith("[@de_leva_1996; @durkin_dowling_2003; @rossi_2013; @merrill_2019].")
    assert entries["merrill_2019"]["doi"] == "10.1016/j.jbiomech.2019.109349"
    assert entries["durkin_dowling_2003"]["doi"] == "10.1115/1.1590359"
    # the page shows a citation of several works as one, and no Pandoc key
    page = methods_html(result, lambda frame: "<table></table>")
    assert "(de Leva (1996); Durkin &amp; Dowling (2003); Rossi et al. (2013); Merrill et al." in (
        page
    )
    assert "[@" not in page


def test_a_citation_of_an_unknown_work_fails_where_it_is_written():
    assert cite(["de_leva_1996", "de_leva_1996"]) == "[@de_leva_1996]"
    assert cite([]) == ""
    with pytest.raises(KeyError, match="de_leva_1997"):
        cite(["de_leva_1996", "de_leva_1997"])
    assert citations("knee stops (Anderson 1999 coefficients), Riener & Edrich 1999") == [
        "riener_edrich_1999",
        "anderson_1999",
    ]


def test_a_living_study_cites_every_source_of_its_joint(living_staged):
    out, _, _ = living_staged
    md = (out / "methods.md").read_text(encoding="utf-8")
    bib = (out / "references.bib").read_text(encoding="utf-8")
    entries = check_cited_both_ways(md, bib)
    assert {
        "de_leva_1996",
        "riener_edrich_1999",  # the knee's literature curve
        "anderson_1999",  # the size of its end stops
        "solin_sarkka_2020",  # the Gaussian process' basis
        "riutort_mayol_2023",  # its number of functions
        "hermens_2000",  # the EMG check
        "hodges_bui_1996",
    } <= set(entries)


def test_the_living_text_names_each_term_its_prior_and_its_source(living_staged):
    out, result, _ = living_staged
    md = (out / "methods.md").read_text(encoding="utf-8")
    living = md[md.index("## Living joint") : md.index("## Priors")]
    paras = [p for p in living.split("\n\n")[1:] if p.strip()]
    knee = load_passive_prior("knee")

    def para(start: str) -> str:
        (found,) = [p for p in paras if p.startswith(start)]
        return found

    model = paras[0]
    assert "tau = I alpha + M_g sin(theta + phi + r_p) + c + P(theta_j) + b omega" in model
    assert "theta_j = theta + 30°" in model
    # P: a nonparametric prior around the literature mean curve, each part with its source
    p = para("Passive elastic moment P(theta_j): a nonparametric prior, a Gaussian process")
    assert "Riener & Edrich's passive knee moment [@riener_edrich_1999]" in p
    mean, sd = knee["curve_scale"]["value"]
    assert f"s ~ N({mean:.3g}, {sd:.3g}) ({knee['curve_scale']['source']}" in p
    mean, sd = knee["stiffness"]["value"]
    assert f"k ~ N({mean:.3g}, {sd:.3g}) N m/rad ({knee['stiffness']['source']}" in p
    assert f"{knee['stop_moment']['source']} [@anderson_1999])" in p
    # the simulated manifest declares the range and the stops' width: said so
    assert "range ends 30° and 120° (set in the study's manifest ([passive]))" in p
    assert "[@solin_sarkka_2020]" in p
    assert "[@riutort_mayol_2023]" in p
    n = sum(
        str(c).startswith("smooth:")
        for c in result.posterior.tree["living/fit"]["coefficient"].values
    )
    assert f"approximated by {n} sine eigenfunctions" in p
    # h, b, r_p: each with its prior and its source
    mean, sd = knee["hysteresis"]["value"]
    assert f"h ~ N({mean:.3g}, {sd:.3g}) N m ({knee['hysteresis']['source']})" in para(
        "Hysteresis h sgn(omega)"
    )
    damping = para("Viscous damping b omega")
    mean, sd = knee["damping"]["value"]
    assert f"b ~ N({mean:.3g}, {sd:.3g}) N m s/rad ({knee['damping']['source']})" in damping
    assert "uniform-deceleration window" in damping
    fitted = result.living["passive_parameters"].set_index("parameter").loc["damping"]
    assert f"b = {fitted['mean']:.3g} ± {fitted['sd']:.2g} N m s/rad" in damping
    postures = para("Postures:")
    assert "'upright' (nominal 0°, the reference)" in postures
    assert "'rotated' (nominal 45°, prior SD 2° per posture, fitted " in postures
    assert "told from the passive curve by a second posture" in living
    holds = int((result.trials["kind"] == "rest").sum())
    assert holds > 0
    assert f"and {holds} rest holds (quiet holds" in living
    # the EMG check names its muscles and its sources
    assert "Surface EMG of biceps and triceps" in md
    assert "[@hermens_2000]" in md
    assert "[@hodges_bui_1996]" in md


# -- no staging path in any output ---------------------------------------------------------


def test_no_output_names_the_staging_folder(living_staged, study_out):
    out, _, staging = living_staged
    assert staging.startswith(".out.new-")
    files = [p for p in out.rglob("*") if p.is_file()]
    assert {"methods.md", "report.html", "posterior.nc", "trials.csv", "summary.csv"} <= {
        p.name for p in files
    }
    for path in files:
        assert staging.encode() not in path.read_bytes(), path
    # netCDF strings as the file holds them, whatever their compression
    tree = xr.open_datatree(out / "posterior.nc")
    texts = [str(v) for node in tree.subtree for v in node.attrs.values()]
    assert texts
    assert not any(staging in t for t in texts)
    provenance = json.loads(tree.attrs["provenance"])
    manifest = Path(provenance["manifest"]["path"])
    assert manifest == out.resolve() / "study" / "study.toml"
    assert manifest.is_file()  # the path written is where the study is now
    assert all(Path(t["path"]).is_file() for t in provenance["trials"])
    assert str(out.resolve() / "study" / "study.toml") in (out / "report.html").read_text(
        encoding="utf-8"
    )
    # `run` on a study outside its output folder: no staging folder either
    for path in (p for p in study_out.rglob("*") if p.is_file()):
        assert b".out.new-" not in path.read_bytes(), path


def test_a_living_fast_trial_figure_shades_the_deceleration_window_it_used(living_staged):
    from PIL import Image

    from inertiafit.plotting.style import figure_dpi
    from inertiafit.report.plots.living import DECELERATION_GID

    out, result, _ = living_staged
    png = out / "fast-trials-attachment+forearm.png"
    with Image.open(png) as image:
        dpi = image.info["dpi"]
        width = image.width
    wanted = figure_dpi()  # 300 for users (test_plots.py); the suite draws at its own
    assert dpi == pytest.approx((wanted, wanted), abs=0.01)
    record = {r.stem: r for r in figure_records(result)}["fast-trials-attachment+forearm"]
    assert "hatched: the uniform-deceleration window" in record.caption
    assert width == pytest.approx(wanted * record.make().get_figwidth(), abs=2)
    # each shaded span is the deceleration window of the trial's own fit, where the filtered
    # acceleration is negative while the shaft still turns the same way
    traces = result.traces[result.traces["condition"] == "attachment+forearm"]
    for _, trial in traces.groupby("trial"):
        start, end = (float(trial[c].iloc[0]) for c in ("deceleration_start", "deceleration_end"))
        inside = trial[(trial["time"] >= start) & (trial["time"] <= end)]
        assert len(inside) > 5
        assert (inside["acceleration"] < 0).all()
        assert (inside["velocity"] > 0).all()
    # drawn on the time axis of each trial's acceleration window (its start at 0), one span
    # per speed at the median of its trials' windows
    fig = record.make()
    for ax in fig.axes[:2]:
        spans = {
            str(a.get_gid()).split(":")[1]: (a.get_x(), a.get_x() + a.get_width())
            for a in ax.patches
            if str(a.get_gid()).startswith(DECELERATION_GID)
        }
        for speed, rows in traces.groupby("speed"):
            first = rows.groupby("trial").first()
            expected = np.median(
                [first["deceleration_start"] - first["window_start"],
                 first["deceleration_end"] - first["window_start"]],
                axis=1,
            )  # fmt: skip
            assert spans[f"{speed:g}"] == pytest.approx(tuple(expected), abs=1e-12)
