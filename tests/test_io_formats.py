"""The c3d, vicon and isomed readers, and binary files given to text formats.

Every fixture is written here from known values in SI units, in the layout each device writes
(docs/devices/); none is copied from a real export.
"""

import math
import re
import warnings

import c3d
import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.io import available_formats, load_study, read_trial, reader_options
from inertiafit.io.readers import binary_formats
from inertiafit.io.readers.registry import binary_kind

# A smooth passive move: velocity the derivative of the angle, torque a gravity moment.
DURATION = 1.0


def motion(t):
    """Angle (deg), velocity (deg/s) and torque (N m) at times t (s)."""
    velocity = 60.0 * np.sin(math.pi * t / DURATION)
    angle = 20.0 + 60.0 * DURATION / math.pi * (1.0 - np.cos(math.pi * t / DURATION))
    torque = 5.0 + 10.0 * np.sin(np.radians(angle))
    return angle, velocity, torque


def assert_trial(trial, t, atol_deg=1e-9, atol_nm=1e-9):
    angle, velocity, torque = motion(t - t[0])
    np.testing.assert_allclose(trial.time.values, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.degrees(trial.angle.values), angle, rtol=0, atol=atol_deg)
    np.testing.assert_allclose(np.degrees(trial.velocity.values), velocity, rtol=0, atol=atol_deg)
    np.testing.assert_allclose(trial.torque.values, torque, rtol=0, atol=atol_nm)


# --------------------------------------------------------------------------------------- c3d

# value = scale x volts + offset, as a lab calibrates Vicon-recorded dynamometer outputs
CALIBRATION = {
    "angle": {"scale": 90.0, "offset": 10.0, "unit": "deg"},
    "velocity": {"scale": 100.0, "unit": "deg/s"},
    "torque": {"scale": -1.44e5, "unit": "N*m"},
}


def write_c3d(
    path, channels, units, *, point_rate=100.0, analog_rate=1000.0, first=1, scales=None
):
    """A C3D file with no markers, written by py-c3d's own writer (float32 samples)."""
    writer = c3d.Writer(point_rate=point_rate, analog_rate=analog_rate)
    labels = list(channels)
    writer.set_analog_labels(labels)
    packed, width = c3d.Writer.pack_labels([units[label] for label in labels])
    writer.analog_group.add_str("UNITS", "Analog units", packed, width, len(labels))
    if scales is not None:
        writer.set_analog_scales(scales)
    writer.set_start_frame(first)
    data = np.vstack([channels[label] for label in labels])
    per_frame = round(analog_rate / point_rate)
    for f in range(data.shape[1] // per_frame):
        block = data[:, f * per_frame : (f + 1) * per_frame]
        writer.add_frames([(np.zeros((0, 5), np.float32), block)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # py-c3d warns that the file has no markers
        with path.open("wb") as handle:
            writer.write(handle)
    return path


def vicon_style_c3d(path, *, first=1, n=500, emg=3, scales=None):
    """Volts as the Biodex analog outputs give them: Angle.1, Angular Velocity.1, Torque.1."""
    angle, velocity, torque = motion(np.arange(n) / 1000.0)
    channels = {
        "Angle.1": (angle - 10.0) / 90.0,
        "Angular Velocity.1": velocity / 100.0,
        "Torque.1": torque / -1.44e5,  # tiny values, a large negative factor
    }
    channels |= {f"Voltage.{i}": np.full(n, 1e-4 * i) for i in range(1, emg + 1)}
    return write_c3d(path, channels, dict.fromkeys(channels, "V"), first=first, scales=scales)


def test_formats_registered_and_c3d_reads_binary():
    assert available_formats()[:4] == ("csv", "analog", "humac", "biodex")
    assert set(available_formats()) >= {"c3d", "vicon", "isomed"}
    assert binary_formats() == ("c3d",)
    assert reader_options("c3d") == ()
    assert reader_options("isomed") == ("phase", "phase_column")


def test_c3d_round_trip_with_calibration(tmp_path):
    # Frame 151 at 100 Hz: time starts at 1.5 s, as on the capture's time line.
    path = vicon_style_c3d(tmp_path / "trial.c3d", first=151, scales=[1.0, 1.0, 2.0, 1, 1, 1])
    trial = read_trial(path, format="c3d", calibration=CALIBRATION)
    assert trial.attrs["format"] == "c3d"
    assert trial.attrs["sampling_rate"] == 1000.0
    assert trial.attrs["analog_labels"] == "Angle.1,Angular Velocity.1,Torque.1"
    assert trial.sizes["time"] == 500
    # float32 samples: 90 x 1.2e-7 relative of ~1 V is ~1e-5 deg; torque |scale| 1.44e5 N m/V
    assert_trial(trial, 1.5 + np.arange(500) / 1000.0, atol_deg=3e-5, atol_nm=3e-6)


def test_c3d_channels_by_label_and_units_from_file(tmp_path):
    n = 300
    angle, velocity, torque = motion(np.arange(n) / 1000.0)
    channels = {"Pos": angle, "Spd": velocity, "Mom": torque, "EMG": np.zeros(n)}
    units = {"Pos": "deg", "Spd": "deg/s", "Mom": "Nm", "EMG": "V"}
    path = write_c3d(tmp_path / "physical.c3d", channels, units)
    columns = {"angle": "pos", "velocity": "Spd", "torque": "Mom"}  # case-insensitive fallback
    trial = read_trial(path, format="c3d", columns=columns)
    assert_trial(trial, np.arange(n) / 1000.0, atol_deg=2e-5, atol_nm=2e-6)
    with pytest.raises(InputError, match=r"units\.torque = 'ft\*lbf' contradicts the file"):
        read_trial(path, format="c3d", columns=columns, units={"torque": "ft*lbf"})


def test_c3d_errors(tmp_path):
    path = vicon_style_c3d(tmp_path / "trial.c3d")
    # volts without calibration (the negative control of the round trip)
    with pytest.raises(InputError, match=r"'Torque\.1' is in V .*give calibration\.torque"):
        read_trial(
            path, format="c3d", calibration={k: CALIBRATION[k] for k in ("angle", "velocity")}
        )
    with pytest.raises(InputError, match=r"'Torque\.2' not found \(ANALOG:LABELS: Angle\.1, "):
        read_trial(path, format="c3d", columns={"torque": "Torque.2"}, calibration=CALIBRATION)
    with pytest.raises(InputError, match=r"columns\.time: a C3D file has no time channel"):
        read_trial(path, format="c3d", columns={"time": "t"}, calibration=CALIBRATION)
    raw = path.read_bytes()
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(raw[: len(raw) - 4000])
    with pytest.raises(InputError, match=r"ends after \d+ of its 50 frames \(1-50\); .*truncated"):
        read_trial(cut, format="c3d", calibration=CALIBRATION)
    header = tmp_path / "header.c3d"
    header.write_bytes(raw[:700])
    with pytest.raises(InputError, match="cannot be read as a C3D file"):
        read_trial(header, format="c3d", calibration=CALIBRATION)
    noise = tmp_path / "noise.c3d"
    noise.write_bytes(np.random.default_rng(3).bytes(5000))
    with pytest.raises(InputError, match="not a C3D file"):
        read_trial(noise, format="c3d")
    text = tmp_path / "text.c3d"
    text.write_text("time,angle,velocity,torque\n0,1,2,3\n")
    with pytest.raises(InputError, match=r"not a C3D file .*\(csv, analog, humac"):
        read_trial(text, format="c3d")


def test_binary_file_given_to_a_text_format(tmp_path):
    path = vicon_style_c3d(tmp_path / "trial.c3d")
    for fmt in ("csv", "analog", "biodex", "vicon", "isomed"):
        with pytest.raises(InputError) as err:
            read_trial(path, format=fmt)
        message = str(err.value)
        assert f"a C3D file (binary), but format '{fmt}' reads text" in message
        assert 'format = "c3d"' in message
        assert "reading binary files: 'c3d'" in message
    noise = tmp_path / "data.csv"
    noise.write_bytes(np.random.default_rng(4).bytes(3000))
    with pytest.raises(
        InputError, match=r"a binary file, not text; .*reading binary files: 'c3d'"
    ):
        read_trial(noise, format="csv")
    utf16 = tmp_path / "utf16.csv"
    utf16.write_text("time,angle\n0,1\n", encoding="utf-16")
    with pytest.raises(InputError, match=r"UTF-16 text .* save the export as UTF-8"):
        read_trial(utf16, format="csv")
    # Negative controls: text in an 8-bit encoding, and a text line starting "?P", are text.
    latin1 = tmp_path / "latin1.txt"
    latin1.write_bytes("Torque Units: N·m ±5°\n".encode("latin-1") * 20)
    assert binary_kind(latin1) is None
    speed = tmp_path / "speed.csv"
    speed.write_text("SPEED,TORQUE\n" + "1,2\n" * 400)
    assert binary_kind(speed) is None


# ------------------------------------------------------------------------------------- vicon


def vicon_text(*, rate=1500, n_sub=15, first_frame=1, n=150, emg=4, torque_unit="N", tail=""):
    """A Vicon Nexus "Devices" export of a Con-Trex and EMG, CRLF line ends."""
    k = np.arange(n)
    frame = first_frame + k // n_sub
    sub = k % n_sub
    t = (frame - 1) / (rate / n_sub) + sub / rate
    angle, velocity, torque = motion(t - t[0])
    emg_names = [f"EMG{i}" for i in range(1, emg + 1)]
    lines = [
        "",
        "Devices",
        f"{rate}",
        ",,Myon - Voltage" + "," * emg + "Contrex - Angle,Contrex - Angular Velocity,"
        "Contrex - Force,",
        ",".join(["Frame", "Sub Frame", *emg_names, "Angle", "Angular velocity", "Torque"]),
        ",".join(["", "", *["V"] * emg, "deg", "deg/s", torque_unit]),
    ]
    for i in range(n):
        cells = [f"{frame[i]}", f"{sub[i]}", *[f"{1e-5 * j:g}" for j in range(emg)]]
        cells += [f"{angle[i]:.9f}", f"{velocity[i]:.9f}", f"{torque[i]:.9f}"]
        lines.append(",".join(cells))
    return "\r\n".join(lines) + "\r\n" + tail, t


@pytest.mark.parametrize("newline", ["\r\n", "\n"])
def test_vicon_round_trip_preamble_and_crlf(tmp_path, newline):
    text, t = vicon_text(first_frame=5)
    path = tmp_path / "contrex.csv"
    path.write_bytes(text.replace("\r\n", newline).encode())
    assert b"\r\n" in path.read_bytes() or newline == "\n"
    trial = read_trial(path, format="vicon")
    assert trial.attrs["format"] == "vicon"
    assert trial.attrs["sampling_rate"] == 1500.0
    assert trial.attrs["torque_unit_in_file"] == "N"  # read as N m (the Con-Trex moment)
    assert float(trial.time[0]) == pytest.approx(0.04, abs=1e-15)  # frame 5 at 100 Hz
    assert_trial(trial, t, atol_deg=1e-8, atol_nm=1e-8)


def test_vicon_frame_rate_from_rate_and_sub_frames(tmp_path):
    # 2000 Hz device, 20 sub frames: 100 Hz frames; 1000 Hz, 5 sub frames: 200 Hz frames.
    for rate, n_sub in ((2000, 20), (1000, 5)):
        text, t = vicon_text(rate=rate, n_sub=n_sub, first_frame=3)
        assert t[0] == pytest.approx(2 * n_sub / rate)
        path = tmp_path / f"v{rate}.csv"
        path.write_text(text, newline="")
        trial = read_trial(path, format="vicon")
        np.testing.assert_allclose(trial.time.values, t, rtol=0, atol=1e-12)
        assert trial.attrs["sampling_rate"] == float(rate)


def test_vicon_section_ends_at_next_section_and_units_checked(tmp_path):
    tail = "\r\nTrajectories\r\n100\r\n,,LTOE\r\nFrame,Sub Frame,X\r\n,,mm\r\n1,0,5\r\n"
    text, t = vicon_text(tail=tail)
    path = tmp_path / "two_sections.csv"
    path.write_text(text, newline="")
    trial = read_trial(path, format="vicon", units={"torque": "N*m"})
    assert trial.sizes["time"] == t.size
    with pytest.raises(InputError, match=r"units\.torque = 'ft\*lbf' contradicts the file"):
        read_trial(path, format="vicon", units={"torque": "ft*lbf"})
    # Only the torque column's "N" is read as N m: an angle labelled N is an unknown unit.
    bad = text.replace(",deg,deg/s,N", ",N,deg/s,N")
    path.write_text(bad, newline="")
    with pytest.raises(InputError, match="unknown angle unit 'N'"):
        read_trial(path, format="vicon")


def test_vicon_errors(tmp_path):
    text, _ = vicon_text()
    lines = text.split("\r\n")

    def fails(body, match, **kwargs):
        path = tmp_path / "bad.csv"
        path.write_text(body, newline="")
        with pytest.raises(InputError, match=match):
            read_trial(path, format="vicon", **kwargs)

    fails(text.replace("Devices", "Trajectories"), "no 'Devices' line")
    fails(text.replace("\r\n1500\r\n", "\r\nfast\r\n"), "line 3: expected the device rate in Hz")
    fails(text, r"column 'Moment' not found .*set columns\.torque", columns={"torque": "Moment"})
    fails(text.replace(",Torque\r\n", ",Angle\r\n"), "'Angle' appears 2 times")
    row = lines[20].split(",")
    fails(
        text.replace(lines[20], ",".join([*row[:-1], "abc"])), r"line 21, column 'Torque': 'abc'"
    )
    fails(
        text.replace(lines[20], ",".join([*row[:-1], "nan"])), r"'Torque' has a missing .* line 21"
    )
    fails(text.replace(lines[20], lines[20] + "\r\n"), "line 22 is empty inside the data rows")
    fails(text.replace(lines[20], ";".join(row)), r"line 21 has 1 comma-separated fields")
    fails("\r\n".join(lines[:40]) + "\r\n" + lines[40][:9], r"line 41 has \d comma-separated")
    fails("\r\n".join(lines[:4]), "ends before its rate, device, column and unit rows")
    fails(text, "calibration is only used by", calibration=CALIBRATION)


# ------------------------------------------------------------------------------------ isomed


def isomed_text(n=200, order=(1, 2, 3, 4), phases=None):
    """IsoMed 2000 rows: ms, then tenths of deg, N m, deg/s (in ``order``), a phase code."""
    t = np.arange(n) / 200.0
    angle, velocity, torque = motion(t)
    phases = np.full(n, 2) if phases is None else phases
    rows = []
    for i in range(n):
        values = {
            order[0]: f"{1000 * t[i]:.0f}",
            order[1]: f"{10 * angle[i]:.0f}",
            order[2]: f"{10 * torque[i]:.0f}",
            order[3]: f"{10 * velocity[i]:.0f}",
            6: f"{phases[i]}",
        }
        cells = [values.get(c, "0") for c in range(1, 11)]
        rows.append("  ".join(f"{c:>6}" for c in cells))
    return "\r\n".join(rows) + "\r\n", t


def test_isomed_round_trip_tenths(tmp_path):
    text, t = isomed_text()
    path = tmp_path / "isomed.txt"
    path.write_text(text)
    trial = read_trial(path, format="isomed")
    assert trial.attrs["sampling_rate"] == 200.0
    # written to the nearest tenth: the error is at most 0.05 deg, 0.05 N m, 0.05 deg/s
    assert_trial(trial, t, atol_deg=0.05 + 1e-9, atol_nm=0.05 + 1e-9)
    angle, _, _ = motion(t)
    assert np.abs(np.degrees(trial.angle.values) - angle).max() > 0.01  # really rounded


def test_isomed_columns_by_number_and_phase(tmp_path):
    phases = np.repeat([1, 2, 3], [50, 100, 50])
    text, t = isomed_text(order=(1, 2, 4, 3), phases=phases)  # torque and velocity swapped
    path = tmp_path / "swapped.txt"
    path.write_text(text)
    trial = read_trial(path, format="isomed", columns={"torque": "4", "velocity": "3"})
    assert_trial(trial, t, atol_deg=0.05 + 1e-9, atol_nm=0.05 + 1e-9)
    two = read_trial(path, format="isomed", columns={"torque": "4", "velocity": "3"}, phase=2)
    assert two.sizes["time"] == 100
    assert float(two.time[0]) == pytest.approx(0.25)
    with pytest.raises(
        InputError, match=r"no rows with phase code 7 .*codes in the file: 1, 2, 3"
    ):
        read_trial(path, format="isomed", phase=7)


def test_isomed_errors(tmp_path):
    text, _ = isomed_text()
    rows = text.split("\r\n")

    def fails(body, match, **kwargs):
        path = tmp_path / "bad.txt"
        path.write_text(body)
        with pytest.raises(InputError, match=match):
            read_trial(path, format="isomed", **kwargs)

    fails("time angle torque velocity\r\n" + text, r"line 1, column 1: 'time' is not a number")
    fails(text.replace("  ", ",").replace(" ", ""), r"line 1 has 1 whitespace-separated fields")
    fails("\r\n".join([*rows[:50], rows[50][:20], *rows[51:]]), r"line 51 has \d fields")
    fails(
        text,
        r"columns\.angle = 'Angle': an IsoMed export has no header",
        columns={"angle": "Angle"},
    )
    nan_row = "  ".join(["nan" if i == 2 else c for i, c in enumerate(rows[9].split())])
    fails(text.replace(rows[9], nan_row), r"column 'column 3' has a missing .* at line 10")
    fails(text, "option phase must be an integer", phase="2")


# --------------------------------------------------------------------- every reader, bad input


def test_every_reader_raises_input_error_on_garbage(tmp_path):
    junk = {
        "random.bin": np.random.default_rng(5).bytes(2000),
        "empty.txt": b"",
        "truncated.txt": b"time,angle,velocity,torque\n0,1,2",
        "prose.txt": b"Ce fichier n'est pas un essai.\n" * 5,
    }
    for name, content in junk.items():
        path = tmp_path / name
        path.write_bytes(content)
        for fmt in available_formats():
            with pytest.raises(InputError, match=re.escape(str(path))):
                read_trial(path, format=fmt, calibration=CALIBRATION if fmt == "analog" else None)


# ---------------------------------------------------------------------------------- manifest


def test_manifest_study_with_c3d_trials(tmp_path):
    (tmp_path / "data").mkdir()
    vicon_style_c3d(tmp_path / "data" / "qs.c3d", first=11)
    (tmp_path / "study.toml").write_text(
        """\
[bodies.attachment]
prior = "biodex-elbow-attachment"

[defaults]
format = "c3d"
columns = { angle = "Angle.1", velocity = "Angular Velocity.1", torque = "Torque.1" }
[defaults.calibration]
angle = { scale = 90.0, offset = 10.0, unit = "deg" }
velocity = { scale = 100.0, unit = "deg/s" }
torque = { scale = -1.44e5, unit = "N*m" }

[[trials]]
file = "data/qs.c3d"
bodies = ["attachment"]
kind = "quasi-static"
"""
    )
    study = load_study(tmp_path / "study.toml")
    assert study.trials[0].format == "c3d"
    trial = study.read(0)
    assert trial.attrs["format"] == "c3d"
    assert trial.attrs["condition"] == "attachment"
    assert_trial(trial, 0.1 + np.arange(500) / 1000.0, atol_deg=3e-5, atol_nm=3e-6)
