import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from inertiafit.errors import InputError
from inertiafit.io import available_formats, read_trial, reader_options, register_reader
from inertiafit.io.readers.registry import READERS
from inertiafit.io.trial import make_trial

DATA = Path(__file__).parent / "data"
FT_LBF = 1.3558179483314004
DEG = math.pi / 180


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def generic_csv(n=20, rate=100.0, header="time,angle,velocity,torque"):
    rows = [header]
    rows += [f"{k / rate:.4f},{10 + k:.1f},60,{2.5 * k:.2f}" for k in range(n)]
    return "\n".join(rows) + "\n"


# ------------------------------------------------------------------------------------- csv


def test_formats_registered():
    assert set(available_formats()) >= {"csv", "biodex", "humac", "analog"}
    assert reader_options("csv") == ("delimiter", "decimal", "derive_velocity")
    assert reader_options("biodex") == ("anatomical", "set", "rep")


def test_csv_defaults_deg_and_newton_metres(tmp_path):
    trial = read_trial(write(tmp_path, "t.csv", generic_csv()))
    assert trial.attrs["format"] == "csv"
    assert trial.attrs["sampling_rate"] == 100.0
    assert trial.sizes["time"] == 20
    assert float(trial.angle[0]) == pytest.approx(10 * DEG, rel=1e-15)
    assert float(trial.velocity[3]) == pytest.approx(math.pi / 3, rel=1e-15)
    assert float(trial.torque[4]) == 10.0
    assert float(trial.time[19]) == pytest.approx(0.19)


def test_csv_fixture_with_mapped_columns_ms_and_foot_pounds():
    trial = read_trial(
        DATA / "generic_ms_ftlb.csv",
        columns={
            "time": "t_ms",
            "angle": "theta_deg",
            "velocity": "omega_dps",
            "torque": "tau_ftlb",
        },
        units={"time": "ms", "torque": "ft-lb"},
    )
    assert trial.sizes["time"] == 30
    assert trial.attrs["sampling_rate"] == 1000.0
    assert float(trial.time[0]) == 0.5  # 500 ms: time starts where the file starts
    assert float(trial.angle[0]) == pytest.approx(math.pi / 2, rel=1e-15)  # 90.00 deg
    assert float(trial.velocity[0]) == pytest.approx(-4 * math.pi / 3, rel=1e-15)  # -240 deg/s
    assert float(trial.torque[0]) == pytest.approx(13.558179483314004, rel=1e-15)  # 10 ft-lbf
    assert float(trial.torque[29]) == pytest.approx(24.5 * FT_LBF, rel=1e-15)
    assert float(trial.angle[29]) == pytest.approx(83.04 * DEG, rel=1e-15)


def test_csv_semicolon_and_decimal_comma(tmp_path):
    text = generic_csv().replace(",", ";").replace(".", ",")
    trial = read_trial(write(tmp_path, "eu.csv", text), delimiter=";", decimal=",")
    assert float(trial.torque[3]) == 7.5


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            {"delimiter": 5},
            r"options\.delimiter: expected one character such as ',' ';' or '\\t', got 5$",
        ),
        ({"delimiter": ""}, r"options\.delimiter: expected one character .*, got ''$"),
        ({"delimiter": ",,"}, r"options\.delimiter: expected one character .*, got ',,'$"),
        (
            {"decimal": ""},
            r"options\.decimal: expected one character such as '\.' or ',', got ''$",
        ),
        ({"delimiter": ";", "decimal": ";"}, r"options\.delimiter and options\.decimal are both"),
    ],
)
def test_csv_delimiter_and_decimal_are_single_distinct_characters(tmp_path, options, message):
    # pandas raised a TypeError or ValueError (a traceback) for each of these
    path = write(tmp_path, "t.csv", generic_csv())
    with pytest.raises(InputError, match=r"^\S*t\.csv: " + message) as err:
        read_trial(path, **options)
    assert "\n" not in str(err.value)


def test_csv_radians_and_trailing_blank_lines(tmp_path):
    path = write(tmp_path, "r.csv", generic_csv() + "\n\n")
    trial = read_trial(path, units={"angle": "rad", "velocity": "rad/s"})
    assert float(trial.angle[0]) == 10.0
    assert trial.sizes["time"] == 20


def test_csv_missing_column_lists_the_files_columns(tmp_path):
    path = write(tmp_path, "A_240_01.csv", generic_csv(header="time,angle,vel,torque"))
    with pytest.raises(
        InputError,
        match=r"A_240_01\.csv: column 'velocity' not found \(columns are: time, angle, vel, "
        r"torque\); set columns\.velocity in the manifest$",
    ):
        read_trial(path)


def test_csv_column_named_twice_is_an_input_error(tmp_path):
    # "torque" and "torque " are one channel once the header is stripped
    text = generic_csv(header="time,angle,velocity,torque").replace("\n", ",0\n")
    text = text.replace("torque,0", "torque,torque ", 1)
    path = write(tmp_path, "dup.csv", text)
    with pytest.raises(
        InputError, match=r"dup\.csv: column 'torque' appears 2 times in the header"
    ):
        read_trial(path)


def test_csv_non_numeric_cell_names_line_and_column(tmp_path):
    text = generic_csv().replace("\n0.0500,15.0,60,12.50\n", "\n0.0500,15.0,60,12.5O\n")
    path = write(tmp_path, "bad.csv", text)
    with pytest.raises(InputError, match=r"bad\.csv: line 7, column 'torque': '12\.5O' is not"):
        read_trial(path)


def test_csv_empty_cell_is_missing_value_on_its_line(tmp_path):
    text = generic_csv().replace("\n0.0300,13.0,60,7.50\n", "\n0.0300,,60,7.50\n")
    with pytest.raises(
        InputError, match=r"e\.csv: column 'angle' has a missing or non-finite value .* line 5"
    ):
        read_trial(write(tmp_path, "e.csv", text))


def test_csv_nan_and_inf_cells(tmp_path):
    text = generic_csv().replace("\n0.0300,13.0,60,7.50\n", "\n0.0300,13.0,inf,7.50\n")
    with pytest.raises(InputError, match=r"i\.csv: column 'velocity' .*\(inf\) at line 5"):
        read_trial(write(tmp_path, "i.csv", text))


def test_csv_gap_and_unsorted_time(tmp_path):
    rows = generic_csv().splitlines()
    gap = write(tmp_path, "gap.csv", "\n".join(rows[:10] + rows[13:]) + "\n")
    with pytest.raises(InputError, match=r"gap\.csv: gap in column 'time' at line 11: 0\.04 s"):
        read_trial(gap)
    swapped = [*rows[:5], rows[6], rows[5], *rows[7:]]
    with pytest.raises(InputError, match=r"u\.csv: column 'time' does not increase at line 7"):
        read_trial(write(tmp_path, "u.csv", "\n".join(swapped) + "\n"))


def test_csv_unknown_unit(tmp_path):
    path = write(tmp_path, "t.csv", generic_csv())
    with pytest.raises(
        InputError,
        match=r"t\.csv: units\.torque: unknown torque unit 'kg\*m' \(accepted: N\*m, ft\*lbf",
    ):
        read_trial(path, units={"torque": "kg*m"})
    with pytest.raises(InputError, match=r"t\.csv: units\.speed: unknown channel"):
        read_trial(path, units={"speed": "deg/s"})


def test_csv_too_short_empty_and_ragged(tmp_path):
    with pytest.raises(InputError, match=r"s\.csv: only 5 samples"):
        read_trial(write(tmp_path, "s.csv", generic_csv(n=5)))
    with pytest.raises(InputError, match=r"z\.csv: file is empty"):
        read_trial(write(tmp_path, "z.csv", ""))
    ragged = generic_csv().replace("\n0.0200,12.0,60,5.00\n", "\n0.0200,12.0,60,5.00,9,9\n")
    with pytest.raises(InputError, match=r"g\.csv: cannot be read as delimited text: .*line 4"):
        read_trial(write(tmp_path, "g.csv", ragged))


def test_read_trial_rejects_missing_file_format_option_and_calibration(tmp_path):
    path = write(tmp_path, "t.csv", generic_csv())
    with pytest.raises(InputError, match=r"nope\.csv: trial file not found"):
        read_trial(tmp_path / "nope.csv")
    with pytest.raises(InputError, match=r"t\.csv: unknown trial format 'excel' \(formats: csv"):
        read_trial(path, format="excel")
    with pytest.raises(
        InputError, match=r"t\.csv: unknown option 'sep' for format 'csv' \(options: delimiter"
    ):
        read_trial(path, sep=";")
    with pytest.raises(
        InputError,
        match=r"t\.csv: calibration is only used by the formats of analog channels in volts \('analog', 'c3d'",
    ):
        read_trial(path, calibration={"torque": {"scale": 1.0}})
    with pytest.raises(InputError, match=r"t\.csv: columns\.torque: expected a column name"):
        read_trial(path, columns={"torque": 3})


def test_study_of_62_trials_at_1khz_reads_whole(tmp_path):
    # Speed belongs to benchmarks/processing.py (the read-and-filter floor), not to a unit test.
    n = 3000
    t = np.arange(n) / 1000
    table = np.column_stack([t, 90 - 240 * t, np.full(n, -240.0), 5 + np.sin(8 * t)])
    text = "time,angle,velocity,torque\n" + "\n".join(
        f"{a:.3f},{b:.4f},{c:.1f},{d:.5f}" for a, b, c, d in table
    )
    paths = [write(tmp_path, f"B_{k:02d}.csv", text) for k in range(62)]
    trials = [read_trial(p) for p in paths]
    assert all(tr.sizes["time"] == n for tr in trials)
    assert all(np.allclose(tr["time"].values, t) for tr in trials)


# ---------------------------------------------------------------------------------- biodex


def test_biodex_fixture_ft_lb_from_metadata():
    trial = read_trial(DATA / "biodex_ftlb.txt", format="biodex")
    assert trial.attrs["format"] == "biodex"
    assert trial.attrs["sampling_rate"] == 100.0
    assert trial.attrs["angle_column"] == "POSITION"
    assert trial.sizes["time"] == 60
    # first data row: "1 1 0 7.46 100.0 90.0 12.0"
    assert float(trial.time[0]) == 0.0
    assert float(trial.torque[0]) == pytest.approx(7.46 * FT_LBF, rel=1e-15)
    assert float(trial.torque[0]) == pytest.approx(10.114401894552247, rel=1e-14)
    assert float(trial.angle[0]) == pytest.approx(100 * DEG, rel=1e-15)
    # VELOCITY follows POS_ANAT; against POSITION it is reversed to follow the angle
    assert float(trial.velocity[0]) == pytest.approx(-12 * DEG, rel=1e-15)
    assert float(trial.velocity[4]) == pytest.approx(-math.pi / 3, rel=1e-15)  # 60 deg/s
    assert trial.attrs["flags"][0].startswith("velocity: column 'VELOCITY' runs against")
    assert float(trial.time[59]) == pytest.approx(0.59, abs=1e-12)


def test_biodex_anatomical_position_and_rep_selection():
    trial = read_trial(DATA / "biodex_ftlb.txt", format="biodex", anatomical=True, rep=2)
    assert trial.attrs["angle_column"] == "POS_ANAT"
    assert trial.sizes["time"] == 30
    # first row of rep 2: "1 2 300 7.48 82.0 108.0 12.0"
    assert float(trial.time[0]) == pytest.approx(0.3)
    assert float(trial.angle[0]) == pytest.approx(108 * DEG, rel=1e-15)
    assert float(trial.torque[0]) == pytest.approx(7.48 * FT_LBF, rel=1e-15)


def test_biodex_six_header_line_variant_in_newton_metres():
    trial = read_trial(DATA / "biodex_6line.txt", format="biodex")
    assert trial.sizes["time"] == 40
    assert trial.attrs["sampling_rate"] == 100.0
    # line 7: "1000 11.28 20.0 90.0 -30.0" (ms, N m, deg, anatomical deg, deg/s)
    assert float(trial.time[0]) == 1.0
    assert float(trial.torque[0]) == 11.28
    assert float(trial.angle[0]) == pytest.approx(20 * DEG, rel=1e-15)
    # VELOCITY follows POS_ANAT; against POSITION it is reversed to follow the angle
    assert float(trial.velocity[0]) == pytest.approx(math.pi / 6, rel=1e-15)
    anatomical = read_trial(DATA / "biodex_6line.txt", format="biodex", anatomical=True)
    assert float(anatomical.angle[39]) == pytest.approx(66.6 * DEG, rel=1e-15)


def biodex_text(unit_line="Torque Units: N-M", rows=None):
    rows = rows or [f"1 1 {10 * k} {1.5 + k} {90 - k} {k} -60" for k in range(15)]
    return "\n".join(
        [
            "BIODEX SYSTEM 3",
            "Joint: Knee",
            unit_line,
            "Set Rep mSec TORQUE POSITION POS_ANAT VELOCITY",
            *rows,
        ]
    )


def test_biodex_units_setting_english_and_user_unit_when_silent(tmp_path):
    english = read_trial(write(tmp_path, "e.txt", biodex_text("Units: English")), format="biodex")
    assert float(english.torque[0]) == pytest.approx(1.5 * FT_LBF, rel=1e-15)
    silent = write(tmp_path, "s.txt", biodex_text("Joint: Knee"))
    assert float(read_trial(silent, format="biodex").torque[0]) == 1.5  # documented N m
    in_lb = read_trial(silent, format="biodex", units={"torque": "in*lbf"})
    assert float(in_lb.torque[0]) == pytest.approx(1.5 * FT_LBF / 12, rel=1e-15)


def test_biodex_user_unit_contradicting_the_metadata(tmp_path):
    path = write(tmp_path, "c.txt", biodex_text("Torque Units: ft-lbs"))
    with pytest.raises(
        InputError,
        match=r"c\.txt: units\.torque = 'N\*m' contradicts the file, whose metadata line 3 says "
        r"'ft\*lbf'",
    ):
        read_trial(path, format="biodex", units={"torque": "N*m"})


def test_biodex_unknown_torque_unit_in_metadata(tmp_path):
    path = write(tmp_path, "u.txt", biodex_text("Torque Units: kg-m"))
    with pytest.raises(
        InputError, match=r"u\.txt: line 3 \('Torque Units: kg-m'\): unknown torque unit 'kg-m'"
    ):
        read_trial(path, format="biodex")


def test_biodex_bad_rows(tmp_path):
    rows = [f"1 1 {10 * k} {1.5 + k} {90 - k} {k} -60" for k in range(15)]
    bad = rows[:]
    bad[4] = "1 1 40 5.5 86 4 ---"
    with pytest.raises(InputError, match=r"n\.txt: line 9, column 'VELOCITY': '---' is not a"):
        read_trial(write(tmp_path, "n.txt", biodex_text(rows=bad)), format="biodex")
    short = rows[:]
    short[2] = "1 1 20 3.5"
    with pytest.raises(InputError, match=r"h\.txt: line 7 has 4 fields, expected at least 7"):
        read_trial(write(tmp_path, "h.txt", biodex_text(rows=short)), format="biodex")
    more = [f"1 1 {10 * k} {1.5 + k} {90 - k} {k} -60" for k in range(12)]
    restart = rows[:8] + [r.replace("1 1 ", "2 1 ", 1) for r in more]
    path = write(tmp_path, "r.txt", biodex_text(rows=restart))
    with pytest.raises(InputError, match=r"r\.txt: column 'MSEC' does not increase at line 13"):
        read_trial(path, format="biodex")
    assert read_trial(path, format="biodex", set=2).sizes["time"] == 12
    with pytest.raises(InputError, match=r"r\.txt: no rows with Set = 3 \(Set values in the file"):
        read_trial(path, format="biodex", set=3)
    for bad in ([], "2", 2.5, True, -1):  # a list ended in a numpy traceback
        with pytest.raises(InputError, match=r"r\.txt: options\.set: expected a whole number"):
            read_trial(path, format="biodex", set=bad)


def test_biodex_missing_column_and_not_a_biodex_file(tmp_path):
    path = write(tmp_path, "m.txt", biodex_text())
    with pytest.raises(
        InputError, match=r"m\.txt: column 'ANGLE' not found \(columns are: SET REP MSEC"
    ):
        read_trial(path, format="biodex", columns={"angle": "angle"})
    other = write(tmp_path, "o.txt", "hello\n" * 10)
    with pytest.raises(InputError, match=r"o\.txt: no column line 'Set Rep mSec TORQUE"):
        read_trial(other, format="biodex")


# ----------------------------------------------------------------------------------- humac
# Two fixtures reproduce the two sites of docs/devices/humac.md (values invented):
# humac_stafford_style.csv: 16 columns, Status quoted and numbers not (".01"), ft-lbf; a
#   leading Status-5 rest with real torque; 7 Status-5 rows with torque written as 0 at every
#   braking; torque a magnitude, 0 through each reversal; Speed against d(Position)/dt; an
#   end-of-set row (Status 11) and the closing row (Status 0, all zeros) at the end.
# humac_crc_style.csv: 5 columns, every field quoted, Status "0001", N m; Status-5 rows with
#   real torque (rest and the return stroke); torque a magnitude, near 0 (never exactly) where
#   it changes sign; Speed with d(Position)/dt; "0011" and "0000" rows at the end.

STAFFORD = DATA / "humac_stafford_style.csv"
CRC = DATA / "humac_crc_style.csv"
REVERSED = "velocity: column 'Speed(d/s)' runs against the derivative of 'Position(Degrees)'"
MAGNITUDE_2_OF_2 = (
    "torque: a magnitude, not a signed moment (never negative; near 0 at 2 of 2 reversals of "
    "the motion)"
)


def test_humac_old_fixture_drops_unmeasured_status_5_rows_at_the_ends():
    trial = read_trial(DATA / "humac_ftlb.csv", format="humac")
    assert trial.attrs["format"] == "humac"
    assert trial.attrs["sampling_rate"] == 100.0
    assert trial.sizes["time"] == 40  # 46 rows, 3 + 3 with Status 5 and torque 0 dropped
    # first kept row, line 5: "1",.03,87.6875,10,150 (Position falls: Speed runs against it)
    assert float(trial.time[0]) == 0.03
    assert float(trial.torque[0]) == pytest.approx(13.558179483314004, rel=1e-15)
    assert float(trial.angle[0]) == pytest.approx(87.6875 * DEG, rel=1e-15)
    assert float(trial.velocity[0]) == pytest.approx(-150 * DEG, rel=1e-15)
    assert trial.attrs["flags"][0].startswith(REVERSED + " (ratio -1 over ")
    # last kept row, line 44: "1",.42,29.1875,19.75,150 ; no status-5 zero survives
    assert float(trial.torque[-1]) == pytest.approx(19.75 * FT_LBF, rel=1e-15)
    assert float(trial.time[-1]) == 0.42
    assert (trial.torque.values != 0).all()
    # never negative: HUMAC's torque is a magnitude (no reversal in this short file)
    assert trial.attrs["torque_kind"] == "magnitude"
    assert trial.attrs["flags"][1] == (
        "torque: a magnitude, not a signed moment (never negative in the 40 samples of the file)"
    )


def test_humac_every_field_quoted_newton_metres_deg_per_sec():
    trial = read_trial(DATA / "humac_nm_quoted.csv", format="humac")
    assert trial.sizes["time"] == 30
    # line 2: "1","2.00","10","-3.5","93.75"
    assert float(trial.time[0]) == 2.0
    assert float(trial.torque[0]) == -3.5
    assert float(trial.angle[0]) == pytest.approx(10 * DEG, rel=1e-15)
    assert float(trial.velocity[0]) == pytest.approx(93.75 * DEG, rel=1e-15)
    assert float(trial.torque[29]) == 0.125
    # a negative torque is a signed moment; Speed follows Position: nothing to flag
    assert trial.attrs["torque_kind"] == "signed"
    assert trial.attrs["flags"] == ()


def test_humac_stafford_style_breaks_are_listed_and_segment_picks_one():
    with pytest.raises(InputError) as info:
        read_trial(STAFFORD, format="humac")
    assert str(info.value) == (
        f"{STAFFORD}: 4 separate stretches of samples, cut by torque not measured (Status 5, "
        "written as 0) at lines 54-60, 107-113, 153-159; a trial is one stretch: pick it with "
        "option segment (1 = lines 2-53 (0-0.51 s), 2 = lines 61-106 (0.59-1.04 s), "
        "3 = lines 114-152 (1.12-1.5 s), 4 = lines 160-168 (1.58-1.66 s))"
    )  # lines 169 ("11", end of set) and 170 ("0", closing row) are in no stretch
    first = read_trial(STAFFORD, format="humac", segment=1)
    assert first.sizes["time"] == 52  # lines 2-53
    # the leading Status-5 rest carries real torque and is kept: "5",0,92.1875,7.3169,.0625
    assert float(first.torque[0]) == pytest.approx(7.3169 * FT_LBF, rel=1e-15)
    assert float(first.angle[0]) == pytest.approx(92.1875 * DEG, rel=1e-15)
    assert float(first.velocity[0]) == pytest.approx(-0.0625 * DEG, rel=1e-15)  # reversed
    # line 53: "1",.51,23.8125,14.7487,180 -> moving towards smaller angles
    assert float(first.velocity[-1]) == pytest.approx(-180 * DEG, rel=1e-15)
    assert first.attrs["torque_kind"] == "magnitude"
    assert first.attrs["flags"] == (
        (
            f"{REVERSED} (ratio -1 over 71 stretches of motion); its sign was reversed to "
            "follow the angle"
        ),
        # the evidence is the whole file's: this stroke alone shows no reversal
        MAGNITUDE_2_OF_2,
    )
    third = read_trial(STAFFORD, format="humac", segment=3)
    assert (float(third.time[0]), float(third.time[-1])) == (1.12, 1.5)
    with pytest.raises(InputError, match=r"humac_stafford_style\.csv: only 9 samples"):
        read_trial(STAFFORD, format="humac", segment=4)
    with pytest.raises(InputError, match=r"option segment = 5 but the file has 4 stretch"):
        read_trial(STAFFORD, format="humac", segment=5)
    with pytest.raises(InputError, match=r"option segment must be an integer, got '1'"):
        read_trial(STAFFORD, format="humac", segment="1")


def test_humac_crc_style_keeps_status_5_rows_with_real_torque_and_drops_the_last_two():
    trial = read_trial(CRC, format="humac")
    assert trial.sizes["time"] == 242  # 244 rows: "0011" and "0000" are not samples
    assert (float(trial.time[0]), float(trial.time[-1])) == (0.0, 2.41)
    # line 10: "0005","0.080","89.250","1.923","0.000": measured while at rest
    assert float(trial.torque[8]) == 1.923
    # line 173: "0005","1.710","47.875","18.350","180.000": measured on the return stroke
    assert float(trial.torque[171]) == 18.35
    assert float(trial.velocity[171]) == pytest.approx(math.pi, rel=1e-15)  # not reversed
    # the closing row's zeros are gone: the angle never drops to 0
    assert float(trial.angle.min()) == pytest.approx(13.625 * DEG, rel=1e-15)
    assert float(trial.angle[-1]) == pytest.approx(68.875 * DEG, rel=1e-15)
    assert trial.attrs["flags"] == (MAGNITUDE_2_OF_2,)


def humac_rows(tmp_path, name, rows, header=None):
    header = (
        header
        or '"Status","Time(Seconds)","Position(Degrees)","Torque(Newton-Meters)","Speed(deg/sec)"'
    )
    text = header + "\n" + "\n".join(",".join(str(c) for c in r) for r in rows) + "\n"
    return write(tmp_path, name, text)


def test_humac_status_5_is_unmeasured_only_where_its_whole_run_is_exactly_0(tmp_path):
    # 30 samples at 60 deg/s; rows 10-14 Status 5. Torque written as 0 on all five rows: a
    # gap. One of them measured (0.8 N m): the run carries real torque and is kept whole.
    def rows(run_torque):
        out = []
        for k in range(30):
            status, torque = (5, run_torque[k - 10]) if 10 <= k < 15 else (1, 2.0 + 0.1 * k)
            out.append((status, f"{k / 100:.2f}", 10 + 0.6 * k, torque, 60))
        return out

    gap = humac_rows(tmp_path, "gap.csv", rows([0, 0, 0, 0, 0]))
    with pytest.raises(
        InputError,
        match=r"gap\.csv: 2 separate stretches of samples, cut by torque not "
        r"measured \(Status 5, written as 0\) at lines 12-16; .*1 = lines 2-11 \(0-0\.09 s\)",
    ):
        read_trial(gap, format="humac")
    assert read_trial(gap, format="humac", segment=2).sizes["time"] == 15
    kept = read_trial(humac_rows(tmp_path, "kept.csv", rows([0, 0, 0.8, 0, 0])), format="humac")
    assert kept.sizes["time"] == 30
    np.testing.assert_array_equal(kept.torque.values[10:15], [0, 0, 0.8, 0, 0])


def test_humac_fatigue_sets_are_separate_stretches(tmp_path):
    # three 1-s sets at 70 deg, each closed by an end-of-set row (Status 11, the previous
    # sample repeated); the file closes with the all-zero Status-0 row.
    rows, t = [], 0.0
    for s in range(3):
        for k in range(100):
            rows.append((1, f"{t:.2f}", 70.0 + 0.0625 * (k % 2), 50 + 10 * s + k % 7, 0))
            t += 0.01
        rows.append((11, f"{t:.2f}", *rows[-1][2:]))
        t += 0.01
    rows.append((0, f"{t:.2f}", 0, 0, 0))
    path = humac_rows(tmp_path, "fatigue.csv", rows)
    with pytest.raises(
        InputError,
        match=r"fatigue\.csv: 3 separate stretches of samples, cut by end of set \(Status 11 "
        r"or 15\) at lines 102, 203; .* \(1 = lines 2-101 \(0-0\.99 s\), 2 = lines 103-202 "
        r"\(1\.01-2 s\), 3 = lines 204-303 \(2\.02-3\.01 s\)\)$",
    ):
        read_trial(path, format="humac")
    second = read_trial(path, format="humac", segment=2)
    assert second.sizes["time"] == 100
    assert float(second.torque[0]) == 60.0
    assert float(np.degrees(np.ptp(second.angle.values))) == pytest.approx(0.0625)
    assert read_trial(path, format="humac", segment=3).time.values[-1] == 3.01  # no 0 row


def test_humac_without_status_column_still_drops_the_closing_row(tmp_path):
    header = '"Time(Seconds)","Position(Degrees)","Torque(Newton-Meters)","Speed(deg/sec)"'
    rows = [(f"{k / 100:.2f}", 10 + 0.6 * k, 2.0, 60) for k in range(20)]
    trial = read_trial(
        humac_rows(tmp_path, "ns.csv", [*rows, ("0.20", 0, 0, 0)], header), format="humac"
    )
    assert trial.sizes["time"] == 20
    # negative control: a last row at 0 deg after a row at 0 deg is a sample
    rows = [(f"{k / 100:.2f}", 0.0, 0.0, 0) for k in range(21)]
    assert (
        read_trial(humac_rows(tmp_path, "z.csv", rows, header), format="humac").sizes["time"] == 21
    )


def test_humac_unknown_status_is_read_and_flagged_and_a_bad_status_is_an_error(tmp_path):
    rows = [(7 if k in (3, 4) else 1, f"{k / 100:.2f}", 10 + 0.6 * k, 2.0, 60) for k in range(20)]
    trial = read_trial(humac_rows(tmp_path, "s7.csv", rows), format="humac")
    assert trial.sizes["time"] == 20
    assert trial.attrs["flags"][0] == (
        "Status 7 at lines 5-6: not a code this reader knows (0, 1, 5, 11, 15); read as samples"
    )
    rows[6] = (1.5, *rows[6][1:])
    with pytest.raises(
        InputError, match=r"s15\.csv: line 8, column 'Status': 1\.5 is not a status code"
    ):
        read_trial(humac_rows(tmp_path, "s15.csv", rows), format="humac")


def test_humac_all_rows_unmeasured(tmp_path):
    text = (DATA / "humac_ftlb.csv").read_text(encoding="utf-8").replace('"1",', '"5",')
    # every row Status 5 but most with real torque: one measured run, read whole (46 rows)
    assert read_trial(write(tmp_path, "all5.csv", text), format="humac").sizes["time"] == 46
    zero = "\n".join(
        ",".join(c if i != 3 else "0" for i, c in enumerate(line.split(",")))
        for line in text.splitlines()[1:]
    )
    zero = text.splitlines()[0] + "\n" + zero + "\n"
    with pytest.raises(InputError, match=r"all0\.csv: no row is a measured sample \(Status 5"):
        read_trial(write(tmp_path, "all0.csv", zero), format="humac")


def test_humac_unknown_header_unit_and_missing_column(tmp_path):
    text = (DATA / "humac_nm_quoted.csv").read_text(encoding="utf-8")
    bad = write(tmp_path, "kgm.csv", text.replace("Newton-Meters", "Kilogram-Meters"))
    with pytest.raises(
        InputError,
        match=r"kgm\.csv: header cell 'Torque\(Kilogram-Meters\)': unknown torque unit",
    ):
        read_trial(bad, format="humac")
    nospeed = write(tmp_path, "ns.csv", text.replace("Speed(deg/sec)", "Rate(deg/sec)"))
    with pytest.raises(
        InputError, match=r"ns\.csv: column 'Speed' not found \(columns are: Status, Time"
    ):
        read_trial(nospeed, format="humac")
    renamed = read_trial(nospeed, format="humac", columns={"velocity": "Rate"})
    assert float(renamed.velocity[0]) == pytest.approx(93.75 * DEG, rel=1e-15)


def test_humac_user_unit_contradicting_header(tmp_path):
    with pytest.raises(InputError, match=r"humac_ftlb\.csv: units\.torque = 'N\*m' contradicts"):
        read_trial(DATA / "humac_ftlb.csv", format="humac", units={"torque": "N m"})


# ---------------------------------------------------------------------------------- analog

CAL = {
    "torque": {"scale": 136.0, "offset": 0.0, "unit": "N*m"},
    "angle": {"scale": 90.0, "offset": 10.0, "unit": "deg"},
    "velocity": {"scale": 100.0, "unit": "deg/s"},
}
ANALOG_COLUMNS = {"torque": "trq_V", "angle": "pos_V", "velocity": "vel_V"}


def test_analog_linear_calibration():
    trial = read_trial(
        DATA / "analog_volts.csv", format="analog", columns=ANALOG_COLUMNS, calibration=CAL
    )
    assert trial.attrs["format"] == "analog"
    assert trial.attrs["sampling_rate"] == 1000.0
    # line 3: 0.001,0.0510,0.9960,-2.0000
    assert float(trial.torque[1]) == pytest.approx(136.0 * 0.0510, rel=1e-14)
    assert float(trial.angle[1]) == pytest.approx((90.0 * 0.9960 + 10.0) * DEG, rel=1e-14)
    assert float(trial.velocity[1]) == pytest.approx(-200 * DEG, rel=1e-14)
    # torque calibrated in ft-lbf (a Biodex analog output), then converted once
    ftlb = {**CAL, "torque": {"scale": 102.4, "unit": "ft-lbf"}}
    trial = read_trial(
        DATA / "analog_volts.csv", format="analog", columns=ANALOG_COLUMNS, calibration=ftlb
    )
    assert float(trial.torque[0]) == pytest.approx(102.4 * 0.05 * FT_LBF, rel=1e-14)


def test_analog_missing_and_malformed_calibration():
    path = DATA / "analog_volts.csv"
    partial = {k: v for k, v in CAL.items() if k != "velocity"}
    with pytest.raises(InputError, match=r"analog_volts\.csv: calibration\.velocity missing"):
        read_trial(path, format="analog", columns=ANALOG_COLUMNS, calibration=partial)
    with pytest.raises(InputError, match=r"analog_volts\.csv: calibration\.angle missing"):
        read_trial(path, format="analog", columns=ANALOG_COLUMNS)
    zero = {**CAL, "torque": {"scale": 0}}
    with pytest.raises(InputError, match=r"calibration\.torque\.scale: must be non-zero"):
        read_trial(path, format="analog", columns=ANALOG_COLUMNS, calibration=zero)
    text = {**CAL, "torque": {"scale": "136"}}
    with pytest.raises(InputError, match=r"calibration\.torque\.scale: expected a number"):
        read_trial(path, format="analog", columns=ANALOG_COLUMNS, calibration=text)
    typo = {**CAL, "torque": {"scale": 1.0, "ofset": 2.0}}
    with pytest.raises(InputError, match=r"calibration\.torque\.ofset: unknown key \(allowed"):
        read_trial(path, format="analog", columns=ANALOG_COLUMNS, calibration=typo)
    bad_unit = {**CAL, "angle": {"scale": 1.0, "unit": "grad"}}
    with pytest.raises(InputError, match=r"calibration\.angle\.unit: unknown angle unit 'grad'"):
        read_trial(path, format="analog", columns=ANALOG_COLUMNS, calibration=bad_unit)
    with pytest.raises(InputError, match=r"units\.torque = 'ft\*lbf' contradicts calibration"):
        read_trial(
            path,
            format="analog",
            columns=ANALOG_COLUMNS,
            calibration=CAL,
            units={"torque": "ft*lbf"},
        )


def test_analog_missing_voltage_column():
    with pytest.raises(
        InputError, match=r"column 'angle' not found \(columns are: time, trq_V, pos_V, vel_V\)"
    ):
        read_trial(DATA / "analog_volts.csv", format="analog", calibration=CAL)


# -------------------------------------------------------------------------------- registry


def test_a_new_format_is_one_function_and_one_registration(tmp_path):
    @register_reader("twocol")
    def read_twocol(path, *, columns=None, units=None, calibration=None, gain=1.0):
        t, m = np.loadtxt(path, unpack=True)
        zeros = np.zeros_like(t)
        return make_trial(t, zeros, zeros, gain * m, source=str(path), format="twocol")

    try:
        path = write(tmp_path, "x.dat", "\n".join(f"{k / 10} {k}" for k in range(12)))
        trial = read_trial(path, format="twocol", gain=2.0)
        assert isinstance(trial, xr.Dataset)
        assert float(trial.torque[3]) == 6.0
        assert trial.attrs["sampling_rate"] == 10.0
        assert "twocol" in available_formats()
    finally:
        del READERS["twocol"]
