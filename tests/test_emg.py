"""EMG channels in the readers and the manifest, and the activity check (issue 20, items 1-2, 6).

The activity check is tested on simulated EMG with bursts at known times: onsets and ends
within the RMS window's half width, quiet muscles and quiet trials give nothing, and a real
Vicon C3D recording in ``../shared/real-exports`` (when present) shows the held contraction.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import inertiafit
from inertiafit.errors import InputError
from inertiafit.io import load_study, make_trial, read_trial
from inertiafit.io.emg import EmgSettings, read_emg_settings
from inertiafit.processing.emg import emg_activity, emg_envelope, rest_level

DATA = Path(__file__).parent / "data"
RATE = 1000.0


# --- simulated trials ----------------------------------------------------------------------


def _still_trial(emg: dict[str, np.ndarray], rate: float = RATE, source: str = "sim.csv"):
    """A trial of a shaft held still, with the given EMG channels (V)."""
    n = len(next(iter(emg.values())))
    t = np.arange(n) / rate
    torque = 2.0 + 0.01 * np.sin(2 * np.pi * 0.5 * t)
    return make_trial(t, np.full(n, 0.3), np.zeros(n), torque, source=source, emg=emg)


def _noise(rng, n, sd=5e-6):
    return rng.normal(0.0, sd, n)


def _burst(rng, n, start, end, ratio, sd=5e-6, rate=RATE):
    """Gaussian noise of SD ``sd`` with a burst ``ratio`` times as large in [start, end) s."""
    x = _noise(rng, n, sd)
    i, j = round(start * rate), round(end * rate)
    x[i:j] = rng.normal(0.0, ratio * sd, j - i)
    return x


@pytest.fixture(scope="module")
def bursts():
    rng = np.random.default_rng(20)
    n = 10_000  # 10 s
    a = _burst(rng, n, 2.0, 2.3, 10.0)
    a[6000:6040] = rng.normal(0.0, 15 * 5e-6, 40)  # a 40 ms reflex-like burst at 6.0 s
    return _still_trial({"biceps": a, "triceps": _noise(rng, n)})


# --- readers -------------------------------------------------------------------------------


def _csv(tmp_path, emg_cols: dict[str, np.ndarray], name="t.csv", n=400):
    t = np.arange(n) / RATE
    header = ["time", "angle", "velocity", "torque", *emg_cols]
    rows = [
        [f"{t[i]:.4f}", "10", "0", "5", *(repr(float(v[i])) for v in emg_cols.values())]
        for i in range(n)
    ]
    path = tmp_path / name
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
    return path


def test_csv_reads_emg_columns_in_their_unit_as_volts(tmp_path):
    rng = np.random.default_rng(1)
    mv = {"biceps": rng.normal(0, 0.05, 400), "triceps": rng.normal(0, 0.02, 400)}
    path = _csv(tmp_path, mv)
    ds = read_trial(path, emg=["triceps", "biceps"], emg_unit="mV")
    assert ds["emg"].dims == ("muscle", "time")
    assert list(ds["muscle"].values) == ["triceps", "biceps"]
    assert ds["emg"].attrs["units"] == "V"
    np.testing.assert_allclose(ds["emg"].sel(muscle="biceps").values, 1e-3 * mv["biceps"])
    ds_uv = read_trial(path, emg=["biceps"], emg_unit="uV")
    np.testing.assert_allclose(ds_uv["emg"].values[0], 1e-6 * mv["biceps"])


def test_a_trial_without_emg_is_exactly_as_before(tmp_path):
    path = _csv(tmp_path, {"biceps": np.zeros(400)})
    plain = read_trial(path)
    assert set(plain.variables) == {"time", "angle", "velocity", "torque"}
    assert set(plain.attrs) == {"source", "sampling_rate", "format", "torque_kind", "flags"}
    assert plain.identical(read_trial(path, emg=[]))
    with_emg = read_trial(path, emg=["biceps"])
    assert with_emg.drop_vars(["emg", "muscle"]).identical(plain)


def test_analog_reads_emg_uncalibrated(tmp_path):
    rng = np.random.default_rng(2)
    volts = rng.normal(0, 1e-4, 400)
    path = _csv(tmp_path, {"EMG1": volts})
    cal = {q: {"scale": 1.0, "unit": u} for q, u in
           (("angle", "deg"), ("velocity", "deg/s"), ("torque", "N*m"))}  # fmt: skip
    ds = read_trial(path, format="analog", calibration=cal, emg=["EMG1"])
    np.testing.assert_allclose(ds["emg"].values[0], volts)


def _vicon(tmp_path, n=3000, emg_unit_cell="V", rate=1500, n_sub=15):
    """A Devices CSV at ``rate`` with two EMG columns; a 300 Hz tone on the first."""
    k = np.arange(n)
    t = k / rate
    tone = 2e-4 * np.sin(2 * np.pi * 300.0 * t)
    lines = [
        "",
        "Devices",
        f"{rate}",
        ",,Myon - Voltage,,Contrex - Angle,Contrex - Angular Velocity,Contrex - Force,",
        "Frame,Sub Frame,LTibA1,LSol2,Angle,Angular velocity,Torque",
        f",,{emg_unit_cell},V,deg,deg/s,N",
    ]
    lines += [
        f"{1 + i // n_sub},{i % n_sub},{tone[i]:.9e},{1e-5 * (-1) ** i:.9e},30,0,15" for i in k
    ]
    path = tmp_path / "vicon.csv"
    path.write_text("\r\n".join(lines) + "\r\n")
    return path, tone


def test_vicon_emg_keeps_its_full_rate(tmp_path):
    path, tone = _vicon(tmp_path)
    ds = read_trial(path, format="vicon", emg=["LTibA1", "lsol2"])
    assert ds.attrs["sampling_rate"] == pytest.approx(1500.0)
    assert list(ds["muscle"].values) == ["LTibA1", "LSol2"]
    np.testing.assert_allclose(ds["emg"].values[0], tone, atol=1e-12)
    # a 300 Hz tone survives: decimating to 100 Hz would have aliased it away
    spectrum = np.abs(np.fft.rfft(ds["emg"].values[0]))
    freqs = np.fft.rfftfreq(ds.sizes["time"], 1 / 1500.0)
    assert freqs[np.argmax(spectrum)] == pytest.approx(300.0, abs=1.0)


def test_vicon_emg_unit_from_its_units_row(tmp_path):
    path, tone = _vicon(tmp_path, emg_unit_cell="mV")
    ds = read_trial(path, format="vicon", emg=["LTibA1"])
    np.testing.assert_allclose(ds["emg"].values[0], 1e-3 * tone, atol=1e-15)
    with pytest.raises(InputError, match=r"emg unit 'V' contradicts the file.*units row"):
        read_trial(path, format="vicon", emg=["LTibA1"], emg_unit="V")
    with pytest.raises(InputError, match=r"'Angle' is in 'deg'.*not a voltage|dynamometer"):
        read_trial(path, format="vicon", emg=["Angle"])


def test_c3d_reads_emg_labels(tmp_path):
    c3d = pytest.importorskip("c3d")
    n = 500
    t = np.arange(n) / RATE
    angle_v = (np.radians(20) * np.sin(2 * np.pi * 0.5 * t)).astype(np.float32)
    vel_v = (np.radians(20) * np.pi * np.cos(2 * np.pi * 0.5 * t)).astype(np.float32)
    emg = (1e-4 * np.sin(2 * np.pi * 120 * t)).astype(np.float32)
    labels = ["Voltage.1", "Angle.1", "Angular Velocity.1", "Torque.1"]
    writer = c3d.Writer(point_rate=100.0, analog_rate=1000.0)
    writer.set_analog_labels(labels)
    block = np.vstack([emg, angle_v, vel_v, np.full(n, 0.1, np.float32)])
    for f in range(n // 10):
        writer.add_frames([(np.zeros((0, 5), np.float32), block[:, 10 * f : 10 * f + 10])])
    path = tmp_path / "t.c3d"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with path.open("wb") as handle:
            writer.write(handle)
    cal = {"angle": {"scale": 1.0, "unit": "rad"}, "velocity": {"scale": 1.0, "unit": "rad/s"},
           "torque": {"scale": 100.0, "unit": "N*m"}}  # fmt: skip
    ds = read_trial(path, format="c3d", calibration=cal, emg=["Voltage.1"], emg_unit="mV")
    np.testing.assert_allclose(ds["emg"].values[0], 1e-3 * emg.astype(np.float64), atol=1e-12)
    with pytest.raises(InputError, match=r"'Voltage.9' not found.*set emg in the manifest"):
        read_trial(path, format="c3d", calibration=cal, emg=["Voltage.9"])
    with pytest.raises(InputError, match="channel of the dynamometer"):
        read_trial(path, format="c3d", calibration=cal, emg=["Torque.1"])


ISOMED = "\n".join(
    "  ".join(str(v) for v in (5 * i, 100 + i, 50, 20, 0, 2, 0, 0, 0, 0)) for i in range(40)
)


@pytest.mark.parametrize(
    ("name", "fmt"),
    [("biodex_ftlb.txt", "biodex"), ("humac_ftlb.csv", "humac"), ("isomed.txt", "isomed")],
)
def test_formats_without_emg_refuse_it_in_one_line(tmp_path, name, fmt):
    path = DATA / name
    if fmt == "isomed":
        path = tmp_path / name
        path.write_text(ISOMED + "\n")
    with pytest.raises(InputError) as err:
        read_trial(path, format=fmt, emg=["biceps"])
    message = str(err.value)
    assert "\n" not in message
    assert f"format '{fmt}' has no EMG channels" in message
    assert "csv, analog, c3d, vicon" in message


@pytest.mark.parametrize(
    ("emg", "unit", "expected"),
    [
        (["x"], None, r"column 'x' not found.*set emg in the manifest"),
        ("biceps", None, "expected a list of EMG column names"),
        (["biceps", "biceps"], None, "listed twice"),
        (["torque"], None, "is the torque channel"),
        (["biceps"], "kV", "unknown EMG unit 'kV'"),
    ],
)
def test_bad_emg_settings_are_one_line_errors(tmp_path, emg, unit, expected):
    path = _csv(tmp_path, {"biceps": np.zeros(400)})
    with pytest.raises(InputError, match=expected) as err:
        read_trial(path, emg=emg, emg_unit=unit)
    assert "\n" not in str(err.value)


def test_a_bad_emg_cell_names_its_line(tmp_path):
    values = np.zeros(400)
    path = _csv(tmp_path, {"biceps": values})
    lines = path.read_text(encoding="utf-8").splitlines()
    lines[12] = lines[12].rsplit(",", 1)[0] + ",nan"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"EMG column 'biceps' has a missing .* at line 13"):
        read_trial(path, emg=["biceps"])
    lines[12] = lines[12].rsplit(",", 1)[0] + ",500"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"500 V .* beyond 100 V"):
        read_trial(path, emg=["biceps"])


# --- the manifest --------------------------------------------------------------------------


def _study(tmp_path, extra: str = "", trial_extra: str = "", fmt: str = "csv") -> Path:
    rng = np.random.default_rng(3)
    _csv(tmp_path, {"biceps": rng.normal(0, 1, 400), "triceps": rng.normal(0, 1, 400)}, "q.csv")
    file = "q.csv" if fmt == "csv" else str(DATA / "biodex_ftlb.txt")
    text = f"""{extra}
[bodies.arm]
prior = "biodex-elbow-attachment"
[[trials]]
file = "{file}"
format = "{fmt}"
bodies = ["arm"]
kind = "quasi-static"
{trial_extra}
"""
    path = tmp_path / "study.toml"
    path.write_text(text)
    return path


def test_manifest_emg_table_reads_every_trial_emg(tmp_path):
    study = load_study(_study(tmp_path, '[emg]\ncolumns = ["biceps"]\nunit = "uV"\n'))
    spec = study.trials[0]
    assert spec.emg == ("biceps",)
    assert spec.emg_unit == "µV"
    assert study.emg == EmgSettings(columns=("biceps",), unit="µV")
    assert spec.reader_settings()["emg"] == ["biceps"]
    ds = study.read(0)
    assert list(ds["muscle"].values) == ["biceps"]
    assert ds["emg"].values.std() == pytest.approx(1e-6, rel=0.2)


def test_manifest_trial_emg_overrides_the_study(tmp_path):
    path = _study(
        tmp_path,
        '[emg]\ncolumns = ["biceps"]\n[defaults]\nemg = ["triceps"]\n',
        trial_extra='emg = ["biceps", "triceps"]',
    )
    assert load_study(path).trials[0].emg == ("biceps", "triceps")
    path = _study(tmp_path, '[defaults]\nemg = ["triceps"]\n')
    assert load_study(path).trials[0].emg == ("triceps",)
    path = _study(tmp_path, '[emg]\ncolumns = ["biceps"]\n', trial_extra="emg = []")
    spec = load_study(path).trials[0]
    assert spec.emg == ()
    assert "emg" not in spec.reader_settings()
    assert "emg" not in spec.read()


def test_manifest_without_emg_has_the_settings_it_had(tmp_path):
    spec = load_study(_study(tmp_path)).trials[0]
    assert spec.emg == ()
    assert set(spec.reader_settings()) == {
        "format", "columns", "units", "calibration", "options", "torque_sign", "window"
    }  # fmt: skip


def test_manifest_refuses_emg_for_a_format_without(tmp_path):
    path = _study(tmp_path, '[emg]\ncolumns = ["biceps"]\n', fmt="biodex")
    with pytest.raises(InputError, match=r"emg.columns: format 'biodex' has no EMG channels"):
        load_study(path)


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        ("band = [450, 20]", r"emg.band: expected two increasing frequencies \[high-pass, low"),
        ("band = [0, 450]", r"emg.band\[0\]: must be positive \(Hz\), got 0"),
        ("rms_window = 0", r"emg.rms_window: expected a number in \(0, 1\] s, got 0"),
        ('rms_window = "50 ms"', r"emg.rms_window: expected a number in \(0, 1\] s, got '50"),
        ("threshold_sd = -3", r"emg.threshold_sd: must be positive \(SDs of the rest envelope\)"),
        ("min_duration = 2", r"emg.min_duration: expected a number in \[0, 1\] s, got 2"),
        ("min_duration = -0.01", r"emg.min_duration: expected a number in \[0, 1\] s"),
        ("mvc_fraction = 2", r"emg.mvc_fraction: expected a number in \(0, 1\] of the MVC"),
        ('on_activity = "ignore"', r'emg.on_activity: expected "exclude", "flag" or "stop"'),
        ('unit = "kV"', r"emg.unit: unknown EMG unit"),
        ("columns = 3", r"emg.columns: expected a list of EMG column names"),
        ("threshold = 3", r"emg.threshold: unknown key \(allowed: columns, unit, band"),
    ],
)
def test_manifest_emg_table_errors(tmp_path, table, expected):
    with pytest.raises(InputError, match=expected) as err:
        load_study(_study(tmp_path, f"[emg]\n{table}\n"))
    assert "\n" not in str(err.value)


def test_emg_settings_read_every_key():
    settings = read_emg_settings(
        {
            "columns": ["a"],
            "unit": "mV",
            "band": [10, 500],
            "rms_window": 0.1,
            "threshold_sd": 2,
            "min_duration": 0.025,
            "mvc_fraction": 0.05,
            "on_activity": "stop",
        },
        where="m: emg",
    )
    assert settings == EmgSettings(("a",), "mV", (10.0, 500.0), 0.1, 2.0, 0.025, 0.05, "stop")


# --- the activity check --------------------------------------------------------------------


def test_bursts_are_found_within_half_a_window(bursts):
    table = emg_activity(bursts, rest=(0.2, 1.8))
    assert list(table.columns) == ["muscle", "start", "end", "peak_ratio"]
    assert list(table["muscle"]) == ["biceps", "biceps"]  # the triceps stays quiet
    # the envelope reaches half a window either way, and the zero-lag high-pass spreads a
    # step by its time constant 1 / (2 pi f_lo) once each way (forwards, backwards)
    settings = EmgSettings()
    half = settings.rms_window / 2 + 2 / (2 * math.pi * settings.band[0]) + 1 / RATE
    for row, (start, end) in zip(table.itertuples(), ((2.0, 2.3), (6.0, 6.04)), strict=True):
        assert abs(row.start - start) <= half
        assert abs(row.end - end) <= half
        assert row.start <= start + 0.005  # a large burst is never found late
    # the held burst's envelope peaks at its ratio plus its noise (3 of its SDs, 11 % each);
    # the 40 ms one is averaged with rest over the 50 ms window
    assert 10.0 < table["peak_ratio"].iloc[0] < 10.0 * 1.5
    assert 15 * math.sqrt(0.04 / 0.05) * 0.8 < table["peak_ratio"].iloc[1] < 15 * 1.2
    assert table.attrs["threshold"]["biceps"] == pytest.approx(
        table.attrs["rest_level"]["biceps"] + 3 * table.attrs["rest_sd"]["biceps"]
    )


def test_a_quiet_trial_gives_an_empty_table():
    rng = np.random.default_rng(7)
    quiet = _still_trial({"a": _noise(rng, 8000), "b": _noise(rng, 8000, sd=2e-5)})
    table = emg_activity(quiet, rest=(0.0, 2.0))
    assert table.empty
    assert list(table.columns) == ["muscle", "start", "end", "peak_ratio"]


def test_negative_controls_a_small_burst_and_a_high_threshold(bursts):
    rng = np.random.default_rng(8)
    faint = _still_trial({"a": _burst(rng, 6000, 3.0, 3.5, 1.15)})
    assert emg_activity(faint, rest=(0.2, 2.5)).empty  # 15 % over rest: below mean + 3 SD
    assert emg_activity(bursts, rest=(0.2, 1.8), threshold_sd=200).empty
    # and the harness can fail: with the burst in the rest span, it is no longer found
    assert len(emg_activity(bursts, rest=(1.9, 2.4))) == 0


def test_rest_as_a_trial_or_levels_gives_the_same_stretches(bursts):
    rng = np.random.default_rng(9)
    rest_trial = _still_trial({"biceps": _noise(rng, 3000), "triceps": _noise(rng, 3000)})
    by_trial = emg_activity(bursts, rest=rest_trial)
    by_span = emg_activity(bursts, rest=(0.2, 1.8))
    assert list(by_trial["muscle"]) == list(by_span["muscle"])
    np.testing.assert_allclose(by_trial["start"], by_span["start"], atol=0.01)
    levels = rest_level(emg_envelope(rest_trial))
    by_levels = emg_activity(bursts, rest=levels)
    np.testing.assert_allclose(by_levels["start"], by_trial["start"])
    means = {m: v[0] for m, v in levels.items()}
    by_means = emg_activity(bursts, rest=means)
    np.testing.assert_allclose(by_means["start"], by_trial["start"], atol=0.01)


def test_a_level_alone_gets_the_sd_of_gaussian_noise():
    rng = np.random.default_rng(10)
    quiet = _still_trial({"a": _noise(rng, 20_000)})
    (mean, sd) = rest_level(emg_envelope(quiet))["a"]
    band = EmgSettings().band
    theory = mean / (2 * math.sqrt((band[1] - band[0]) * EmgSettings().rms_window))
    assert sd == pytest.approx(theory, rel=0.3)


def test_a_short_reflex_burst_counts():
    rng = np.random.default_rng(11)
    x = _noise(rng, 5000)
    x[3000:3020] = rng.normal(0.0, 8 * 5e-6, 20)  # 20 ms at 8 x rest
    table = emg_activity(_still_trial({"a": x}), rest=(0.2, 2.5))
    assert len(table) == 1
    assert abs(table["start"].iloc[0] - 3.0) <= 0.025 + 2 / (2 * math.pi * 20) + 0.001


def test_an_mvc_threshold_hides_activity_below_its_fraction(bursts):
    rng = np.random.default_rng(12)
    mvc = _still_trial({"biceps": _noise(rng, 3000, sd=5e-4), "triceps": _noise(rng, 3000)})
    # MVC at 100 x rest: 20 % of it (20 x rest) hides both bursts of the biceps
    assert emg_activity(bursts, rest=(0.2, 1.8), mvc=mvc, mvc_fraction=0.2).empty
    table = emg_activity(bursts, rest=(0.2, 1.8), mvc=mvc, mvc_fraction=0.02)
    assert len(table) == 2
    assert table.attrs["mvc_fraction"] == 0.02


def test_settings_from_a_study_are_used(bursts):
    settings = EmgSettings(threshold_sd=200.0)
    assert emg_activity(bursts, rest=(0.2, 1.8), settings=settings).empty


def test_the_ends_of_the_settings_ranges(bursts):
    # min_duration may be 0 (the window alone), rms_window 1 s; mvc_fraction 1 is the MVC
    assert not emg_activity(bursts, rest=(0, 1), min_duration=0.0).empty
    with pytest.raises(InputError, match=r"^rms_window: expected a number in \(0, 1\] s"):
        emg_activity(bursts, rest=(0, 1), rms_window=1.5)
    with pytest.raises(InputError, match=r"^mvc_fraction: expected a number in \(0, 1\]"):
        emg_activity(bursts, rest=(0, 1), mvc_fraction=0)


@pytest.mark.parametrize(
    ("call", "expected"),
    [
        (lambda b, q: emg_activity(q, rest=(0, 1)), "has no EMG channels; read it with emg"),
        (lambda b, q: emg_activity(b, rest=(20, 30)), r"rest span \(20, 30\) s holds 0"),
        (lambda b, q: emg_activity(b, rest="quiet"), "rest: expected a span"),
        (lambda b, q: emg_activity(b, rest={"biceps": 1e-6}), "rest: no level for muscle"),
        (lambda b, q: emg_activity(b, rest={"biceps": -1, "triceps": 1}), r"rest.biceps"),
        (lambda b, q: emg_activity(b, rest=(0, 1), muscles=["x"]), "no EMG channel 'x'"),
        (lambda b, q: emg_activity(b, rest=(0, 1), threshold_sd=0), "^threshold_sd: must be pos"),
        (lambda b, q: emg_activity(b, rest=(0, 1), band=(450, 20)), "^band: expected two incr"),
    ],
)
def test_activity_errors_are_one_line(bursts, call, expected):
    quiet = bursts.drop_vars(["emg", "muscle"])
    with pytest.raises(InputError, match=expected) as err:
        call(bursts, quiet)
    assert "\n" not in str(err.value)


def test_emg_at_a_low_rate_cannot_be_band_passed():
    rng = np.random.default_rng(13)
    slow = _still_trial({"a": _noise(rng, 500)}, rate=100.0)
    with pytest.raises(InputError, match="EMG sampled at 100 Hz cannot be band-passed"):
        emg_activity(slow, rest=(0, 2))


def test_the_public_name():
    assert inertiafit.emg_activity is emg_activity


# --- the real recording (issue 20, item 6) ---------------------------------------------------

#: ``../shared/real-exports`` beside the repository: files of real devices, never copied here.
REAL = Path(__file__).resolve().parents[2] / "shared" / "real-exports"
REAL_C3D = REAL / "biodex-analog-vicon" / "5-20b.c3d"
#: The lab's calibration (its README): angle and velocity x 35.6838, torque x -144049.
REAL_CALIBRATION = {
    "angle": {"scale": 35.6838, "unit": "deg"},
    "velocity": {"scale": 35.6838, "unit": "deg/s"},
    "torque": {"scale": -144049.0, "unit": "N*m"},
}


@pytest.fixture(scope="module")
def real_trial() -> xr.Dataset:
    if not REAL_C3D.is_file():
        pytest.skip(f"the real Vicon C3D is not here ({REAL_C3D}); nothing to check against")
    channels = [f"Voltage.{i}" for i in range(1, 17)]
    return read_trial(REAL_C3D, format="c3d", calibration=REAL_CALIBRATION, emg=channels)


def test_the_real_c3d_shows_the_held_contraction_and_nothing_after(real_trial):
    assert real_trial.sizes == {"time": 16850, "muscle": 16}
    table = emg_activity(real_trial, rest=(11.5, 16.8))
    active = table[table["muscle"] == "Voltage.2"]
    # held from the start to 10.5-11 s, 20-40 x its resting RMS
    assert active["start"].iloc[0] == pytest.approx(0.0, abs=0.01)
    assert active["end"].iloc[0] > 10.5
    assert active["end"].max() < 11.0
    assert 20 < active["peak_ratio"].max() < 60
    # the quiet stretch after it: nothing on any channel
    assert (table["end"] < 11.0).all()
    # the silent channels (Voltage.1 is an unconnected input at 2.3 mV): nothing at all. Their
    # noise has single spikes of 5-6 SD that lift the 50 ms envelope above rest + 3 SD for
    # exactly the window (50-53 ms, twice, while Voltage.2 contracts); activity must outlast
    # the window by min_duration
    assert set(table["muscle"]) == {"Voltage.2"}


def test_one_spike_lifts_the_envelope_for_its_window_and_is_not_activity():
    """One sample at 10 or 24 SD: above the threshold for about the window, and not active."""
    for amplitude in (10.0, 24.0):
        rng = np.random.default_rng(13)
        x = _noise(rng, 5000)
        x[3000] = amplitude * 5e-6
        trial = _still_trial({"a": x})
        env = emg_envelope(trial)
        level = rest_level(env.isel(time=slice(200, 2500)))["a"]
        above = np.flatnonzero(env.values[0, 2900:3100] > level[0] + 3 * level[1]) + 2900
        # one run around the spike, as long as the 50-sample window (and the band-pass's
        # few ms)
        assert above.max() - above.min() + 1 == len(above)
        assert 48 <= len(above) <= 56
        assert above.min() <= 3000 <= above.max()
        assert emg_activity(trial, rest=(0.2, 2.5)).empty
        # ten such samples in a row (10 ms at that level) are activity
        y = x.copy()
        y[3000:3010] = amplitude * 5e-6 * rng.choice([-1.0, 1.0], 10)
        assert len(emg_activity(_still_trial({"a": y}), rest=(0.2, 2.5))) == 1
