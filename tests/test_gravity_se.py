"""The quasi-static gravity fit's standard errors against the spread of simulated trials.

``benchmarks/gravity_se.py`` runs 200 trials per setting; these run 40, seeded, and derive
their tolerance from the Monte Carlo error of the root mean square of ``error / SE``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from inertiafit.processing.gravity import (
    MIN_SE_DOF,
    GravityFit,
    fit_gravity,
    gravity_regression,
)
from inertiafit.processing.study import combine_gravity
from inertiafit.simulate import Noise, simulate_trial

DEG = math.pi / 180
MOMENT, PHASE, OFFSET = 10.0, 0.3, 0.5


def quasi_static(seed, **noise):
    return simulate_trial(
        inertia=0.3,
        gravity_moment=MOMENT,
        kind="quasi-static",
        phi=PHASE,
        offset=OFFSET,
        rng=seed,
        noise=Noise(**noise),
    )


def plain_ols_se(trial):
    """The plain OLS standard error of M_g (white residuals assumed): the negative control."""
    theta, torque = trial["angle"].values, trial["torque"].values
    design = np.column_stack([np.sin(theta), np.cos(theta), np.ones_like(theta)])
    # the normal equations (three well-separated columns over 90 deg): the least-squares fit
    # to rounding, at a fraction of lstsq's SVD of the 90 000 x 3 design
    bread = np.linalg.inv(design.T @ design)
    coef = bread @ (design.T @ torque)
    resid = torque - design @ coef
    cov = bread * float(resid @ resid) / (theta.size - 3)
    g = np.array([coef[0], coef[1], 0.0]) / math.hypot(coef[0], coef[1])
    return math.hypot(coef[0], coef[1]), math.sqrt(g @ cov @ g)


def rms_and_mc_error(z):
    z2 = np.asarray(z) ** 2
    rms = math.sqrt(z2.mean())
    return rms, z2.std(ddof=1) / (2 * rms * math.sqrt(z2.size))


#: Monte Carlo SE of RMS(error/SE) over 200 trials in ``benchmarks/gravity_se.py`` (0.05 to
#: 0.08 in every setting): over ``n`` trials it is about ``0.08 sqrt(200 / n)``.
MC_200 = 0.08


@pytest.mark.slow
@pytest.mark.parametrize(
    "noise",
    [
        {"drift_time": 3.0, "drift_sd": 0.1},  # a drift of T/30: about 5 degrees of freedom
        {"hysteresis": 0.3},  # friction building up over 2 deg at the start of the sweep
    ],
    ids=["drift-3s", "friction"],
)
def test_error_over_se_has_unit_rms_and_the_plain_ols_se_fails(noise):
    n = 100
    truth = np.array([MOMENT, PHASE, OFFSET + noise.get("hysteresis", 0.0)])
    z, z_ols = [], []
    for seed in range(n):
        trial = quasi_static(seed, **noise)
        fit = fit_gravity(trial)
        values = np.array([fit.gravity_moment, fit.gravity_phase, fit.offset])
        ses = np.array([fit.gravity_moment_se, fit.gravity_phase_se, fit.offset_se])
        z.append((values - truth) / ses)
        moment, se = plain_ols_se(trial)
        z_ols.append((moment - MOMENT) / se)
    tolerance = 3 * MC_200 * math.sqrt(200 / n)  # 0.34
    for column in np.array(z).T:  # M_g, phi, offset
        rms, mc = rms_and_mc_error(column)
        assert abs(rms - 1.0) < max(tolerance, 3 * mc), (rms, mc)
    rms_ols, mc_ols = rms_and_mc_error(z_ols)
    assert rms_ols > 1.0 + 10 * mc_ols  # measured 12-18: white-noise SEs are far too small


def test_a_drift_of_a_tenth_of_the_sweep_is_flagged_and_the_default_noise_is_not():
    slow = fit_gravity(quasi_static(1, drift_time=10.0, drift_sd=0.1))
    assert slow.se_dof < MIN_SE_DOF
    assert any(f.startswith("drifting residuals: correlation time") for f in slow.flags)
    usual = fit_gravity(quasi_static(1))
    assert usual.se_dof > 2 * MIN_SE_DOF
    assert usual.flags == ()
    # without noise the fit is exact (the rests and their start/stop spikes left out) and
    # rounding-level residuals raise no flag
    exact = fit_gravity(quasi_static(1, **dataclasses.asdict(Noise.none())))
    assert exact.gravity_moment == pytest.approx(MOMENT, abs=1e-9)
    assert exact.flags == ()
    # the covariance is widened by dof / (dof - 2) and the SEs follow from it
    g = np.array([math.cos(usual.gravity_phase), math.sin(usual.gravity_phase), 0.0])
    assert usual.gravity_moment_se == pytest.approx(math.sqrt(g @ usual.covariance @ g))
    assert usual.coefficients == pytest.approx(
        [
            usual.gravity_moment * math.cos(usual.gravity_phase),
            usual.gravity_moment * math.sin(usual.gravity_phase),
            usual.offset,
        ]
    )


def test_friction_build_up_is_fitted_and_flagged_and_without_it_m_g_is_off():
    trial = quasi_static(3, hysteresis=0.3)
    fit = fit_gravity(trial)
    assert fit.gravity_moment == pytest.approx(MOMENT, abs=3 * fit.gravity_moment_se)
    assert fit.offset == pytest.approx(OFFSET + 0.3, abs=3 * fit.offset_se)
    assert any(f.startswith("friction builds up at the start of the sweep: 0.") for f in fit.flags)
    reg = gravity_regression(trial["angle"].values, trial["torque"].values)
    assert reg.friction_probability > 0.99
    assert reg.friction == pytest.approx(0.3, abs=0.1)
    # negative control: the same fit without the friction model misses M_g by many SEs
    plain = gravity_regression(trial["angle"].values, trial["torque"].values, friction=False)
    a, b = plain.coefficients[:2]
    assert math.hypot(a, b) - MOMENT > 4 * fit.gravity_moment_se
    # no friction, no flag
    assert not any(f.startswith("friction") for f in fit_gravity(quasi_static(3)).flags)


def test_a_friction_that_switches_at_once_is_absorbed_by_the_offset():
    # Coulomb friction: only the rest before the move differs, and the fit leaves the rest out
    trial = quasi_static(4, hysteresis=0.3, hysteresis_angle=0.0)
    reg = gravity_regression(trial["angle"].values, trial["torque"].values, friction=False)
    assert math.hypot(*reg.coefficients[:2]) == pytest.approx(MOMENT, abs=0.05)
    assert reg.coefficients[2] == pytest.approx(OFFSET + 0.3, abs=0.05)
    assert reg.fitted.start > 200  # the 0.2 s at rest (200 samples) is not fitted


def test_simulated_friction_builds_up_over_its_angle_and_holds_at_rest():
    plain = quasi_static(5)
    rubbing = quasi_static(5, hysteresis=0.3, hysteresis_angle=2 * DEG)
    friction = rubbing["torque"].values - plain["torque"].values
    theta = plain["angle"].values  # quantised; the friction follows the exact angle
    start = int(np.argmax(theta > 0))
    assert np.all(friction[: start - 60] == 0.0)  # at rest before the move
    travelled = np.array([1.0, 2.0, 4.0, 10.0]) * DEG
    at = [int(np.argmax(theta >= a)) for a in travelled]
    expected = 0.3 * (1 - np.exp(-travelled / (2 * DEG)))
    assert friction[at] == pytest.approx(expected, abs=0.3 * 0.05)  # 0.05 deg quantisation
    assert friction[-1] == pytest.approx(0.3, abs=1e-6)  # held at rest after the move
    assert rubbing.attrs["true_hysteresis"] == 0.3
    assert "true_hysteresis" not in plain.attrs
    with pytest.raises(ValueError, match="hysteresis"):
        quasi_static(5, hysteresis=-0.1)


def test_combined_fits_weigh_by_their_covariance():
    fits = [fit_gravity(quasi_static(seed)) for seed in (6, 7)]
    both = combine_gravity(fits, "condition a")
    assert both.source == "condition a"
    assert both.n == fits[0].n + fits[1].n
    precision = sum(np.linalg.inv(f.covariance) for f in fits)
    assert both.covariance == pytest.approx(np.linalg.inv(precision))
    expected = np.linalg.solve(
        precision, sum(np.linalg.inv(f.covariance) @ f.coefficients for f in fits)
    )
    assert both.coefficients == pytest.approx(expected)
    assert both.gravity_moment == pytest.approx(math.hypot(*expected[:2]))
    assert both.offset == pytest.approx(expected[2])
    # two similar trials: each SE shrinks by about sqrt(2)
    for name in ("gravity_moment_se", "gravity_phase_se", "offset_se"):
        single = np.mean([getattr(f, name) for f in fits])
        assert getattr(both, name) == pytest.approx(single / math.sqrt(2), rel=0.2)
    assert both.se_dof == pytest.approx(fits[0].se_dof + fits[1].se_dof)
    # one fit: itself
    assert combine_gravity(fits[:1], "x") is fits[0]


def test_a_gravity_fit_made_by_hand_gets_its_coefficients_and_covariance():
    fit = GravityFit(10.0, 0.1, 0.3, 0.002, 0.5, 0.05, 0.4, 100, 50.0, 1.57, 0.017)
    a, b = 10.0 * math.cos(0.3), 10.0 * math.sin(0.3)
    assert fit.coefficients == pytest.approx([a, b, 0.5])
    g_m = np.array([a, b, 0.0]) / 10.0
    g_p = np.array([-b, a, 0.0]) / 100.0
    assert math.sqrt(g_m @ fit.covariance @ g_m) == pytest.approx(0.1)
    assert math.sqrt(g_p @ fit.covariance @ g_p) == pytest.approx(0.002)
    assert math.sqrt(fit.covariance[2, 2]) == pytest.approx(0.05)
    assert fit == GravityFit(10.0, 0.1, 0.3, 0.002, 0.5, 0.05, 0.4, 100, 50.0, 1.57, 0.017)
    exact = GravityFit(10.0, 0.0, 0.3, 0.0, 0.5, 0.0, 0.0, 100, 100.0, 1.57, 0.017)
    # an exact model (zero covariance) is used alone when combined
    assert combine_gravity([exact, fit], "c").gravity_moment == 10.0
