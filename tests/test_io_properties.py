"""Property-based tests of every trial reader and of the manifest parser (hypothesis).

Two promises, for random input:

- a valid file round-trips: what a reader returns, in SI units, is what was written in the
  file's units;
- anything else — random bytes, a valid file cut short, the wrong delimiter, huge or NaN
  values, random TOML — gives an :class:`~inertiafit.errors.InputError` (or, for a file cut
  short at a row boundary, a valid trial), never another exception.

The suite runs these with the ``ci`` profile (few examples, derandomised: same examples every
run). The fuzz command runs the same tests with many random examples::

    make fuzz            # = pytest tests/test_io_properties.py --hypothesis-profile=fuzz

(see ``docs/devices/index.md``).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from inertiafit.errors import InputError
from inertiafit.io import available_formats, load_study, read_trial
from inertiafit.io.units import from_si

ANGLE_UNITS = ("deg", "rad")
TORQUE_UNITS = ("N*m", "ft*lbf", "in*lbf")
TIME_UNITS = ("s", "ms")


#: Where the examples' files are written: the module's own temporary folder (pytest removes
#: old ones), not the system's (a folder per example piled up there, 1500 a fuzz run).
_ROOT: list[Path] = []


@pytest.fixture(scope="module", autouse=True)
def _scratch_root(tmp_path_factory):
    _ROOT[:] = [tmp_path_factory.mktemp("examples")]
    yield
    _ROOT.clear()


def _scratch(name: str, data: bytes | str) -> Path:
    folder = Path(tempfile.mkdtemp(dir=_ROOT[0]))
    path = folder / name
    if isinstance(data, bytes):
        path.write_bytes(data)
    else:
        path.write_text(data, encoding="utf-8")
    return path


def _read_only_input_errors(path: Path, **kwargs) -> xr.Dataset | None:
    """Read; an InputError is an answer, any other exception fails the test."""
    return _input_error_or(lambda: read_trial(path, **kwargs))


def _input_error_or(call):
    """``call()``, or None when it raised an InputError of one non-empty line."""
    try:
        return call()
    except InputError as exc:
        message = str(exc)
    assert message
    assert "\n" not in message
    return None


@st.composite
def trials(draw):
    """A physically consistent trial in SI units: the velocity is the angle's derivative."""
    rate = draw(st.sampled_from([100.0, 200.0, 1000.0]))
    n = draw(st.integers(min_value=30, max_value=400))
    t = draw(st.floats(min_value=0.0, max_value=100.0)) + np.arange(n) / rate
    speed = math.radians(draw(st.floats(min_value=5.0, max_value=400.0)))
    speed *= draw(st.sampled_from([1.0, -1.0]))
    freq = draw(st.floats(min_value=0.1, max_value=2.0))
    start = math.radians(draw(st.floats(min_value=-90.0, max_value=90.0)))
    # a smooth move: angle = start + (speed / w) sin(w (t - t0)), velocity its derivative
    w = 2 * math.pi * freq
    tau = t - t[0]
    angle = start + speed / w * np.sin(w * tau)
    velocity = speed * np.cos(w * tau)
    scale = draw(st.floats(min_value=0.1, max_value=300.0))
    torque = scale * np.sin(angle + draw(st.floats(min_value=-math.pi, max_value=math.pi)))
    return {"time": t, "angle": angle, "velocity": velocity, "torque": torque, "rate": rate}


def _units(draw_angle: str, draw_torque: str, draw_time: str) -> dict[str, str]:
    return {
        "time": draw_time,
        "angle": draw_angle,
        "velocity": f"{draw_angle}/s",
        "torque": draw_torque,
    }


def _columns_in_units(trial: dict, units: dict[str, str]) -> dict[str, np.ndarray]:
    return {
        q: from_si(trial[q], q, units[q], where="test")
        for q in ("time", "angle", "velocity", "torque")
    }


def _assert_round_trip(ds: xr.Dataset, trial: dict) -> None:
    np.testing.assert_allclose(ds["time"].values, trial["time"], rtol=1e-12, atol=1e-12)
    for q in ("angle", "velocity", "torque"):
        np.testing.assert_allclose(ds[q].values, trial[q], rtol=1e-9, atol=1e-9)
    assert ds.attrs["sampling_rate"] == pytest.approx(trial["rate"], rel=1e-6)


# --- valid files round-trip ---------------------------------------------------------------


@given(
    trial=trials(),
    angle=st.sampled_from(ANGLE_UNITS),
    torque=st.sampled_from(TORQUE_UNITS),
    time=st.sampled_from(TIME_UNITS),
    delimiter=st.sampled_from([",", ";", "\t"]),
)
def test_csv_round_trips_through_the_units(trial, angle, torque, time, delimiter):
    units = _units(angle, torque, time)
    cols = _columns_in_units(trial, units)
    lines = [delimiter.join(cols)]
    lines += [
        delimiter.join(repr(float(cols[q][i])) for q in cols) for i in range(len(trial["time"]))
    ]
    path = _scratch("trial.csv", "\n".join(lines) + "\n")
    ds = read_trial(path, format="csv", units=units, delimiter=delimiter)
    _assert_round_trip(ds, trial)


@given(
    trial=trials(),
    gains=st.tuples(
        st.floats(min_value=1e-3, max_value=1e3),
        st.floats(min_value=1e-3, max_value=1e3),
        st.floats(min_value=-2e5, max_value=-1.0) | st.floats(min_value=1.0, max_value=2e5),
    ),
    offsets=st.tuples(*(st.floats(min_value=-10, max_value=10) for _ in range(3))),
)
def test_analog_channels_round_trip_through_their_calibration(trial, gains, offsets):
    # volts = (value - offset) / scale in the calibration's unit; read back: scale * volts + offset
    cal = {}
    volts = {}
    for q, g, o in zip(("angle", "velocity", "torque"), gains, offsets, strict=True):
        unit = {"angle": "deg", "velocity": "deg/s", "torque": "N*m"}[q]
        cal[q] = {"scale": g, "offset": o, "unit": unit}
        volts[q] = (from_si(trial[q], q, unit, where="test") - o) / g
    lines = ["time,angle,velocity,torque"]
    lines += [
        ",".join(repr(float(v)) for v in (trial["time"][i], *(volts[q][i] for q in volts)))
        for i in range(len(trial["time"]))
    ]
    path = _scratch("analog.csv", "\n".join(lines) + "\n")
    ds = read_trial(path, format="analog", calibration=cal)
    np.testing.assert_allclose(ds["time"].values, trial["time"], rtol=1e-12)
    for q in ("angle", "velocity", "torque"):
        span = float(np.ptp(trial[q])) or 1.0
        np.testing.assert_allclose(ds[q].values, trial[q], rtol=1e-8, atol=1e-9 * span)


def _vendor_trial(draw, rate: float, n_max: int = 300) -> dict:
    """A consistent trial at a vendor's fixed rate, starting at t = 0."""
    trial = draw(trials())
    n = min(len(trial["time"]), n_max)
    t = np.arange(n) / rate
    w = draw(st.floats(min_value=0.2, max_value=2.0)) * 2 * math.pi
    speed = math.radians(draw(st.floats(min_value=20.0, max_value=300.0)))
    angle = math.radians(draw(st.floats(min_value=-40, max_value=40))) + speed / w * np.sin(w * t)
    torque = draw(st.floats(min_value=1.0, max_value=200.0)) * (np.cos(angle) + 0.2)
    return {"time": t, "angle": angle, "velocity": speed * np.cos(w * t), "torque": torque,
            "rate": rate}  # fmt: skip


def _assert_quantised(ds: xr.Dataset, trial: dict, steps: dict[str, float]) -> None:
    """Round trip of values written rounded to ``steps`` (SI units of each channel)."""
    np.testing.assert_allclose(ds["time"].values, trial["time"], atol=1e-9)
    for q, step in steps.items():
        np.testing.assert_allclose(ds[q].values, trial[q], rtol=0, atol=0.51 * step + 1e-12)


@given(st.data())
def test_humac_round_trips_through_its_units(data):
    torque_unit = data.draw(st.sampled_from(["Newton-Meters", "Foot-Pounds"]))
    trial = _vendor_trial(data.draw, 100.0)
    unit = "N*m" if torque_unit == "Newton-Meters" else "ft*lbf"
    deg = {q: np.degrees(trial[q]) for q in ("angle", "velocity")}
    torque = from_si(trial["torque"], "torque", unit, where="test")
    lines = [f'"Status","Time(Seconds)","Position(Degrees)","Torque({torque_unit})","Speed(d/s)"']
    lines += [
        f'"1","{trial["time"][i]:.2f}","{deg["angle"][i]:.6f}","{torque[i]:.6f}",'
        f'"{deg["velocity"][i]:.6f}"'
        for i in range(len(trial["time"]))
    ]
    end = len(trial["time"]) / 100.0
    lines.append(f'"0","{end:.2f}","0","0","0"')  # the closing row every HUMAC file ends with
    ds = read_trial(_scratch("humac.csv", "\n".join(lines) + "\n"), format="humac")
    steps = {"angle": math.radians(1e-6), "velocity": math.radians(1e-6)}
    steps["torque"] = 1e-6 * (1.0 if unit == "N*m" else 1.3558179483314004)
    _assert_quantised(ds, trial, steps)


@given(st.data())
def test_biodex_round_trips_through_its_units(data):
    trial = _vendor_trial(data.draw, 100.0)
    t_ms = 1000.0 * trial["time"]
    deg = {q: np.degrees(trial[q]) for q in ("angle", "velocity")}
    lines = [
        "SYNTHETIC TEST TRIAL (6-header-line Biodex variant)",
        "Knee Extension/Flexion  Passive  60 deg/sec",
        "Right",
        "03/14/2024 10:20:05",
        (
            "Columns: time (ms), torque (N-m), position (deg), anatomical position (deg), velocity "
            "(deg/sec)"
        ),
        "",
    ]
    lines += [
        f"{t_ms[i]:.0f}\t{trial['torque'][i]:.6f}\t{deg['angle'][i]:.6f}\t"
        f"{90 - deg['angle'][i]:.6f}\t{deg['velocity'][i]:.6f}"
        for i in range(len(t_ms))
    ]
    ds = read_trial(_scratch("biodex.txt", "\n".join(lines) + "\n"), format="biodex")
    _assert_quantised(
        ds, trial, {"angle": math.radians(1e-6), "velocity": math.radians(1e-6), "torque": 1e-6}
    )


@given(st.data())
def test_vicon_devices_csv_round_trips(data):
    n_sub = data.draw(st.sampled_from([10, 15]))
    rate = 100.0 * n_sub
    trial = _vendor_trial(data.draw, rate)
    k = np.arange(len(trial["time"]))
    frame, sub = 1 + k // n_sub, k % n_sub
    deg = {q: np.degrees(trial[q]) for q in ("angle", "velocity")}
    lines = ["", "Devices", f"{rate:g}", (",,Contrex - Angle,Contrex - Angular Velocity,"
             "Contrex - Force,"), "Frame,Sub Frame,Angle,Angular velocity,Torque",
             ",,deg,deg/s,N"]  # fmt: skip
    lines += [
        f"{frame[i]},{sub[i]},{deg['angle'][i]:.9f},{deg['velocity'][i]:.9f},"
        f"{trial['torque'][i]:.9f}"
        for i in k
    ]
    ds = read_trial(_scratch("vicon.csv", "\r\n".join(lines) + "\r\n"), format="vicon")
    step = 1e-9
    _assert_quantised(
        ds, trial, {"angle": math.radians(step), "velocity": math.radians(step), "torque": step}
    )


@given(st.data())
def test_isomed_round_trips_its_tenths(data):
    trial = _vendor_trial(data.draw, 200.0)
    t_ms = 1000.0 * trial["time"]
    tenths = {
        "angle": np.round(10 * np.degrees(trial["angle"])),
        "torque": np.round(10 * trial["torque"]),
        "velocity": np.round(10 * np.degrees(trial["velocity"])),
    }
    rows = [
        "  ".join(
            f"{v:>7.0f}"
            for v in (
                t_ms[i],
                tenths["angle"][i],
                tenths["torque"][i],
                tenths["velocity"][i],
                0,
                2,
                0,
                0,
                0,
                0,
            )
        )
        for i in range(len(t_ms))
    ]
    ds = read_trial(_scratch("isomed.txt", "\n".join(rows) + "\n"), format="isomed")
    _assert_quantised(
        ds, trial, {"angle": math.radians(0.1), "velocity": math.radians(0.1), "torque": 0.1}
    )


@given(st.data())
def test_c3d_analog_channels_round_trip_through_their_calibration(data):
    c3d = pytest.importorskip("c3d")
    import warnings

    trial = _vendor_trial(data.draw, 1000.0, n_max=400)
    n = 10 * (len(trial["time"]) // 10)
    trial = {q: (v[:n] if isinstance(v, np.ndarray) else v) for q, v in trial.items()}
    gain = {
        "angle": data.draw(st.floats(min_value=10, max_value=200)),
        "velocity": data.draw(st.floats(min_value=10, max_value=500)),
        "torque": data.draw(st.sampled_from([100.0, -1.44e5])),
    }
    units = {"angle": "deg", "velocity": "deg/s", "torque": "N*m"}
    labels = {"angle": "Angle.1", "velocity": "Angular Velocity.1", "torque": "Torque.1"}
    volts = {
        q: (from_si(trial[q], q, units[q], where="test") / gain[q]).astype(np.float32)
        for q in labels
    }
    writer = c3d.Writer(point_rate=100.0, analog_rate=1000.0)
    writer.set_analog_labels([labels[q] for q in labels])
    block = np.vstack([volts[q] for q in labels])
    for f in range(n // 10):
        writer.add_frames([(np.zeros((0, 5), np.float32), block[:, 10 * f : 10 * f + 10])])
    path = _scratch("trial.c3d", b"")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # py-c3d warns that the file has no markers
        with path.open("wb") as handle:
            writer.write(handle)
    cal = {q: {"scale": gain[q], "offset": 0.0, "unit": units[q]} for q in labels}
    ds = read_trial(path, format="c3d", calibration=cal)
    np.testing.assert_allclose(ds["time"].values, trial["time"], atol=1e-9)
    for q in labels:  # float32 volts: 1e-7 of the largest value
        span = float(np.max(np.abs(trial[q])))
        np.testing.assert_allclose(ds[q].values, trial[q], rtol=0, atol=1e-6 * span)


# --- anything else is an InputError --------------------------------------------------------


@given(data=st.binary(min_size=0, max_size=2000), format=st.sampled_from(available_formats()))
def test_random_bytes_give_input_error(data, format):
    _read_only_input_errors(_scratch("random.dat", data), format=format)


@given(
    text=st.text(alphabet=st.characters(codec="utf-8", exclude_categories=["Cs"]), max_size=1500),
    format=st.sampled_from(available_formats()),
)
def test_random_text_gives_input_error(text, format):
    _read_only_input_errors(_scratch("random.txt", text), format=format)


def _valid_csv(trial: dict) -> str:
    units = _units("deg", "N*m", "s")
    cols = _columns_in_units(trial, units)
    rows = [",".join(repr(float(cols[q][i])) for q in cols) for i in range(len(trial["time"]))]
    return "time,angle,velocity,torque\n" + "\n".join(rows) + "\n"


@given(trial=trials(), cut=st.floats(min_value=0.0, max_value=1.0))
def test_a_truncated_file_is_an_input_error_or_a_shorter_valid_trial(trial, cut):
    text = _valid_csv(trial)
    path = _scratch("cut.csv", text[: int(cut * len(text))])
    ds = _read_only_input_errors(path, format="csv")
    if ds is not None:  # cut at a row boundary: the rows before the cut, unchanged
        n = ds.sizes["time"]
        np.testing.assert_allclose(ds["time"].values, trial["time"][:n], rtol=1e-12)


@given(trial=trials(), delimiter=st.sampled_from([";", "\t", " ", "|"]))
def test_the_wrong_delimiter_is_an_input_error(trial, delimiter):
    path = _scratch("wrong.csv", _valid_csv(trial).replace(",", delimiter))
    with pytest.raises(InputError):
        read_trial(path, format="csv")


@given(
    trial=trials(),
    value=st.sampled_from(["nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e400", "", "x"]),
    where=st.tuples(st.integers(min_value=0, max_value=10_000), st.integers(0, 3)),
)
def test_a_bad_cell_is_an_input_error(trial, value, where):
    lines = _valid_csv(trial).splitlines()
    row = 1 + where[0] % (len(lines) - 1)
    cells = lines[row].split(",")
    cells[where[1]] = value
    lines[row] = ",".join(cells)
    path = _scratch("bad.csv", "\n".join(lines) + "\n")
    ds = _read_only_input_errors(path, format="csv")
    if ds is not None:  # only a huge but finite torque can be a valid value
        assert value in ("1e308", "-1e308")
        for q in ("time", "angle", "velocity", "torque"):
            assert np.isfinite(ds[q].values).all()


#: Valid files of every text format (the readers' own fixtures) and how to read them: the seeds
#: the mutation test below edits byte by byte.
DATA = Path(__file__).parent / "data"
SEEDS = [
    ("generic_ms_ftlb.csv", {
        "format": "csv",
        "columns": {"time": "t_ms", "angle": "theta_deg", "velocity": "omega_dps",
                    "torque": "tau_ftlb"},
        "units": {"time": "ms", "angle": "deg", "velocity": "deg/s", "torque": "ft*lbf"},
    }),
    ("analog_volts.csv", {
        "format": "analog",
        "columns": {"torque": "trq_V", "angle": "pos_V", "velocity": "vel_V"},
        "calibration": {
            "torque": {"scale": 100.0, "offset": 0.0, "unit": "N*m"},
            "angle": {"scale": 90.0, "offset": 0.0, "unit": "deg"},
            "velocity": {"scale": 120.0, "offset": 0.0, "unit": "deg/s"},
        },
    }),
    ("humac_ftlb.csv", {"format": "humac"}),
    ("humac_nm_quoted.csv", {"format": "humac"}),
    ("biodex_ftlb.txt", {"format": "biodex"}),
    ("biodex_6line.txt", {"format": "biodex"}),
]  # fmt: skip


def test_every_seed_file_is_valid_as_given():  # else the mutation test fuzzes only errors
    for name, kwargs in SEEDS:
        assert read_trial(DATA / name, **kwargs).sizes["time"] > 0, name


@given(
    seed=st.sampled_from(SEEDS),
    edits=st.lists(
        st.tuples(st.floats(0, 1), st.integers(0, 8), st.binary(max_size=8)),
        min_size=1,
        max_size=6,
    ),
)
def test_a_mutated_file_of_every_format_gives_input_error_or_a_trial(seed, edits):
    name, kwargs = seed
    data = (DATA / name).read_bytes()
    for at, length, insert in edits:
        i = int(at * len(data))
        data = data[:i] + insert + data[i + length :]
    ds = _read_only_input_errors(_scratch(name, data), **kwargs)
    if ds is not None:  # whatever is read is a valid trial: finite SI values, time increasing
        assert np.isfinite(ds["time"].values).all()
        assert (np.diff(ds["time"].values) > 0).all()
        for q in ("angle", "velocity", "torque"):
            assert np.isfinite(ds[q].values).all()


def test_the_harness_fails_on_any_other_exception(monkeypatch):  # negative control
    from inertiafit.io.readers import registry

    def broken(path, *, columns=None, units=None, calibration=None):
        raise ValueError("not an InputError")

    monkeypatch.setitem(registry.READERS, "csv", broken)
    with pytest.raises(ValueError, match="not an InputError"):
        _read_only_input_errors(_scratch("x.csv", "a"), format="csv")


# --- the manifest parser -------------------------------------------------------------------

MANIFEST = """name = "fuzzed"
[bodies.attachment]
prior = "biodex-elbow-attachment"
[[trials]]
file = "qs.csv"
bodies = ["attachment"]
kind = "quasi-static"
[[trials]]
file = "fast.csv"
bodies = ["attachment"]
kind = "fast"
speed = 240
"""


@given(
    edits=st.lists(
        st.tuples(
            st.integers(min_value=0, max_value=len(MANIFEST)),
            st.integers(min_value=0, max_value=20),
            st.text(max_size=12),
        ),
        min_size=1,
        max_size=4,
    )
)
@settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
def test_a_mangled_manifest_is_an_input_error(edits):
    text = MANIFEST
    for at, length, insert in edits:
        text = text[:at] + insert + text[at + length :]
    assume(text != MANIFEST)
    folder = _scratch("qs.csv", "time,angle,velocity,torque\n").parent
    (folder / "fast.csv").write_text("time,angle,velocity,torque\n")
    manifest = folder / "study.toml"
    manifest.write_text(text, encoding="utf-8")
    _input_error_or(lambda: load_study(manifest))


@given(data=st.binary(max_size=600))
def test_manifest_of_random_bytes_is_an_input_error(data):
    path = _scratch("study.toml", data)
    _input_error_or(lambda: load_study(path))


# --- EMG channels (issue 20) ---------------------------------------------------------------

EMG_UNITS = {"V": 1.0, "mV": 1e-3, "uV": 1e-6, "µV": 1e-6}
#: Names of the other columns of the files written below (never an EMG channel's).
_CHANNEL_NAMES = {"time", "angle", "velocity", "torque", "frame", "sub frame", "angular velocity"}
#: EMG column names: a letter first (a name that reads as a number is not a header), then any
#: printable characters but the delimiters and quotes.
EMG_NAMES = st.text(
    alphabet=st.characters(codec="utf-8", exclude_categories=["Cs", "Cc", "Z"],
                           exclude_characters=',;\t"\'|'),
    min_size=1, max_size=12,
).filter(lambda s: s[0].isalpha() and s.strip().lower() not in _CHANNEL_NAMES)  # fmt: skip


#: EMG labels a C3D file can hold (py-c3d writes labels as ASCII).
C3D_EMG_NAMES = st.from_regex(r"[A-Za-z][A-Za-z0-9._]{0,11}", fullmatch=True).filter(
    lambda s: s.lower() not in ("angle.1", "angular velocity.1", "torque.1")
)


@st.composite
def emg_channels(draw, n: int, names=EMG_NAMES):
    """One to three EMG channels in volts (Gaussian noise), distinct names."""
    names = draw(st.lists(names, min_size=1, max_size=3, unique_by=str.lower))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    level = draw(st.sampled_from([5e-6, 1e-4, 2e-3]))
    return {m: rng.normal(0.0, level, n) for m in names}


@given(st.data())
def test_csv_emg_round_trips_through_its_unit(data):
    trial = data.draw(trials())
    n = len(trial["time"])
    emg = data.draw(emg_channels(n))
    unit = data.draw(st.sampled_from(list(EMG_UNITS)))
    delimiter = data.draw(st.sampled_from([",", ";", "\t"]))
    cols = _columns_in_units(trial, _units("deg", "N*m", "s"))
    header = delimiter.join([*cols, *emg])
    rows = [
        delimiter.join(
            [*(repr(float(cols[q][i])) for q in cols)]
            + [repr(float(v[i] / EMG_UNITS[unit])) for v in emg.values()]
        )
        for i in range(n)
    ]
    path = _scratch("emg.csv", header + "\n" + "\n".join(rows) + "\n")
    ds = read_trial(path, format="csv", delimiter=delimiter, emg=list(emg), emg_unit=unit)
    _assert_round_trip(ds, trial)
    assert list(ds["muscle"].values) == list(emg)
    for i, values in enumerate(emg.values()):
        np.testing.assert_allclose(ds["emg"].values[i], values, rtol=1e-12, atol=1e-18)


@given(st.data())
def test_vicon_emg_round_trips_at_the_device_rate(data):
    n_sub = data.draw(st.sampled_from([10, 15]))
    rate = 100.0 * n_sub
    trial = _vendor_trial(data.draw, rate)
    k = np.arange(len(trial["time"]))
    emg = data.draw(emg_channels(k.size))
    unit = data.draw(st.sampled_from(["V", "mV", ""]))  # "": the units cell is empty
    frame, sub = 1 + k // n_sub, k % n_sub
    deg = {q: np.degrees(trial[q]) for q in ("angle", "velocity")}
    factor = EMG_UNITS.get(unit, 1.0)
    lines = ["", "Devices", f"{rate:g}", ",," + ",".join("Myon - Voltage" for _ in emg)
             + ",Contrex - Angle,Contrex - Angular Velocity,Contrex - Force,",
             "Frame,Sub Frame," + ",".join(emg) + ",Angle,Angular velocity,Torque",
             ",," + ",".join(unit for _ in emg) + ",deg,deg/s,N"]  # fmt: skip
    lines += [
        f"{frame[i]},{sub[i]},"
        + ",".join(f"{v[i] / factor:.12e}" for v in emg.values())
        + f",{deg['angle'][i]:.9f},{deg['velocity'][i]:.9f},{trial['torque'][i]:.9f}"
        for i in k
    ]
    path = _scratch("vicon.csv", "\r\n".join(lines) + "\r\n")
    ds = read_trial(path, format="vicon", emg=list(emg))
    assert ds.sizes["time"] == k.size  # every device sample: the EMG keeps its rate
    assert ds.attrs["sampling_rate"] == pytest.approx(rate)
    for i, values in enumerate(emg.values()):
        np.testing.assert_allclose(ds["emg"].values[i], values, rtol=1e-11, atol=1e-18)


@given(st.data())
def test_c3d_emg_round_trips_at_the_analog_rate(data):
    c3d = pytest.importorskip("c3d")
    import warnings

    trial = _vendor_trial(data.draw, 1000.0, n_max=300)
    n = 10 * (len(trial["time"]) // 10)
    trial = {q: (v[:n] if isinstance(v, np.ndarray) else v) for q, v in trial.items()}
    emg = data.draw(emg_channels(n, names=C3D_EMG_NAMES))
    labels = {"angle": "Angle.1", "velocity": "Angular Velocity.1", "torque": "Torque.1"}
    units = {"angle": "deg", "velocity": "deg/s", "torque": "N*m"}
    volts = [(from_si(trial[q], q, units[q], where="test") / 100.0) for q in labels]
    block = np.vstack([*emg.values(), *volts]).astype(np.float32)
    writer = c3d.Writer(point_rate=100.0, analog_rate=1000.0)
    writer.set_analog_labels([*emg, *labels.values()])
    for f in range(n // 10):
        writer.add_frames([(np.zeros((0, 5), np.float32), block[:, 10 * f : 10 * f + 10])])
    path = _scratch("emg.c3d", b"")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # py-c3d warns that the file has no markers
        with path.open("wb") as handle:
            writer.write(handle)
    cal = {q: {"scale": 100.0, "unit": units[q]} for q in labels}
    ds = read_trial(path, format="c3d", calibration=cal, emg=list(emg))
    assert ds.sizes["time"] == n
    for i, values in enumerate(emg.values()):
        stored = values.astype(np.float32).astype(np.float64)
        np.testing.assert_allclose(ds["emg"].values[i], stored, rtol=1e-6, atol=1e-12)


def _valid_csv_with_emg(trial: dict, rng: np.random.Generator) -> str:
    lines = _valid_csv(trial).splitlines()
    emg = rng.normal(0.0, 1e-4, len(lines) - 1)
    out = [lines[0] + ",biceps"] + [f"{row},{e!r}" for row, e in zip(lines[1:], emg, strict=True)]
    return "\n".join(out) + "\n"


@given(
    trial=trials(),
    edits=st.lists(
        st.tuples(st.floats(0, 1), st.integers(0, 8), st.binary(max_size=8)),
        min_size=1,
        max_size=4,
    ),
    fmt=st.sampled_from(["csv", "analog"]),
)
def test_a_mutated_emg_file_gives_input_error_or_finite_emg(trial, edits, fmt):
    data = _valid_csv_with_emg(trial, np.random.default_rng(0)).encode()
    for at, length, insert in edits:
        i = int(at * len(data))
        data = data[:i] + insert + data[i + length :]
    cal = None
    if fmt == "analog":
        cal = {q: {"scale": 1.0, "unit": u} for q, u in
               (("angle", "deg"), ("velocity", "deg/s"), ("torque", "N*m"))}  # fmt: skip
    ds = _read_only_input_errors(_scratch("emg.csv", data), format=fmt, calibration=cal,
                                 emg=["biceps"])  # fmt: skip
    if ds is not None:
        assert ds["emg"].dims == ("muscle", "time")
        assert np.isfinite(ds["emg"].values).all()
        assert (np.abs(ds["emg"].values) <= 100.0).all()


@given(
    emg=st.one_of(
        st.none(),
        st.text(max_size=8),
        st.lists(st.one_of(st.text(max_size=8), st.integers(), st.none()), max_size=4),
        st.integers(),
    ),
    unit=st.one_of(
        st.none(),
        st.sampled_from(["V", "mV", "uV", "µV", "kV", "", "volt"]),
        st.text(max_size=4),
    ),
    fmt=st.sampled_from(available_formats()),
)
def test_any_emg_setting_gives_input_error_or_a_trial(emg, unit, fmt):
    trial = {"time": np.arange(50) / 100.0, "angle": np.linspace(0, 1, 50),
             "velocity": np.full(50, 100.0 / 49), "torque": np.ones(50)}  # fmt: skip
    text = _valid_csv(trial).splitlines()
    body = [text[0] + ",biceps"] + [f"{row},1e-5" for row in text[1:]]
    path = _scratch("any.csv", "\n".join(body) + "\n")
    ds = _read_only_input_errors(path, format=fmt, emg=emg, emg_unit=unit)
    if ds is not None:
        assert fmt == "csv"  # the others fail on this file or refuse EMG
        assert ("emg" in ds) == bool(emg)


EMG_TABLES = st.dictionaries(
    st.sampled_from(["columns", "unit", "band", "rms_window", "threshold_sd", "min_duration",
                     "mvc_fraction", "on_activity", "other"]),
    st.one_of(st.integers(-5, 600), st.floats(allow_nan=True, allow_infinity=True),
              st.text(max_size=6), st.lists(st.integers(-5, 600), max_size=3),
              st.lists(st.text(max_size=4), max_size=3), st.booleans()),
    max_size=4,
)  # fmt: skip


@given(table=EMG_TABLES)
def test_any_emg_table_gives_input_error_or_settings(table):
    from inertiafit.io.emg import EmgSettings, read_emg_settings

    settings = _input_error_or(lambda: read_emg_settings(table, where="study.toml: emg"))
    if settings is not None:
        assert isinstance(settings, EmgSettings)
        assert 0 < settings.band[0] < settings.band[1]
        assert 0 < settings.rms_window <= 1
        assert 0 <= settings.min_duration <= 1
        assert 0 < settings.mvc_fraction <= 1
        assert settings.threshold_sd > 0
        assert settings.on_activity in ("exclude", "flag", "stop")
