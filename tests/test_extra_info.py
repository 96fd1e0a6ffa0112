"""Extra information from files and the simulator: a weighed mass, a balance point, a second
mounting at a known offset and known added masses (manifest -> evidence -> posterior)."""

import math
import tomllib

import numpy as np
import pandas as pd
import pytest

from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.inference.evidence import condition_evidence, study_model
from inertiafit.inference.fit import fit, fit_body
from inertiafit.inference.model import Model
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.io import load_study
from inertiafit.measured import MEASURED_QUANTITIES, Measurement, measurements
from inertiafit.mounting import Mounting
from inertiafit.processing.study import process_study
from inertiafit.simulate import PAPER_PRIORS, PAPER_TRUTH, Noise, simulate_study

HEAD = """\
[bodies.attachment]
prior = "biodex-elbow-attachment"
[bodies.disk]
prior = { mass = 2.92, radius_of_gyration = 0.035, com_distance = 0.45, spread = 0.5 }
"""


def trial(file, bodies, kind="quasi-static", extra=""):
    speed = "speed = 240\n" if kind == "fast" else ""
    return f'[[trials]]\nfile = "{file}"\nbodies = {bodies}\nkind = "{kind}"\n{speed}{extra}'


PLAIN = trial("a.csv", '["attachment"]') + trial("ad.csv", '["attachment", "disk"]')


@pytest.fixture
def folder(tmp_path):
    for name in ("a", "ad", "m1", "m2", "m3", "f1", "f2"):
        (tmp_path / f"{name}.csv").write_text("time,angle,velocity,torque\n0,0,0,0\n")
    return tmp_path


def load(folder, text):
    path = folder / "study.toml"
    path.write_text(text)
    return load_study(path)


def refused(folder, text, pattern):
    with pytest.raises(InputError, match=r"study\.toml: " + pattern) as info:
        load(folder, text)
    assert "\n" not in str(info.value)


# ------------------------------------------------------------------------------ manifest


def test_measured_mass_and_balance_point_in_si(folder):
    body = (
        'mass = { value = 2930, sd = 5, unit = "g" }\n'
        'com_distance = { value = 45.5, resolution = 0.1, unit = "cm" }\n'
    )
    study = load(folder, HEAD + body + PLAIN)
    value, sd = study.bodies["disk"].measured["mass"]
    assert (value, sd) == pytest.approx((2.93, 0.005), rel=1e-12)
    value, sd = study.bodies["disk"].measured["com_distance"]
    assert value == pytest.approx(0.455, rel=1e-12)
    assert sd == pytest.approx(0.001 / math.sqrt(12), rel=1e-12)  # rounding error alone
    assert study.bodies["attachment"].measured == {}
    assert list(study.measured) == ["disk"]
    # SI by default
    study = load(folder, HEAD + "mass = { value = 2.93, resolution = 0.01 }\n" + PLAIN)
    assert study.bodies["disk"].measured["mass"] == pytest.approx((2.93, 0.01 / math.sqrt(12)))


@pytest.mark.parametrize(
    ("line", "pattern"),
    [
        ("mass = 2.93", r"bodies\.disk\.mass: expected a table"),
        ("mass = { value = 2.93, sd = 0.01, scale = 1 }", r"bodies\.disk\.mass\.scale: unknown"),
        ("mass = { sd = 0.01 }", r"bodies\.disk\.mass\.value: missing"),
        ("mass = { value = -2.93, sd = 0.01 }", r"bodies\.disk\.mass\.value: must be positive"),
        ("mass = { value = 2.93, sd = 0 }", r"bodies\.disk\.mass\.sd: must be positive"),
        ("mass = { value = 2.93, resolution = -1 }", r"bodies\.disk\.mass\.resolution: must be"),
        ("mass = { value = 2.93, sd = true }", r"bodies\.disk\.mass\.sd: expected a positive"),
        (
            "mass = { value = 2.93, sd = 0.01, resolution = 0.01 }",
            r"bodies\.disk\.mass: give sd .* or resolution .*, not both",
        ),
        (
            "mass = { value = 2.93 }",
            r"bodies\.disk\.mass\.sd: missing; give .* sd or .*resolution",
        ),
        (
            'mass = { value = 2.93, sd = 1, unit = "lb" }',
            r"bodies\.disk\.mass\.unit: unknown mass",
        ),
        (
            'com_distance = { value = 0.45, sd = 0.01, unit = "kg" }',
            r"bodies\.disk\.com_distance\.unit: unknown length unit 'kg'",
        ),
    ],
)
def test_bad_measurement(folder, line, pattern):
    refused(folder, HEAD + line + "\n" + PLAIN, pattern)


def test_offset_and_added_masses_make_their_own_conditions(folder):
    moved = "offset = { disk = 0.05 }\n"
    same = 'offset = { disk = { value = 5, unit = "cm" } }\n'
    added = "added_mass = { mass = 0.5, com_distance = 0.30 }\n"
    two = (
        "added_mass = [{ mass = 0.2, com_distance = -0.1, radius_of_gyration = 0.02 },"
        " { mass = 0.5, com_distance = 0.3 }]\n"
    )
    text = (
        HEAD
        + PLAIN
        + trial("m1.csv", '["attachment", "disk"]', extra=moved)
        + trial("m2.csv", '["disk", "attachment"]', "fast", extra=same)
        + trial("m3.csv", '["attachment"]', extra=added)
        + trial("f1.csv", '["attachment"]', "fast", extra=added)
        + trial("f2.csv", '["attachment"]', extra=two)
    )
    study = load(folder, text)
    assert [t.condition for t in study.trials] == [
        "attachment",
        "attachment+disk",
        "attachment+disk@disk+5cm",
        "attachment+disk@disk+5cm",  # 5 cm and 0.05 m are one mounting
        "attachment+added0.5kg@30cm",
        "attachment+added0.5kg@30cm",
        "attachment+added0.2kg@-10cm+added0.5kg@30cm",
    ]
    # label -> bodies keeps working; the mountings carry the rest
    assert study.conditions["attachment+disk@disk+5cm"] == ("attachment", "disk")
    specs = study.mountings
    assert specs["attachment+disk"].plain
    moved_spec = specs["attachment+disk@disk+5cm"]
    assert (moved_spec.offset_body, moved_spec.offset) == ("disk", 0.05)
    a, i = specs["attachment+added0.2kg@-10cm+added0.5kg@30cm"].added_moments
    assert a == pytest.approx(0.5 * 0.3 - 0.2 * 0.1, rel=1e-12)
    assert i == pytest.approx(0.5 * 0.09 + 0.2 * (0.02**2 + 0.01), rel=1e-12)


def test_labels_are_unchanged_without_extra_keys_and_unique_with_them(folder):
    assert Mounting(("attachment", "disk")).label == "attachment+disk"
    assert Mounting(("a", "b"), "b", -0.0125).label == "a+b@b-12.5mm"
    # two added masses that differ only in their radius of gyration: distinct conditions
    first = "added_mass = { mass = 0.5, com_distance = 0.3 }\n"
    second = "added_mass = { mass = 0.5, com_distance = 0.3, radius_of_gyration = 0.05 }\n"
    study = load(
        folder,
        HEAD
        + PLAIN
        + trial("m1.csv", '["attachment"]', extra=first)
        + trial("m2.csv", '["attachment"]', extra=second),
    )
    assert list(study.conditions) == [
        "attachment",
        "attachment+disk",
        "attachment+added0.5kg@30cm",
        "attachment+added0.5kg@30cm_2",
    ]


def test_moved_condition_needs_its_own_quasi_static_trial(folder):
    text = (
        HEAD
        + PLAIN
        + trial("f1.csv", '["attachment", "disk"]', "fast", "offset = { disk = 0.05 }\n")
    )
    refused(
        folder,
        text,
        r"trials: condition 'attachment\+disk@disk\+5cm' has fast trials \(trials\[2\]\) but no "
        r"quasi-static trial",
    )


@pytest.mark.parametrize(
    ("extra", "pattern"),
    [
        (
            "offset = { disk = 0.05, attachment = 0.01 }",
            r"trials\[2\]\.offset: expected exactly one",
        ),
        (
            "offset = { attachment = 0.05 }",
            r"trials\[2\]\.offset\.attachment: body 'attachment' is",
        ),
        ("offset = { disk = 0 }", r"trials\[2\]\.offset\.disk: expected a non-zero distance"),
        ("offset = { disk = nan }", r"trials\[2\]\.offset\.disk: expected a distance"),
        ("offset = 0.05", r"trials\[2\]\.offset: expected a table"),
        (
            'offset = { disk = { value = 5, unit = "in" } }',
            r"trials\[2\]\.offset\.disk\.unit: unknown length",
        ),
        ("offset = { disk = { unit = 'cm' } }", r"trials\[2\]\.offset\.disk\.value: missing"),
        ("added_mass = []", r"trials\[2\]\.added_mass: expected \{ mass = kg"),
        ("added_mass = { mass = 0.5 }", r"trials\[2\]\.added_mass\.com_distance: missing"),
        (
            "added_mass = { mass = 0, com_distance = 0.3 }",
            r"trials\[2\]\.added_mass\.mass: must be positive",
        ),
        (
            "added_mass = [{ mass = 0.5, com_distance = 0.3, rho = 0.1 }]",
            r"trials\[2\]\.added_mass\[0\]\.rho: unknown key",
        ),
        (
            "added_mass = { mass = 0.5, com_distance = 0.3, radius_of_gyration = -0.1 }",
            r"trials\[2\]\.added_mass\.radius_of_gyration: expected a radius >= 0",
        ),
    ],
)
def test_bad_mounting(folder, extra, pattern):
    refused(folder, HEAD + PLAIN + trial("m1.csv", '["disk"]', extra=extra + "\n"), pattern)


@pytest.mark.parametrize(
    "key", ["offset = { disk = 0.05 }", "added_mass = { mass = 1, com_distance = 0.1 }"]
)
def test_mounting_keys_are_per_trial_only(folder, key):
    refused(folder, HEAD + f"[defaults]\n{key}\n" + PLAIN, r"defaults\.\w+: per trial only")


# ------------------------------------------------------------------------------ simulator


BODIES = {b: (t.mass, t.radius_of_gyration, t.com_distance) for b, t in PAPER_TRUTH.items()}
D = 0.10  # the disk's second mounting, 10 cm further out


def test_simulated_mounting_and_weighing_reach_the_manifest(tmp_path):
    kwargs = {"bodies": BODIES, "trials_per_speed": 1, "speeds": (240.0,), "priors": PAPER_PRIORS}
    plain = simulate_study(tmp_path / "p", conditions=[("attachment",)], **kwargs)
    conditions = [
        ("attachment",),
        {"bodies": ("attachment", "weight"), "offset": {"weight": D}},
        {"bodies": ("attachment",), "added_mass": {"mass": 0.5, "com_distance": 0.3}},
    ]
    measured = {"attachment": {"mass": 0.005}, "weight": {"com_distance": (0.451, 0.002)}}
    path = simulate_study(tmp_path / "x", conditions=conditions, measured=measured, **kwargs)
    # measuring and more conditions leave the other trials' bytes alone
    for name in ("A_quasistatic.csv", "A_240_01.csv"):
        assert (path.parent / "data" / name).read_bytes() == (
            plain.parent / "data" / name
        ).read_bytes()
    study = load_study(path)
    value, sd = study.bodies["attachment"].measured["mass"]
    assert sd == 0.005
    assert value != 2.85  # drawn from the truth ...
    assert abs(value - 2.85) < 4 * sd  # ... with that SD
    assert study.bodies["weight"].measured["com_distance"] == (0.451, 0.002)  # as given
    assert list(study.conditions) == [
        "attachment",
        "attachment+weight@weight+10cm",
        "attachment+added0.5kg@30cm",
    ]
    truth = tomllib.loads((path.parent / "truth.toml").read_text(encoding="utf-8"))
    w, a = PAPER_TRUTH["weight"], PAPER_TRUTH["attachment"]
    assert truth["bodies"]["weight"]["com_distance"] == w.com_distance  # the body's own truth
    moved = w.mass * (w.radius_of_gyration**2 + (w.com_distance + D) ** 2)
    assert truth["conditions"]["B"]["inertia"] == pytest.approx(a.inertia + moved, rel=1e-12)
    assert truth["conditions"]["C"]["gravity_moment"] == pytest.approx(
        (a.mass * a.com_distance + 0.5 * 0.3) * 9.81, rel=1e-12
    )
    with pytest.raises(ValueError, match="offset"):
        simulate_study(
            tmp_path / "y",
            conditions=[{"bodies": ("attachment",), "offset": {"weight": D}}],
            **kwargs,
        )


# ------------------------------------------------------------------------------ posterior


def hdi_widths(post):
    s = post.summary(0.95).set_index(["body", "parameter"])
    return s, s["hdi_upper"] - s["hdi_lower"]


def test_second_mounting_and_weighing_narrow_the_posterior(tmp_path):
    """The disk is mounted twice (the second time 10 cm further out) and the attachment is
    weighed (SD 5 g); a third condition carries a known 0.5 kg mass. The posterior holds the
    truth, and is far narrower than from the two plain conditions alone."""
    conditions = [
        ("attachment",),
        ("attachment", "weight"),
        {"bodies": ("attachment", "weight"), "offset": {"weight": D}},
        {"bodies": ("attachment",), "added_mass": {"mass": 0.5, "com_distance": 0.3}},
    ]
    path = simulate_study(
        tmp_path,
        bodies=BODIES,
        conditions=conditions,
        trials_per_speed=3,
        speeds=(240.0,),
        priors=PAPER_PRIORS,
        noise=Noise.paper(),
        seed=4,
        measured={"attachment": {"mass": 0.005}},
    )
    processed = process_study(load_study(path))
    extra = study_model(processed)
    conds = {c.label: c for c in extra.conditions}
    added = conds["attachment+added0.5kg@30cm"]
    assert (added.added_first_moment, added.added_inertia) == pytest.approx((0.15, 0.045))
    assert (
        conds["attachment+weight@weight+10cm"].offset_body,
        conds["attachment+weight@weight+10cm"].offset,
    ) == ("weight", D)
    assert extra.measured["attachment"]["mass"].scale == 0.005
    plain = Model(
        extra.priors,
        [
            c
            for c in condition_evidence(processed)
            if c.label in ("attachment", "attachment+weight")
        ],
        gravity=extra.gravity,
    )
    settings = SamplerSettings(ess_min=400)
    s_extra, w_extra = hdi_widths(fit(extra, seed=2, settings=settings))
    _, w_plain = hdi_widths(fit(plain, seed=2, settings=settings))
    for body, true in PAPER_TRUTH.items():
        for name in ("mass", "com_distance", "radius_of_gyration"):
            row = s_extra.loc[(body, name)]
            assert row["hdi_lower"] <= getattr(true, name) <= row["hdi_upper"], (body, name)
    ratio = w_plain / w_extra
    print(ratio.round(2).to_string())
    assert ratio[("attachment", "mass")] > 30  # weighed to 5 g
    assert ratio[("attachment", "com_distance")] > 10
    assert ratio[("weight", "mass")] > 2.5  # the second mounting weighs the disk
    assert ratio[("weight", "com_distance")] > 2.5


# ------------------------------------------------------------------------------ fit_body, CLI

NUMBERS = {
    "inertia": 0.2052,
    "inertia_se": 0.002,
    "gravity_moment": 6.71,
    "gravity_moment_se": 0.02,
}


def test_fit_body_takes_a_weighing_and_a_balance_point():
    prior = "biodex-elbow-attachment"
    base = hdi_widths(fit_body(prior, seed=1, **NUMBERS))[1]
    s, w = hdi_widths(fit_body(prior, seed=1, mass=2.85, mass_sd=0.005, **NUMBERS))
    assert base[(prior, "mass")] / w[(prior, "mass")] > 30
    assert s.loc[(prior, "mass"), "hdi_lower"] < 2.85 < s.loc[(prior, "mass"), "hdi_upper"]
    s, w = hdi_widths(fit_body(prior, seed=1, com_distance=0.24, com_distance_sd=0.002, **NUMBERS))
    assert base[(prior, "com_distance")] / w[(prior, "com_distance")] > 5
    assert s.loc[(prior, "mass"), "hdi_lower"] < 2.85 < s.loc[(prior, "mass"), "hdi_upper"]
    with pytest.raises(InputError, match=r"^mass: needs its SD mass_sd too$"):
        fit_body(prior, mass=2.85, **NUMBERS)
    with pytest.raises(InputError, match=r"^com_distance_sd: needs the value com_distance too$"):
        fit_body(prior, com_distance_sd=0.01, **NUMBERS)


def test_fit_body_takes_measurements_as_data_the_same_as_its_keyword_pairs():
    # a Measurement (its quantity from the registry) is the pair of keywords, draw for draw
    prior = "biodex-elbow-attachment"
    mass = MEASURED_QUANTITIES["mass"]
    as_data = fit_body(prior, seed=1, measured=[Measurement(mass, 2.85, 0.005)], **NUMBERS)
    as_pair = fit_body(prior, seed=1, mass=2.85, mass_sd=0.005, **NUMBERS)
    assert np.array_equal(as_data.draws(prior, "mass"), as_pair.draws(prior, "mass"))
    assert measurements(mass=(2.85, 0.005), com_distance=(None, None)) == (
        Measurement(mass, 2.85, 0.005),
    )
    with pytest.raises(InputError, match=r"^mass: given twice$"):
        fit_body(
            prior, measured=measurements(mass=(2.85, 0.005)), mass=2.8, mass_sd=0.01, **NUMBERS
        )
    with pytest.raises(InputError, match=r"^mass_sd: must be positive"):
        fit_body(prior, measured=[Measurement(mass, 2.85, -1.0)], **NUMBERS)
    with pytest.raises(InputError, match=r"^measured: unknown quantity 'volume'"):
        measurements(volume=(1.0, 0.1))


CLI = ["fit", "--prior", "biodex-elbow-attachment", "--inertia", "0.2052", "--inertia-se", "0.002"]
CLI += ["--gravity-moment", "6.71", "--gravity-moment-se", "0.02"]


def test_cli_fit_with_mass(tmp_path, capsys, no_figures):
    assert main([*CLI, "--mass", "2.85", "--mass-sd", "0.005", "--out", str(tmp_path / "o")]) == 0
    summary = pd.read_csv(tmp_path / "o" / "summary.csv").set_index("parameter")
    assert summary.loc["mass", "hdi_upper"] - summary.loc["mass", "hdi_lower"] < 0.03
    assert np.isclose(summary.loc["mass", "median"], 2.85, atol=0.005)
    capsys.readouterr()
    assert main([*CLI, "--mass", "2.85", "--out", str(tmp_path / "p")]) == 2
    assert capsys.readouterr().err == "inertiafit: error: --mass: needs its SD --mass-sd too\n"
    assert main([*CLI, "--mass", "2.85", "--mass-sd", "-1", "--out", str(tmp_path / "p")]) == 2
    assert "--mass-sd: must be positive, got -1.0" in capsys.readouterr().err
