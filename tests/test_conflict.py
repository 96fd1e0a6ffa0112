"""Prior-data conflict (issue 34): a body's measured I and M_g against what its prior allows.

Exact answers: the prior-predictive tail probabilities of a uniform box by quadrature (the
radius of gyration, then m and x, on Gauss-Legendre grids; Gaussian and Student-t errors; a
segment measured by the difference of two conditions), and of a de Leva M_g (a lognormal
product: one integral over log m). The user's case: a de Leva forearm prior of a 72 kg man with
data from a body twice as heavy is said, by the warning, the tables, the text and report.html;
the same numbers are said for every sampler seed. Calibration: on studies simulated from the
prior the rate of false alarms is the nominal one within its binomial error, and a body twice
as heavy as its prior's (the negative control) is caught in most studies.
"""

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import special

from inertiafit.errors import PriorDataConflictWarning
from inertiafit.inference.fit import fit_body
from inertiafit.inference.priors import anthropometric_prior, load_prior
from inertiafit.physics import GRAVITY, PARAMETERS
from inertiafit.posterior import conflict, pins
from inertiafit.posterior.conflict import CONFLICT_TAIL, ConditionData

ATTACHMENT = "biodex-elbow-attachment"


def spec_of(prior):
    return {
        p: pins.parameter_spec(prior.lower[p], prior.upper[p], prior.distribution.get(p, {}))
        for p in PARAMETERS
    }


def heavy_prior():
    """de Leva's forearm + hand of a 72 kg man, 0.27 m: I 0.075 kg m^2, M_g 2.87 N m."""
    return anthropometric_prior("de-leva-male", "forearm+hand", 72.0, 0.27, name="forearm")


# -- exact answers -----------------------------------------------------------------------------
def _legendre(lo, hi, n):
    x, w = np.polynomial.legendre.leggauss(n)
    return lo + (x + 1) / 2 * (hi - lo), w / 2


def box_inertia_tail(prior, center, se, df, n=96):
    """P(I + se T <= center) under the box: a Gauss-Legendre grid over m, x and rho."""
    (m, wm), (x, wx), (r, wr) = (_legendre(prior.lower[p], prior.upper[p], n) for p in PARAMETERS)
    inertia = m[:, None, None] * (x[None, :, None] ** 2 + r[None, None, :] ** 2)
    weight = wm[:, None, None] * wx[None, :, None] * wr[None, None, :]
    z = (center - inertia) / se
    cdf = special.ndtr(z) if math.isinf(df) else special.stdtr(df, z)
    return float(np.sum(weight * cdf))


def box_moment_tail(prior, center, se, n=400):
    """P(g m x + se Z <= center) under the box: a Gauss-Legendre grid over m and x."""
    (m, wm), (x, wx) = (_legendre(prior.lower[p], prior.upper[p], n) for p in PARAMETERS[:2])
    moment = GRAVITY * m[:, None] * x[None, :]
    return float(np.sum(wm[:, None] * wx[None, :] * special.ndtr((center - moment) / se)))


def test_a_box_priors_tail_probabilities_are_its_quadrature():
    prior = load_prior(ATTACHMENT)  # m, x, rho uniform on +-50 % of 2.91 kg, 0.225 m, 0.13 m
    draws = {"attachment": conflict.prior_draws(spec_of(prior), GRAVITY)}
    cases = [  # (quantity, centre, SE, degrees of freedom): both tails, both error shapes
        ("inertia", 0.058, 0.002, math.inf),
        ("inertia", 0.065, 0.004, 9.0),
        ("inertia", 0.42, 0.01, math.inf),
        ("inertia", 0.43, 0.01, 4.0),
        ("gravity_moment", 2.0, 0.05, math.inf),
        ("gravity_moment", 13.5, 0.05, math.inf),
    ]
    for quantity, center, se, df in cases:
        row = ConditionData("attachment", ("attachment",), center, se, df)
        check = conflict.check_body("attachment", quantity, [row], draws)
        exact = (
            box_inertia_tail(prior, center, se, df)
            if quantity == "inertia"
            else box_moment_tail(prior, center, se)
        )
        small = min(exact, 1 - exact)  # 0.005-0.06: the tail that decides
        assert 0.004 < small < 0.07
        assert min(check.lower_tail, 1 - check.lower_tail) == pytest.approx(small, rel=0.005)
        assert check.p == pytest.approx(2 * small, rel=0.005)
        assert check.estimate == center
        assert check.se == pytest.approx(
            se * math.sqrt(df / (df - 2)) if math.isfinite(df) else se
        )
    # negative control: the centre of the prior is no conflict at all
    middle = ConditionData("attachment", ("attachment",), 0.2, 0.003, math.inf)
    assert conflict.check_body("attachment", "inertia", [middle], draws).p > 0.8


def test_a_segment_is_checked_by_the_difference_of_its_conditions():
    # A (attachment alone) and B (attachment + the box body): the body's own I is B - A, whose
    # prior predictive is its prior's I plus both conditions' errors (Gaussian: sqrt(se_A^2 +
    # se_B^2)); the attachment's prior does not enter it.
    box, attachment = load_prior("disk-3kg"), load_prior(ATTACHMENT)
    draws = {
        "attachment": conflict.prior_draws(spec_of(attachment), GRAVITY, stream=0),
        "disk": conflict.prior_draws(spec_of(box), GRAVITY, stream=1),
    }
    rows = [
        ConditionData("A", ("attachment",), 0.216, 0.003, math.inf),
        ConditionData("B", ("attachment", "disk"), 0.216 + 0.16, 0.004, math.inf),
    ]
    check = conflict.check_body("disk", "inertia", rows, draws)
    assert check.estimate == pytest.approx(0.16)
    assert check.se == pytest.approx(0.005)
    exact = box_inertia_tail(box, 0.16, 0.005, math.inf)
    assert exact == pytest.approx(0.0525, abs=0.001)  # the disk's I spans 0.13-1.6 kg m^2
    assert check.lower_tail == pytest.approx(exact, rel=0.005)
    # the attachment alone: condition A, not B
    alone = conflict.check_body("attachment", "inertia", rows, draws)
    assert alone.estimate == pytest.approx(0.216)
    assert alone.se == pytest.approx(0.003)
    # measured only together (no condition A): no check of either body alone
    assert conflict.check_body("disk", "inertia", rows[1:], draws) is None


def lognormal_moment_upper_tail(prior, center, se):
    """P(g m x + se Z >= center) for lognormal m and x (truncated at 4.75 SDs: renormalised).

    log m + log x: one Gauss-Legendre integral over log m of log x's survival function, then
    the Gaussian error by Gauss-Hermite.
    """
    d = {p: prior.distribution[p] for p in ("mass", "com_distance")}
    mu = {p: math.log(d[p]["median"]) for p in d}
    sd = {p: d[p]["sd_log"] for p in d}
    lo = {p: math.log(prior.lower[p]) for p in d}
    hi = {p: math.log(prior.upper[p]) for p in d}
    a, wa = _legendre(lo["mass"], hi["mass"], 2000)
    za, zlo, zhi = ((v - mu["mass"]) / sd["mass"] for v in (a, lo["mass"], hi["mass"]))
    dens = np.exp(-0.5 * za**2) / (sd["mass"] * math.sqrt(2 * math.pi))
    dens *= (hi["mass"] - lo["mass"]) / (special.ndtr(zhi) - special.ndtr(zlo))
    xl, xh = ((v - mu["com_distance"]) / sd["com_distance"] for v in (lo["com_distance"],
              hi["com_distance"]))  # fmt: skip
    e, we = np.polynomial.hermite_e.hermegauss(80)
    total = 0.0
    for ek, wk in zip(e, we / math.sqrt(2 * math.pi), strict=True):
        need = (np.log((center - se * ek) / GRAVITY) - a - mu["com_distance"]) / sd["com_distance"]
        surv = (special.ndtr(xh) - special.ndtr(np.clip(need, xl, xh))) / (
            special.ndtr(xh) - special.ndtr(xl)
        )
        total += wk * float(np.sum(wa * dens * surv))
    return total


# -- the user's case ---------------------------------------------------------------------------
HEAVY = {  # a body twice as heavy as de Leva's: I 0.150 kg m^2, M_g 5.74 N m
    "inertia": 0.150,
    "inertia_sd": 0.005,
    "inertia_n": 10,
    "gravity_moment": 5.74,
    "gravity_moment_se": 0.03,
}


@pytest.fixture(scope="module")
def heavy():
    with pytest.warns(PriorDataConflictWarning) as caught:
        post = fit_body(heavy_prior(), seed=0, **HEAVY)
    return post, [str(w.message) for w in caught]


def test_a_body_twice_as_heavy_as_its_de_leva_prior_is_said(heavy):
    post, said = heavy
    assert len(said) == 2
    assert said[0].startswith("prior-data conflict: forearm I: the data give 0.15 ± 0.0018")
    assert said[1].startswith("prior-data conflict: forearm M_g: the data give 5.74 ± 0.03")
    assert all("\n" not in line and "above what its prior allows" in line for line in said)
    table = post.prior_predictive().set_index("quantity")
    # M_g's tail against the lognormal product's quadrature (4e7 plain draws: 5.89e-5 +- 0.12e-5);
    # so deep in the tail about 8 of the 131 072 quasi-random draws reach it: 10 % is its error
    exact = lognormal_moment_upper_tail(heavy_prior(), 5.74, 0.03)
    assert exact == pytest.approx(6.04e-5, rel=0.01)
    assert table.loc["gravity_moment", "tail_probability"] == pytest.approx(2 * exact, rel=0.15)
    # I: 0.150 against a prior whose 95 % lies within 0.050-0.115
    assert table.loc["inertia", "prior_high"] == pytest.approx(0.115, abs=0.001)
    assert 0.001 < table.loc["inertia", "tail_probability"] < 0.0025
    assert table["conflict"].all()
    # the identification table carries it on the rows of I and M_g
    ident = post.identification().set_index("parameter")
    assert ident["prior_data_conflict"].tolist() == [False, False, False, True, True]
    assert ident.loc["inertia", "prior_predictive_p"] == table.loc["inertia", "tail_probability"]
    assert ident.loc[list(PARAMETERS), "prior_predictive_p"].isna().all()
    # the shares of m, x, rho leave 0-1 (1.6-2.7): said as the conflict, not as noise
    assert (ident.loc[list(PARAMETERS), "prior_share"] > 1.4).all()
    text = post.report()
    assert "Monte Carlo noise:" not in text.replace("not Monte Carlo noise", "")
    line = post.what_pins_what()["forearm"]
    assert "beyond 0-1 it is the data contradicting the prior, not Monte Carlo noise" in line
    assert "prior-data conflict in I and M_g" in text
    assert "forearm I 0.0016 (conflict), M_g 0.00013 (conflict)" in text
    assert "prior-data conflict: forearm I" in post._repr_html_()


def test_the_check_reads_the_prior_and_the_data_not_the_draws(heavy):
    post, _ = heavy
    with pytest.warns(PriorDataConflictWarning):
        other = fit_body(heavy_prior(), seed=1, **HEAVY)
    assert not np.array_equal(other.draws("forearm", "mass"), post.draws("forearm", "mass"))
    pd.testing.assert_frame_equal(other.prior_predictive(), post.prior_predictive())
    # negative control: the same prior and data at de Leva's own values are no conflict
    with warnings.catch_warnings():
        warnings.simplefilter("error", PriorDataConflictWarning)
        fine = fit_body(
            heavy_prior(), seed=0, **{**HEAVY, "inertia": 0.0755, "gravity_moment": 2.87}
        )
    assert not fine.prior_predictive()["conflict"].any()
    assert fine.conflict_warnings() == []
    assert (fine.prior_predictive()["tail_probability"] > 0.9).all()


def test_fit_prints_it_and_writes_it_in_every_table(tmp_path, capsys, no_figures):
    from inertiafit.cli import main

    prior = tmp_path / "forearm.toml"
    prior.write_text(
        'name = "forearm"\nanthropometric = "de-leva-male"\nsegment = "forearm+hand"\n'
        "body_mass = 72.0\nsegment_length = 0.27\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    args = ["fit", "--prior", str(prior), "--inertia", "0.150", "--inertia-sd", "0.005"]
    args += ["--inertia-n", "10", "--gravity-moment", "5.74", "--gravity-moment-se", "0.03"]
    assert main([*args, "--out", str(out)]) == 0
    printed = capsys.readouterr()
    warned = [line for line in printed.out.splitlines() if line.startswith("warning: ")]
    assert [w.split(":")[1:3] for w in warned] == [
        [" prior-data conflict", " forearm I"],
        [" prior-data conflict", " forearm M_g"],
    ]
    assert "PriorDataConflictWarning" not in printed.err  # said once, as a line
    ident = pd.read_csv(out / "identification.csv")
    assert ident["prior_data_conflict"].tolist() == [False, False, False, True, True]
    assert (ident["prior_predictive_p"].iloc[3:] < CONFLICT_TAIL).all()
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count("prior-data conflict: forearm") == 2


# -- calibration: studies simulated from the prior ----------------------------------------------
N_DRAWS = 2**13  # per check; its quasi-Monte Carlo error is far below the binomial one here
TRIALS, TRIAL_SD, MOMENT_SE = 10, 0.017, 0.023  # the paper's fast trials, a quasi-static SE


def simulated_checks(rng, priors, draws, heavier=1.0):
    """Truths from the priors (the forearm's mass times ``heavier``), conditions A and A + F:
    ten fast trials each (Student-t evidence), one quasi-static M_g each (Gaussian)."""
    values = {}
    for body, prior in priors.items():
        d = {p: float(v[0]) for p, v in prior.sample(1, rng).items()}
        m = d["mass"] * (heavier if body == "forearm" else 1.0)
        x, r = d["com_distance"], d["radius_of_gyration"]
        values[body] = {"inertia": m * (r * r + x * x), "gravity_moment": m * GRAVITY * x}
    out = {}
    for quantity in ("inertia", "gravity_moment"):
        rows = []
        for bodies in (("attachment",), ("attachment", "forearm")):
            mu = sum(values[b][quantity] for b in bodies)
            if quantity == "inertia":
                y = mu + TRIAL_SD * rng.standard_normal(TRIALS)
                scale = float(y.std(ddof=1)) / math.sqrt(TRIALS)
                rows.append(ConditionData("", bodies, float(y.mean()), scale, TRIALS - 1.0))
            else:
                y = mu + MOMENT_SE * rng.standard_normal()
                rows.append(ConditionData("", bodies, float(y), MOMENT_SE, math.inf))
        for body in priors:
            out[(body, quantity)] = conflict.check_body(body, quantity, rows, draws).p
    return out


@pytest.mark.slow
def test_false_alarms_on_studies_from_the_prior_are_the_nominal_rate():
    priors = {
        "attachment": load_prior(ATTACHMENT),
        "forearm": anthropometric_prior(
            "de-leva-male", "forearm+hand", 72.5, 0.27, name="forearm"
        ),
    }
    draws = {
        b: conflict.prior_draws(spec_of(p), GRAVITY, N_DRAWS, stream=k)
        for k, (b, p) in enumerate(priors.items())
    }
    n = 1000
    p = pd.DataFrame(
        [simulated_checks(np.random.default_rng([7, i]), priors, draws) for i in range(n)]
    )
    alarms = p < CONFLICT_TAIL
    # each check: the nominal 1 % within 3 binomial SEs of 4000 checks (0.16 %); measured 0.95 %
    rate = float(alarms.to_numpy().mean())
    se = math.sqrt(CONFLICT_TAIL * (1 - CONFLICT_TAIL) / alarms.size)
    assert abs(rate - CONFLICT_TAIL) < 3 * se
    # a study's four checks: at most 1 - 0.99^4 = 3.9 % plus 3 SEs of 1000 studies (0.6 %)
    per_study = float(alarms.any(axis=1).mean())
    assert per_study < 1 - (1 - CONFLICT_TAIL) ** 4 + 3 * math.sqrt(0.039 * 0.961 / n)
    # the tail probabilities are uniform: 5 % below 0.05 as well (3 SEs of 4000 checks)
    assert abs(float((p < 0.05).to_numpy().mean()) - 0.05) < 3 * math.sqrt(0.05 * 0.95 / p.size)
    # negative control: the forearm twice as heavy as its prior's is caught in most studies
    heavy = pd.DataFrame(
        [
            simulated_checks(np.random.default_rng([8, i]), priors, draws, heavier=2.0)
            for i in range(200)
        ]
    )
    assert float((heavy[("forearm", "gravity_moment")] < CONFLICT_TAIL).mean()) > 0.8
    assert float((heavy.filter(like="forearm") < CONFLICT_TAIL).any(axis=1).mean()) > 0.8
    # and the attachment, whose prior is right, stays at the nominal rate
    assert float((heavy.filter(like="attachment") < CONFLICT_TAIL).to_numpy().mean()) < 0.03


# -- silent on the demo; said on the living tutorial's data -------------------------------------
@pytest.mark.slow
def test_the_demo_paper_study_its_numbers_and_its_de_leva_forearm_are_no_conflict(
    tmp_path, monkeypatch
):
    from inertiafit.errors import ConvergenceWarning
    from inertiafit.inference import fit as fit_module
    from inertiafit.inference.sampler import SamplerSettings
    from inertiafit.pipeline import information
    from inertiafit.pipeline.demo import paper_cases
    from inertiafit.pipeline.study import study_posterior
    from inertiafit.simulate import paper_study

    smallest = []
    with warnings.catch_warnings():
        warnings.simplefilter("error", PriorDataConflictWarning)
        for case in paper_cases():  # the demo's paper-numbers fits
            keys = ("inertia_se", "inertia_sd", "inertia_n", "gravity_moment_se")
            post = fit_body(
                case["prior"],
                inertia=case["inertia"],
                gravity_moment=case["gravity_moment"],
                seed=0,
                **{k: case.get(k) for k in keys},
            )
            smallest.append(post.prior_predictive()["tail_probability"].min())
    manifest = paper_study(tmp_path / "study", seed=0)  # the demo's study, its seed
    post = study_posterior(manifest, seed=0)
    assert post.conflict_warnings() == []
    smallest.append(post.prior_predictive()["tail_probability"].min())

    # the information demo's fits (a weighed weight; the de Leva forearm drawn from its prior),
    # each run short: the check reads the prior and the evidence, not the draws
    def short(model, *, seed=0, **_kwargs):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            fitted = fit_module.fit(
                model, seed=seed, settings=SamplerSettings(max_steps=200, chunk=100)
            )
        smallest.append(fitted.prior_predictive()["tail_probability"].min())
        assert fitted.conflict_warnings() == []
        return fitted

    monkeypatch.setattr(information, "fit", short)
    information.run_information_demo(tmp_path / "information", manifest, echo=lambda _m: None)
    assert len(smallest) == 2 + 1 + 4
    assert min(smallest) > 0.2  # measured: 0.26 (the de Leva forearm's M_g), others > 0.6


@pytest.mark.slow
def test_the_living_demo_is_no_conflict(tmp_path):
    from inertiafit.pipeline.study import study_posterior
    from inertiafit.simulate import simulate_living_study

    demo = study_posterior(simulate_living_study(tmp_path / "demo", seed=0, postures="two"))
    assert demo.conflict_warnings() == []
    assert demo.prior_predictive()["tail_probability"].min() > 0.5  # measured 0.84


@pytest.mark.slow
def test_the_living_tutorials_forearm_is_said_and_not_told_to_weigh_it(tmp_path):
    from inertiafit.pipeline.study import analyse_study
    from inertiafit.simulate import simulate_living_study

    # the living tutorial's study before issue 34 made its forearm an adult's: a de Leva prior
    # (78 kg, 0.28 m) on the simulator's default forearm of 1.5 kg, x 0.15 m, rho 0.08 m -
    # whose I (0.043) is half what that prior expects (0.088)
    de_leva = {"anthropometric": "de-leva-male", "segment": "forearm+hand"}
    de_leva |= {"body_mass": 78.0, "segment_length": 0.28}
    manifest = simulate_living_study(
        tmp_path / "study", seed=1, postures="two", priors={"forearm": de_leva}
    )
    result = analyse_study(manifest)
    warned = [w for w in result.warnings if "prior-data conflict" in w]  # what `run` prints
    assert len(warned) == 1
    assert warned[0].startswith("prior-data conflict: forearm I: the data give 0.042")
    table = result.posterior.prior_predictive().set_index(["body", "quantity"])
    assert table.loc[("forearm", "inertia"), "tail_probability"] < 0.002  # measured 7e-4
    assert table.loc[("forearm", "gravity_moment"), "tail_probability"] > CONFLICT_TAIL
    assert result.identification()["prior_data_conflict"].sum() == 1
    line = result.posterior.what_pins_what()["forearm"]
    assert "weigh it" not in line
    assert "a living segment can be neither weighed nor remounted" in line
    assert "weigh it" in result.posterior.what_pins_what()["attachment"]  # rigid: it may
