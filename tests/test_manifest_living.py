"""The manifest of a living segment (issue 19): living, [passive], [postures], posture, rest."""

import math

import pytest
from cases import PRIORS, TRUTH

from inertiafit.errors import InputError
from inertiafit.inference.priors import available_priors
from inertiafit.io import PassivePrior, Posture, load_passive_prior, load_study, shipped_dirs
from inertiafit.io.shipped import PASSIVE_ENTRIES
from inertiafit.passive import JOINTS
from inertiafit.processing.living import passive_basis
from inertiafit.simulate.study import simulate_study

BODIES = """\
[bodies.attachment]
prior = "biodex-elbow-attachment"
[bodies.forearm]
prior = { mass = 1.5, radius_of_gyration = 0.1, com_distance = 0.15 }
living = true
"""

PASSIVE = """\
[passive]
joint = "elbow"
joint_angle_at_zero = 90
stiffness = { mean = 1.5, sd = 0.3 }
range = [20.0, 140.0]
"""

POSTURES = """\
[postures.upright]
gravity_rotation = 0
[postures.tilted]
gravity_rotation = 45
gravity_rotation_sd = "free"
[postures.flat]
gravity_rotation = -10.5
gravity_rotation_sd = 0.5
axis_tilt = 90
"""

TRIALS = """\
[defaults]
posture = "upright"
[[trials]]
file = "A_qs.csv"
bodies = ["attachment"]
kind = "quasi-static"
[[trials]]
file = "F_qs.csv"
bodies = ["attachment", "forearm"]
kind = "quasi-static"
[[trials]]
file = "F_rest.csv"
bodies = ["attachment", "forearm"]
kind = "rest"
[[trials]]
file = "F_240.csv"
bodies = ["attachment", "forearm"]
kind = "fast"
speed = 240
[[trials]]
file = "F_qs_tilted.csv"
bodies = ["forearm", "attachment"]
kind = "quasi-static"
posture = "tilted"
"""

VALID = BODIES + PASSIVE + POSTURES + TRIALS


def trial_csv():
    rows = ["time,angle,velocity,torque"]
    rows += [f"{0.01 * k:.2f},{90 - 2.4 * k:.1f},-240,{1.5 + k}" for k in range(20)]
    return "\n".join(rows) + "\n"


@pytest.fixture
def folder(tmp_path):
    for name in ("A_qs", "F_qs", "F_rest", "F_240", "F_qs_tilted"):
        (tmp_path / f"{name}.csv").write_text(trial_csv())
    return tmp_path


def load(folder, text):
    path = folder / "study.toml"
    path.write_text(text)
    return load_study(path)


def test_a_living_manifest_loads_with_its_passive_prior_postures_and_trials(folder):
    study = load(folder, VALID)
    assert study.living_body == "forearm"
    assert [b.living for b in study.bodies.values()] == [False, True]

    passive = study.passive
    assert isinstance(passive, PassivePrior)
    assert passive.joint == "elbow"
    assert passive.joint_angle_at_zero == 90.0
    # overrides from the manifest, the rest from priors/passive/elbow.toml
    assert passive.stiffness == (1.5, 0.3)
    assert passive.range == (20.0, 140.0)
    assert passive.stop_moment == (0.0, 2.0)
    assert passive.stop_width == 10.0
    assert passive.damping == (0.1, 0.1)
    assert passive.hysteresis == (0.05, 0.1)
    assert passive.curve_scale is None  # the elbow has no literature curve
    assert passive.curve == "smooth"  # shaped by the data unless curve = "fixed"
    assert passive.sources["stiffness"] == "manifest"
    assert passive.sources["range"] == "manifest"
    shipped = load_passive_prior("elbow")["stiffness"]
    assert shipped["value"] == (1.1, 0.45)
    assert "Wiegner & Watts 1986" in shipped["source"]
    assert "(from abstracts)" in shipped["source"]
    assert "wide prior" in passive.sources["stop_moment"]
    assert "modelling choice" in passive.sources["damping"]
    assert set(passive.sources) == set(PASSIVE_ENTRIES) - {"curve_scale"}

    assert list(study.postures) == ["upright", "tilted", "flat"]  # manifest order
    assert study.postures["upright"] == Posture("upright", 0.0, 2.0, 0.0)
    assert study.postures["tilted"].gravity_rotation == 45.0
    assert study.postures["tilted"].gravity_rotation_sd == math.inf  # "free"
    assert study.postures["flat"] == Posture("flat", -10.5, 0.5, 90.0)

    assert [t.kind for t in study.trials] == [
        "quasi-static",
        "quasi-static",
        "rest",
        "fast",
        "quasi-static",
    ]
    assert [t.posture for t in study.trials] == ["upright"] * 4 + ["tilted"]
    assert study.trials[2].speed is None
    # postures do not split conditions: what is mounted does
    assert study.conditions == {
        "attachment": ("attachment",),
        "attachment+forearm": ("attachment", "forearm"),
    }
    assert study.read(4).attrs["posture"] == "tilted"
    assert study.read(2).attrs["kind"] == "rest"


def test_knee_prior_keeps_the_shipped_sources_and_its_curve(folder):
    text = VALID.replace('joint = "elbow"', 'joint = "knee"').replace(
        "range = [20.0, 140.0]\n", "curve_scale = { mean = 0.8, sd = 0.2 }\n"
    )
    passive = load(folder, text).passive
    assert passive is not None
    assert passive.curve_scale == (0.8, 0.2)
    assert passive.sources["curve_scale"] == "manifest"
    assert passive.damping == (0.41, 0.21)
    assert "pendulum test" in passive.sources["damping"]
    assert "from abstracts" in passive.sources["damping"]
    assert passive.range == (0.0, 120.0)
    assert "Riener & Edrich 1999" in load_passive_prior("knee")["curve_scale"]["source"]


def test_the_fixed_passive_curve_is_chosen_by_name(folder):
    text = VALID.replace(
        "joint_angle_at_zero = 90\n", 'joint_angle_at_zero = 90\ncurve = "fixed"\n'
    )
    passive = load(folder, text).passive
    assert passive is not None
    assert passive.curve == "fixed"
    assert not passive_basis(passive).smooth
    assert passive_basis(load(folder, VALID).passive).smooth


def test_without_postures_a_trial_has_none(folder):
    text = (
        BODIES
        + PASSIVE
        + TRIALS.replace('posture = "upright"\n', "").replace('posture = "tilted"\n', "")
    )
    study = load(folder, text)
    assert study.postures == {}
    assert {t.posture for t in study.trials} == {""}
    assert "posture" not in study.read(0).attrs


@pytest.mark.parametrize("joint", JOINTS)
def test_every_shipped_passive_prior_cites_every_number(joint):
    prior = load_passive_prior(joint)
    for key in PASSIVE_ENTRIES:
        if key == "curve_scale" and joint in ("elbow", "generic"):
            assert key not in prior
            continue
        assert len(prior[key]["source"]) > 20, (joint, key)


def test_passive_prior_files_are_not_body_priors():
    assert (shipped_dirs("passive")[0] / "elbow.toml").is_file()
    names = available_priors()
    assert not set(names) & set(JOINTS)
    assert all(p.parent.name == "priors" for p in names.values())


def _drop(text, line):
    assert line in text
    return text.replace(line, "")


BAD = {
    "two living bodies": (
        VALID.replace(
            'prior = "biodex-elbow-attachment"\n',
            'prior = "biodex-elbow-attachment"\nliving = true\n',
        ),
        r"bodies\.forearm\.living: one living body per study; 'attachment' is living already",
    ),
    "living without [passive]": (
        BODIES + POSTURES + TRIALS,
        r"passive: missing; body 'forearm' is living: add a \[passive\] table",
    ),
    "[passive] without living": (
        _drop(BODIES, "living = true\n") + PASSIVE + POSTURES + TRIALS,
        r"passive: no body is living; mark the living one with living = true",
    ),
    "unknown joint": (
        VALID.replace('joint = "elbow"', 'joint = "wrist"'),
        r"passive\.joint: unknown joint 'wrist' \(joints: elbow, knee, ankle, generic\)",
    ),
    "unknown key in [passive]": (
        VALID.replace("joint_angle_at_zero = 90\n", "joint_angle_at_zero = 90\nstiff = 1\n"),
        r"passive\.stiff: unknown key \(allowed: joint, joint_angle_at_zero, curve, stiffness,",
    ),
    "stiffness per degree": (
        VALID.replace(
            "stiffness = { mean = 1.5, sd = 0.3 }", "stiffness = { mean = 0.03, sd = 0.01 }"
        ),
        (
            r"passive\.stiffness: mean 0\.03 N m/rad is 37 times below .* looks like a value "
            r"per degree; give it per radian: \{ mean = 1\.72, sd = 0\.573 \}"
        ),
    ),
    "unknown passive curve": (
        VALID.replace(
            "joint_angle_at_zero = 90\n", 'joint_angle_at_zero = 90\ncurve = "spline"\n'
        ),
        r"passive\.curve: expected \"smooth\" \(shaped by the data\) or \"fixed\" .*got 'spline'",
    ),
    "unknown key in a posture": (
        VALID.replace("axis_tilt = 90\n", "axis_tilt = 90\ntilt = 3\n"),
        r"postures\.flat\.tilt: unknown key \(allowed: gravity_rotation, gravity_rotation_sd,",
    ),
    "sd = 0": (
        VALID.replace("sd = 0.3 }", "sd = 0 }"),
        r"passive\.stiffness\.sd: must be positive \(N m/rad\), got 0",
    ),
    "sd < 0": (
        VALID.replace("range = [20.0, 140.0]\n", "damping = { mean = 0.1, sd = -1 }\n"),
        r"passive\.damping\.sd: must be positive \(N m s/rad\), got -1",
    ),
    "range lo >= hi": (
        VALID.replace("range = [20.0, 140.0]", "range = [140.0, 20.0]"),
        r"passive\.range: expected two increasing joint angles \[lo, hi\] in deg",
    ),
    "curve_scale on the elbow": (
        VALID.replace("range = [20.0, 140.0]", "curve_scale = { mean = 1, sd = 0.5 }"),
        r"passive\.curve_scale: only the joints with a literature curve have one",
    ),
    "no joint_angle_at_zero": (
        _drop(VALID, "joint_angle_at_zero = 90\n"),
        r"passive\.joint_angle_at_zero: missing; the joint angle \(deg",
    ),
    "axis_tilt 120": (
        VALID.replace("axis_tilt = 90", "axis_tilt = 120"),
        r"postures\.flat\.axis_tilt: expected an angle in \[0, 90\] deg .* got 120",
    ),
    "gravity_rotation 400": (
        VALID.replace("gravity_rotation = 45", "gravity_rotation = 400"),
        r"postures\.tilted\.gravity_rotation: expected a number in \(-360, 360\) deg, got 400",
    ),
    "no gravity_rotation": (
        _drop(VALID, "gravity_rotation = -10.5\n"),
        r"postures\.flat\.gravity_rotation: missing;",
    ),
    "gravity_rotation_sd fixed": (
        VALID.replace('gravity_rotation_sd = "free"', 'gravity_rotation_sd = "fixed"'),
        r"postures\.tilted\.gravity_rotation_sd: expected an SD in deg \(> 0\) or \"free\"",
    ),
    "gravity_rotation_sd 0": (
        VALID.replace("gravity_rotation_sd = 0.5", "gravity_rotation_sd = 0"),
        r"postures\.flat\.gravity_rotation_sd: must be positive \(deg\), got 0",
    ),
    "posture undefined": (
        VALID.replace('posture = "tilted"', 'posture = "lying"'),
        r"trials\[4\]\.posture: unknown posture 'lying' \(postures: upright, tilted, flat\)",
    ),
    "posture undefined in [defaults]": (
        VALID.replace('posture = "upright"', 'posture = "lying"'),
        r"defaults\.posture: unknown posture 'lying'",
    ),
    "posture named without [postures]": (
        BODIES + PASSIVE + _drop(TRIALS, 'posture = "upright"\n'),
        r"trials\[4\]\.posture: no \[postures\] in the manifest to name",
    ),
    "trial without posture when postures exist": (
        BODIES + PASSIVE + POSTURES + _drop(TRIALS, 'posture = "upright"\n'),
        r"trials\[0\]\.posture: missing; with \[postures\] every trial names its posture",
    ),
    "rest trial in a rigid condition": (
        VALID.replace(
            'bodies = ["attachment"]\nkind = "quasi-static"',
            'bodies = ["attachment"]\nkind = "rest"',
        ),
        (
            r"trials\[0\]\.kind: \"rest\" \(a quiet hold of a living joint\) needs the living body "
            r"'forearm' mounted, got bodies attachment"
        ),
    ),
    "rest trial in a rigid study": (
        _drop(BODIES, "living = true\n") + POSTURES + TRIALS,
        r"trials\[2\]\.kind: \"rest\" .* needs a living body \(none is\) mounted",
    ),
    "speed on a rest trial": (
        VALID.replace('kind = "rest"\n', 'kind = "rest"\nspeed = 30\n'),
        r"trials\[2\]\.speed: a rest trial holds one angle: remove its speed",
    ),
    "rest trials alone in a living condition": (
        VALID.replace(
            'bodies = ["attachment", "forearm"]\nkind = "quasi-static"',
            'bodies = ["attachment", "forearm"]\nkind = "rest"',
        )
        .replace('kind = "fast"\nspeed = 240\n', 'kind = "rest"\n')
        .replace('kind = "quasi-static"\nposture = "tilted"', 'kind = "rest"\nposture = "tilted"'),
        (
            r"trials\[1\]\.kind: condition 'attachment\+forearm' holds the living body 'forearm' but "
            r"has no quasi-static trial; rest trials alone do not do"
        ),
    ),
    "damping mean < 0": (
        VALID.replace("range = [20.0, 140.0]\n", "damping = { mean = -0.1, sd = 0.1 }\n"),
        r"passive\.damping\.mean: must not be negative \(N m s/rad\), got -0\.1",
    ),
    "stop_width 0": (
        VALID.replace("range = [20.0, 140.0]\n", "stop_width = 0\n"),
        r"passive\.stop_width: must be positive \(deg\), got 0",
    ),
    "an override with a unit": (
        VALID.replace("sd = 0.3 }", 'sd = 0.3, unit = "N m/deg" }'),
        r"passive\.stiffness: expected \{ mean = \.\.\., sd = \.\.\. \} \(N m/rad\), got",
    ),
    "a posture name that cannot name a file": (
        VALID.replace("[postures.flat]", '[postures."flat/table"]'),
        r"postures: posture 'flat/table': expected no '/' in a name",
    ),
    'living = "yes"': (
        VALID.replace("living = true", 'living = "yes"'),
        r"bodies\.forearm\.living: expected true or false, got 'yes'",
    ),
}


@pytest.mark.parametrize("case", BAD)
def test_each_bad_living_value_is_one_line_naming_the_key(folder, case):
    text, pattern = BAD[case]
    path = folder / "study.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=r"study\.toml: " + pattern) as info:
        load_study(path)
    assert "\n" not in str(info.value)


def test_a_rigid_simulated_study_has_no_living_body_posture_or_passive_prior(tmp_path):
    path = simulate_study(
        tmp_path,
        bodies=TRUTH,
        conditions=[("attachment",), ("attachment", "weight")],
        speeds=(240.0,),
        trials_per_speed=1,
        priors=PRIORS,
    )
    study = load_study(path)
    assert study.living_body == ""
    assert study.passive is None
    assert study.postures == {}
    assert not any(b.living for b in study.bodies.values())
    assert [t.kind for t in study.trials] == ["quasi-static", "fast"] * 2
    assert {t.posture for t in study.trials} == {""}
    assert "posture" not in study.read(1).attrs
