"""A real relaxed ankle (Tecchio et al. 2023, Apache-2.0; tests/data/tecchio-ankle/README.md).

Two slow sweeps (one each way) and six relaxed holds of one participant's ankle, analysed as
passive-only data: the static curve (the foot's gravity and the passive moment together: one
posture cannot split them) fitted from the two sweeps with the smooth passive curve, then
checked against what the recording shows — the holds, the two sweeps' difference, and a quiet
tibialis anterior.
"""

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.signal

from inertiafit.io.manifest import PassivePrior
from inertiafit.io.shipped import load_passive_prior
from inertiafit.io.trial import make_trial
from inertiafit.processing.emg import emg_activity
from inertiafit.processing.living import (
    PostureGeometry,
    StaticRecord,
    fit_statics,
    passive_basis,
)

DATA = Path(__file__).parent / "data" / "tecchio-ankle"
SWEEPS = ("Pas_Long2Sho", "Pas_Sho2Long")  # toward dorsiflexion, toward plantarflexion
HOLDS = ("Pas_-15", "Pas_-10", "Pas_5", "Pas_10", "Pas_20", "Pas_25")
POSTURE = {"seated": PostureGeometry("seated")}
#: The joint angle is the crank's (plantarflexion positive, 0 = neutral): joint_angle_at_zero 0.
ENTRIES = ("stiffness", "stop_moment", "stop_width", "range", "curve_scale", "damping")


def _read(name: str) -> pd.DataFrame:
    return pd.read_csv(DATA / f"{name}.csv.gz")


def _basis(curve: str = "smooth"):
    shipped = load_passive_prior("ankle")
    values = {k: shipped[k]["value"] for k in (*ENTRIES, "hysteresis")}
    return passive_basis(
        PassivePrior(joint="ankle", joint_angle_at_zero=0.0, curve=curve, **values)
    )


def _fit(curve: str = "smooth"):
    records = []
    for name in SWEEPS:
        f = _read(name)
        angle, torque = np.radians(f["angle_deg"].to_numpy()), f["torque_Nm"].to_numpy()
        records.append(StaticRecord(angle, torque, "foot", "seated", "quasi-static", name, 1e3))
    return fit_statics(records, POSTURE, _basis(curve))


@pytest.fixture(scope="module")
def ankle():
    return _fit()


def test_the_sweeps_are_cut_to_their_moves(ankle):
    # each file holds 4 s still at either end (and a filter's glitch at its first sample):
    # the fit takes the move alone, about -20 to +21 deg
    lo, hi = np.degrees(ankle.angle_range)
    assert -20.5 < lo < -19.0
    assert 20.0 < hi < 21.0


def test_the_holds_inside_the_swept_range_are_predicted(ankle):
    # The five holds inside the swept range lie within the 95 % band of what a hold there
    # reads (the curve's midline, its error, and the hysteresis band a joint at rest holds
    # anything within). The curve's own band alone (negative control) misses at least one:
    # the holds sit up to 0.5 N m off the midline.
    margin = math.radians(0.5)  # the hold at -20.0 deg sits at the sweeps' end (-19.9)
    lo, hi = ankle.angle_range[0] - margin, ankle.angle_range[1] + margin
    inside, missed_by_curve = 0, 0
    for name in HOLDS:
        f = _read(name)
        theta = math.radians(f["angle_deg"].mean())
        if not lo <= theta <= hi:
            assert name == "Pas_25"  # +26 deg: beyond the sweeps, not predicted
            continue
        mean, sd = ankle.hold_prediction(np.array([theta]), "foot", "seated")
        value = f["torque_Nm"].mean()
        assert abs(value - mean[0]) < 1.96 * sd[0], name
        x = np.array(
            [
                np.broadcast_to(c, (1,))[0]
                for c in ankle.columns(np.array([theta]), "foot", "seated", 0)
            ]
        )
        curve_sd = math.sqrt(x @ ankle.covariance @ x)
        missed_by_curve += abs(value - mean[0]) > 1.96 * curve_sd
        inside += 1
    assert inside == 5
    assert missed_by_curve >= 1


def test_the_direction_dependent_part_matches_the_sweeps_difference(ankle):
    # Measured on the raw sweeps: toward dorsiflexion the torque reads 2.0-3.1 N m more
    # negative than toward plantarflexion over -15 to +15 deg. The fitted 2 h(theta) stays in
    # that span there, and its mean over the angles is within 0.3 N m of the data's.
    curve = ankle.passive_curve()
    raw = {name: _read(name) for name in SWEEPS}
    model, data = [], []
    for angle in range(-15, 16, 5):
        row = curve.iloc[int((curve["device_angle"] - angle).abs().argmin())]
        model.append(2.0 * row["hysteresis"])
        means = []
        for name in SWEEPS:
            f = raw[name]
            near = (f["angle_deg"] - angle).abs() < 1.0
            moving = (f["time_s"] > 5.0) & (f["time_s"] < 14.0)  # the holds left out
            means.append(f.loc[near & moving, "torque_Nm"].mean())
        data.append(means[1] - means[0])
    model = np.array(model)
    assert np.all((model > 2.0) & (model < 3.1)), model
    assert abs(model.mean() - np.mean(data)) < 0.3
    assert min(data) > 1.9  # the README's reading of these files: 2.0-3.1
    assert max(data) < 3.2


def test_the_fixed_curve_is_flagged_on_the_real_ankle():
    # the prior file's fixed shape leaves structure in both sweeps; the smooth curve in at
    # most the one that wobbles (toward dorsiflexion: +-0.4 N m every 10 deg, which no curve
    # shared by both sweeps follows)
    fixed = _fit("fixed")
    assert all(c.flagged for c in fixed.checks.values())
    smooth = _fit()
    assert not smooth.checks["Pas_Sho2Long"].flagged
    assert smooth.checks["Pas_Sho2Long"].structure < 0.05


def _emg_trial(name: str, burst: bool = False):
    f = _read(name)
    angle = np.radians(f["angle_deg"].to_numpy())
    time = f["time_s"].to_numpy()
    if np.ptp(f["angle_deg"]) > 10.0:  # a sweep: the velocity from the smoothed angle
        velocity = np.gradient(scipy.signal.savgol_filter(angle, 201, 2), time)
    else:
        velocity = np.zeros_like(angle)
    emg = f["emg_ta_V"].to_numpy().copy()
    if burst:  # a 0.3 s contraction: ten times the channel's sample-to-sample noise
        rng = np.random.default_rng(0)
        emg[9000:9300] += 10.0 * np.std(np.diff(emg)) * rng.standard_normal(300)
    return make_trial(
        time, angle, velocity, f["torque_Nm"].to_numpy(), source=name, emg={"ta": emg}
    )


def test_the_tibialis_anterior_reads_as_quiet():
    # Against the hold in the middle of the range as its rest: over both sweeps no stretch
    # reaches twice the rest level and under 2 % of the time is above threshold; a 0.3 s
    # burst added to the same channel (negative control) is found, above three times.
    rest = _emg_trial("Pas_5")
    for name in SWEEPS:
        found = emg_activity(_emg_trial(name), rest)
        active = float((found["end"] - found["start"]).sum()) if len(found) else 0.0
        assert found.empty or found["peak_ratio"].max() < 2.0, found
        assert active < 0.02 * 17.0
        burst = emg_activity(_emg_trial(name, burst=True), rest)
        assert ((burst["start"] < 9.1) & (burst["end"] > 9.2) & (burst["peak_ratio"] > 3.0)).any()


def test_the_tutorial_s_ankle_code_runs_as_printed(monkeypatch):
    # docs/tutorials/living-forearm.md shows this fit: its code block, run from the
    # repository's root as a reader would, gives the holds' predictions
    root = Path(__file__).resolve().parents[1]
    text = (root / "docs" / "tutorials" / "living-forearm.md").read_text(encoding="utf-8")
    start = text.index("```python\nimport numpy as np, pandas as pd\n")
    code = text[start + len("```python\n") : text.index("```", start + 10)]
    monkeypatch.chdir(root)
    namespace: dict = {}
    exec(compile(code, "living-forearm.md", "exec"), namespace)
    mean, sd = namespace["mean"], namespace["sd"]
    assert mean.shape == sd.shape == (3,)
    assert np.all((sd > 0.3) & (sd < 1.0))
    assert np.all(np.diff(mean) > 0)  # the ankle's moment rises toward plantarflexion
