"""The planner with a living body: postures and rest trials as design choices."""

import math
from pathlib import Path

import pytest

from inertiafit.errors import InputError
from inertiafit.planning.design import design_variants
from inertiafit.planning.files import load_plan_file
from inertiafit.planning.planner import plan

HEAD = """
[bodies.attachment]
mass = 2.91
radius_of_gyration = 0.13
com_distance = 0.225
prior = "biodex-elbow-attachment"

[bodies.forearm]
mass = 1.5
radius_of_gyration = 0.08
com_distance = 0.15
living = true

[passive]
joint = "elbow"
joint_angle_at_zero = 30
range = [30, 120]

[postures.upright]
gravity_rotation = 0
[postures.tilted]
gravity_rotation = 45
[postures.plane]
gravity_rotation = 0
axis_tilt = 90

[defaults]
conditions = [["attachment"], ["attachment", "forearm"]]
speeds = [180]
trials_per_speed = 5
quasi_static_trials = 2
"""

DESIGNS = """
[[designs]]
name = "one posture"

[[designs]]
name = "two postures"
postures = ["upright", "tilted"]

[[designs]]
name = "horizontal plane"
postures = ["upright", "plane"]

[[designs]]
name = "rest trials"
rest_trials = 3
"""


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "design.toml"
    path.write_text(HEAD + text, encoding="utf-8")
    return path


def test_postures_narrow_the_living_gravity_moment(tmp_path):
    result = plan(**load_plan_file(_file(tmp_path, DESIGNS)), seed=0)
    table = result.table
    width = {
        d: float(
            table[
                (table.design == d)
                & (table.body == "forearm")
                & (table.parameter == "gravity_moment")
            ]["hdi_width"].iloc[0]
        )
        for d in ("one posture", "two postures", "horizontal plane", "rest trials")
    }
    # the passive prior alone separates M_g from the passive curve in one posture; a second
    # posture, better the horizontal plane, lets the data do it
    assert width["two postures"] < 0.85 * width["one posture"]
    assert width["horizontal plane"] < 0.2 * width["one posture"]
    assert width["rest trials"] <= width["one posture"]
    n = dict(zip(table.design, table.n_trials, strict=False))
    assert n["one posture"] == 2 * (5 + 2)  # each condition: 5 fast + 2 sweeps
    assert n["two postures"] == (5 + 2) + 2 * (5 + 2)  # the living condition in both postures
    assert n["rest trials"] == (5 + 2) + (5 + 2 + 3)
    rigid = table[(table.body == "attachment") & (table.parameter == "gravity_moment")]
    assert math.isclose(rigid["hdi_width"].max(), rigid["hdi_width"].min(), rel_tol=0.2)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[[designs]]\nname = "w"\nweigh = { forearm = 0.02 }\n', "living: it cannot be weighed"),
        ('[[designs]]\nname = "b"\nbalance = { forearm = 0.005 }\n', "cannot be weighed or bal"),
        (
            (
                '[[designs]]\nname = "o"\nconditions = [["attachment"], { bodies = ["attachment", '
                '"forearm"], offset = { forearm = 0.05 } }]\n'
            ),
            "cannot be moved along the lever",
        ),
        ('[[designs]]\nname = "p"\npostures = ["sideways"]\n', "unknown posture 'sideways'"),
        ('[[designs]]\nname = "r"\nrest_trials = -1\n', "rest_trials: expected a whole number"),
        ('[[designs]]\nname = "s"\nrotation_sweeps = 1\n', "rotation_sweeps: expected true or"),
        (
            (
                '[[designs]]\nname = "t"\nconditions = [["attachment", "forearm"]]\n'
                "rotation_sweeps = true\n"
            ),
            "rotation_sweeps: no rigid condition",
        ),
    ],
)
def test_a_living_body_is_never_weighed_or_remounted(tmp_path, text, message):
    with pytest.raises(InputError, match=message) as err:
        plan(**load_plan_file(_file(tmp_path, text)), seed=0)
    assert "\n" not in str(err.value)


def test_a_rigid_sweep_in_the_second_posture_is_predicted_to_pin_the_gravity_moment(tmp_path):
    # With a smooth passive curve two postures measure M_g only through their rotation: the
    # attachment swept in the second posture as well measures it, one trial more, and the
    # plan predicts the forearm's M_g interval several times narrower
    text = (
        DESIGNS
        + '[[designs]]\nname = "measured"\npostures = ["upright", "tilted"]\n'
        + "rotation_sweeps = true\n"
    )
    table = plan(**load_plan_file(_file(tmp_path, text)), seed=0).table
    forearm = table[(table.body == "forearm") & (table.parameter == "gravity_moment")]
    width = dict(zip(forearm.design, forearm.hdi_width, strict=True))
    assert width["measured"] < 0.35 * width["two postures"]
    assert width["measured"] < 0.3  # the aim for two postures: 25 % or less
    n = dict(zip(table.design, table.n_trials, strict=False))
    assert n["measured"] == n["two postures"] + 1


def test_variants_never_weigh_or_remount_the_living_body(tmp_path):
    design = load_plan_file(_file(tmp_path, '[[designs]]\nname = "base"\n'))["designs"][0]
    with pytest.raises(InputError, match="living"):
        design_variants(design, [5], {"forearm": 0.02}, {})
    with pytest.raises(InputError, match="remounted"):
        design_variants(design, [5], {}, {"forearm": [0.05]})
    assert len(design_variants(design, [5], {"attachment": 0.02}, {})) == 2


def test_postures_without_a_living_body_are_refused(tmp_path):
    text = HEAD.replace("living = true\n", "").split("[passive]")[0]
    path = tmp_path / "design.toml"
    path.write_text(
        text + '[defaults]\nconditions = [["attachment"]]\n[[designs]]\nname = "x"\n'
        "rest_trials = 2\n",
        encoding="utf-8",
    )
    with pytest.raises(InputError, match="rest_trials: for a living body"):
        load_plan_file(path)
