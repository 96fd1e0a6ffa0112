"""The population's report (issue 33): its files, its page and the published tables beside it."""

from __future__ import annotations

import base64
import functools
import json
import math
import re
import warnings

import numpy as np
import pandas as pd
import pytest

import inertiafit
from inertiafit.errors import InertiafitWarning
from inertiafit.inference import pooling
from inertiafit.inference.anthropometric import segment_values
from inertiafit.inference.priors import anthropometric_prior
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.report.population import TABLE_COLUMNS, write_population_report

BODY = "forearm+hand"
#: Four men (the last of unrecorded sex): body mass (kg), forearm length (m).
SUBJECTS = [(62.0, 0.25, "male"), (70.0, 0.27, "male"), (78.0, 0.28, "male"), (88.0, 0.30, None)]


def _subject(k: int, body_mass: float, length: float, sex: str | None, rng):
    """A subject measured exactly at de Leva's values (I and M_g with 0.5 % noise, 1 % SE)."""
    truth = segment_values("de-leva-male", BODY, body_mass, length)
    inertia = truth.inertia * (1 + 0.005 * rng.standard_normal())
    moment = truth.mass * 9.81 * truth.com_distance * (1 + 0.005 * rng.standard_normal())
    post = inertiafit.fit_body(
        anthropometric_prior("de-leva-male", BODY, body_mass, length),
        inertia=inertia,
        gravity_moment=moment,
        inertia_se=0.01 * inertia,
        gravity_moment_se=0.01 * moment,
        seed=k,
        settings=SamplerSettings(ess_min=200),
    )
    subject = {"id": f"S{k + 1}", "body_mass": body_mass, "height": None, "sex": sex}
    post.tree.attrs["inputs"] = json.dumps(
        {"subject": {**subject, "covariates": {}}, "segment_length": {BODY: length}}
    )
    return post


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The population of the four subjects and its report (600 steps, 1000 draws each)."""
    rng = np.random.default_rng(5)
    posts = [_subject(k, *s, rng) for k, s in enumerate(SUBJECTS)]
    short = functools.partial(pooling.fit_population, max_steps=600, chunk=150)
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        mp.setattr(pooling, "fit_population", short)
        mp.setattr(pooling, "POINTS", 4000)  # 1000 draws per subject
        warnings.simplefilter("ignore", InertiafitWarning)  # 1000 steps: not converged
        pop = pooling.population(posts, seed=1)
    folder = tmp_path_factory.mktemp("population")
    written = write_population_report(folder, pop, formats=("png", "svg"))
    return folder, written, pop


def test_every_file_is_written_and_returned(report):
    folder, written, _ = report
    figures = {
        f"population-{k}-{BODY}.{f}" for k in ("forest", "regression") for f in ("png", "svg")
    }
    assert set(written) == figures | {"population-tables.csv", "report.html"}
    assert len(written) == len(set(written))
    assert sorted(p.name for p in folder.iterdir()) == sorted(written)


def test_page_links_its_contents_and_embeds_every_figure(report):
    folder, _, _ = report
    page = (folder / "report.html").read_text(encoding="utf-8")
    links = re.findall(r"href='#([^']+)'", page)
    ids = set(re.findall(r"id='([^']+)'", page))
    assert len(links) == 1 + 1 + 6  # the introduction, the body and its six parts
    assert set(links) <= ids
    assert "Hogg, Myers &amp; Bovy 2010" in page
    assert re.search(
        r"importance-weight ESS of \d+ draws each: S1 \d+, S2 \d+, S3 \d+, S4 \d+", page
    )
    assert "Decided by the hyperprior, not the subjects:" in page
    assert "<details><summary>own and pooled estimates of 4 subjects</summary>" in page
    assert "The typical subject against each table at the reference covariates" in page
    embedded = re.findall(r"src='data:image/png;base64,([^']+)'", page)
    saved = [
        (folder / f"population-{k}-{BODY}.png").read_bytes() for k in ("forest", "regression")
    ]
    assert [base64.b64decode(e) for e in embedded] == saved


def test_tables_csv_has_each_table_of_each_subject(report):
    folder, _, _ = report
    tables = pd.read_csv(folder / "population-tables.csv")
    assert list(tables.columns) == TABLE_COLUMNS
    # three men compared with de Leva's men; the fourth, sex unknown, with both sexes
    counts = tables.groupby("table")["n_subjects"].unique().to_dict()
    assert {t: list(n) for t, n in counts.items()} == {
        "de-leva-female": [1],
        "de-leva-male": [4],
        "dempster": [4],
    }
    assert (tables.groupby("table").size() == 5).all()
    values = tables[["bias_median_percent", "bias_lower_percent", "bias_upper_percent"]]
    assert np.isfinite(values.to_numpy()).all()
    assert (tables["bias_lower_percent"] <= tables["bias_median_percent"]).all()
    assert (tables["bias_median_percent"] <= tables["bias_upper_percent"]).all()


def test_the_true_table_is_unbiased_and_another_biased_by_their_difference(report):
    folder, _, _ = report
    tables = pd.read_csv(folder / "population-tables.csv").set_index(["table", "parameter"])
    # the subjects are de Leva's men: no bias on what their data pin (I and M_g); m, x and rho
    # lie on a ridge the priors and the hyperprior decide
    for p in ("inertia", "gravity_moment"):
        row = tables.loc[("de-leva-male", p)]
        assert row["bias_lower_percent"] < 0 < row["bias_upper_percent"], p
    # de Leva's women for the fourth subject (sex unknown): lighter, so a negative bias
    m, x, _ = SUBJECTS[-1]
    women = segment_values("de-leva-female", BODY, m, x).inertia
    assert women < segment_values("de-leva-male", BODY, m, x).inertia
    assert tables.loc[("de-leva-female", "inertia"), "bias_upper_percent"] < 0
    # Dempster-Winter against de Leva's men, straight from the tables: I about 5 % higher
    ratios = [
        segment_values("dempster", BODY, m, x).inertia
        / segment_values("de-leva-male", BODY, m, x).inertia
        for m, x, _ in SUBJECTS
    ]
    known = 100 * math.expm1(np.mean(np.log(ratios)))
    row = tables.loc[("dempster", "inertia")]
    assert known > 2
    assert row["bias_lower_percent"] > 0
    assert row["bias_median_percent"] == pytest.approx(known, abs=1.5)


def test_a_population_read_back_from_its_file_gets_its_page_without_the_tables(report, tmp_path):
    """``population.nc`` keeps no study: no predictive band, no table compared, but a page."""
    _, _, pop = report
    pop.save(tmp_path / "population.nc")
    again = pooling.open_population(tmp_path / "population.nc")
    written = write_population_report(tmp_path, again)
    assert f"population-forest-{BODY}.png" in written
    assert pd.read_csv(tmp_path / "population-tables.csv").empty
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "No subject could be compared with a table." in page
    assert page.count("src='data:image/png;base64,") == 2
