"""Anthropometric priors: the table files, the numbers they give, their errors, and SBC.

The tables are checked against the published rows (de Leva 1996 Table 4; Winter's Table 4.1
after Dempster 1955), the forearm + hand composite against a hand computation, Dempster's
radii against the parallel-axis theorem, and the priors by simulation-based calibration: truths
from an anthropometric prior are ranked uniformly among the posterior draws of a fit with the
same prior, and not with a prior whose mass median is two of its SDs too high.
"""

import math
from dataclasses import replace

import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.inference import anthropometric as an
from inertiafit.inference.fit import fit
from inertiafit.inference.priors import anthropometric_prior, load_prior, parse_prior
from inertiafit.io import load_study
from inertiafit.physics import REPORTED
from inertiafit.validation.sbc import (
    SBC_SETTINGS,
    Design,
    SBCResult,
    calibrated,
    calibration_table,
    draw_truth_and_data,
    run_sbc,
    sbc_ranks,
)

SEGMENTS = ("forearm", "hand", "forearm+hand", "upper-arm", "shank", "foot", "shank+foot", "thigh")


def table(name):
    return an.load_table(an.available_tables()[name])


# ------------------------------------------------------------------------- the table files


def test_shipped_tables_and_their_names():
    assert sorted(an.available_tables()) == ["de-leva", "dempster-winter"]
    assert table("de-leva").names() == ["de-leva-female", "de-leva-male"]
    assert table("dempster-winter").names() == ["dempster-winter", "dempster"]
    for name in ("de-leva", "dempster-winter"):
        t = table(name)
        assert set(t.segments) == set(SEGMENTS)
        assert t.citation
        assert t.radius == "transverse"
        assert t.spread_source.startswith("chosen")


def test_de_leva_rows_are_the_published_table_4():
    t = table("de-leva")
    # (mass, CoM from the proximal joint, transverse radius) per sex, Table 4 of de Leva 1996
    published = {
        "upper-arm": {"female": (0.0255, 0.5754, 0.260), "male": (0.0271, 0.5772, 0.269)},
        "forearm": {"female": (0.0138, 0.4559, 0.257), "male": (0.0162, 0.4574, 0.265)},
        "hand": {"female": (0.0056, 0.7474, 0.454), "male": (0.0061, 0.7900, 0.513)},
        "thigh": {"female": (0.1478, 0.3612, 0.364), "male": (0.1416, 0.4095, 0.329)},
        "shank": {"female": (0.0481, 0.4352, 0.263), "male": (0.0433, 0.4395, 0.246)},
    }
    for seg, rows in published.items():
        for sex, (m, c, r) in rows.items():
            f = t.segments[seg].fractions[sex]
            assert (f["mass"], f["com"], f["radius"]) == (m, c, r)
    assert t.segments["forearm"].mean_length_mm == {"female": 264.3, "male": 268.9}
    assert t.segments["hand"].mean_length_mm == {"female": 78.0, "male": 86.2}


def test_dempster_rows_satisfy_the_parallel_axis_theorem():
    # Rg_prox^2 = Rg_CM^2 + CM^2 and Rg_dist^2 = Rg_CM^2 + (1 - CM)^2, to table rounding
    t = table("dempster-winter")
    for seg in SEGMENTS:
        f = t.segments[seg].fractions[""]
        assert math.hypot(f["radius"], f["com"]) == pytest.approx(f["rg_proximal"], abs=0.005)
        assert math.hypot(f["radius"], 1 - f["com"]) == pytest.approx(f["rg_distal"], abs=0.005)


def test_the_parallel_axis_check_fails_on_a_wrong_row():
    # negative control: a row with the CoM measured from the other end fails the same check
    f = table("dempster-winter").segments["forearm+hand"].fractions[""]
    assert abs(math.hypot(f["radius"], 1 - f["com"]) - f["rg_proximal"]) > 0.005


# ------------------------------------------------------------------------------ the numbers


def test_a_70_kg_males_forearm():
    p = anthropometric_prior("de-leva-male", "forearm", 70, 0.27)
    assert p.distribution["mass"] == {"kind": "lognormal", "median": 0.0162 * 70, "sd_log": 0.15}
    assert p.distribution["com_distance"]["median"] == pytest.approx(0.4574 * 0.27, rel=1e-12)
    assert p.distribution["radius_of_gyration"]["median"] == pytest.approx(0.265 * 0.27, rel=1e-12)
    assert p.distribution["radius_of_gyration"]["sd_log"] == 0.10
    assert p.description == "de Leva (1996) male forearm, body mass 70 kg, segment length 0.27 m"
    assert "Journal of Biomechanics 29(9):1223-1230" in p.source
    assert p.lower["mass"] == pytest.approx(0.0162 * 70 * math.exp(-4.753 * 0.15), rel=1e-4)


def test_dempster_forearm_and_hand_uses_the_forearm_length():
    p = anthropometric_prior("Dempster", "Forearm and hand", 80, 0.28)
    assert p.nominal["mass"] == pytest.approx(0.022 * 80)
    assert p.nominal["com_distance"] == pytest.approx(0.682 * 0.28)
    assert p.nominal["radius_of_gyration"] == pytest.approx(0.468 * 0.28)
    assert p.reference["inertia"] == pytest.approx(0.022 * 80 * (0.827 * 0.28) ** 2, rel=0.005)
    # the upper arm has its own CoM spread (the two tables disagree there)
    arm = anthropometric_prior("dempster", "upper arm", 80, 0.3)
    assert arm.distribution["com_distance"]["sd_log"] == 0.15


def test_de_leva_forearm_and_hand_is_combined_by_parallel_axes():
    lf, lh, body = 0.26, 0.09, 72.5
    p = anthropometric_prior(
        "de-leva-female", "forearm+hand", body, segment_lengths={"forearm": lf, "hand": lh}
    )
    # by hand: the forearm's and the hand's CoM from the elbow, moments about the elbow
    m1, m2 = 0.0138 * body, 0.0056 * body
    x1, x2 = 0.4559 * lf, lf + 0.7474 * lh
    i_elbow = m1 * ((0.257 * lf) ** 2 + x1**2) + m2 * ((0.454 * lh) ** 2 + x2**2)
    m, x = m1 + m2, (m1 * x1 + m2 * x2) / (m1 + m2)
    assert p.nominal["mass"] == pytest.approx(m, rel=1e-12)
    assert p.nominal["com_distance"] == pytest.approx(x, rel=1e-12)
    assert p.nominal["radius_of_gyration"] == pytest.approx(math.sqrt(i_elbow / m - x * x))
    assert p.reference["inertia"] == pytest.approx(i_elbow, rel=1e-12)
    # one length: the hand from de Leva's mean hand/forearm ratio (78.0 / 264.3 mm)
    q = anthropometric_prior("de-leva-female", "forearm+hand", body, lf)
    r = anthropometric_prior(
        "de-leva-female",
        "forearm+hand",
        body,
        segment_lengths={"forearm": lf, "hand": lf * 78.0 / 264.3},
    )
    assert q.nominal == pytest.approx(r.nominal, rel=1e-12)
    assert "hand 0.07673 m from the mean ratio" in q.description
    # and it lands near Dempster's measured forearm + hand row (CoM 0.682 of the forearm)
    male = anthropometric_prior("de-leva-male", "forearm+hand", 70, 0.27)
    assert male.nominal["com_distance"] / 0.27 == pytest.approx(0.675, abs=0.001)


def test_every_support_box_is_positive_and_inside_the_body():
    for name in ("de-leva-female", "de-leva-male", "dempster"):
        for seg in SEGMENTS:
            if name.startswith("de-leva") and seg in ("foot", "shank+foot"):
                continue
            p = anthropometric_prior(name, seg, 70, 0.3)
            total = 0.3 * (1.4 if "+" in seg else 1.0)  # the distal part adds < 40 %
            if name.startswith("de-leva") and seg == "hand":
                total = 0.6  # measured to the knuckle (MET3); the fingers about double it
            assert all(p.lower[k] > 0 for k in p.lower)
            assert p.upper["com_distance"] < 1.2 * total, (name, seg)
            assert p.upper["radius_of_gyration"] < total, (name, seg)
            assert p.upper["mass"] < 0.35 * 70  # the thigh: 14.8 % x 2.04


# ---------------------------------------------------------------------- manifests and files


def test_the_manifest_inline_table(tmp_path):
    (tmp_path / "qs.csv").write_text("t,angle,velocity,moment\n0,90,0,1.5\n10,89,-1,1.6\n")
    (tmp_path / "study.toml").write_text(
        "[bodies.arm]\n"
        'prior = { anthropometric = "de-leva-male", segment = "forearm+hand", '
        "body_mass = 72.5, segment_length = 0.27 }\n"
        '[[trials]]\nfile = "qs.csv"\nbodies = "arm"\nkind = "quasi-static"\n'
        'columns = { time = "t", torque = "moment" }\n'
    )
    study = load_study(tmp_path / "study.toml")
    prior = load_prior(study.bodies["arm"].prior, base_dir=study.base_dir, name="arm")
    assert prior.name == "arm"
    assert prior.nominal["mass"] == pytest.approx((0.0162 + 0.0061) * 72.5)
    assert prior.description.startswith("de Leva (1996) male forearm+hand, body mass 72.5 kg")
    assert prior.kind("mass") == "lognormal"


def test_an_inline_table_and_a_prior_file_say_the_same(tmp_path):
    spec = {
        "anthropometric": "de leva",
        "sex": "Male",
        "segment": "Shank",
        "body_mass": 81,
        "segment_length": 0.42,
    }
    inline = load_prior(spec, name="shank")
    path = tmp_path / "shank.toml"
    path.write_text(
        'anthropometric = "de-leva"\nsex = "male"\nsegment = "leg"\n'
        "body_mass = 81.0\nsegment_length = 0.42\n"
    )
    from_file = load_prior(path)
    assert from_file.name == "shank"
    assert from_file.nominal == inline.nominal
    assert from_file.distribution == inline.distribution
    assert inline.nominal["mass"] == pytest.approx(0.0433 * 81)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"anthropometric": "winter-female"}, ("unknown anthropometric table 'winter-female'; "
         "expected one of de-leva-female, de-leva-male, dempster-winter, dempster")),
        ({"anthropometric": "de-leva"}, "needs a sex; use one of de-leva-female, de-leva-male"),
        ({"anthropometric": "de-leva-male", "sex": "female"}, "is for sex 'male'"),
        ({"anthropometric": "dempster", "sex": "male"}, "not sex-specific; leave out 'sex'"),
        ({"segment": "neck"}, "unknown segment 'neck'; expected one of hand, forearm"),
        ({"anthropometric": "de-leva-male", "segment": "foot"}, "heel to the toe tip"),
        ({"body_mass": -70}, "'body_mass' must lie in (0, 500] kg, got -70"),
        ({"body_mass": 725}, "'body_mass' must lie in (0, 500] kg, got 725"),
        ({"body_mass": "72"}, "'body_mass' must be a number in kg"),
        ({"segment_length": 27}, "'segment_length' must lie in (0, 2.5] m, got 27"),
        ({"segment_length": 0}, "'segment_length' must lie in (0, 2.5] m"),
        ({"segment_length": None}, "'segment_length' is missing (FOREARM length: elbow axis"),
        ({"body_mass": None}, "'body_mass' is missing"),
        ({"mass": 2.0}, "unknown key 'mass' for an anthropometric prior"),
        ({"segment_lengths": {"forearm": 0.27}}, "give 'segment_length' or 'segment_lengths'"),
        ({"anthropometric": "de-leva-male", "segment_length": None,
          "segment_lengths": {"forearm": 0.27}}, "must name exactly forearm, hand"),
        ({"segment": "forearm", "segment_length": None,
          "segment_lengths": {"forearm": 0.27}}, "'segment_lengths' is for a segment made of"),
    ],
)  # fmt: skip
def test_bad_inputs_are_one_line_errors(spec, message):
    full = {
        "anthropometric": "dempster",
        "segment": "forearm+hand",
        "body_mass": 72.5,
        "segment_length": 0.27,
        **spec,
    }
    full = {k: v for k, v in full.items() if v is not None}
    with pytest.raises(InputError) as info:
        parse_prior(full, name="arm", where="study.toml: bodies.arm.prior")
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith("study.toml: bodies.arm.prior: ")
    assert message in text


# ------------------------------------------------------------------------------------ SBC


def _design(prior):
    return Design({"arm": prior}, (("arm",),), "mean_se")


@pytest.mark.slow
def test_sbc_truths_from_an_anthropometric_prior_are_calibrated():
    design = _design(anthropometric_prior("dempster", "forearm+hand", 72.5, 0.27, name="arm"))
    result = run_sbc(design, 16, seed=5)
    assert not result.failures
    assert result.n_studies == 16
    assert calibrated(calibration_table(result), 0.001)


@pytest.mark.slow
def test_negative_control_a_prior_with_its_com_two_sds_out_is_not_calibrated():
    # Truths from the prior above, fitted with the CoM distance's median exp(2 x 0.10) = 1.22
    # times too far out: the data fix m x and I, the prior decides where along that curve the
    # body lies, so the truths' CoM ranks pile up at the bottom and the mass ranks at the top.
    # (Shifting the mass median by 2 of its SDs instead is partly absorbed by x and rho: its
    # mass ranks average 66 of 199, too weak a failure for 12 studies.)
    truth = anthropometric_prior("dempster", "forearm+hand", 72.5, 0.27, name="arm")
    shifted = {p: {"distribution": "lognormal", **d} for p, d in truth.distribution.items()}
    for d in shifted.values():
        del d["kind"]
    shifted["com_distance"]["median"] *= math.exp(2 * shifted["com_distance"]["sd_log"])
    wrong = parse_prior(shifted, name="arm", where="shifted")
    design, wrong_design = _design(truth), _design(wrong)
    ranks, inside = [], []
    for i in range(12):
        rng = np.random.default_rng([5, i])
        sim = draw_truth_and_data(design, rng)
        post = fit(
            replace(sim, design=wrong_design).model(),
            seed=int(rng.integers(2**31)),
            settings=SBC_SETTINGS,
        )
        draws = {"arm": {q: post.draws("arm", q).ravel() for q in REPORTED}}
        r, h = sbc_ranks(draws, sim.truth, np.random.default_rng([5, i, 1]))
        ranks.append(r)
        inside.append(h)
    result = SBCResult(
        design=design,
        scale=1.0,
        quantities=[("arm", q) for q in REPORTED],
        ranks=np.array(ranks),
        ranks_unweighted=np.array(ranks),
        hdi_inside=np.array(inside),
        n_draws=199,
    )
    assert not calibrated(calibration_table(result), 0.001)
    mean_rank = dict(zip(REPORTED, result.ranks.mean(axis=0), strict=True))
    assert mean_rank["com_distance"] < 40  # calibrated: 99.5 on average
    assert mean_rank["mass"] > 160
