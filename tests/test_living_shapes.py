"""Living joints whose passive curve is not the prior file's shape (issue 32).

The smooth part of the passive curve (:class:`~inertiafit.processing.living.SmoothPassive`),
the fit's check of every sweep, one posture's unmeasured ``M_g``, and a small seeded version
of ``benchmarks/living_shapes.py`` (the smooth curve and the fixed one on the same studies).
"""

import dataclasses
import math
import shutil
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from inertiafit.errors import InputError
from inertiafit.inference.evidence import condition_evidence
from inertiafit.processing.living import CHECK_TOLERANCE, SmoothPassive
from inertiafit.processing.study import process_study
from inertiafit.simulate import simulate_living_study

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import living_shapes

LIVING = "attachment+forearm"


def test_the_basis_approximates_a_squared_exponential_kernel():
    # Solin & Sarkka's approximation: Phi diag(S) Phi' against the exact kernel
    # a^2 exp(-d^2 / 2 l^2) over the swept range (not the margin beyond it), for the
    # length-scales the basis is sized for; within 2 % of the kernel's peak.
    smooth = SmoothPassive.over(math.radians(30.0), math.radians(120.0))
    t = np.linspace(math.radians(30.0), math.radians(120.0), 60)
    phi = np.column_stack(smooth.columns(t))
    for amplitude, length in [(0.3, math.radians(8.0)), (1.0, math.radians(25.0))]:
        approx = phi @ np.diag(smooth.variances(amplitude, length)) @ phi.T
        exact = amplitude**2 * np.exp(-0.5 * (t[:, None] - t[None, :]) ** 2 / length**2)
        assert np.max(np.abs(approx - exact)) < 0.02 * amplitude**2
    # beyond the domain the smooth part is zero; the hyperprior's mixture variance is the
    # mean of the grid's
    far = np.column_stack(smooth.columns(np.array([smooth.centre + 1.01 * smooth.half_width])))
    assert np.allclose(far, 0.0)
    grid = [smooth.variances(a, ell) for a, ell in smooth.grid]
    assert np.allclose(smooth.prior_variance(), np.mean(grid, axis=0))


@pytest.fixture(scope="module")
def cubic_two_postures(tmp_path_factory):
    """A two-posture study whose elbow stiffens as a cubic, stops undeclared."""
    rng = np.random.default_rng([3, 32])
    passive = living_shapes.draw_passive(rng, "cubic") | {"shape_size": 2.5}
    root = tmp_path_factory.mktemp("cubic")
    return simulate_living_study(
        root, seed=3, postures="two", passive=passive, declare_stops=False, trials_per_speed=3
    )


def test_the_fixed_curve_on_a_cubic_joint_is_flagged_and_refused(cubic_two_postures):
    # Today's fixed-shape model leaves the cubic in the sweeps' residuals: the check refuses
    # it, naming the key and the trials; the smooth curve passes every trial's check.
    fixed = living_shapes.fixed_view(cubic_two_postures)
    with pytest.raises(InputError, match=r'curve = "fixed".*structure of up to') as err:
        process_study(fixed)
    assert "quasistatic" in str(err.value)
    assert "\n" not in str(err.value)
    processed = process_study(cubic_two_postures)
    checks = processed.living.checks
    assert len(checks) == 2 * (2 + 3)  # two sweeps and three holds per posture
    assert not any(c.flagged for c in checks.values())
    assert max(c.structure for c in checks.values()) < CHECK_TOLERANCE
    assert not processed.trials["flags"].fillna("").str.contains("misfit").any()


def test_a_sweep_the_smooth_curve_cannot_follow_is_flagged(tmp_path, cubic_two_postures):
    # One sweep whose torque jumps by 0.5 N m halfway (a contraction the EMG did not see):
    # the same curve in every other trial cannot make it, so that sweep alone is flagged, in
    # trials.csv and in a study warning, and the study goes on.
    study = tmp_path / "study"
    shutil.copytree(cubic_two_postures.parent, study)
    path = study / "data" / "B_rotated_quasistatic_up.csv"
    frame = pd.read_csv(path)
    frame.loc[frame.index >= len(frame) // 2, "torque"] += 0.5
    frame.to_csv(path, index=False)
    processed = process_study(study / "study.toml")
    flagged = [Path(s).name for s, c in processed.living.checks.items() if c.flagged]
    assert flagged == [path.name]
    row = processed.trials[processed.trials["file"].str.endswith(path.name)].iloc[0]
    assert "static model misfit" in row["flags"]
    assert any("leaves structure" in w and path.name in w for w in processed.warnings)


def test_one_posture_leaves_the_living_gravity_moment_to_the_priors(tmp_path):
    # With one posture a smooth curve can mimic gravity: the living condition's M_g is not
    # evidence (the rigid condition's is), its I is, with the static curve's whole error;
    # the study and the joint's table say so. The fixed curve keeps it as evidence.
    manifest = simulate_living_study(tmp_path, seed=5, postures="one", trials_per_speed=3)
    processed = process_study(manifest)
    assert not processed.living.gravity_identified
    assert processed.living.pinned_by(LIVING) == "passive prior"
    evidence = {c.label: c for c in condition_evidence(processed)}
    assert evidence[LIVING].gravity_moment is None
    assert evidence[LIVING].coupling == 0.0
    assert evidence[LIVING].inertia is not None
    assert evidence["attachment"].gravity_moment is not None
    assert any("M_g is not measured" in w for w in processed.warnings)
    fixed = process_study(living_shapes.fixed_view(manifest))
    assert fixed.living.gravity_identified
    assert {c.label: c for c in condition_evidence(fixed)}[LIVING].gravity_moment is not None


def test_small_seeded_shapes_two_postures():
    # Three studies of the benchmark (a kink, a bump, stops where the prior file does not
    # put them), two postures, the living condition's own evidence: the smooth curve's 95 %
    # intervals of I and M_g hold the truth; the fixed curve (negative control) is refused
    # by its check or misses M_g in at least two of them.
    fixed_fails = 0
    for seed in (20261203, 20261204, 20261205):
        r = living_shapes.one_study("two", seed, sample=False)
        assert r["smooth I inside"], r
        assert r["smooth M_g inside"], r
        assert r["smooth pinned_by"] == "a second posture"
        assert abs(r["smooth M_g z"]) < 3.0
        fixed_fails += "fixed refused" in r or not r["fixed M_g inside"]
    assert fixed_fails >= 2


def test_a_subject_s_knee_curve_has_its_own_shape():
    # Riener & Edrich's knee curve at another hip and ankle angle is not the prior file's
    # curve scaled: the best scale leaves several N m (the model's smooth part must take it)
    from inertiafit.passive import literature_curve
    from inertiafit.simulate.living import PassiveTruth

    theta = np.radians(np.linspace(20.0, 110.0, 46))
    truth = PassiveTruth.draw(
        np.random.default_rng(0),
        joint="knee",
        joint_angle_at_zero=20.0,
        joint_range=(20.0, 110.0),
        given={"curve_scale": 1.0, "hip_angle": 70.0, "ankle_angle": 15.0},
    )
    prior = literature_curve("knee", theta)
    own = truth.literature(theta)
    scale = float(own @ prior / (prior @ prior))
    assert np.max(np.abs(own - scale * prior)) > 2.0
    # negative control: seated as the prior file assumes, the same curve exactly
    seated = dataclasses.replace(truth, hip_angle=90.0, ankle_angle=0.0)
    np.testing.assert_allclose(seated.literature(theta), prior, rtol=1e-12)


def test_small_seeded_knee_with_a_shank():
    # The benchmark's seated knee (a shank on a knee attachment; the subject's Riener & Edrich
    # curve at its own hip and ankle angles, stops, a shape on top), two postures and the
    # horizontal plane: the living condition's M_g and the shank's own I (the condition's less
    # the attachment's, as the posterior takes it) hold the truth. (The condition's I alone
    # misses at seed 20261207: 0.2 % low with an SE of 0.06 %, the attachment's 0.4 % low; a
    # heavy shank's fast trials are precise enough to show the inertia estimate's bias of a
    # few tenths of a per cent, which the difference mostly cancels.)
    for design, seed in (("two", 20261206), ("horizontal", 20261207)):
        r = living_shapes.one_study(design, seed, sample=False, joint="knee")
        assert r["smooth body I inside"], r
        assert r["smooth M_g inside"], r
        assert abs(r["smooth M_g z"]) < 3.0, r


@pytest.fixture(scope="module")
def measured_rotation(tmp_path_factory):
    """A two-posture study whose rigid attachment is swept in both postures; a cubic elbow."""
    rng = np.random.default_rng([9, 32])
    passive = living_shapes.draw_passive(rng, "cubic")
    root = tmp_path_factory.mktemp("rotation")
    manifest = simulate_living_study(
        root,
        seed=9,
        postures="two",
        passive=passive,
        declare_stops=False,
        trials_per_speed=2,
        rigid_rotation_sweeps=True,
    )
    truth = tomllib.loads((root / "truth.toml").read_text(encoding="utf-8"))
    return manifest, truth


def _declare(manifest: Path, rotation: float, *, rigid_sweep: bool = True) -> Path:
    """The same study with the rotated posture declared at ``rotation`` deg."""
    text = manifest.read_text(encoding="utf-8").replace(
        "gravity_rotation = 45.0", f"gravity_rotation = {rotation}"
    )
    if not rigid_sweep:  # today's design: the rigid condition in the first posture only
        entry = '[[trials]]\nfile = "data/A_rotated_quasistatic.csv"'
        start = text.index(entry)
        end = text.index("[[trials]]", start + len(entry))
        text = text[:start] + text[end:]
    out = manifest.with_name(f"declared_{rotation:g}_{int(rigid_sweep)}.toml")
    out.write_text(text)
    return out


def test_a_rigid_sweep_measures_the_rotation_and_the_declared_one_is_checked(measured_rotation):
    # With a smooth passive curve two postures measure M_g sin(r/2) and the phase alone, so
    # M_g hangs on the rotation r. The attachment swept in both postures measures r to a
    # fraction of a degree: M_g is then right whatever the manifest declares (30 deg or the
    # sign flipped, against a true 45 +- 2), and a declaration that far off is said, naming
    # the key. Without that sweep (negative control) a 30 deg declaration moves M_g by more
    # than 3 SEs, silently as far as the rotation goes.
    manifest, truth = measured_rotation
    true_rotation = truth["passive"]["postures"]["rotated"]["gravity_rotation"]
    true_moment = truth["conditions"]["B"]["gravity_moment"]
    right = process_study(_declare(manifest, 45.0))
    fit = right.gravity[LIVING]
    rotation = math.degrees(right.living.postures["rotated"].rotation)
    assert abs(rotation - true_rotation) < 1.0
    assert abs(fit.gravity_moment - true_moment) < 3.0 * fit.gravity_moment_se
    assert not any("gravity_rotation" in w for w in right.warnings)
    for declared in (30.0, -45.0):
        wrong = process_study(_declare(manifest, declared))
        assert wrong.gravity[LIVING].gravity_moment == pytest.approx(fit.gravity_moment, rel=1e-6)
        said = [w for w in wrong.warnings if "postures.rotated.gravity_rotation" in w]
        assert len(said) == 1
        assert "a rigid sweep measures" in said[0]
    unmeasured = process_study(_declare(manifest, 45.0, rigid_sweep=False))
    assert unmeasured.gravity[LIVING].gravity_moment_se > 2.0 * fit.gravity_moment_se
    slipped = process_study(_declare(manifest, 30.0, rigid_sweep=False)).gravity[LIVING]
    assert abs(slipped.gravity_moment - true_moment) > 3.0 * slipped.gravity_moment_se


def test_a_rigid_condition_s_fast_trials_share_one_posture(measured_rotation, tmp_path):
    manifest, _ = measured_rotation
    text = manifest.read_text(encoding="utf-8")
    entry = '[[trials]]\nfile = "data/A_180_01.csv"\nbodies = ["attachment"]'
    start = text.index(entry)
    posture = text.index('posture = "upright"', start)
    moved = text[:posture] + 'posture = "rotated"' + text[posture + len('posture = "upright"') :]
    bad = manifest.with_name("moved.toml")
    bad.write_text(moved)
    with pytest.raises(InputError, match=r"condition attachment: fast trials in postures") as err:
        process_study(bad)
    assert "\n" not in str(err.value)
    tilted = manifest.with_name("tilted.toml")
    tilted.write_text(
        text.replace("axis_tilt = 0.0\n\n[[trials]]", "axis_tilt = 20.0\n\n[[trials]]", 1)
    )
    with pytest.raises(InputError, match=r"posture 'rotated' tilts the axis \(20 deg\)"):
        process_study(tilted)
