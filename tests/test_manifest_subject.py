"""Who the subject is (issue 33, item 1): ``[subject]`` and each body's ``segment_length``.

Read as a section of the manifest, checked value by value (a one-line error naming the key
and what was expected, the likely unit slip named), and recorded in ``posterior.nc`` for a
population of studies.
"""

import json

import pytest
from cases import one_condition_study

from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.io import load_study
from inertiafit.io.sections.subject import Subject
from inertiafit.posterior import open_posterior

SUBJECT = """\
[subject]
id = "S07"
body_mass = 72.5
height = 1.78
sex = "female"
age = 34
forearm_girth = 0.27
"""


@pytest.fixture(scope="module")
def study_dir(tmp_path_factory):
    return one_condition_study(tmp_path_factory.mktemp("subject") / "study")


def _with(study_dir, tmp_path, head: str, body_extra: str = ""):
    text = (study_dir / "study.toml").read_text(encoding="utf-8")
    text = text.replace("[bodies.attachment]\n", f"[bodies.attachment]\n{body_extra}", 1)
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "data").symlink_to(study_dir / "data")
    path = folder / "study.toml"
    # a table goes after the others; a top-level key before the first table
    text = text + "\n" + head if head.startswith("[") else head + "\n" + text
    path.write_text(text, encoding="utf-8")
    return path


def test_the_subject_and_a_segment_length_are_read(study_dir, tmp_path):
    study = load_study(_with(study_dir, tmp_path, SUBJECT, "segment_length = 0.28\n"))
    assert study.subject == Subject(
        "S07", 72.5, 1.78, "female", {"age": 34.0, "forearm_girth": 0.27}
    )
    assert study.bodies["attachment"].segment_length == 0.28
    # without them (negative control): none, and the study reads as before
    plain = load_study(study_dir / "study.toml")
    assert plain.subject is None
    assert plain.bodies["attachment"].segment_length is None


@pytest.mark.parametrize(
    ("head", "extra", "expected"),
    [
        ("[subject]\nbody_mass = 70\n", "", r"subject\.id: missing; the subject's name"),
        (
            "[subject]\nid = 7\nbody_mass = 70\n",
            "",
            r"subject\.id: expected a name \(a string\), got 7",
        ),
        (
            '[subject]\nid = "a/b"\nbody_mass = 70\n',
            "",
            r"subject\.id: subject id 'a/b': expected no '/'",
        ),
        (
            '[subject]\nid = "S1"\n',
            "",
            r"subject\.body_mass: missing; the subject's body mass in kg",
        ),
        (
            '[subject]\nid = "S1"\nbody_mass = 72500\n',
            "",
            r"subject\.body_mass: expected 1 to 500 kg, got 72500 \(a mass in g or lb\?\)",
        ),
        (
            '[subject]\nid = "S1"\nbody_mass = "72"\n',
            "",
            r"subject\.body_mass: expected a number in kg, got '72'",
        ),
        (
            '[subject]\nid = "S1"\nbody_mass = 72\nheight = 178\n',
            "",
            r"subject\.height: expected 0\.3 to 2\.8 m, got 178 \(in cm\?\)",
        ),
        (
            '[subject]\nid = "S1"\nbody_mass = 72\nsex = "f"\n',
            "",
            r'subject\.sex: expected "female" or "male", got \'f\'',
        ),
        (
            '[subject]\nid = "S1"\nbody_mass = 72\nhanded = "left"\n',
            "",
            r"subject\.handed: expected a number \(a covariate of your own\), got 'left'",
        ),
        (
            '[subject]\nid = "S1"\nbody_mass = 72\nage = true\n',
            "",
            r"subject\.age: expected a number \(a covariate of your own\), got True",
        ),
        ("subject = 72\n", "", r"subject: expected a table"),
        (
            "",
            "segment_length = 28\n",
            r"bodies\.attachment\.segment_length: expected 0\.01 to 2 m, got 28 \(in cm\?\)",
        ),
        (
            "",
            'segment_length = "0.28"\n',
            r"bodies\.attachment\.segment_length: expected a length in m, got '0\.28'",
        ),
    ],
)
def test_every_bad_value_is_one_line(study_dir, tmp_path, head, extra, expected):
    with pytest.raises(InputError, match=r"study\.toml: " + expected) as err:
        load_study(_with(study_dir, tmp_path, head, extra))
    assert "\n" not in str(err.value)


def test_the_subject_is_recorded_in_the_posterior(study_dir, tmp_path, no_figures):
    manifest = _with(study_dir, tmp_path, SUBJECT, "segment_length = 0.28\n")
    out = tmp_path / "out"
    assert main(["run", str(manifest), "--out", str(out)]) == 0
    inputs = json.loads(open_posterior(out / "posterior.nc").tree.attrs["inputs"])
    assert inputs["subject"] == {
        "id": "S07",
        "body_mass": 72.5,
        "height": 1.78,
        "sex": "female",
        "covariates": {"age": 34.0, "forearm_girth": 0.27},
    }
    assert inputs["segment_length"] == {"attachment": 0.28}
