"""The likelihood-term recipe of docs/architecture.md, followed literally (issue 35, items 1
and 5): a toy kind of evidence -- a body's radius of gyration measured by a pendulum test,
with its SD -- defined here in one class and one registration, fitted from reported numbers
to the written outputs. It must be credited by its own name in identification.csv, leave its
reading and SD in posterior.nc and its sentence in methods.md, and move the posterior of rho
as the exact quadrature (inference.reference) says, against the same fit without it."""

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from inertiafit import physics
from inertiafit.inference.fit import fit_body
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior
from inertiafit.inference.reference import reference_posterior
from inertiafit.inference.terms import (
    CORE_SDS,
    TERM_KINDS,
    WINDOW_TAIL,
    CurvePiece,
    Datum,
    MethodsText,
    Point,
    Source,
    TermData,
    register_term,
)
from inertiafit.pipeline.fit import fit_result
from inertiafit.report.outputs import write_outputs

TRUE = (2.76, 0.236, 0.13)  # an elbow attachment (m, x, rho); its prior box is +-50 %
I_TRUE = float(physics.inertia(TRUE[0], TRUE[2], TRUE[1]))
MG_TRUE = float(physics.gravity_moment(TRUE[0], TRUE[1]))
I_SE, MG_SE = 0.002 * I_TRUE, 0.002 * MG_TRUE  # the dynamometer fixes the curve of (m x, I)
READING, READING_SD = 0.140, 0.002  # the pendulum's rho (m) and its SD
LABEL = "pendulum test"


def _rho_masses(a, b, r):
    """Masses on the curve of ``(a, b)`` where ``rho >= r``: ``rho^2 = b/m - a^2/m^2``."""
    r = np.maximum(r, 0.0)
    disc = b * b - 4 * a * a * r * r
    root = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide="ignore"):
        lo, hi = 2 * a * a / (b + root), 2 * a * a / (b - root)
    reach = disc > 0  # where the curve never reaches r, the term allows nothing better
    return np.where(reach, lo, 0.0), np.where(reach, hi, np.inf)


# -- step 1 of the recipe: one frozen dataclass, decorated by @register_term (below) -----------
@dataclasses.dataclass(frozen=True)
class PendulumRho:
    """A body's radius of gyration about its CoM read by a pendulum test, as a Gaussian."""

    body: str
    observation: Observation
    kind: ClassVar[str] = "test-pendulum-rho"
    VARIABLES: ClassVar[tuple[str, ...]] = ("pendulum_rho",)
    SOURCES: ClassVar[Mapping[str, Source]] = {
        "pendulum_rho": Source(LABEL, pins=("radius_of_gyration",))
    }

    @property
    def variables(self) -> tuple[str, ...]:
        return self.VARIABLES

    @property
    def bodies(self) -> tuple[str, ...]:
        return (self.body,)

    @property
    def angle_body(self) -> str:
        return self.body  # rho moves along the body's curve of constant (a, b)

    @property
    def label(self) -> str:
        return self.body

    def dims(self) -> dict[str, str]:
        return {"pendulum_rho": "pendulum_body"}

    def log_likelihood(self, point: Point) -> dict[str, np.ndarray]:
        rho = point.parameters(self.body)["radius_of_gyration"]
        return {"pendulum_rho": self.observation.logpdf(rho)}

    def curve(self, point: Point | None, a_k, b_k) -> CurvePiece:
        del point
        obs = self.observation

        def on_curve(m, x):
            return obs.logpdf(np.sqrt(np.maximum(b_k[:, None] / m - x * x, 0.0)))

        window = _rho_masses(a_k, b_k, obs.center - obs.quantile_halfwidth(WINDOW_TAIL))
        core = _rho_masses(a_k, b_k, obs.center - CORE_SDS * obs.total_scale)
        return CurvePiece(on_curve, window, core)

    def body_masses(self, first_moment, tail: float) -> tuple[float, float]:
        del first_moment, tail
        return 0.0, math.inf

    def body_log_likelihood(self, params: Mapping[str, Any]):
        return self.observation.logpdf(params["radius_of_gyration"])

    @classmethod
    def data(cls, terms: Sequence["PendulumRho"], bodies: Sequence[str]) -> TermData:
        del bodies
        if not terms:
            return TermData()
        names = [t.body for t in terms]
        coords = {"pendulum_body": names}
        return TermData(
            observed={
                "pendulum_rho": Datum(
                    "pendulum_body", np.array([t.observation.center for t in terms]), "m", coords
                )
            },
            constant={
                "pendulum_rho_sd": Datum(
                    "pendulum_body", np.array([t.observation.scale for t in terms]), "m", coords
                )
            },
        )

    @classmethod
    def methods(cls, tree) -> list[MethodsText]:
        if "pendulum_rho" not in tree["observed_data"]:
            return []
        return [
            MethodsText(
                "a pendulum test of the radius of gyration",
                sentence="The radius of gyration measured by a pendulum test entered the "
                "likelihood as a Gaussian with the test's SD",
                cite=("dempster_1955",),
                measures=("radius_of_gyration",),
            )
        ]


@pytest.fixture
def pendulum():
    """The kind registered for one test and removed after it (other tests see the registry
    as it was)."""
    register_term(PendulumRho)
    yield PendulumRho
    TERM_KINDS.pop(PendulumRho.kind)


def fitted(folder, terms=()):
    """One body from reported numbers to every output but the figures."""
    prior = load_prior("biodex-elbow-attachment")
    post = fit_body(
        prior,
        inertia=I_TRUE * 1.001,
        inertia_se=I_SE,
        gravity_moment=MG_TRUE * 0.999,
        gravity_moment_se=MG_SE,
        seed=5,
        terms=terms,
    )
    result = fit_result(
        post,
        prior,
        inertia=I_TRUE * 1.001,
        gravity_moment=MG_TRUE * 0.999,
        gravity=physics.GRAVITY,
        hdi_prob=0.95,
    )
    write_outputs(folder, result, formats=("png",))
    return prior, post


def test_a_term_added_by_the_recipe_is_credited_stored_cited_and_moves_rho_exactly(
    pendulum, tmp_path, no_figures
):
    prior = load_prior("biodex-elbow-attachment")
    body = prior.name
    reading = Observation.from_mean_se(READING, READING_SD)
    with_term, without = tmp_path / "with", tmp_path / "without"
    with_term.mkdir()
    without.mkdir()
    _, post = fitted(with_term, [pendulum(body, reading)])
    _, plain = fitted(without)

    # credited by its own name, for rho (not "the data")
    ident = pd.read_csv(with_term / "identification.csv").set_index("parameter")
    # rho is what it measures (named alone); m and x follow from it with m x and I
    assert ident.loc["radius_of_gyration", "pinned_by"] == LABEL
    assert ident.loc["mass", "pinned_by"] == f"data + {LABEL}"
    assert ident.loc["gravity_moment", "pinned_by"] == "data"
    plain_ident = pd.read_csv(without / "identification.csv").set_index("parameter")
    assert LABEL not in " ".join(plain_ident["pinned_by"])  # negative control
    assert "prior" in plain_ident.loc["radius_of_gyration", "pinned_by"]

    # its reading and SD in posterior.nc, its variable credited by name
    tree = xr.open_datatree(with_term / "posterior.nc", engine="h5netcdf")
    assert float(tree["observed_data"]["pendulum_rho"].sel(pendulum_body=body)) == READING
    assert tree["observed_data"]["pendulum_rho"].attrs["units"] == "m"
    assert float(tree["constant_data"]["pendulum_rho_sd"].sel(pendulum_body=body)) == READING_SD
    assert tree["log_likelihood"]["pendulum_rho"].attrs["source"] == LABEL
    plain_tree = xr.open_datatree(without / "posterior.nc", engine="h5netcdf")
    assert "pendulum_rho" not in plain_tree["observed_data"]
    assert "pendulum_rho" not in plain_tree["log_likelihood"]

    # its sentence in the Methods, its citation in references.bib
    methods = (with_term / "methods.md").read_text(encoding="utf-8")
    assert "Further evidence on the bodies: a pendulum test of the radius of gyration." in methods
    assert "as a Gaussian with the test's SD [@dempster_1955]." in methods
    assert "{dempster_1955," in (with_term / "references.bib").read_text(encoding="utf-8")
    assert "pendulum" not in (without / "methods.md").read_text(encoding="utf-8")

    # the physics: the exact posterior by quadrature with and without the term
    inertia = Observation.from_mean_se(I_TRUE * 1.001, I_SE)
    gravity_moment = Observation.from_mean_se(MG_TRUE * 0.999, MG_SE)
    exact = reference_posterior(prior, inertia, gravity_moment, terms=[pendulum("body", reading)])
    exact_plain = reference_posterior(prior, inertia, gravity_moment)
    rho = post.draws(body, "radius_of_gyration")
    rho_plain = plain.draws(body, "radius_of_gyration")
    ess = float(
        post.summary()
        .set_index(["body", "parameter"])
        .loc[(body, "radius_of_gyration"), "ess_bulk"]
    )
    mc_error = exact.sd("radius_of_gyration") / math.sqrt(ess)
    assert abs(rho.mean() - exact.mean("radius_of_gyration")) < 4 * mc_error
    assert rho.std() == pytest.approx(exact.sd("radius_of_gyration"), rel=0.1)
    # the SD shrinks by the factor the quadrature predicts, and the mean moves to the reading
    predicted = exact.sd("radius_of_gyration") / exact_plain.sd("radius_of_gyration")
    assert predicted < 0.3
    assert rho.std() / rho_plain.std() == pytest.approx(predicted, rel=0.15)
    assert abs(rho.mean() - READING) < 1.5 * READING_SD
    assert abs(rho_plain.mean() - READING) > 5 * READING_SD
