"""Extra information as likelihood terms (issue 13, item 3): a weighed mass, a balance point, a
second mounting and known added masses in the joint posterior. The sampler is held to the
quadrature reference on a grid in (m, m x, I) that shares nothing with its angle grid, with
negative controls; the blocked and joint samplers agree; SBC with every term."""

import dataclasses
import warnings
from functools import cache

import numpy as np
import pytest

from inertiafit import physics
from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.inference.fit import fit
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior, parse_prior
from inertiafit.inference.reference import reference_posterior
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.validation.sbc import calibrated, calibration_table, extra_design, run_sbc

QUANTITIES = ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment")
TRUE = (2.76, 0.236, 0.13)  # an elbow attachment: m, x, rho (its prior box is +-50 %)
I_TRUE = float(physics.inertia(TRUE[0], TRUE[2], TRUE[1]))
MG_TRUE = float(physics.gravity_moment(TRUE[0], TRUE[1]))
INERTIA = Observation(I_TRUE * 1.001, 0.002 * I_TRUE, 9.0, 10)
GRAVITY_MOMENT = Observation.from_mean_se(MG_TRUE * 0.999, 0.002 * MG_TRUE)
D = 0.1
A_D, B_D = (float(v) for v in physics.moved_moments(TRUE[0] * TRUE[1], I_TRUE, TRUE[0], D))
MOVED = {
    "offset": D,
    "offset_inertia": Observation(B_D * 0.999, 0.002 * B_D, 9.0, 10),
    "offset_gravity_moment": Observation.from_mean_se(9.81 * A_D * 1.001, 0.002 * 9.81 * A_D),
}
CASES = {
    "weighed mass": {"mass": Observation.from_mean_se(2.77, 0.01)},
    "balance point": {"com_distance": Observation.from_mean_se(0.235, 0.002)},
    "second mounting": MOVED,
}


def disk_model(prior, extra: dict) -> Model:
    conditions = [Condition(("disk",), INERTIA, GRAVITY_MOMENT)]
    if "offset" in extra:
        conditions.append(
            Condition(
                ("disk",),
                extra["offset_inertia"],
                extra["offset_gravity_moment"],
                label="disk moved",
                offset_body="disk",
                offset=extra["offset"],
            )
        )
    measured = {k: v for k, v in extra.items() if k in ("mass", "com_distance")}
    return Model({"disk": prior}, conditions, measured={"disk": measured} if measured else None)


@cache
def elbow_reference(case: str = ""):
    """The quadrature reference of the elbow attachment's box with one case's term ("": none).

    A deterministic quadrature of a second or so: computed once per test process, as three
    tests want the plain one and two the second mounting's (read only).
    """
    prior = load_prior("biodex-elbow-attachment")
    return reference_posterior(prior, INERTIA, GRAVITY_MOMENT, **CASES.get(case, {}))


def agreement(post, ref, body="disk") -> tuple[float, float]:
    """``ref.agreement`` of one body's draws of the five quantities."""
    return ref.agreement({q: post.draws(body, q) for q in QUANTITIES})


# -- the model -------------------------------------------------------------------------------


def test_moved_moments_is_the_parallel_axis_theorem_at_x_plus_d():
    m, x, rho, d = 1.7, 0.21, 0.06, 0.13
    a_d, b_d = physics.moved_moments(m * x, physics.inertia(m, rho, x), m, d)
    assert a_d == pytest.approx(m * (x + d), rel=1e-12)
    assert b_d == pytest.approx(float(physics.inertia(m, rho, x + d)), rel=1e-12)
    a, b = physics.point_moments(0.5, 0.3, 0.02)
    assert (a, b) == pytest.approx((0.15, 0.5 * (0.02**2 + 0.09)), rel=1e-12)


def test_a_known_added_mass_is_the_same_as_removing_it_from_the_evidence():
    prior = load_prior("biodex-elbow-attachment")
    a_add, b_add = physics.point_moments(0.5, 0.3, 0.02)
    g = 9.81
    with_added = Model(
        {"disk": prior},
        [
            Condition(
                ("disk",),
                Observation.from_mean_se(I_TRUE + float(b_add), 0.003),
                Observation.from_mean_se(MG_TRUE + g * float(a_add), 0.03),
                added=((0.5, 0.3, 0.02),),
            )
        ],
    )
    plain = Model(
        {"disk": prior},
        [
            Condition(
                ("disk",),
                Observation.from_mean_se(I_TRUE, 0.003),
                Observation.from_mean_se(MG_TRUE, 0.03),
            )
        ],
    )
    rng = np.random.default_rng(0)
    z = np.log([[TRUE[0] * TRUE[1], I_TRUE]]) + 0.01 * rng.standard_normal((50, 2))
    assert np.allclose(with_added.log_prob(z), plain.log_prob(z), atol=1e-9)
    # negative control: the same evidence without declaring the added mass is another posterior
    cond = with_added.conditions[0]
    plain_mounting = dataclasses.replace(cond.mounting, added=())
    undeclared = Model({"disk": prior}, [dataclasses.replace(cond, mounting=plain_mounting)])
    assert not np.allclose(undeclared.log_prob(z), plain.log_prob(z), atol=1.0)


def test_the_angle_grid_integrates_a_weighed_mass_as_well_as_a_fine_quadrature():
    """log of the integral over psi of prior x L(m(psi)) against 200 000 midpoints."""
    prior = load_prior("biodex-elbow-attachment")
    weighed = Observation.from_mean_se(2.77, 0.004)
    model = Model(
        {"disk": prior},
        [Condition(("disk",), INERTIA, GRAVITY_MOMENT)],
        measured={"disk": {"mass": weighed}},
    )
    a = np.array([TRUE[0] * TRUE[1], TRUE[0] * TRUE[1] * 1.01])
    b = np.array([I_TRUE, I_TRUE * 0.995])
    got = model.body_log_curve(0, a, b)
    for i in range(2):
        from inertiafit.inference.model import feasible_angles

        lo1, hi1, lo2, hi2 = (float(v) for v in feasible_angles(a[i], b[i], prior))
        psi = np.concatenate(
            [
                np.linspace(lo1, hi1, 100_001)[:-1] + (hi1 - lo1) / 200_000,
                np.linspace(lo2, hi2, 100_001)[:-1] + max(hi2 - lo2, 0) / 200_000,
            ]
        )
        width = np.concatenate([np.full(100_000, (hi1 - lo1) / 1e5),
                                np.full(100_000, max(hi2 - lo2, 0.0) / 1e5)])  # fmt: skip
        m, x, rho = physics.parameters_from_identified(a[i], b[i], psi)
        f = np.exp(prior.log_density(m, x, rho, check_support=False) + weighed.logpdf(m))
        assert got[i] == pytest.approx(np.log(np.sum(f * width)), abs=2e-4)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"offset_body": "other", "offset": 0.1}, "is not mounted"),
        ({"offset_body": "disk", "offset": 0.0}, "non-zero distance"),
        ({"offset": 0.1}, "needs the body"),
        ({"added": ((-1.0, 0.3, 0.0),)}, "added mass"),
        ({"added": ((0.5, float("nan"), 0.0),)}, "added mass"),
    ],
)
def test_bad_conditions_say_what_is_wrong_in_one_line(kwargs, message):
    with pytest.raises(InputError, match=message) as err:
        Condition(("disk",), INERTIA, GRAVITY_MOMENT, **kwargs)
    assert "\n" not in str(err.value)


def test_bad_measurements_say_what_is_wrong_in_one_line():
    prior = load_prior("biodex-elbow-attachment")
    cond = [Condition(("disk",), INERTIA, GRAVITY_MOMENT)]
    weighed = Observation.from_mean_se(2.9, 0.01)
    for measured, message in [
        ({"nobody": {"mass": weighed}}, "unknown body 'nobody'"),
        ({"disk": {"inertia": weighed}}, "unknown quantity 'inertia'"),
        ({"disk": {"mass": 2.9}}, "expected an Observation"),
    ]:
        with pytest.raises(InputError, match=message) as err:
            Model({"disk": prior}, cond, measured=measured)
        assert "\n" not in str(err.value)


# -- the sampler against the quadrature reference --------------------------------------------


@pytest.mark.parametrize("case", list(CASES))
def test_sampler_matches_the_quadrature_posterior_with_each_term(case):
    prior = load_prior("biodex-elbow-attachment")
    extra = CASES[case]
    ref = elbow_reference(case)
    post = fit(disk_model(prior, extra), seed=3)
    assert post.converged
    worst_mean, worst_sd = agreement(post, ref)
    assert worst_mean < 0.1
    assert worst_sd < 0.10
    # the term pins the mass: without it the reference is many times wider
    plain = elbow_reference()
    assert plain.sd("mass") > 5 * ref.sd("mass")


def test_sampler_matches_the_reference_for_a_normal_prior_and_a_weighed_mass():
    prior = parse_prior(
        {
            "mass": {"distribution": "normal", "mean": 2.9, "sd": 0.3},
            "com_distance": {"distribution": "lognormal", "median": 0.23, "sd_log": 0.05},
            "radius_of_gyration": {"nominal": 0.13},
        },
        name="disk",
        where="test",
    )
    extra = {"mass": Observation.from_mean_se(2.77, 0.02)}
    ref = reference_posterior(prior, INERTIA, GRAVITY_MOMENT, **extra)
    post = fit(disk_model(prior, extra), seed=4)
    worst_mean, worst_sd = agreement(post, ref)
    assert worst_mean < 0.1
    assert worst_sd < 0.10


def test_negative_control_a_term_left_out_of_the_model_fails_against_the_reference():
    prior = load_prior("biodex-elbow-attachment")
    ref = elbow_reference("second mounting")  # CASES["second mounting"] is MOVED
    post = fit(disk_model(prior, {}), seed=3)
    worst_mean, worst_sd = agreement(post, ref)
    assert worst_mean >= 0.1 or worst_sd >= 0.10
    # and the wrong offset (10 % off) is caught as well: the two mountings disagree, so the
    # sampler would run to its 20 000 steps (11 s); 500 (0.8 s) show a posterior 40 SDs off
    # already (2000: 36)
    wrong = dict(MOVED, offset=1.1 * D)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        post = fit(disk_model(prior, wrong), seed=3, settings=SamplerSettings(max_steps=500))
    assert max(agreement(post, ref)) >= 0.1


@pytest.mark.slow
def test_blocked_and_joint_samplers_agree_with_weighed_bodies_and_a_gain():
    att, disk = load_prior("biodex-elbow-attachment"), load_prior("disk-3kg")
    ta, td = (2.76, 0.236, 0.13), (2.9, 0.45, 0.05)
    i_d, m_d = float(physics.inertia(td[0], td[2], td[1])), float(physics.gravity_moment(*td[:2]))
    i_a, m_a = float(physics.inertia(ta[0], ta[2], ta[1])), float(physics.gravity_moment(*ta[:2]))
    conds = [
        Condition(("attachment",), Observation(i_a, 0.003 * i_a, 29.0, 30),
                  Observation.from_mean_se(m_a, 0.003 * m_a)),
        Condition(("attachment", "disk"), Observation(i_a + i_d, 0.003 * (i_a + i_d), 29.0, 30),
                  Observation.from_mean_se(m_a + m_d, 0.003 * (m_a + m_d))),
    ]  # fmt: skip
    measured = {
        "disk": {"mass": Observation.from_mean_se(td[0], 0.01)},
        "attachment": {"com_distance": Observation.from_mean_se(0.236, 0.002)},
    }
    model = Model({"attachment": att, "disk": disk}, conds, measured=measured,
                  torque_gain_sd=0.01)  # fmt: skip
    blocked = fit(model, seed=5, settings=SamplerSettings(moves="blocked"))
    joint = fit(model, seed=5, settings=SamplerSettings(moves="independent"))
    assert blocked.attrs["moves"] == "blocked"
    for body in model.bodies:
        for q in QUANTITIES:
            x, y = blocked.draws(body, q).ravel(), joint.draws(body, q).ravel()
            assert abs(x.mean() - y.mean()) < 0.1 * y.std(), (body, q)
            assert abs(x.std() / y.std() - 1) < 0.10, (body, q)


# -- simulation-based calibration ------------------------------------------------------------


@pytest.mark.slow
def test_sbc_with_every_extra_term_is_calibrated():
    result = run_sbc(extra_design("all"), 12, seed=13)
    assert not result.failures
    assert calibrated(calibration_table(result))


@pytest.mark.slow
def test_sbc_negative_control_overconfident_extra_terms_fail():
    result = run_sbc(extra_design("all"), 6, seed=13, scale=0.3)
    assert not calibrated(calibration_table(result))
