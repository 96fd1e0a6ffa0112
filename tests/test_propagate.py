"""``inertiafit.propagate``: a joint moment's draws, band and variance shares along a motion."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from inertiafit import InputError, Posterior, propagate
from inertiafit.inference.priors import anthropometric_prior, load_prior

# One body by hand: m = 1.5 kg, x = 0.15 m, rho = 0.08 m, g = 9.81 m/s^2:
# I = 1.5 (0.08^2 + 0.15^2) = 0.04335 kg m^2, M_g = 1.5 * 9.81 * 0.15 = 2.20725 N m.
# Motion theta = 0.5 sin(2 pi t): at t = 0.25 s theta = 0.5 rad, alpha = -0.5 (2 pi)^2 =
# -19.7392088 rad/s^2; with phi = 0.1 rad: M = 0.04335 * -19.7392088 + 2.20725 sin(0.6)
# = -0.8557 + 1.24630 = 0.390612 N m.
HAND = 0.3906123978
BODY = {"mass": 1.5, "com_distance": 0.15, "radius_of_gyration": 0.08}
TIME = np.linspace(0.0, 1.0, 1001)
ANGLE = 0.5 * np.sin(2 * np.pi * TIME)


def test_one_body_by_hand():
    result = propagate(BODY, (TIME, ANGLE), phase=0.1)
    assert result.moments.shape == (1, TIME.size)
    assert result.acceleration[250] == pytest.approx(-0.5 * (2 * math.pi) ** 2, rel=1e-7)
    assert result.moments[0, 250] == pytest.approx(HAND, rel=1e-7)
    assert result.median[250] == pytest.approx(HAND, rel=1e-7)
    # given accelerations are used as they are
    given = propagate(BODY, {"time": TIME, "angle": ANGLE, "acceleration": np.zeros_like(TIME)})
    assert given.moments[0, 250] == pytest.approx(2.20725 * math.sin(0.5), rel=1e-12)


def test_shares_by_parameter_and_by_identified_pair():
    rng = np.random.default_rng(1)
    n = 4000
    only_mass = {**BODY, "mass": rng.normal(1.5, 0.1, n)}
    shares = propagate(only_mass, (TIME, ANGLE)).shares()
    row = shares.iloc[100]
    assert row["share_mass"] == pytest.approx(1.0, abs=0.02)
    assert row["share_com_distance"] < 0.02
    assert row["share_radius_of_gyration"] < 0.02
    exact = row[["share_inertia", "share_gravity_moment", "share_covariance"]].sum()
    assert exact == pytest.approx(1.0, abs=1e-9)
    # rho alone moves I only: where alpha is zero (t = 0.5 s... theta = 0) nothing varies
    only_rho = {**BODY, "radius_of_gyration": rng.uniform(0.05, 0.11, n)}
    shares = propagate(only_rho, (TIME, ANGLE)).shares()
    assert shares.iloc[250]["share_radius_of_gyration"] == pytest.approx(1.0, abs=0.02)
    assert shares.iloc[250]["share_inertia"] == pytest.approx(1.0, abs=1e-9)
    assert shares.iloc[250]["share_mass"] < 0.02


def test_shares_of_two_independent_parameters():
    # No acceleration: M = m g x sin(theta). With m and x independent, CVs 0.10 and 0.05,
    # first order: Var M / M^2 = 0.10^2 + 0.05^2, so S_m = 0.8 and S_x = 0.2.
    rng = np.random.default_rng(3)
    n = 20_000
    draws = {
        "mass": 1.5 * (1 + 0.10 * rng.standard_normal(n)),
        "com_distance": 0.15 * (1 + 0.05 * rng.standard_normal(n)),
        "radius_of_gyration": 0.08,
    }
    motion = {"time": TIME[::50], "angle": ANGLE[::50], "acceleration": np.zeros(21)}
    row = propagate(draws, motion).shares().iloc[5]  # t = 0.25 s
    assert row["share_mass"] == pytest.approx(0.8, abs=0.02)
    assert row["share_com_distance"] == pytest.approx(0.2, abs=0.02)
    assert row["share_radius_of_gyration"] < 0.01
    assert row["share_gravity_moment"] == pytest.approx(1.0, abs=1e-9)


def _posterior(draws: dict[str, np.ndarray]) -> Posterior:
    data = {p: (("chain", "draw", "body"), v.reshape(4, -1, 1)) for p, v in draws.items()}
    return Posterior(
        xr.DataTree.from_dict(
            {
                "posterior": xr.Dataset(data, coords={"body": ["forearm"]}),
                "constant_data": xr.Dataset({"gravity": 9.81}),
            }
        )
    )


def test_band_narrows_from_box_to_de_leva_to_posterior():
    de_leva = anthropometric_prior("de-leva-male", "forearm", 75.0, 0.27, name="forearm")
    box = load_prior({**de_leva.nominal, "spread": 0.5}, name="box")
    # a posterior: draws of de Leva's prior kept where I and M_g match 'measured' values
    rng = np.random.default_rng(2)
    many = de_leva.sample(200_000, rng)
    i = many["mass"] * (many["radius_of_gyration"] ** 2 + many["com_distance"] ** 2)
    mg = many["mass"] * 9.81 * many["com_distance"]
    keep = (np.abs(i / 0.025 - 1) < 0.02) & (np.abs(mg / 1.5 - 1) < 0.02)
    kept = {p: v[keep][:2000] for p, v in many.items()}
    assert kept["mass"].size == 2000
    post = _posterior(kept)
    motion = (TIME[::10], ANGLE[::10])
    widths = []
    for source in (box, de_leva, post):
        peak = propagate(source, motion, seed=4).peak()
        widths.append(peak["hdi_upper"] - peak["hdi_lower"])
    assert widths[0] > 1.5 * widths[1] > 1.5 * 3 * widths[2]
    # the posterior's band is its draws' HDI: it holds about 95 % of them at every sample
    result = propagate(post, motion)
    inside = (result.moments >= result.hdi[:, 0]) & (result.moments <= result.hdi[:, 1])
    assert inside.mean(axis=0).min() > 0.94
    table = result.table()
    assert list(table.columns[:7]) == [
        "time", "angle", "acceleration", "median", "hdi_lower", "hdi_upper", "sd"
    ]  # fmt: skip
    assert propagate(post, motion, draws=100, seed=1).moments.shape == (100, 101)


def test_a_trial_file(tmp_path):
    path = tmp_path / "trial.csv"
    velocity = 0.5 * 2 * np.pi * np.cos(2 * np.pi * TIME)
    lines = ["time,angle,velocity,torque"] + [
        f"{float(t)!r},{math.degrees(a)!r},{math.degrees(v)!r},0.0"
        for t, a, v in zip(TIME, ANGLE, velocity, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")
    result = propagate(BODY, path, phase=0.1)
    assert result.moments[0, 250] == pytest.approx(HAND, rel=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"motion": (TIME, ANGLE[:-1])}, "motion: time and angle"),
        ({"motion": (TIME[::-1], ANGLE)}, "motion: time must increase"),
        ({"motion": {"time": TIME}}, "motion: 'angle' is missing"),
        ({"motion": 3}, "motion: expected"),
        ({"posterior": {"mass": 1.0}}, "posterior: 'com_distance' is missing"),
        ({"posterior": 2.0}, "posterior: expected"),
        ({"hdi_prob": 1.5}, "hdi_prob"),
        ({"draws": 0}, "draws"),
    ],
)
def test_bad_inputs(kwargs, message):
    args = {"posterior": BODY, "motion": (TIME, ANGLE), **kwargs}
    with pytest.raises(InputError, match=message) as err:
        propagate(args.pop("posterior"), args.pop("motion"), **args)
    assert "\n" not in str(err.value)
