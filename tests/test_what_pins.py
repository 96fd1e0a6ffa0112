"""What pins what: the prior's share against known answers, psense on our trees, the sources.

Known answers: the prior's share of a Gaussian prior with a Gaussian likelihood (closed form),
and one body with very precise I and M_g and a box, where m, x and rho lie on the curve of
constant (m x, I) and the box alone decides where (the share by quadrature over the curve).
Negative controls: I and M_g of that body (pinned by the data: share ~0), a box far from
the draws (share exactly 0), and the same body once a weighed mass pins it.
"""

import math

import numpy as np
import pytest
import xarray as xr
from arviz_stats import psense, psense_summary

from inertiafit.inference.fit import fit, fit_body
from inertiafit.inference.model import Condition, Model, angles_at
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior, parse_prior
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.physics import GRAVITY, PARAMETERS, REPORTED, parameters_from_identified
from inertiafit.posterior import Posterior, pins

ATTACHMENT = "biodex-elbow-attachment"
I_OBS, MG_OBS = 0.216, 7.415


@pytest.fixture(scope="module")
def precise():
    """The attachment's box with I and M_g known to 0.1 %: only the box decides m, x, rho."""
    return fit_body(
        ATTACHMENT,
        inertia=I_OBS,
        inertia_se=0.0002,
        gravity_moment=MG_OBS,
        gravity_moment_se=0.007,
        seed=4,
    )


def curve_case():
    """Quadrature over the curve at (M_g/g, I): psi uniform on Psi(a, b) (the box's conditional)."""
    prior = load_prior(ATTACHMENT)
    a = MG_OBS / GRAVITY
    psi = angles_at(a, I_OBS, prior, (np.arange(100_000) + 0.5) / 100_000)
    m, x, rho = parameters_from_identified(a, I_OBS, psi)
    return prior, {"mass": m, "com_distance": x, "radius_of_gyration": rho}


def box_specs(prior):
    return {
        p: {
            "log": False,
            "center": 0.5 * (prior.lower[p] + prior.upper[p]),
            "scale": math.nan,
            "gaussian": False,
            "lower": prior.lower[p],
            "upper": prior.upper[p],
        }
        for p in PARAMETERS
    }


def test_a_gaussian_prior_share_is_the_closed_form_finite_difference():
    # prior N(0, s^2), likelihood N(y, d^2) with s = d: posterior SD s/sqrt(2); the prior's
    # fraction of the precision is 1/2 and the 10 % step gives log(SD'/SD)/log(0.9) = 0.527.
    rng = np.random.default_rng(7)
    s, d = 1.0, 1.0
    post_sd = (1 / s**2 + 1 / d**2) ** -0.5
    n = 400_000
    draws = {"mass": rng.normal(0.3, post_sd, n), "com_distance": rng.uniform(1, 2, n)}
    draws["radius_of_gyration"] = rng.uniform(1, 2, n)
    wide = {"log": False, "center": 1.5, "scale": math.nan, "gaussian": False}
    specs = {
        "mass": {
            "log": False,
            "center": 0.0,
            "scale": s,
            "gaussian": True,
            "lower": -9,
            "upper": 9,
        },
        "com_distance": {**wide, "lower": 0.0, "upper": 3.0},
        "radius_of_gyration": {**wide, "lower": 0.0, "upper": 3.0},
    }
    lam = 1 - pins.PRIOR_SCALE_STEP
    shrunk_sd = (1 / (lam * s) ** 2 + 1 / d**2) ** -0.5
    expected = math.log(shrunk_sd / post_sd) / math.log(lam)
    assert expected == pytest.approx(0.527, abs=1e-3)
    share = pins.prior_share(draws, specs)
    assert share["mass"] == pytest.approx(expected, abs=0.01)
    # negative control: boxes far wider than the draws (x and rho) take no share at all
    assert abs(share["com_distance"]) < 0.01
    assert abs(share["radius_of_gyration"]) < 0.01
    # a lognormal is the same in log: log(mass) ~ N(0.3, post_sd^2) around median 1
    logn = {**specs, "mass": {**specs["mass"], "log": True, "lower": -9, "upper": 9}}
    log_draws = {**draws, "mass": np.exp(draws["mass"])}
    w = np.exp(pins.prior_scaling_log_weights(log_draws, logn, lam))
    weighted = np.sqrt(np.cov(draws["mass"], aweights=w))
    assert weighted / post_sd == pytest.approx(shrunk_sd / post_sd, abs=0.005)


def test_curve_case_the_box_decides_m_x_rho_and_the_data_pin_i_and_mg(precise):
    prior, grid = curve_case()
    expected = pins.prior_share(grid, box_specs(prior))
    # shrinking the box about its centre shortens the arc inside it a little faster than the
    # box for m and rho (the arc ends on the upper mass bound and the lower rho bound)
    assert expected["mass"] == pytest.approx(1.145, abs=0.01)
    assert expected["com_distance"] == pytest.approx(1.01, abs=0.01)
    assert expected["radius_of_gyration"] == pytest.approx(1.11, abs=0.01)
    ident = precise.identification().set_index("parameter")
    for p in PARAMETERS:  # Monte Carlo error of the share about 0.035 (seeds 5-10)
        assert ident.loc[p, "prior_share"] == pytest.approx(expected[p], abs=0.1)
        assert 0.01 < ident.loc[p, "prior_share_se"] < 0.1  # its batch-means estimate
        # the prior sets the width along the curve, but the data cut the box to the arc the
        # curve leaves in it (SD ratio 0.44-0.59): both decide, and the verdict says both
        assert 0.4 < ident.loc[p, "sd_ratio"] < 0.65
        assert ident.loc[p, "identified_by"] == ident.loc[p, "pinned_by"] == "data + prior"
    for p in ("inertia", "gravity_moment"):  # negative control: the data pin these
        assert abs(ident.loc[p, "prior_share"]) < 0.1
        assert ident.loc[p, "pinned_by"] == "data"
    assert ident["psense_prior"].isna().all()  # a box: power-scaling changes nothing
    assert (ident["psense_likelihood"] >= 0).all()
    assert ident["calibration_share"].isna().all()
    # the correlations along the curve, by quadrature
    corr = precise.correlations().iloc[0]
    c = np.corrcoef([grid[p] for p in PARAMETERS])
    assert corr["corr_m_x"] == pytest.approx(c[0, 1], abs=0.02)
    assert corr["corr_m_rho"] == pytest.approx(c[0, 2], abs=0.02)
    assert corr["corr_x_rho"] == pytest.approx(c[1, 2], abs=0.02)
    assert corr["corr_m_x"] < -0.95
    line = precise.what_pins_what()[ATTACHMENT]
    assert "m, x and rho by the data and the prior together (prior share " in line
    assert "the data fix the curve of m·x and I, the prior where on it" in line
    assert "I and M_g pinned by the data" in line
    assert "weigh it" in line


def with_weighed_mass(post: Posterior, mass: float, sd: float, seed: int) -> Posterior:
    """The posterior once a weighed mass N(mass, sd^2) is added: the draws resampled by its
    likelihood, which is stored as the log_likelihood variable ``mass`` (dim ``mass_body``)."""
    tree = post.tree
    body = post.bodies[0]
    m = post.draws(body, "mass")
    ll = -0.5 * ((m - mass) / sd) ** 2
    w = np.exp(ll - ll.max()).ravel()
    pick = np.random.default_rng(seed).choice(w.size, w.size, p=w / w.sum())

    def resample(ds):
        out = {}
        for v, arr in ds.data_vars.items():
            flat = arr.stack(sample=("chain", "draw")).transpose("sample", ...)
            values = flat.values[pick].reshape(arr.transpose("chain", "draw", ...).shape)
            out[v] = (arr.transpose("chain", "draw", ...).dims, values)
        return xr.Dataset(out, coords=ds.coords)

    groups = {k: tree[k].to_dataset() for k in tree.children}
    for k in ("posterior", "log_likelihood", "log_prior"):
        groups[k] = resample(groups[k])
    groups["log_likelihood"]["mass"] = xr.DataArray(
        ll.ravel()[pick].reshape(m.shape)[..., None],
        dims=("chain", "draw", "mass_body"),
        coords={"mass_body": [body]},
    )
    return Posterior(xr.DataTree.from_dict({"/": xr.Dataset(attrs=tree.attrs), **groups}))


def test_a_weighed_mass_pins_what_the_prior_decided(precise):
    weighed = with_weighed_mass(precise, 3.3, 0.03, seed=1)
    assert pins.body_sources(weighed.tree, ATTACHMENT) == ["data", "weighed mass"]
    ident = weighed.identification().set_index("parameter")
    assert (ident["prior_share"].abs() < 0.1).all()
    # the data (0.1 %) are far more precise than the scale (1 %): the weighed mass sets m,
    # and x = (M_g/g)/m and rho follow from it and the data
    assert ident["pinned_by"].tolist() == [
        "weighed mass",
        "data + weighed mass",
        "data + weighed mass",
        "data",
        "data",
    ]
    assert ident.loc["mass", "sd_ratio"] < 0.05
    assert weighed.what_pins_what()[ATTACHMENT] == (
        f"{ATTACHMENT}: m pinned by the weighed mass; x and rho pinned by the data + weighed "
        "mass; I and M_g pinned by the data"
    )


def test_sources_of_a_second_mounting_and_of_todays_trees(precise):
    tree = precise.tree
    assert pins.body_sources(tree, ATTACHMENT) == ["data"]  # today's trees: nothing extra
    groups = {k: tree[k].to_dataset() for k in tree.children}
    label = str(groups["constant_data"]["condition"].values[0])
    cd = groups["constant_data"].assign(
        offset=("condition", [0.1]), offset_body=("condition", [ATTACHMENT])
    )
    mounted = xr.DataTree.from_dict(
        {"/": xr.Dataset(attrs=tree.attrs), **groups, "constant_data": cd}
    )
    assert pins.body_sources(mounted, ATTACHMENT) == ["data", "second mounting"]
    terms = pins.source_terms(mounted, ATTACHMENT)
    # the one condition is the mounting: its terms move from "data" to "second mounting"
    total = sum(
        groups["log_likelihood"][v].sum(f"{v}_condition") for v in ("inertia", "gravity_moment")
    )
    np.testing.assert_allclose(terms["second mounting"], total)
    np.testing.assert_allclose(terms["data"], 0.0)
    other = cd.assign(offset_body=("condition", ["forearm"]))
    assert pins.body_sources(
        xr.DataTree.from_dict({"/": xr.Dataset(), **groups, "constant_data": other}), ATTACHMENT
    ) == ["data"]
    assert label


def test_psense_runs_on_our_trees_and_the_log_prior_is_the_prior_density():
    seg = parse_prior(
        {
            "mass": {"distribution": "normal", "mean": 2.9, "sd": 0.3},
            "com_distance": {"nominal": 0.225},
            "radius_of_gyration": {"distribution": "lognormal", "median": 0.13, "sd_log": 0.2},
        },
        name="seg",
        where="seg",
    )
    model = Model(
        {"seg": seg},
        [
            Condition(
                ("seg",),
                Observation.from_mean_se(0.216, 0.004),
                Observation.from_mean_se(7.415, 0.05),
            )
        ],
        torque_gain_sd=0.01,
    )
    post = fit(model, seed=5, settings=SamplerSettings(progress=False))
    lp = post.tree["log_prior"]
    d = {p: post.draws("seg", p) for p in PARAMETERS}
    np.testing.assert_allclose(
        lp["body_prior"].sel(body="seg").values,
        seg.log_density(d["mass"], d["com_distance"], d["radius_of_gyration"]),
    )
    z = np.log(post.tree["posterior"]["torque_gain"].values) / 0.01
    np.testing.assert_allclose(
        lp["torque_gain"].values, -0.5 * z * z - math.log(0.01 * math.sqrt(2 * math.pi))
    )
    table = psense_summary(post.tree, var_names=list(REPORTED))
    assert list(table.columns) == ["prior", "likelihood", "diagnosis"]
    assert len(table) == 5
    prior_sense = psense(post.tree, group="prior", var_names=["mass"])
    assert (
        float(prior_sense["mass"].sel(body="seg")) > 0.01
    )  # a normal prior on m that the curve leans on
    ident = post.identification().set_index("parameter")
    assert np.isfinite(ident["psense_prior"]).all()
    assert np.isfinite(ident["calibration_share"]).all()
    # M_g = observed / gain: relative variances 0.674 % (SE) and 1 % (gain) add; the gain's
    # 10 % step gives 0.5 log((0.674^2 + 0.9^2) / (0.674^2 + 1)) / log(0.9) = 0.666
    rel = 0.05 / 7.415 * 100
    expected = 0.5 * math.log((rel**2 + 0.81) / (rel**2 + 1)) / math.log(0.9)
    assert expected == pytest.approx(0.666, abs=0.002)
    assert ident.loc["gravity_moment", "calibration_share"] == pytest.approx(expected, abs=0.08)


def test_text_html_and_report_tables_show_it(precise):
    from inertiafit.report.tables import correlation_display, identification_display

    text = precise.report()
    assert "prior share" in text
    assert "What pins what" in text
    assert "posterior correlations m-x -0.9" in text
    assert "What pins what" in precise._repr_html_()
    shown = identification_display(precise.identification())
    assert list(shown.columns)[-2:] == ["pinned by", "prior-predictive p"]
    assert shown["prior-predictive p"].tolist()[:3] == ["", "", ""]  # m, x, rho: not measured
    assert shown["psense prior"].eq("").all()
    corr = correlation_display(precise.correlations())
    assert corr.loc[0, "corr(m, x)"].startswith("-0.9")
