"""The Methods text, its references and the report's Priors section, from one fitted body."""

import dataclasses
import re

import pytest

from inertiafit.formatting import plural
from inertiafit.inference.fit import fit_body
from inertiafit.inference.priors import anthropometric_prior, load_prior
from inertiafit.physics import PARAMETERS
from inertiafit.pipeline.fit import fit_result
from inertiafit.report.figures import figure_records
from inertiafit.report.html import PRIOR_SHARE_NOTE, study_report
from inertiafit.report.methods import methods_markdown, prior_table, references_of
from inertiafit.report.references import ALWAYS, REFERENCES, bibtex, cited
from inertiafit.report.text import truth_comparison_text


@pytest.fixture(scope="module")
def disk():
    prior = load_prior("disk-3kg")
    post = fit_body(
        prior, inertia=0.594, inertia_se=0.0105, gravity_moment=12.8, gravity_moment_se=0.05
    )
    return fit_result(post, prior, inertia=0.594, gravity_moment=12.8, gravity=9.81, hdi_prob=0.95)


def bib_keys(text):
    return re.findall(r"^@\w+\{([^,]+),", text, flags=re.MULTILINE)


def test_plural_says_one_body_and_two_bodies():
    assert plural(1, "body") == "1 body"
    assert plural(2, "body") == "2 bodies"
    assert plural(0, "trial") == "0 trials"
    assert plural(3, "day") == "3 days"  # a vowel before the y
    assert plural(2, "axis", "axes") == "2 axes"


def test_sources_pick_their_references():
    assert [r.key for r in cited([])] == list(ALWAYS)
    leva = cited(["de Leva P. (1996) ...; spread: guided by Durkin & Dowling (2003)"])
    assert [r.key for r in leva][len(ALWAYS) :] == ["de_leva_1996", "durkin_dowling_2003"]
    emg = [r.key for r in cited([], emg=True)]
    assert emg[len(ALWAYS) :] == ["hermens_2000", "hodges_bui_1996"]
    text = bibtex(REFERENCES.values())
    assert bib_keys(text) == list(REFERENCES)
    assert text.count("{") == text.count("}")


def test_methods_of_a_fit_give_its_numbers_prior_and_convergence(disk):
    md = methods_markdown(disk)
    summary = disk.posterior.summary(0.95)
    assert "I = 0.594 kg m^2 (scale 0.0105 kg m^2; Gaussian)" in md
    assert "M_g = 12.8 N m (scale 0.05 N m; Gaussian)" in md
    assert f"largest R-hat {summary['r_hat'].max():.3f}" in md
    assert f"smallest bulk ESS {summary['ess_bulk'].min():.0f}" in md
    assert f"{disk.posterior.attrs['n_walkers']} walkers" in md
    prior = disk.priors["disk-3kg"]
    for p in PARAMETERS:
        assert f"[{prior.lower[p]:.4g}, {prior.upper[p]:.4g}]" in md
    assert "Source: Son et al., Determination of inertial parameters" in md
    assert "emcee 3." in md  # the software versions recorded in the posterior
    # every citation of the text is an entry of references.bib, and only those are listed
    keys = bib_keys(bibtex(references_of(disk)))
    assert keys == list(ALWAYS)
    assert set(re.findall(r"\[@([\w]+)\]", md)) == set(keys)


def test_an_anthropometric_prior_cites_its_table(disk):
    leva = anthropometric_prior("de-leva-male", "forearm", 70, 0.27)
    result = dataclasses.replace(disk, priors={"disk-3kg": dataclasses.replace(leva)})
    keys = [r.key for r in references_of(result)]
    assert keys[len(ALWAYS) :] == [
        "de_leva_1996",
        "durkin_dowling_2003",
        "rossi_2013",
        "merrill_2019",
    ]
    table = prior_table(leva).set_index("distribution")
    assert set(table.index) == {"lognormal"}
    median = leva.distribution["mass"]["median"]
    assert f"median {median:.4g} kg" in table.iloc[0]["parameters"]
    assert "lognormal" in methods_markdown(result)


def test_report_shows_priors_methods_and_folded_provenance(disk, tmp_path):
    page = study_report(tmp_path / "report.html", disk, {}, 0.95).read_text(encoding="utf-8")
    priors = page[page.index("<h2 id='priors'>Priors</h2>") : page.index("<h2 id='comparison")]
    assert "<h3>disk-3kg</h3>" in priors
    assert "source: Son et al., Determination of inertial parameters" in priors
    assert priors.count(">uniform</td>") == 3
    assert "<h2 id='methods'>Methods</h2>" in page
    assert "(Foreman-Mackey et al. (2013))" in page  # [@key] shown as a citation
    assert "[@" not in page
    inputs = page[page.index("<h2 id='inputs-and-provenance'>Inputs and provenance</h2>") :]
    assert inputs.index("<details><summary>Fitted from reported numbers") < inputs.index("seed")
    assert PRIOR_SHARE_NOTE.replace("'", "&#x27;") in page
    assert "body(ies)" not in page
    assert "m·x" in page
    assert " m x " not in page


def test_text_report_says_one_body_and_explains_the_prior_share(disk):
    text = disk.posterior.report()
    assert text.startswith("inertiafit posterior: 1 body; ")
    assert "disk-3kg: the data identify m·x and I;" in text
    assert "1 when the prior alone sets a quantity's width, 0 when the data do" in text


def test_truth_is_shown_beside_the_posterior_apart_from_the_ideal(disk):
    assert truth_comparison_text(disk) == ""  # measured data have no truth
    row = disk.comparison.set_index("parameter").loc["mass"]
    inside = dataclasses.replace(disk, truths={"disk-3kg": {"mass": row.posterior_median}})
    outside = dataclasses.replace(disk, truths={"disk-3kg": {"mass": 2 * row.hdi_upper}})
    line = truth_comparison_text(inside).splitlines()[1]
    assert line.split()[:3] == ["disk-3kg", "mass", "[kg]"]
    assert line.endswith("+0.0%  yes")
    assert truth_comparison_text(outside).splitlines()[1].endswith("NO")
    records = {r.stem: r for r in figure_records(inside)}
    assert records["corner"].caption.endswith("lines: the simulation's truth (solid)")
