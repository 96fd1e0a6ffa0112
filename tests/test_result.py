import warnings

import numpy as np
import pytest

from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.inference.fit import fit, fit_body
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.posterior import open_posterior


@pytest.fixture(scope="module")
def attachment():
    return fit_body(
        "biodex-elbow-attachment",
        inertia=[0.216],
        inertia_sd=0.017,
        inertia_n=30,
        gravity_moment=[7.415],
        gravity_moment_se=0.05,
        seed=2,
    )


def test_text_report_states_intervals_identification_and_the_mass_bound(attachment):
    text = str(attachment)
    assert "95% HDI" in text
    assert "converged" in text
    assert "data + prior" in text
    assert "m >= (M_g/g)^2/I = 2.64" in text
    # header lines, 5 quantities, one bound line, "what pins what" with a line per body,
    # the prior-data check, a correlation line per body, the calibration line
    assert text.count("\n") == 1 + 5 + 1 + 2 + 1 + 1 + 1
    assert "m, x and rho by the data and the prior together" in text
    assert "Prior-data check" in text
    assert "(conflict)" not in text
    assert text.endswith("every interval assumes an exact torque calibration.")


def test_html_display_is_a_table(attachment):
    html = attachment._repr_html_()
    assert html.count("<tr>") == 1 + 5
    assert "<th>prior share</th>" in html
    assert html.count("<li>") == 2  # what pins what, and the correlations
    assert "radius_of_gyration" in html
    assert "kg m^2" in html


def test_summary_hdi_contains_the_median_and_narrows_with_probability(attachment):
    s95 = attachment.summary(0.95).set_index("parameter")
    s50 = attachment.summary(0.5).set_index("parameter")
    assert (s95.hdi_lower <= s95["median"]).all()
    assert (s95["median"] <= s95.hdi_upper).all()
    assert ((s50.hdi_upper - s50.hdi_lower) < (s95.hdi_upper - s95.hdi_lower)).all()
    with pytest.raises(InputError, match=r"^hdi_prob: expected a probability in \(0, 1\)"):
        attachment.summary(1.0)


def test_posterior_derived_quantities_follow_the_physics(attachment):
    d = {
        q: attachment.draws("biodex-elbow-attachment", q)
        for q in ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment")
    }
    np.testing.assert_allclose(
        d["inertia"],
        d["mass"] * (d["radius_of_gyration"] ** 2 + d["com_distance"] ** 2),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        d["gravity_moment"], 9.81 * d["mass"] * d["com_distance"], rtol=1e-12
    )
    box = load_prior("biodex-elbow-attachment")
    assert box.contains(d["mass"], d["com_distance"], d["radius_of_gyration"]).all()


def test_log_likelihood_group_matches_the_evidence(attachment):
    ll = attachment.tree["log_likelihood"]["inertia"].values[..., 0]
    inertia = attachment.draws("biodex-elbow-attachment", "inertia")
    expected = Observation.from_mean_sd(0.216, 0.017, 30).logpdf(inertia)
    np.testing.assert_allclose(ll, expected, rtol=1e-10)


def test_corner_returns_a_figure_with_a_panel_per_pair(attachment):
    fig = attachment.corner(truths={"mass": 2.91}, parameters=("mass", "com_distance"))
    assert len(fig.axes) == 4
    lo, hi = fig.axes[0].get_xlim()  # zoomed to the posterior, at most 5 % past the box
    assert 1.455 - 0.05 * 2.91 - 1e-9 <= lo < hi <= 4.365 + 0.05 * 2.91 + 1e-9
    spanned = attachment.corner(parameters=("mass", "com_distance"), prior_box=True)
    assert spanned.axes[0].get_xlim() == pytest.approx((1.455, 4.365))  # the prior box


def test_step_bound_warns_and_marks_the_result_unconverged():
    model = Model(
        {"d": load_prior("disk-3kg")},
        [
            Condition(
                ("d",),
                Observation.from_mean_se(0.594, 0.0105),
                Observation.from_mean_se(12.8, 0.05),
            )
        ],
    )
    with pytest.warns(ConvergenceWarning, match="max_steps=40"):
        post = fit(model, seed=0, settings=SamplerSettings(chunk=20, max_steps=40))
    assert not post.converged
    assert "NOT CONVERGED" in str(post)


def test_open_posterior_rejects_other_files(tmp_path):
    with pytest.raises(InputError, match="posterior file not found"):
        open_posterior(tmp_path / "missing.nc")
    bad = tmp_path / "bad.nc"
    bad.write_text("not netcdf")
    with pytest.raises(InputError, match="not a readable posterior file"):
        open_posterior(bad)


def test_no_warnings_on_a_normal_fit():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit_body(
            "disk-3kg",
            inertia=[0.59, 0.60, 0.58, 0.61],
            gravity_moment=[12.8],
            gravity_moment_se=0.05,
            seed=1,
        )
