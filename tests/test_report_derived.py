"""The report's derived quantities (issue 34 item 3): I about the centre of mass, the
parameters relative to the subject, and the published tables beside the posterior."""

from __future__ import annotations

import numpy as np
import pytest
from arviz_stats import hdi

from inertiafit.inference.anthropometric import segment_values
from inertiafit.physics import gravity_moment, inertia
from inertiafit.posterior import open_posterior
from inertiafit.report import derived


@pytest.fixture(scope="module")
def disk(disk_fit):
    return open_posterior(disk_fit / "posterior.nc")


def test_derived_quantities_are_medians_and_hdis_of_the_draws(disk):
    body = disk.bodies[0]
    table = derived.derived_table(
        disk, 0.9, body_mass=70.0, segment_lengths={body: 0.3}
    ).set_index("quantity")
    m, x, rho = (
        disk.draws(body, p).ravel() for p in ("mass", "com_distance", "radius_of_gyration")
    )
    expected = {
        "I_com = m rho^2": m * rho**2,
        "m / body mass": 100 * m / 70.0,
        "x / segment length": 100 * x / 0.3,
        "rho / segment length": 100 * rho / 0.3,
    }
    assert list(table.index) == list(expected)
    for quantity, draws in expected.items():
        row = table.loc[quantity]
        assert row["median"] == pytest.approx(np.median(draws), rel=1e-12)
        lo, hi = hdi(draws, prob=0.9)
        assert (row["hdi_lower"], row["hdi_upper"]) == pytest.approx((lo, hi), rel=1e-12)
    # the disk (2.9 kg, rho 3.5 cm): I_com is a small part of its I about the axis
    i_com = table.loc["I_com = m rho^2", "median"]
    assert 0.002 < i_com < 0.006
    assert i_com < 0.02 * np.median(disk.draws(body, "inertia"))
    # without the subject's sizes, I_com alone
    alone = derived.derived_table(disk, 0.9)
    assert list(alone["quantity"]) == ["I_com = m rho^2"]


def test_published_tables_beside_the_posterior(disk, monkeypatch):
    body = disk.bodies[0]
    assert derived.published_table(
        disk, gravity=9.81, body_mass=70.0, segment_lengths={body: 0.3}
    ).empty  # a disk names no segment
    monkeypatch.setattr(derived, "_segment", lambda post, b: "forearm")
    table = derived.published_table(
        disk, gravity=9.81, body_mass=70.0, segment_lengths={body: 0.3}, sex="male"
    )
    assert sorted(set(table["table"])) == ["Dempster (Winter)", "de Leva (1996), male"]
    for name, key in (("de Leva (1996), male", "de-leva-male"), ("Dempster (Winter)", "dempster")):
        v = segment_values(key, "forearm", 70.0, 0.3)
        rows = table[table["table"] == name].set_index("parameter")
        predicted = {
            "mass": v.mass,
            "com_distance": v.com_distance,
            "radius_of_gyration": v.radius_of_gyration,
            "inertia": inertia(v.mass, v.radius_of_gyration, v.com_distance),
            "gravity_moment": gravity_moment(v.mass, v.com_distance, 9.81),
        }
        for p, value in predicted.items():
            draws = disk.draws(body, p).ravel()
            median, sd = np.median(draws), draws.std(ddof=1)
            row = rows.loc[p]
            assert row["table_value"] == pytest.approx(value, rel=1e-12)
            assert row["percent_of_median"] == pytest.approx(100 * (value / median - 1))
            assert row["posterior_sds"] == pytest.approx((value - median) / sd)
    # a 70 kg man's forearm is lighter than the 2.9 kg disk: below its median by ~60 %
    mass = table[(table["parameter"] == "mass") & (table["table"] == "Dempster (Winter)")]
    assert -75 < float(mass["percent_of_median"].iloc[0]) < -45
    # no body mass: nothing to predict
    assert derived.published_table(disk, gravity=9.81, body_mass=None, segment_lengths={}).empty


def test_report_html_folds_the_derived_quantities_in_its_posterior_section(study_out):
    page = (study_out / "report.html").read_text(encoding="utf-8")
    fold = page.index("<summary>Derived: I about the centre of mass</summary>")
    assert page.index("id='posterior'") < fold < page.index("id='what-pins-what'")
    assert "I_com = m rho^2" in page
