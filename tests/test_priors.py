import math

import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.inference.priors import Prior, available_priors, load_prior


def test_shipped_priors_have_the_papers_ideal_bodies():
    names = available_priors()
    assert {"biodex-elbow-attachment", "disk-3kg"} <= set(names)
    att = load_prior("biodex-elbow-attachment")
    assert att.nominal == pytest.approx(
        {"mass": 2.91, "radius_of_gyration": 0.130, "com_distance": 0.225}
    )
    # +-50 % box (Son et al. Eq. 4)
    assert att.lower["mass"] == pytest.approx(1.455)
    assert att.upper["com_distance"] == pytest.approx(0.3375)
    assert "Table 2" in att.source
    disk = load_prior("disk-3kg")
    assert disk.nominal["com_distance"] == pytest.approx(0.45)
    assert "Table 3" in disk.source


def test_prior_found_by_path_and_units_converted(tmp_path):
    f = tmp_path / "forearm.toml"
    f.write_text(
        'description = "x"\nsource = "y"\nspread = 0.2\n'
        '[mass]\nnominal = 1500\nunit = "g"\n'
        '[radius_of_gyration]\nnominal = 8\nunit = "cm"\nspread = 0.4\n'
        '[com_distance]\nnominal = 150\nunit = "mm"\nlower = 100\nupper = 200\n'
    )
    p = load_prior(f)
    assert p.name == "forearm"
    assert p.nominal["mass"] == pytest.approx(1.5)
    assert (p.lower["mass"], p.upper["mass"]) == pytest.approx((1.2, 1.8))
    assert (p.lower["radius_of_gyration"], p.upper["radius_of_gyration"]) == pytest.approx(
        (0.048, 0.112)
    )
    assert (p.lower["com_distance"], p.upper["com_distance"]) == pytest.approx((0.1, 0.2))


def test_inline_table_and_box_constructor_agree():
    a = load_prior({"mass": 2.92, "radius_of_gyration": 0.035, "com_distance": 0.45}, name="w")
    b = Prior.box("w", mass=2.92, com_distance=0.45, radius_of_gyration=0.035)
    assert a.lower == b.lower
    assert a.upper == b.upper


def test_prior_sampling_is_uniform_on_the_box():
    p = load_prior("disk-3kg")
    d = p.sample(200_000, np.random.default_rng(0))
    for k in ("mass", "com_distance", "radius_of_gyration"):
        lo, hi = p.lower[k], p.upper[k]
        assert d[k].min() >= lo
        assert d[k].max() <= hi
        # mean and SD of a uniform, to 5 Monte Carlo standard errors
        sd = (hi - lo) / math.sqrt(12)
        assert abs(d[k].mean() - (lo + hi) / 2) < 5 * sd / math.sqrt(2e5)
        assert d[k].std() == pytest.approx(sd, rel=0.01)


GOOD = "[mass]\nnominal = 2\n[radius_of_gyration]\nnominal = 0.1\n[com_distance]\nnominal = 0.2\n"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (GOOD.replace("nominal = 2\n", 'unit = "kg"\n'), r"mass\.nominal' is missing"),
        (GOOD.replace("nominal = 2\n", "nominal = -2\n"), r"mass\.nominal' must be positive"),
        (GOOD + "colour = 1\n", "unknown key 'com_distance.colour'"),
        ("wibble = 1\n" + GOOD, "unknown key 'wibble'"),
        (
            GOOD.replace("nominal = 0.2\n", "nominal = 0.2\nlower = 0.3\nupper = 0.1\n"),
            r"com_distance\.lower' \(0\.3\) must be below",
        ),
        (GOOD.replace("nominal = 0.2\n", "nominal = 0.2\nlower = 0.1\n"), "give both"),
        (GOOD.replace("nominal = 0.2\n", 'nominal = 0.2\nunit = "inch"\n'), "expected one of"),
        (GOOD.replace("nominal = 2\n", 'nominal = "two"\n'), "must be a number"),
        ("spread = 1.5\n" + GOOD, r"'spread' must lie in \(0, 1\)"),
        (GOOD.replace("[com_distance]\nnominal = 0.2\n", ""), r"missing parameter table '\[com_"),
        (GOOD + "[[", "not valid TOML"),
        (
            GOOD.replace("nominal = 0.2\n", "nominal = 0.5\nlower = 0.1\nupper = 0.3\n"),
            "lies outside",
        ),
    ],
)
def test_malformed_prior_files_are_one_line_errors(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(InputError, match=match) as err:
        load_prior(f)
    assert str(f) in str(err.value)
    assert "\n" not in str(err.value)


def test_unknown_prior_name_lists_the_shipped_ones():
    with pytest.raises(InputError, match=r"no such shipped prior.*biodex-elbow-attachment"):
        load_prior("biodex-knee")
    with pytest.raises(InputError, match="prior file not found"):
        load_prior("missing/prior.toml")
