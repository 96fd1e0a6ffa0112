"""Likelihood terms as objects with one registry (issue 18, item 3): the model, the blocked
sampler's submodel and the exact reference consume the same terms; a new kind is one class and
its registration; each direct measurement is declared once (inertiafit.measured)."""

import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import pytest

from inertiafit import physics
from inertiafit.errors import InputError
from inertiafit.inference.blocked import BlockedGibbs
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior
from inertiafit.inference.reference import reference_posterior
from inertiafit.inference.star import star_structure
from inertiafit.inference.terms import (
    TERM_KINDS,
    ConditionEvidence,
    CurvePiece,
    MeasuredEvidence,
    Point,
    register_term,
)
from inertiafit.io.manifest import BODY_KEYS
from inertiafit.measured import MEASURED_QUANTITIES

TRUE = (2.76, 0.236, 0.13)
I_TRUE = float(physics.inertia(TRUE[0], TRUE[2], TRUE[1]))
MG_TRUE = float(physics.gravity_moment(TRUE[0], TRUE[1]))
INERTIA = Observation(I_TRUE * 1.001, 0.002 * I_TRUE, 9.0, 10)
GRAVITY_MOMENT = Observation.from_mean_se(MG_TRUE * 0.999, 0.002 * MG_TRUE)
WEIGHED = Observation.from_mean_se(2.77, 0.01)
MG_READING = Observation.from_mean_se(MG_TRUE, 0.004 * MG_TRUE)


def rows(n: int = 40, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.log([[TRUE[0] * TRUE[1], I_TRUE]]) + 0.003 * rng.standard_normal((n, 2))


def attachment_and_disk():
    """Two priors and the two conditions of a star: the attachment alone and with the disk."""
    conds = [
        Condition(("attachment",), INERTIA, GRAVITY_MOMENT),
        Condition(
            ("attachment", "disk"),
            Observation.from_mean_se(I_TRUE + 0.6, 0.003),
            Observation.from_mean_se(MG_TRUE + 12.8, 0.03),
        ),
    ]
    return load_prior("biodex-elbow-attachment"), load_prior("disk-3kg"), conds


@dataclasses.dataclass(frozen=True)
class GravityReading:
    """A new kind, as a module would add it: ``M_g`` of one body read by a second instrument."""

    body: str
    observation: Observation
    gravity: float = physics.GRAVITY
    kind: ClassVar[str] = "test-gravity-reading"
    VARIABLES: ClassVar[tuple[str, ...]] = ("gravity_reading",)

    variables = VARIABLES
    angle_body = ""

    @property
    def bodies(self) -> tuple[str, ...]:
        return (self.body,)

    @property
    def label(self) -> str:
        return self.body

    def dims(self) -> dict[str, str]:
        return {"gravity_reading": "reading_body"}

    def log_likelihood(self, point: Point) -> dict[str, np.ndarray]:
        a = point.true_a[..., point.column(self.body)]
        return {"gravity_reading": self.observation.logpdf(self.gravity * a)}

    def curve(self, point: Point | None, a_k) -> CurvePiece:
        del point, a_k
        raise AssertionError("not on an angle")

    def body_masses(self, first_moment, tail: float) -> tuple[float, float]:
        del first_moment, tail
        return 0.0, np.inf

    def body_log_likelihood(self, params: Mapping[str, Any]):
        return self.observation.logpdf(self.gravity * params["first_moment"])


@pytest.fixture
def registered():
    register_term(GravityReading)
    yield GravityReading
    TERM_KINDS.pop(GravityReading.kind)


def test_the_registry_holds_every_kind_once_and_refuses_a_second_registration(registered):
    assert list(TERM_KINDS)[:2] == ["condition", "measured"]
    assert TERM_KINDS["test-gravity-reading"] is registered
    with pytest.raises(ValueError, match="already registered"):
        register_term(registered)

    class NoKind:
        pass

    with pytest.raises(TypeError, match="kind"):
        register_term(NoKind)


def test_a_new_kind_of_term_enters_the_density_and_the_likelihood_variables(registered):
    prior = load_prior("biodex-elbow-attachment")
    reading = Observation.from_mean_se(MG_TRUE * 1.002, 0.004 * MG_TRUE)
    base = [Condition(("disk",), INERTIA, GRAVITY_MOMENT)]
    with_term = Model({"disk": prior}, base, terms=[registered("disk", reading)])
    # the same evidence written as a second condition with only a gravity moment
    as_condition = Model({"disk": prior}, [*base, Condition(("disk",), None, reading, "again")])
    plain = Model({"disk": prior}, base)
    z = rows()
    assert np.allclose(with_term.log_prob(z), as_condition.log_prob(z), rtol=0, atol=1e-9)
    assert not np.allclose(with_term.log_prob(z), plain.log_prob(z), atol=0.1)  # it counts
    ll = with_term.log_likelihood_terms(z)
    assert with_term.variables == ("inertia", "gravity_moment", "gravity_reading")
    assert with_term.likelihood_coords()["gravity_reading"] == ("reading_body", ["disk"])
    expected = as_condition.log_likelihood_terms(z)["gravity_moment"][:, 1]
    np.testing.assert_allclose(ll["gravity_reading"][:, 0], expected, rtol=1e-12)
    # the exact reference takes the same object: a tight reading pulls M_g to the precision-
    # weighted mean of the two Gaussians (0.999 with SD 0.002, 1.004 with SD 0.0002, x MG_TRUE)
    tight = registered("disk", Observation.from_mean_se(MG_TRUE * 1.004, 0.0002 * MG_TRUE))
    ref = reference_posterior(prior, INERTIA, GRAVITY_MOMENT, terms=[tight])
    w = np.array([1 / 0.002**2, 1 / 0.0002**2])
    combined = (w @ [0.999, 1.004]) / w.sum()
    assert abs(ref.mean("gravity_moment") / MG_TRUE - combined) < 0.5 / np.sqrt(w.sum())
    plain_ref = reference_posterior(prior, INERTIA, GRAVITY_MOMENT)
    assert abs(plain_ref.mean("gravity_moment") / MG_TRUE - combined) > 0.002
    with pytest.raises(InputError, match="unknown body 'nobody'"):
        Model({"disk": prior}, base, terms=[registered("nobody", reading)])


def test_measured_terms_are_the_measured_argument_and_the_reference_takes_them():
    prior = load_prior("biodex-elbow-attachment")
    base = [Condition(("disk",), INERTIA, GRAVITY_MOMENT)]
    by_argument = Model({"disk": prior}, base, measured={"disk": {"mass": WEIGHED}})
    by_term = Model({"disk": prior}, base, terms=[MeasuredEvidence("disk", "mass", WEIGHED)])
    z = rows()
    assert np.array_equal(by_argument.log_prob(z), by_term.log_prob(z))
    assert by_term.measured == {"disk": {"mass": WEIGHED}}
    assert [t.kind for t in by_term.terms] == ["measured", "condition"]
    as_keyword = reference_posterior(prior, INERTIA, GRAVITY_MOMENT, mass=WEIGHED)
    as_term = reference_posterior(
        prior, INERTIA, GRAVITY_MOMENT, terms=[MeasuredEvidence("body", "mass", WEIGHED)]
    )
    assert np.array_equal(as_keyword.weights, as_term.weights)
    assert as_term.sd("mass") < 0.2 * reference_posterior(prior, INERTIA, GRAVITY_MOMENT).sd(
        "mass"
    )


def test_likelihood_columns_follow_the_model_bodies_whatever_order_measured_is_given_in():
    a, b = load_prior("biodex-elbow-attachment"), load_prior("disk-3kg")
    conds = [
        Condition(("a",), INERTIA, GRAVITY_MOMENT),
        Condition(("a", "b"), Observation.from_mean_se(2 * I_TRUE, 0.01), None),
    ]
    obs_a, obs_b = Observation.from_mean_se(2.7, 0.01), Observation.from_mean_se(2.9, 0.01)
    model = Model({"a": a, "b": b}, conds, measured={"b": {"mass": obs_b}, "a": {"mass": obs_a}})
    assert model.likelihood_coords()["mass"] == ("mass_body", ["a", "b"])
    z = np.log([[0.65, 0.2, 1.3, 0.4]])
    mass = np.array([[2.71, 2.95]])
    ll = model.log_likelihood_terms(z, mass)["mass"]
    np.testing.assert_allclose(ll[0], [obs_a.logpdf(2.71), obs_b.logpdf(2.95)], rtol=1e-12)


def test_condition_terms_hold_the_conditions_and_the_blocked_submodel_gets_the_shared_terms():
    att, disk, conds = attachment_and_disk()
    measured = {"attachment": {"com_distance": Observation.from_mean_se(0.236, 0.002)},
                "disk": {"mass": WEIGHED}}  # fmt: skip
    model = Model({"attachment": att, "disk": disk}, conds, measured=measured)
    kinds = [(t.kind, t.label) for t in model.terms]
    assert kinds == [("measured", "attachment"), ("measured", "disk"),
                     ("condition", "attachment"), ("condition", "attachment+disk")]  # fmt: skip
    assert all(isinstance(t, ConditionEvidence) for t in model.terms[2:])
    star = star_structure(model)
    assert star is not None
    sub = BlockedGibbs.shared_submodel(model, star)
    assert [(t.kind, t.label) for t in sub.extra_terms] == [("measured", "attachment")]
    # a term across two bodies ties a leaf to the attachment: no star
    across = dataclasses.replace(conds[1])
    tied = Model(
        {"attachment": att, "disk": disk}, conds, terms=[ConditionEvidence(1, across, 9.81)]
    )
    assert star_structure(tied) is None


def test_each_measured_quantity_is_declared_once_and_read_from_the_registry():
    assert set(MEASURED_QUANTITIES) == {"mass", "com_distance"}
    assert set(MEASURED_QUANTITIES) <= set(BODY_KEYS)
    com = MEASURED_QUANTITIES["com_distance"]
    assert (com.unit, com.quantity, com.body_dim) == ("m", "length", "com_body")
    assert com.constant_vars == ("measured_com_distance", "measured_com_distance_sd")
    lo, hi = com.masses(0.2, 0.25, np.array([0.5]))  # x = a / m in [0.2, 0.25]
    np.testing.assert_allclose([lo[0], hi[0]], [2.0, 2.5])
    lo, hi = com.masses(-0.1, 0.25, np.array([0.5]))
    assert hi[0] == np.inf
    with pytest.raises(InputError, match="unknown quantity 'volume'"):
        MeasuredEvidence("disk", "volume", WEIGHED)


def test_a_term_off_the_angle_of_a_leaf_keeps_the_blocked_sampler_off(registered):
    att, disk, conds = attachment_and_disk()
    reading = Observation.from_mean_se(12.8, 0.05)
    priors = {"attachment": att, "disk": disk}
    # the blocked sampler's leaf density holds only the leaf's prior and its angle's terms
    assert star_structure(Model(priors, conds, terms=[registered("disk", reading)])) is None
    # on the attachment it is part of the shared bodies' own density
    on_shared = Model(priors, conds, terms=[registered("attachment", MG_READING)])
    star = star_structure(on_shared)
    assert star is not None
    assert BlockedGibbs.shared_submodel(on_shared, star).extra_terms == on_shared.extra_terms
