"""Simulated living-limb studies: the joint's moments, postures, rest trials and their files."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from inertiafit.simulate import (
    Motion,
    Noise,
    PassiveTruth,
    simulate_living_study,
    simulate_study,
    simulate_trial,
)
from inertiafit.simulate.living import HYSTERESIS_SPEED, POSTURE_DESIGNS

DEG = math.pi / 180
#: Short sweeps (10 deg/s) and one fast trial per speed: every file of a study in a second.
QUICK = {"quasi_static_speed": 10.0, "trials_per_speed": 1, "speeds": (180.0,)}


def study(path: Path, **kwargs) -> tuple[dict, dict]:
    """Write a living study; its manifest and truth as TOML tables."""
    manifest = simulate_living_study(path, **{**QUICK, **kwargs})
    truth = tomllib.loads((path / "truth.toml").read_text(encoding="utf-8"))
    return tomllib.loads(manifest.read_text(encoding="utf-8")), truth


def read(path: Path, entry: dict) -> dict[str, np.ndarray]:
    """A trial's CSV in SI units (the study's default units: s, deg, deg/s, N m)."""
    t, angle, velocity, torque = np.loadtxt(path / entry["file"], delimiter=",", skiprows=1).T
    return {"time": t, "angle": angle * DEG, "velocity": velocity * DEG, "torque": torque}


def model_torque(trial: dict[str, np.ndarray], truth: dict, condition: str, posture: str):
    """The issue's model written out (not through inertiafit.passive), and where it holds.

    The acceleration is the velocity's central difference, exact on the piecewise-linear
    noise-free profile; the few samples at the profile's corners, where it is not, are masked.
    """
    theta, omega, t = trial["angle"], trial["velocity"], trial["time"]
    dt = t[1] - t[0]
    ahead = np.diff(omega, append=omega[-1]) / dt
    behind = np.diff(omega, prepend=omega[0]) / dt
    smooth = np.isclose(ahead, behind, atol=1e-3)
    alpha = 0.5 * (ahead + behind)
    cond = truth["conditions"][condition]
    p = truth["passive"]
    rot = truth["passive"]["postures"][posture]
    tilt = rot["axis_tilt"] * DEG
    gravity = (
        0.0
        if rot["axis_tilt"] == 90
        else math.cos(tilt)
        * cond["gravity_moment"]
        * np.sin(theta + rot["gravity_rotation"] * DEG)
    )
    rigid = cond["inertia"] * alpha + gravity + truth["offset"]
    if condition == "A":
        return rigid, smooth
    j = p["joint_angle_at_zero"] * DEG + theta
    lo, hi = (v * DEG for v in p["range"])
    w = p["stop_width"] * DEG
    elastic = (
        p["stiffness"] * (j - p["relaxed_angle"] * DEG)
        + p["stop_moment_high"] * np.exp((j - hi) / w)
        - p["stop_moment_low"] * np.exp((lo - j) / w)
    )
    viscous = p["damping"] * omega + p["hysteresis"] * np.tanh(omega / HYSTERESIS_SPEED)
    return rigid + elastic + viscous, smooth


@pytest.mark.parametrize("design", ["two", "horizontal"])
def test_every_trial_is_the_living_model_at_the_truth(tmp_path, design):
    manifest, truth = study(tmp_path, seed=4, postures=design, noise=Noise.none(), offset=0.3)
    assert truth["passive"]["stiffness"] > 0.4  # a joint is there to be found
    kinds = set()
    for entry in manifest["trials"]:
        trial = read(tmp_path, entry)
        condition = "B" if "forearm" in entry["bodies"] else "A"
        expected, smooth = model_torque(trial, truth, condition, entry["posture"])
        assert smooth.mean() > 0.99
        np.testing.assert_allclose(trial["torque"][smooth], expected[smooth], atol=2e-6)
        kinds.add((condition, entry["kind"]))
    assert kinds == {
        ("A", "quasi-static"),
        ("A", "fast"),
        ("B", "quasi-static"),
        ("B", "fast"),
        ("B", "rest"),
    }


def test_the_joint_adds_its_moments_to_a_rigid_trial_and_nothing_else():
    joint = PassiveTruth(
        joint="elbow",
        joint_angle_at_zero=30.0,
        stiffness=1.2,
        relaxed_angle=100.0,
        stop_moment_low=0.3,
        stop_moment_high=0.2,
        stop_width=10.0,
        range=(30.0, 120.0),
        curve_scale=0.0,
        damping=0.2,
        hysteresis=0.08,
    )
    common = {"inertia": 0.24, "gravity_moment": 8.6, "phi": 0.1, "offset": 0.2}
    exact = {"angle_step": 0.0, "velocity_sd": 0.0}  # channels that show the true motion
    cases = [
        ("fast", Noise(**exact), 0),
        ("fast", Noise(lag=0.003, **exact), 3),  # the torque channel 3 samples behind
        ("quasi-static", Noise(**exact), 0),
        ("rest", Noise(**exact), 0),
    ]
    for kind, noise, lag in cases:
        motion = Motion(start=40 * DEG) if kind == "rest" else Motion(start=90 * DEG, end=0.0)
        args = {**common, "kind": kind, "noise": noise, "motion": motion, "rng": 3}
        rigid = simulate_trial(**args)
        living = simulate_trial(extra_torque=joint.torque, **args)
        # The same draws: the channels other than the torque are bit for bit the rigid trial's.
        assert np.array_equal(living["angle"].values, rigid["angle"].values)
        assert np.array_equal(living["velocity"].values, rigid["velocity"].values)
        added = living["torque"].values - rigid["torque"].values
        theta = np.roll(rigid["angle"].values, lag)
        omega = np.roll(rigid["velocity"].values, lag)
        theta[:lag], omega[:lag] = motion.start, 0.0
        np.testing.assert_allclose(added, joint.torque(theta, omega), atol=1e-9)
        if kind != "rest":  # the joint's moments move the torque by more than its noise
            assert np.ptp(added) > 1.0
    # At rest only the elastic moment: no damping, no hysteresis.
    assert added == pytest.approx(float(joint.elastic(40 * DEG)), abs=1e-12)


def test_a_rest_trial_holds_still_and_sweeps_go_both_ways(tmp_path):
    manifest, _ = study(tmp_path, seed=1, postures="two")
    by_name = {Path(e["file"]).name: e for e in manifest["trials"]}
    for posture in POSTURE_DESIGNS["two"]:
        up = read(tmp_path, by_name[f"B_{posture}_quasistatic_up.csv"])
        down = read(tmp_path, by_name[f"B_{posture}_quasistatic_down.csv"])
        assert up["angle"][0] == 0.0
        assert up["angle"][-1] == pytest.approx(90 * DEG, abs=0.1 * DEG)
        assert down["angle"][0] == pytest.approx(90 * DEG, abs=0.1 * DEG)
        assert down["angle"][-1] == pytest.approx(0.0, abs=0.1 * DEG)
        assert np.all(np.diff(up["angle"]) >= 0)
        assert np.all(np.diff(down["angle"]) <= 0)
        assert np.median(up["velocity"]) == pytest.approx(10 * DEG, rel=0.02)
        assert np.median(down["velocity"]) == pytest.approx(-10 * DEG, rel=0.02)
        for k, angle in enumerate((15.0, 45.0, 75.0), start=1):
            rest = read(tmp_path, by_name[f"B_{posture}_rest_{k}.csv"])
            assert np.all(rest["angle"] == pytest.approx(angle * DEG, abs=1e-9))
            assert rest["time"][-1] == pytest.approx(5.0)
            # Velocity: channel noise alone (0.5 deg/s white) about zero.
            assert abs(np.mean(rest["velocity"])) < 0.05 * DEG
            assert np.std(rest["velocity"]) == pytest.approx(0.5 * DEG, rel=0.1)


def test_horizontal_posture_has_no_gravity_part(tmp_path):
    _, truth = study(tmp_path, seed=2, postures="horizontal", noise=Noise.none())
    data = tmp_path / "data"
    assert truth["passive"]["postures"]["horizontal"]["axis_tilt"] == 90.0
    p = PassiveTruth(
        joint="elbow",
        joint_angle_at_zero=truth["passive"]["joint_angle_at_zero"],
        range=tuple(truth["passive"]["range"]),
        **{
            k: v
            for k, v in truth["passive"].items()
            if k not in ("joint", "joint_angle_at_zero", "range", "postures")
        },
    )
    for k in (1, 2, 3):
        rest = {
            posture: read(tmp_path, {"file": data / f"B_{posture}_rest_{k}.csv"})
            for posture in ("upright", "horizontal")
        }
        theta = rest["horizontal"]["angle"][0]
        # The horizontal plane: the elastic moment and the offset alone.
        assert rest["horizontal"]["torque"] == pytest.approx(float(p.elastic(theta)), abs=1e-9)
        # Upright: the condition's gravity on top of it.
        gravity = truth["conditions"]["B"]["gravity_moment"] * math.sin(theta)
        assert rest["upright"]["torque"] - rest["horizontal"]["torque"] == pytest.approx(
            gravity, abs=1e-8
        )
        assert abs(gravity) > 1.0


def test_manifest_has_the_living_keys(tmp_path):
    manifest, truth = study(tmp_path, seed=0, postures="two", fast_directions=("up", "down"))
    assert manifest["bodies"]["forearm"] == {
        "prior": {"mass": 1.5, "radius_of_gyration": 0.08, "com_distance": 0.15},
        "living": True,
    }
    assert "living" not in manifest["bodies"]["attachment"]
    assert manifest["passive"] == {
        "joint": "elbow",
        "joint_angle_at_zero": 30.0,
        "range": [30.0, 120.0],
        "stop_width": 10.0,
    }
    assert manifest["postures"] == {
        "upright": {"gravity_rotation": 0.0, "gravity_rotation_sd": 2.0, "axis_tilt": 0.0},
        "rotated": {"gravity_rotation": 45.0, "gravity_rotation_sd": 2.0, "axis_tilt": 0.0},
    }
    counts: dict[tuple, int] = {}
    for entry in manifest["trials"]:
        assert entry["posture"] in manifest["postures"]
        assert ("speed" in entry) == (entry["kind"] == "fast")
        assert (tmp_path / entry["file"]).is_file()
        key = (tuple(entry["bodies"]), entry["posture"], entry["kind"])
        counts[key] = counts.get(key, 0) + 1
    rigid, living = ("attachment",), ("attachment", "forearm")
    assert counts == {
        (rigid, "upright", "quasi-static"): 1,
        (rigid, "upright", "fast"): 1,
        (living, "upright", "quasi-static"): 2,
        (living, "upright", "rest"): 3,
        (living, "upright", "fast"): 2,
        (living, "rotated", "quasi-static"): 2,
        (living, "rotated", "rest"): 3,
        (living, "rotated", "fast"): 2,
    }
    # The truth: the second posture's setup off its nominal 45 deg by a 2 deg SD draw.
    assert truth["passive"]["postures"]["upright"]["gravity_rotation"] == 0.0
    assert truth["passive"]["postures"]["rotated"]["gravity_rotation"] == pytest.approx(45, abs=8)
    assert truth["passive"]["postures"]["rotated"]["gravity_rotation"] != 45.0
    assert truth["conditions"]["B"]["inertia"] == pytest.approx(
        0.19649775 + 1.5 * (0.08**2 + 0.15**2)
    )


def test_same_seed_same_files_and_another_seed_another_truth(tmp_path):
    for run in ("a", "b"):
        simulate_living_study(tmp_path / run, seed=7, **QUICK)
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*.*"))
    assert len(files) == 2 + 2 + 2 + 3 + 1
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()
    _, other = study(tmp_path / "c", seed=8)
    same = tomllib.loads((tmp_path / "a" / "truth.toml").read_text(encoding="utf-8"))
    for key in ("stiffness", "relaxed_angle", "damping", "hysteresis", "stop_moment_low"):
        assert other["passive"][key] != same["passive"][key]


def test_the_drawn_joint_spans_the_published_ranges():
    rng = np.random.default_rng(0)
    draws = [
        PassiveTruth.draw(rng, joint_angle_at_zero=30.0, joint_range=(30.0, 120.0))
        for _ in range(400)
    ]
    k = np.array([d.stiffness for d in draws])
    b = np.array([d.damping for d in draws])
    h = np.array([d.hysteresis for d in draws])
    stops = np.array([(d.stop_moment_low, d.stop_moment_high) for d in draws])
    relaxed = np.array([d.relaxed_angle for d in draws])
    # Uniform over the ranges: every draw inside, the extremes of 400 draws near the ends.
    for values, (lo, hi) in (
        (k, (0.4, 1.8)),
        (b, (0.02, 0.25)),
        (h, (0.0, 0.1)),
        (stops, (0.1, 0.5)),
    ):
        assert np.all((values >= lo) & (values <= hi))
        assert (values.min(), values.max()) == pytest.approx((lo, hi), abs=0.03 * (hi - lo))
    assert np.mean(relaxed) == pytest.approx(107, abs=3 * 10 / 20)
    assert np.std(relaxed) == pytest.approx(10, rel=0.15)
    assert {d.curve_scale for d in draws} == {0.0}
    # Giving a value keeps it and leaves every other draw as it was.
    again = PassiveTruth.draw(
        np.random.default_rng(0),
        joint_angle_at_zero=30.0,
        joint_range=(30.0, 120.0),
        given={"stiffness": 1.0, "damping": 0.0},
    )
    assert (again.stiffness, again.damping) == (1.0, 0.0)
    assert again.relaxed_angle == draws[0].relaxed_angle
    assert again.hysteresis == draws[0].hysteresis


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"postures": "three"}, "postures must be one of"),
        ({"postures": {"tilted": (0.0, 120.0)}}, "axis tilt in"),
        ({"living": "shank"}, "living body 'shank'"),
        ({"sweeps": ()}, "sweeps must be one or both"),
        ({"fast_directions": ("sideways",)}, "fast_directions"),
        ({"passive": {"stifness": 1.0}}, "unknown keys"),
        ({"passive": {"damping": -0.1}}, "damping must be >= 0"),
        ({"joint": "hip"}, "joint must be one of"),
        ({"gravity_rotation_sd": 0.0}, "gravity_rotation_sd"),
        ({"passive_prior": {"range": [0, 90]}}, "written from the truth"),
    ],
)
def test_bad_arguments_are_refused(tmp_path, kwargs, match):
    with pytest.raises(ValueError, match=match):
        simulate_living_study(tmp_path, **kwargs)


def test_a_rest_trial_takes_no_speed():
    with pytest.raises(ValueError, match="a rest trial has no speed"):
        simulate_trial(inertia=0.2, gravity_moment=6.0, kind="rest", speed_deg_s=1.0)
    with pytest.raises(ValueError, match="hold must be positive"):
        simulate_trial(inertia=0.2, gravity_moment=6.0, kind="rest", motion=Motion(hold=0.0))


def test_rigid_studies_are_as_before_the_living_simulator(tmp_path):
    """Values written by ``simulate_study`` before the living simulator existed (to 1e-8).

    Every random draw goes into these numbers: a changed draw order would move them by
    whole noise SDs, not in their last digits.
    """
    simulate_study(
        tmp_path,
        bodies={"attachment": (2.91, 0.13, 0.225), "forearm": (1.5, 0.08, 0.15)},
        conditions=[("attachment",), ("attachment", "forearm")],
        speeds=(180.0,),
        trials_per_speed=2,
        seed=11,
    )
    before = {
        "A_quasistatic.csv": [
            [0.0, 0.0, 0.2929873946, 0.5255242604],
            [0.15, 0.0, 0.05690950478, 0.1198116183],
            [0.3, 0.1, 0.1125278731, 0.5522947463],
            [0.45, 0.2, 0.5313601445, -0.5703494562],
        ],
        "B_180_02.csv": [
            [0.0, 0.0, 0.4854553427, 0.243783365],
            [0.15, 0.0, 0.3921196103, 0.04758484666],
            [0.3, 9.9, 180.7249458, 1.766867441],
            [0.45, 36.9, 179.3527081, 5.11210305],
        ],
    }
    sizes = {"A_quasistatic.csv": 90402, "B_180_02.csv": 991}
    for name, rows in before.items():
        x = np.loadtxt(tmp_path / "data" / name, delimiter=",", skiprows=1)
        assert x.shape == (sizes[name], 4)
        np.testing.assert_allclose(x[[0, 150, 300, 450]], rows, rtol=1e-8, atol=1e-9)


@pytest.mark.parametrize("design", ["one", "two", "horizontal"])
def test_the_manifest_loads(tmp_path, design):
    from inertiafit.io import load_study

    manifest, truth = study(tmp_path, seed=3, postures=design)
    loaded = load_study(tmp_path / "study.toml")
    assert loaded.living_body == "forearm"
    assert loaded.passive is not None
    assert loaded.passive.joint == "elbow"
    assert loaded.passive.joint_angle_at_zero == 30.0
    assert loaded.passive.range == (30.0, 120.0)
    assert loaded.passive.sources["range"] == "manifest"
    assert {name: (p.gravity_rotation, p.axis_tilt) for name, p in loaded.postures.items()} == (
        POSTURE_DESIGNS[design]
    )
    assert [(t.kind, t.posture) for t in loaded.trials] == [
        (t["kind"], t["posture"]) for t in manifest["trials"]
    ]
    assert truth["passive"]["range"] == [30.0, 120.0]


def test_a_knee_alone_has_its_literature_curve(tmp_path):
    manifest, truth = study(
        tmp_path,
        seed=5,
        bodies={"shank": (3.5, 0.1, 0.2)},
        living="shank",
        joint="knee",
        joint_angle_at_zero=10.0,
        noise=Noise.none(),
    )
    assert set(truth["conditions"]) == {"B"}
    assert {tuple(e["bodies"]) for e in manifest["trials"]} == {("shank",)}
    assert manifest["bodies"]["shank"]["living"] is True
    p = truth["passive"]
    assert p["range"] == [10.0, 100.0]
    assert 0.5 <= p["curve_scale"] <= 1.5
    # A rest trial: gravity, the spring, the stops and the scaled Riener & Edrich curve.
    rest = read(tmp_path, {"file": "data/B_upright_rest_2.csv"})
    knee = 10.0 + 45.0
    curve = -(
        math.exp(1.800 - 0.0352 * knee + 0.0217 * 90)
        - math.exp(-3.971 + 0.0495 * knee - 0.0128 * 90)
        - 4.820
        + math.exp(2.220 - 0.150 * knee)
    )
    expected = (
        truth["conditions"]["B"]["gravity_moment"] * math.sin(45 * DEG)
        + p["stiffness"] * (knee - p["relaxed_angle"]) * DEG
        + p["stop_moment_high"] * math.exp((knee - 100.0) / 10.0)
        - p["stop_moment_low"] * math.exp((10.0 - knee) / 10.0)
        + p["curve_scale"] * curve
    )
    assert rest["torque"] == pytest.approx(expected, abs=1e-8)
    assert abs(p["curve_scale"] * curve) > 0.5
