"""The checks every reader gets from make_trial, and the torque's sign (issue 11).

- the velocity against the derivative of the angle: a reversed sign is corrected and flagged,
  a unit factor refused, and a trial that barely moves (isometric, 1 deg/s) never refused;
- time evenly sampled;
- a torque written as a magnitude (never negative, ~0 where the motion reverses) is recorded,
  and signed only as ``torque_sign`` says (``"motion"`` for a fast trial);
- end to end: a simulated trial written the way a HUMAC NORM writes it (magnitude torque,
  reversed speed, braking rows not measured, end-of-set and closing rows) gives the true
  inertia through the manifest, and the same trial read as a signed torque is refused at
  reading, not turned into a negative inertia.
"""

import math

import numpy as np
import pytest

from inertiafit.errors import InputError
from inertiafit.io import load_study, read_trial
from inertiafit.io.trial import (
    MAGNITUDE_FLAG,
    apply_torque_sign,
    compare_velocity,
    make_trial,
    motion_direction,
)
from inertiafit.io.units import FT_LBF
from inertiafit.processing import estimate_inertia, fit_gravity
from inertiafit.simulate import Motion, simulate_trial

DEG = math.pi / 180
RATE = 100.0


def stroke(n=120, speed=180.0, start=90.0):
    """A 100 Hz move from rest at ``start`` deg towards smaller angles: angle, its velocity."""
    t = np.arange(n) / RATE
    v = -np.minimum(speed, 3000.0 * np.maximum(t - 0.1, 0.0)) * DEG  # rest, ramp, cruise
    angle = start * DEG + np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) / RATE)))
    return t, angle, v


def q16(x_deg):
    return np.round(np.asarray(x_deg) * 16) / 16


# ------------------------------------------------------------------ velocity against angle


def test_a_velocity_against_the_angle_is_reversed_and_flagged():
    t, angle, v = stroke()
    torque = np.full(t.size, -5.0)
    trial = make_trial(t, angle, -v, torque, source="A.csv", columns={"velocity": "Speed"})
    np.testing.assert_array_equal(trial.velocity.values, v)
    assert trial.attrs["flags"] == (
        (
            "velocity: column 'Speed' runs against the derivative of 'angle' (ratio -1 over 227 "
            "stretches of motion); its sign was reversed to follow the angle"
        ),
    )
    # negative control: the same velocity with the angle's sign is left alone
    same = make_trial(t, angle, v, torque, source="A.csv")
    np.testing.assert_array_equal(same.velocity.values, v)
    assert same.attrs["flags"] == ()
    assert compare_velocity(t, angle, v).ratio == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize(
    ("factor", "cause"),
    [
        (180 / math.pi, r"velocity in deg/s read as rad/s, or angle in rad read as deg"),
        (math.pi / 180, r"velocity in rad/s read as deg/s, or angle in deg read as rad"),
        (-180 / math.pi, r"velocity in deg/s read as rad/s"),
    ],
)
def test_a_velocity_off_by_a_unit_factor_is_refused_naming_the_units(factor, cause):
    t, angle, v = stroke()
    units = {"time": "s", "angle": "deg", "velocity": "deg/s"}
    with pytest.raises(InputError) as info:
        make_trial(t, angle, factor * v, np.zeros(t.size) - 1, source="A.csv", units=units)
    message = str(info.value)
    assert message.startswith(f"A.csv: column 'velocity' is {abs(factor):.3g} x the derivative")
    assert cause in message
    assert "(read as time 's', angle 'deg', velocity 'deg/s'); correct the units" in message
    assert ("opposite sign" in message) == (factor < 0)


def test_time_in_ms_read_as_seconds_is_named_and_a_small_scale_error_passes():
    t, angle, v = stroke()
    with pytest.raises(
        InputError, match=r"is 1e\+03 x the derivative .*\(time in ms read as s\?\)"
    ):
        make_trial(1000 * t, angle, v, np.ones(t.size), source="A.csv")
    # negative controls: a tachometer 30 % off is not a unit mix-up, and 2.5 x is flagged only
    trial = make_trial(t, angle, 1.3 * v, np.ones(t.size), source="A.csv")
    assert trial.attrs["flags"] == ()
    trial = make_trial(t, angle, 2.5 * v, np.ones(t.size), source="A.csv")
    np.testing.assert_array_equal(trial.velocity.values, 2.5 * v)
    assert trial.attrs["flags"] == (
        (
            "velocity: column 'velocity' is 2.5 x the derivative of 'angle' (over 227 stretches "
            "of motion), a factor no unit explains; left as it is"
        ),
    )


def test_humac_speed_in_rad_per_s_under_a_deg_per_sec_header_is_refused(tmp_path):
    t, angle, v = stroke(n=60)
    rows = [
        '"Status","Time(Seconds)","Position(Degrees)","Torque(Newton-Meters)","Speed(deg/sec)"'
    ]
    rows += [
        f'"1","{t[k]:.3f}","{q16(angle[k] / DEG)[()]:.3f}","-2.000","{v[k]:.4f}"'
        for k in range(t.size)
    ]
    path = tmp_path / "rad.csv"
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(
        InputError,
        match=r"rad\.csv: column 'Speed\(deg/sec\)' is 0\.017\d x the derivative of column "
        r"'Position\(Degrees\)' .*\(velocity in rad/s read as deg/s, or angle in deg read as "
        r"rad\?\) \(read as time 's', angle 'deg', velocity 'deg/s'\)",
    ):
        read_trial(path, format="humac")


def test_an_angle_in_rad_read_as_deg_is_refused_though_it_sweeps_under_2_deg():
    # An 83-deg fast move written in rad under a deg header: read as deg it moves 1.45 deg, too
    # little for the velocity-against-angle comparison, and its inertia came out 8 % high.
    t, angle, v = stroke(n=60, speed=180.0)
    as_if_deg = angle * DEG  # the rad numbers taken for degrees, then converted
    assert np.ptp(as_if_deg) < np.radians(2.0)
    with pytest.raises(
        InputError,
        match=r"^A\.csv: column 'angle' moves 1\.\d+ deg in all while the integral of column "
        r"'velocity' travels 36 deg in 0\.2 s \(velocity in deg/s read as rad/s, or angle in rad "
        r"read as deg\?\); correct the angle's unit or channel$",
    ):
        make_trial(t, as_if_deg, v, np.ones(t.size), source="A.csv")


def test_a_dead_angle_channel_under_a_moving_velocity_is_refused():
    t, angle, v = stroke(n=120, speed=180.0)
    with pytest.raises(InputError, match=r"moves 0 deg in all .*a dead or unplugged angle"):
        make_trial(t, np.full(t.size, angle[0]), v, np.ones(t.size), source="A.csv")


def test_an_isometric_velocity_offset_is_not_taken_for_travel():
    # 3 deg/s of offset and noise on a still shaft integrate to 0.6 deg in 0.2 s: no alarm
    rng = np.random.default_rng(5)
    t = np.arange(2000) / RATE
    angle = (70 + q16(rng.normal(0, 0.05, t.size))) * DEG
    v = (3.0 + rng.normal(0, 1.0, t.size)) * DEG
    assert make_trial(t, angle, v, np.ones(t.size), source="iso").attrs["flags"] == ()


def test_slow_and_isometric_trials_are_never_refused():
    rng = np.random.default_rng(11)
    # quasi-static: 1 deg/s over 40 deg, angle and velocity on a 1/16-deg grid, velocity noisy
    t = np.arange(4000) / RATE
    angle = q16(10 + 1.0 * t) * DEG
    v = q16(1.0 + rng.normal(0, 0.3, t.size)) * DEG
    torque = 20 * np.sin(angle)
    assert make_trial(t, angle, v, torque, source="qs").attrs["flags"] == ()
    flipped = make_trial(t, angle, -v, torque, source="qs")  # reversed: corrected all the same
    np.testing.assert_array_equal(flipped.velocity.values, v)
    assert flipped.attrs["flags"][0].startswith("velocity: column 'velocity' runs against")
    # isometric: the angle jitters by 1/16 deg, the velocity is noise: nothing to compare
    angle = (70 + q16(rng.normal(0, 0.05, t.size))) * DEG
    noise = rng.normal(0, 1.0, t.size) * DEG
    assert compare_velocity(t, angle, noise) is None
    iso = make_trial(t, angle, noise, 100 + 50 * np.sin(t), source="iso")
    assert iso.attrs["flags"] == ()
    np.testing.assert_array_equal(iso.velocity.values, noise)


def test_a_velocity_unrelated_to_the_angle_is_flagged_not_corrected():
    rng = np.random.default_rng(3)
    t, angle, _ = stroke(n=300, speed=60.0)
    noise = rng.normal(0, 60, t.size) * DEG
    trial = make_trial(t, angle, noise, np.ones(t.size), source="A.csv")
    np.testing.assert_array_equal(trial.velocity.values, noise)
    assert trial.attrs["flags"][0].startswith(
        "velocity: column 'velocity' does not follow the derivative of 'angle' consistently"
    )


@pytest.mark.parametrize("channel", ["angle", "velocity", "torque"])
def test_a_value_no_dynamometer_reaches_is_refused_naming_its_line(channel):
    # a torque of 1e308 passed as finite: its squares overflowed into a NaN inertia, named as
    # the manifest's condition
    t, angle, v = stroke()
    given = {"angle": angle, "velocity": v, "torque": np.ones(t.size)}
    given[channel] = given[channel].copy()
    given[channel][30] = 1e308
    with pytest.raises(
        InputError,
        match=rf"^A\.csv: column '{channel}' holds 1e\+308 (rad|rad/s|N m) at line 32, beyond 1e\+09 ",
    ):
        make_trial(t, **given, source="A.csv", lines=np.arange(t.size) + 2)
    given[channel][30] = 0.9e9 if channel == "torque" else given[channel][29]
    make_trial(t, **given, source="A.csv")  # a large torque, but one a reading can hold


# ------------------------------------------------------------------------- swapped columns

#: The file's column of each channel in the swap tests (other names than the channels').
FILE_COLUMNS = {"angle": "Pos", "velocity": "Vel", "torque": "Tq"}


@pytest.fixture(scope="module")
def simulated_pair():
    """A fast and a quasi-static trial of the attachment (angle rad, velocity rad/s, N m)."""
    common = {"inertia": 0.2, "gravity_moment": 6.7, "phi": 0.2, "offset": 1.5}
    return {
        "fast": simulate_trial(kind="fast", speed_deg_s=240, rng=3, **common),
        "quasi-static": simulate_trial(kind="quasi-static", speed_deg_s=4, rng=4, **common),
    }


@pytest.mark.parametrize("kind", ["fast", "quasi-static"])
@pytest.mark.parametrize(
    "read_as",  # the channel each of the file's angle, velocity, torque columns is read as
    [
        ("torque", "velocity", "angle"),
        ("angle", "torque", "velocity"),
        ("velocity", "angle", "torque"),
        ("velocity", "torque", "angle"),
        ("torque", "angle", "velocity"),
    ],
)
def test_swapped_columns_are_named_with_the_mapping_that_fixes_them(simulated_pair, kind, read_as):
    trial = simulated_pair[kind]
    true = ("angle", "velocity", "torque")
    given = {read: trial[channel].values for channel, read in zip(true, read_as, strict=True)}
    columns = {read: FILE_COLUMNS[channel] for channel, read in zip(true, read_as, strict=True)}
    moved = " and ".join(c for c in true if columns[c] != FILE_COLUMNS[c]).replace(
        "angle and velocity and", "angle, velocity and"
    )
    with pytest.raises(InputError) as error:
        make_trial(trial.time.values, **given, source="A.csv", columns=columns)
    message = str(error.value)
    assert message.startswith(f"A.csv: {moved} columns swapped? ")
    assert message.endswith(
        'map columns = { angle = "Pos", velocity = "Vel", torque = "Tq" } (and their units) '
        "in the manifest"
    )
    assert "torque_sign" not in message
    assert "\n" not in message
    # negative control: the same channels mapped right are read without a word about them
    right = make_trial(
        trial.time.values,
        *(trial[c].values for c in true),
        source="A.csv",
        columns=FILE_COLUMNS,
    )
    assert not [f for f in right.attrs["flags"] if f.startswith("velocity:")]


def test_a_sinusoid_read_in_order_is_not_called_swapped():
    """Found by the fuzz run: under a harmonic motion the angle is also proportional to the
    velocity's derivative, and a 0.1-deg angle over a 3-deg swing follows its own velocity a
    little less tightly than the velocity "follows" it. The declared pair follows, so no swap."""
    t = np.arange(49) / 200.0
    w = 1.90625 * 2 * np.pi
    speed = np.radians(20.0)

    def tenths(x):  # an IsoMed file's resolution
        return np.round(10 * x) / 10

    angle = np.radians(tenths(np.degrees(speed / w * np.sin(w * t))))
    velocity = np.radians(tenths(np.degrees(speed * np.cos(w * t))))
    torque = tenths(np.cos(angle) + 0.2)
    ds = make_trial(t, angle, velocity, torque, source="A.csv")
    np.testing.assert_array_equal(ds.angle.values, angle)
    assert not [f for f in ds.attrs["flags"] if f.startswith("velocity:")]
    # (swapped columns of isokinetic moves, whose pairs cannot both follow, are still named:
    # test_swapped_columns_are_named_with_the_mapping_that_fixes_them)


def test_a_short_piece_of_a_sinusoid_is_not_called_swapped():
    """Found by the fuzz run too: 30 samples of a 0.4-deg swing give the declared pair 19
    stretches to compare, too few to say it does not follow, and the swapped pair 21."""
    t = np.arange(30) / 200.0
    w = 4 * np.pi
    angle = 0.0873 / w * np.sin(w * t)
    velocity = 0.0873 * np.cos(w * t)
    ds = make_trial(t, angle, velocity, angle.copy(), source="A.csv")
    np.testing.assert_array_equal(ds.velocity.values, velocity)


# ------------------------------------------------------------------------------ even time


def test_time_must_be_evenly_sampled():
    t, angle, v = stroke()
    at = 50  # a sample inserted 3 ms after sample 49
    t, angle, v = (np.insert(x, at, x[at - 1] + 0.3 * (x[at] - x[at - 1])) for x in (t, angle, v))
    with pytest.raises(
        InputError,
        match=r"^A\.csv: uneven sampling in column 'time' at line 52: 0\.003 s between "
        r"t = 0\.49 s and t = 0\.493 s, less than 0\.5 x the median step 0\.01 s",
    ):
        make_trial(t, angle, v, np.ones(t.size), source="A.csv", lines=np.arange(t.size) + 2)
    # negative control: 3 % jitter (times rounded in the file) is even enough
    t, angle, v = stroke()
    jitter = t + np.random.default_rng(0).uniform(-0.0003, 0.0003, t.size)
    assert make_trial(jitter, angle, v, np.ones(t.size), source="A.csv").sizes["time"] == 120


# ------------------------------------------------------------------------ magnitude torque


def back_and_forth(n=600):
    """Three strokes between 10 and 80 deg at 100 Hz; a signed torque that drives each."""
    t = np.arange(n) / RATE
    angle = (45 - 35 * np.cos(2 * np.pi * 0.5 * t)) * DEG
    v = 35 * np.pi * np.sin(2 * np.pi * 0.5 * t) * DEG
    signed = 30 * np.sin(2 * np.pi * 0.5 * t + 0.3)  # leads the velocity a little
    return t, angle, v, signed


def test_a_torque_that_vanishes_at_every_reversal_is_a_magnitude():
    t, angle, v, signed = back_and_forth()
    trial = make_trial(t, angle, v, np.abs(signed), source="A.csv")
    assert trial.attrs["torque_kind"] == "magnitude"
    assert trial.attrs["flags"] == (
        f"{MAGNITUDE_FLAG} (never negative; near 0 at 5 of 5 reversals of the motion)",
    )
    # negative controls: the signed torque; and a gravity moment that never changes sign over
    # the same sweeps (never negative, but not near 0 where the motion reverses)
    assert make_trial(t, angle, v, signed, source="A.csv").attrs["torque_kind"] == "signed"
    gravity = make_trial(t, angle, v, 5 + 20 * np.sin(angle), source="A.csv")
    assert gravity.attrs["torque_kind"] == "signed"
    assert gravity.attrs["flags"] == ()


def test_motion_direction_carries_the_next_motion_back_over_rest():
    v = np.array([0.0, 0.01, -0.01, -1.0, -2.0, -1.0, 0.0, 0.0, 1.5, 2.0, 0.02, 0.0])
    np.testing.assert_array_equal(motion_direction(v), [-1, -1, -1, -1, -1, -1, 1, 1, 1, 1, 1, 1])
    assert not motion_direction(np.full(5, 0.01)).any()


def test_torque_sign_of_a_magnitude_fast_trial_must_be_motion():
    t, angle, v, signed = back_and_forth()
    trial = make_trial(t, angle, v, np.abs(signed), source="A.csv")
    with pytest.raises(InputError) as info:
        apply_torque_sign(trial, 1, kind="fast")
    assert str(info.value) == (
        "A.csv: torque is written as a magnitude (never negative; near 0 at 5 of 5 reversals "
        "of the motion), not a signed moment: read as it is, the inertia takes the sign of the "
        'direction of motion; set torque_sign = "motion" for this fast trial (signs it by the '
        "direction of motion, right in its acceleration window)"
    )
    signed_back = apply_torque_sign(trial, "motion", kind="fast")
    # right where the motion speeds up (velocity and acceleration of one sign), wrong where
    # the torque brakes the motion before a reversal (it leads the velocity here)
    speeding_up = v * np.gradient(v) > 0
    np.testing.assert_array_equal(signed_back.torque.values[speeding_up], signed[speeding_up])
    braking = (v * signed < 0) & (np.abs(v) > 10 * DEG)
    assert braking.sum() == 42  # the torque leads by 95 ms: ~8 braking samples per reversal
    np.testing.assert_array_equal(signed_back.torque.values[braking], -signed[braking])
    assert signed_back.attrs["torque_sign"] == "motion"
    assert signed_back.attrs["flags"] == (
        (
            f"{MAGNITUDE_FLAG} (never negative; near 0 at 5 of 5 reversals of the motion); "
            'signed by the direction of motion (torque_sign = "motion")'
        ),
    )
    assert "torque_sign" not in trial.attrs  # the trial given is not changed
    np.testing.assert_array_equal(trial.torque.values, np.abs(signed))


def test_torque_sign_motion_is_refused_where_it_is_wrong():
    t, angle, v, signed = back_and_forth()
    magnitude = make_trial(t, angle, v, np.abs(signed), source="A.csv")
    with pytest.raises(InputError, match=r'A\.csv: torque_sign = "motion" .* wrong for a quasi'):
        apply_torque_sign(magnitude, "motion", kind="quasi-static")
    with pytest.raises(InputError, match=r"is for a torque written as a magnitude, but this "):
        apply_torque_sign(make_trial(t, angle, v, signed, source="A.csv"), "motion", kind="fast")
    with pytest.raises(InputError, match=r"A\.csv: torque_sign: expected 1, -1 or \"motion\""):
        apply_torque_sign(magnitude, 2, kind="fast")
    # a quasi-static trial keeps torque_sign's factor, with the caveat in its flag
    held = apply_torque_sign(magnitude, -1, kind="quasi-static")
    np.testing.assert_array_equal(held.torque.values, -np.abs(signed))
    assert held.attrs["flags"][0].endswith(
        "read x torque_sign = -1: right only while the moment keeps one sign over the sweep"
    )


# ---------------------------------------------------------------------- end to end (HUMAC)

INERTIA, GRAVITY_MOMENT = 0.25, 20.0


def write_humac_export(trial, path, *, braking):
    """Write a simulated Trial the way a HUMAC NORM at the "Stafford" site does."""
    t = trial.time.values
    deg = np.degrees(trial.angle.values)
    dps = np.degrees(trial.velocity.values)
    ftlb = np.abs(trial.torque.values) / FT_LBF  # a magnitude
    status = np.ones(t.size, dtype=int)
    status[: int(np.argmax(np.abs(dps) > 3))] = 5  # rest before the move: real torque
    if braking:  # 7 braking rows, torque written as 0, once the speed falls below 80 %
        peak = int(np.argmax(np.abs(dps)))
        b = peak + int(np.argmax(np.abs(dps[peak:]) < 0.8 * np.abs(dps).max()))
        status[b : b + 7], ftlb[b : b + 7] = 5, 0.0
    rows = ['"Status","Time(Seconds)","Position(Degrees)","Torque(Foot-Pounds)","Speed(d/s)"']
    cells = [
        (f'"{s}"', f"{x:.2f}", f"{q16(a):g}", f"{m:.4f}", f"{-q16(w):g}")  # Speed reversed
        for s, x, a, m, w in zip(status, t, deg, ftlb, dps, strict=True)
    ]
    cells.append(('"11"', f"{t[-1] + 0.01:.2f}", *cells[-1][2:]))  # end of set
    cells.append(('"0"', f"{t[-1] + 0.02:.2f}", "0", "0", "0"))  # closing row
    path.write_text("\n".join(rows + [",".join(c) for c in cells]) + "\n")


@pytest.fixture(scope="module")
def humac_study(tmp_path_factory):
    # gravity pulls one way over the whole range (phi = pi, offset -1.5 N m): a magnitude
    # loses a sign that torque_sign = -1 restores for the quasi-static trial; in the fast
    # trial's acceleration (towards smaller angles) the torque has the motion's sign
    folder = tmp_path_factory.mktemp("humac_study")
    common = {"inertia": INERTIA, "gravity_moment": GRAVITY_MOMENT, "phi": math.pi, "rate": RATE}
    qs = simulate_trial(
        kind="quasi-static",
        offset=-1.5,
        rng=1,
        motion=Motion(start=10 * DEG, end=90 * DEG),
        **common,
    )
    fast = simulate_trial(
        kind="fast", speed_deg_s=180, offset=-1.5, rng=2,
        motion=Motion(start=90 * DEG, end=10 * DEG, acceleration=1000 * DEG), **common,
    )  # fmt: skip
    write_humac_export(qs, folder / "qs.csv", braking=False)
    write_humac_export(fast, folder / "fast.csv", braking=True)
    return folder


MANIFEST = """
[bodies.attachment]
prior = "biodex-elbow-attachment"
[defaults]
format = "humac"
[[trials]]
file = "qs.csv"
bodies = ["attachment"]
kind = "quasi-static"
torque_sign = -1
[[trials]]
file = "fast.csv"
bodies = ["attachment"]
kind = "fast"
speed = 180
options = { segment = 1 }
"""


def test_a_humac_export_gives_the_true_inertia_with_torque_sign_motion(humac_study):
    path = humac_study / "study.toml"
    path.write_text(MANIFEST + 'torque_sign = "motion"\n')
    study = load_study(path)
    assert study.trials[1].torque_sign == "motion"
    qs, fast = study.read(0), study.read(1)
    assert fast.attrs["torque_sign"] == "motion"
    assert fast.attrs["flags"][0].startswith("velocity: column 'Speed(d/s)' runs against")
    assert fast.attrs["flags"][1].endswith(
        'signed by the direction of motion (torque_sign = "motion")'
    )
    gravity = fit_gravity(qs)
    assert gravity.gravity_moment == pytest.approx(GRAVITY_MOMENT, rel=0.01)
    estimate = estimate_inertia(fast, gravity)
    assert estimate.inertia == pytest.approx(INERTIA, rel=0.02)  # 0.2496 measured


def test_a_humac_export_read_as_signed_is_refused_not_a_negative_inertia(humac_study):
    path = humac_study / "signed.toml"
    path.write_text(MANIFEST)  # the fast trial keeps the default torque_sign = 1
    study = load_study(path)
    with pytest.raises(InputError, match=r'fast\.csv: torque is written as a magnitude .* set '
                       r'torque_sign = "motion" for this fast trial'):  # fmt: skip
        study.read(1)
    # what that refusal prevents: the magnitude read as a signed moment looks like a negative
    # inertia, whose hint (torque_sign = -1) cannot fix a sign that depends on the motion
    raw = read_trial(humac_study / "fast.csv", format="humac", segment=1)
    gravity = fit_gravity(study.read(0))
    unsigned = raw.copy()
    unsigned.attrs["torque_kind"] = "signed"  # as if nothing had noticed the magnitude
    with pytest.raises(InputError, match=r"inertia -\d.* is negative"):
        estimate_inertia(unsigned, gravity, speed_deg_s=180)
    # read with read_trial and given straight to estimate_inertia: the real cause, no hint loop
    for sign in (1, -1):
        with pytest.raises(InputError, match=r"torque is written as a magnitude"):
            estimate_inertia(raw, gravity, speed_deg_s=180, torque_sign=sign)
    # and motion is refused for the quasi-static trial
    path.write_text(MANIFEST.replace("torque_sign = -1", 'torque_sign = "motion"'))
    with pytest.raises(InputError, match=r'qs\.csv: torque_sign = "motion" signs the torque'):
        load_study(path).read(0)
