import math
from pathlib import Path

import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.io import BodySpec, Study, TrialSpec, load_study, read_trial_spec

DATA = Path(__file__).parent / "data"

BODIES = """\
name = "Elbow attachment with 3 kg disk"
gravity = 9.80665
description = "test study"
[bodies.attachment]
prior = "biodex-elbow-attachment"
[bodies.weight]
prior = { mass = 2.92, radius_of_gyration = 0.035, com_distance = 0.45, spread = 0.5 }
ideal = { shape = "solid disk" }
"""

TRIALS = """\
[defaults]
columns = { time = "t", torque = "moment" }
units = { time = "ms", torque = "N*m" }
[[trials]]
file = "data/A_qs.csv"
bodies = ["attachment"]
kind = "quasi-static"
[[trials]]
file = "data/A_240_01.csv"
bodies = ["attachment"]
kind = "fast"
speed = 240
window = [0.1, 0.2]
[[trials]]
file = "data/B_qs.csv"
bodies = ["weight", "attachment"]
kind = "quasi-static"
torque_sign = -1
units = { torque = "ft*lbf" }
[[trials]]
file = "data/B_240_01.csv"
bodies = ["weight", "attachment"]
kind = "fast"
speed = 240.0
columns = { angle = "theta" }
"""


def trial_csv(angle="angle"):
    rows = [f"t,{angle},velocity,moment"]
    rows += [f"{10 * k},{90 - 2.4 * k:.1f},-240,{1.5 + k}" for k in range(20)]
    return "\n".join(rows) + "\n"


@pytest.fixture
def study_dir(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    for name in ("A_qs", "A_240_01", "B_qs"):
        (data / f"{name}.csv").write_text(trial_csv())
    (data / "B_240_01.csv").write_text(trial_csv(angle="theta"))
    return tmp_path


def manifest(study_dir, text, name="study.toml"):
    path = study_dir / name
    path.write_text(text)
    return path


def test_load_study(study_dir):
    study = load_study(manifest(study_dir, BODIES + TRIALS))
    assert isinstance(study, Study)
    assert study.name == "Elbow attachment with 3 kg disk"
    assert study.gravity == 9.80665
    assert study.description == "test study"
    assert study.path == (study_dir / "study.toml").resolve()
    assert study.base_dir == study_dir.resolve()
    assert list(study.bodies) == ["attachment", "weight"]
    assert study.bodies["attachment"] == BodySpec("attachment", "biodex-elbow-attachment", None)
    assert study.bodies["weight"].prior["mass"] == 2.92  # kept raw
    assert study.bodies["weight"].ideal == {"shape": "solid disk"}
    assert len(study.trials) == 4
    a_qs, a_fast, b_qs, b_fast = study.trials
    assert all(isinstance(t, TrialSpec) for t in study.trials)
    assert a_qs.file == (study_dir / "data" / "A_qs.csv").resolve()
    assert a_qs.file.is_absolute()
    assert (a_qs.kind, a_qs.speed, a_qs.window, a_qs.torque_sign) == (
        "quasi-static",
        None,
        None,
        1,
    )
    assert (a_fast.kind, a_fast.speed, a_fast.window) == ("fast", 240.0, (0.1, 0.2))
    assert a_fast.format == "csv"
    # condition label follows the [bodies] order, not the trial's list order
    assert b_qs.bodies == ("attachment", "weight")
    assert b_qs.condition == "attachment+weight"
    assert study.conditions == {
        "attachment": ("attachment",),
        "attachment+weight": ("attachment", "weight"),
    }
    # [defaults] merge key by key with each trial's partial override
    assert b_qs.units == {"time": "ms", "torque": "ft*lbf"}
    assert b_qs.torque_sign == -1
    assert b_fast.columns == {"time": "t", "torque": "moment", "angle": "theta"}
    assert a_qs.columns == {"time": "t", "torque": "moment"}


def test_study_read_applies_mapping_units_and_torque_sign(study_dir):
    study = load_study(manifest(study_dir, BODIES + TRIALS))
    a = study.read(0)
    assert a.attrs["sampling_rate"] == 100.0
    assert a.attrs["condition"] == "attachment"
    assert a.attrs["kind"] == "quasi-static"
    assert a.attrs["torque_sign"] == 1
    assert "speed" not in a.attrs
    assert float(a.time[1]) == 0.01  # 10 ms
    assert float(a.torque[0]) == 1.5
    assert float(a.angle[0]) == pytest.approx(math.pi / 2, rel=1e-15)
    b = study.read(study.trials[2])
    assert float(b.torque[0]) == pytest.approx(-1.5 * 1.3558179483314004, rel=1e-15)
    assert b.torque.attrs["units"] == "N m"
    fast = read_trial_spec(study.trials[3])
    assert fast.attrs["speed"] == 240.0
    assert fast.attrs["condition"] == "attachment+weight"
    np.testing.assert_allclose(fast.velocity.values, -4 * math.pi / 3, rtol=1e-15)
    assert study.trials[1].read().attrs["window"] == [0.1, 0.2]


def test_minimal_manifest_defaults(study_dir):
    text = """\
[bodies.arm]
prior = "forearm.toml"
[[trials]]
file = "data/A_qs.csv"
bodies = "arm"
kind = "quasi-static"
columns = { time = "t", torque = "moment" }
"""
    study = load_study(manifest(study_dir, text, name="elbow.toml"))
    assert study.name == "elbow"
    assert study.gravity == 9.81
    assert study.trials[0].condition == "arm"
    assert study.trials[0].units == {}


VENDOR = f"""\
[bodies.attachment]
prior = "biodex-elbow-attachment"
[defaults]
format = "biodex"
options = {{ anatomical = true }}
[[trials]]
file = "{DATA / "biodex_ftlb.txt"}"
bodies = ["attachment"]
kind = "quasi-static"
options = {{ rep = 2 }}
[[trials]]
file = "{DATA / "analog_volts.csv"}"
bodies = ["attachment"]
kind = "fast"
speed = 300
format = "analog"
columns = {{ torque = "trq_V", angle = "pos_V", velocity = "vel_V" }}
[trials.calibration]
torque = {{ scale = 136.0, offset = 0.0, unit = "N*m" }}
angle = {{ scale = 90.0, offset = 10.0, unit = "deg" }}
velocity = {{ scale = 100.0, unit = "deg/s" }}
"""


def test_vendor_formats_options_and_calibration_in_manifest(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(VENDOR.replace("options = { anatomical = true }\n", ""))
    study = load_study(path)
    biodex, analog = study.trials
    assert (biodex.format, analog.format) == ("biodex", "analog")
    assert biodex.options == {"rep": 2}
    trial = study.read(biodex)
    assert trial.sizes["time"] == 30
    assert float(trial.torque[0]) == pytest.approx(7.48 * 1.3558179483314004, rel=1e-15)
    assert analog.calibration["torque"] == {"scale": 136.0, "offset": 0.0, "unit": "N*m"}
    volts = study.read(analog)
    assert float(volts.torque[1]) == pytest.approx(136.0 * 0.0510, rel=1e-14)


def test_default_option_the_trials_reader_does_not_take(tmp_path):
    path = tmp_path / "study.toml"
    path.write_text(VENDOR)
    with pytest.raises(
        InputError,
        match=r"study\.toml: trials\[1\]\.options\.anatomical: unknown option for format "
        r"'analog' \(options: delimiter, decimal\)",
    ):
        load_study(path)


# ------------------------------------------------------------------------------ bad input


def expect(study_dir, text, pattern):
    path = manifest(study_dir, text)
    with pytest.raises(InputError, match=r"study\.toml: " + pattern) as info:
        load_study(path)
    assert "\n" not in str(info.value)
    return str(info.value)


def test_toml_syntax_error_names_the_line(study_dir):
    expect(study_dir, BODIES + "[[trials]\nfile = 1\n", r"TOML syntax error: .*line 9")


def test_unknown_keys(study_dir):
    expect(
        study_dir,
        "gravitation = 9.8\n" + BODIES + TRIALS,
        r"gravitation: unknown top-level key \(allowed: name, description, gravity, bodies",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("speed = 240\n", "speed = 240\nspeeds = 1\n"),
        r"trials\[1\]\.speeds: unknown key \(allowed: file, bodies, kind, speed, window",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("[defaults]\n", "[defaults]\nkind = 'fast'\n"),
        r"defaults\.kind: unknown key \(allowed: format, columns",
    )
    expect(
        study_dir,
        BODIES.replace("ideal = {", "weight = 3\nideal = {") + TRIALS,
        r"bodies\.weight\.weight: unknown key \(allowed: prior, ideal, mass, com_distance, living, "
        r"segment_length\)",
    )


def test_missing_trial_file_names_index_and_path(study_dir):
    (study_dir / "data" / "B_qs.csv").unlink()
    message = expect(study_dir, BODIES + TRIALS, r"trials\[2\]\.file: file not found: ")
    assert message.endswith(str((study_dir / "data" / "B_qs.csv").resolve()))


def test_unknown_body(study_dir):
    expect(
        study_dir,
        BODIES + TRIALS.replace('["weight", "attachment"]', '["wieght", "attachment"]', 1),
        r"trials\[2\]\.bodies: unknown body 'wieght' \(bodies: attachment, weight\)",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace('bodies = ["attachment"]', "bodies = []", 1),
        r"trials\[0\]\.bodies: expected a non-empty list of body names",
    )


def test_body_without_prior_or_with_bad_prior(study_dir):
    expect(
        study_dir,
        BODIES.replace('prior = "biodex-elbow-attachment"', 'description = "x"') + TRIALS,
        r"bodies\.attachment\.description: unknown key",
    )
    expect(
        study_dir,
        BODIES.replace('prior = "biodex-elbow-attachment"\n', "") + TRIALS,
        r"bodies\.attachment\.prior: missing; give a prior name",
    )
    expect(
        study_dir,
        BODIES.replace('prior = "biodex-elbow-attachment"', "prior = 3") + TRIALS,
        r"bodies\.attachment\.prior: expected a prior name or path \(a string\) or an inline",
    )
    expect(study_dir, TRIALS, r"bodies: no bodies")


def test_bad_kind_speed_window_and_torque_sign(study_dir):
    expect(
        study_dir,
        BODIES + TRIALS.replace('kind = "quasi-static"', 'kind = "slow"', 1),
        r"trials\[0\]\.kind: expected \"quasi-static\", \"fast\", \"rest\" or \"mvc\", got 'slow'",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("speed = 240\n", ""),
        r"trials\[1\]\.speed: missing; a fast trial needs its nominal speed in deg/s",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("speed = 240\n", "speed = -240\n"),
        r"trials\[1\]\.speed: must be positive \(deg/s\), got -240",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("speed = 240\n", 'speed = "240"\n'),
        r"trials\[1\]\.speed: expected a positive number",
    )
    for window in ("[0.2, 0.1]", "[0.1]", '["a", "b"]', "0.1"):
        expect(
            study_dir,
            BODIES + TRIALS.replace("[0.1, 0.2]", window),
            r"trials\[1\]\.window: expected two increasing numbers \[start, end\] in s",
        )
    for sign in ("2", "0", "true", '"-1"'):
        expect(
            study_dir,
            BODIES + TRIALS.replace("torque_sign = -1", f"torque_sign = {sign}"),
            r"trials\[2\]\.torque_sign: must be 1 or -1, got ",
        )


def test_no_trials(study_dir):
    expect(study_dir, BODIES, r"trials: no trials")
    expect(study_dir, "trials = []\n" + BODIES, r"trials: no trials")


def test_fast_trials_without_quasi_static_in_their_condition(study_dir):
    text = TRIALS.replace('file = "data/B_qs.csv"', 'file = "data/B_qs.csv"\nspeed = 270')
    text = text.replace(
        'kind = "quasi-static"\ntorque_sign = -1', 'kind = "fast"\ntorque_sign = -1'
    )
    expect(
        study_dir,
        BODIES + text,
        r"trials: condition 'attachment\+weight' has fast trials \(trials\[2\], trials\[3\]\) "
        r"but no quasi-static trial",
    )


def test_bad_reader_settings(study_dir):
    expect(
        study_dir,
        BODIES + TRIALS.replace('units = { torque = "ft*lbf" }', 'units = { torque = "lbs" }'),
        r"trials\[2\]\.units\.torque: unknown torque unit 'lbs' \(accepted: N\*m",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace('time = "ms", ', 'time = "min", '),
        r"defaults\.units\.time: unknown time unit 'min'",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace('columns = { angle = "theta" }', 'columns = { theta = "x" }'),
        r"trials\[3\]\.columns\.theta: unknown channel",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("speed = 240.0\n", 'speed = 240.0\nformat = "xlsx"\n'),
        r"trials\[3\]\.format: unknown trial format 'xlsx' \(formats: csv",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("speed = 240.0\n", "speed = 240.0\noptions = { sep = ';' }\n"),
        r"trials\[3\]\.options\.sep: unknown option for format 'csv' \(options: delimiter",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("speed = 240.0\n", 'speed = 240.0\nformat = "analog"\n'),
        r"trials\[3\]\.calibration\.angle: missing; the analog format needs",
    )
    expect(
        study_dir,
        BODIES + TRIALS.replace("[defaults]\n", "[defaults]\ncalibration = { torque = 5 }\n"),
        r"defaults\.calibration\.torque: expected a table",
    )


def test_duplicate_file_and_bad_gravity(study_dir):
    expect(
        study_dir,
        BODIES + TRIALS.replace("data/B_qs.csv", "data/A_qs.csv"),
        r"trials\[2\]\.file: .*A_qs\.csv is already trials\[0\]",
    )
    expect(
        study_dir,
        BODIES.replace("gravity = 9.80665", "gravity = 0") + TRIALS,
        r"gravity: must be positive \(m/s\^2\), got 0",
    )


def test_manifest_not_found(tmp_path):
    with pytest.raises(InputError, match=r"missing\.toml: study manifest not found"):
        load_study(tmp_path / "missing.toml")


def test_bad_data_reaches_the_user_with_the_trial_file_named(study_dir):
    (study_dir / "data" / "A_240_01.csv").write_text(trial_csv().replace(",-240,", ",fast,", 1))
    study = load_study(manifest(study_dir, BODIES + TRIALS))
    with pytest.raises(InputError, match=r"A_240_01\.csv: line 2, column 'velocity': 'fast'"):
        study.read(1)


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("a/b", r"no '/' in a name"),
        ("x" * 300, r"at most 64 bytes in UTF-8 \(it names output files\), got 300 \(300 "),
        ("\U0001f600" * 64, r"at most 64 bytes in UTF-8 \(it names output files\), got 256 \(64 "),
        ("a\x00b", r"no '\\x00' in a name"),
        (".hidden", r"does not start with '\.'"),
        ("arm+hand", r"no '\+' in a name"),
        ("", r"not empty"),
    ],
)
def test_body_names_that_cannot_name_a_file_are_refused_before_any_work(study_dir, name, expected):
    # A body's name becomes part of output file names (corner-<body>.pdf) and condition labels;
    # these ended in a traceback after sampling.
    key = '"' + name.replace("\\", "\\\\").replace("\x00", "\\u0000") + '"'
    # beyond ASCII as TOML escapes: the manifest is then ASCII whatever the locale writes
    key = "".join(c if ord(c) < 128 else f"\\U{ord(c):08X}" for c in key)
    text = (
        (BODIES + TRIALS)
        .replace("[bodies.weight]", f"[bodies.{key}]")
        .replace('["weight", "attachment"]', f'[{key}, "attachment"]')
    )
    with pytest.raises(
        InputError, match=r"study\.toml: bodies: body .*: expected .*" + expected
    ) as err:
        load_study(manifest(study_dir, text))
    assert "\n" not in str(err.value)
    assert len(str(err.value)) < 300 + len(str(study_dir))


def test_a_body_name_in_any_script_with_spaces_is_accepted(study_dir):
    text = (
        (BODIES + TRIALS)
        .replace("[bodies.weight]", '[bodies."Unterarm (links)"]')
        .replace('["weight", "attachment"]', '["Unterarm (links)", "attachment"]')
    )
    study = load_study(manifest(study_dir, text))
    assert "Unterarm (links)" in study.bodies


def test_a_trial_path_holding_nul_is_one_line(study_dir):
    # NUL in a path made pathlib raise ValueError (a traceback) when the file was resolved
    text = (BODIES + TRIALS).replace('file = "data/A_qs.csv"', 'file = "data/A\\u0000qs.csv"')
    with pytest.raises(
        InputError,
        match=r"study\.toml: trials\[0\]\.file: a path cannot hold a NUL character, got "
        r"'data/A\\x00qs\.csv'$",
    ):
        load_study(manifest(study_dir, text))
