"""The paper's published numbers: self-consistency, pooling by hand, and known inconsistencies."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from inertiafit import paper


def _exact_sample(mean: float, sd: float, n: int) -> np.ndarray:
    """N values whose sample mean and SD (ddof=1) are exactly ``mean`` and ``sd``."""
    z = np.linspace(-1.0, 1.0, n)
    z = (z - z.mean()) / z.std(ddof=1)
    return mean + sd * z


def _trials(summary: paper.SpeedSummary) -> list[np.ndarray]:
    return [
        _exact_sample(m, s, n) for m, s, n in zip(summary.mean, summary.sd, summary.n, strict=True)
    ]


# --- constants as printed ---------------------------------------------------------------------


def test_section_3_1_constants():
    assert paper.GRAVITY == 9.81
    assert paper.SPEEDS == (240.0, 270.0, 300.0)
    a, b = paper.ATTACHMENT_INERTIA, paper.ATTACHMENT_WITH_WEIGHT_INERTIA
    assert a.mean == (0.216, 0.215, 0.216)
    assert a.sd == (0.017, 0.016, 0.017)
    assert b.mean == (0.821, 0.823, 0.824)
    assert b.sd == (0.054, 0.058, 0.053)
    assert a.n == b.n == (10, 10, 10)
    assert (a.anova_p, b.anova_p) == (0.287, 0.276)
    assert paper.WEIGHT_INERTIA == 0.594


# --- Tables 2 and 3 are self-consistent to their printed rounding --------------------------------


def _rounding_bound(row: paper.TableRow, half_units: tuple[float, float, float]) -> float:
    """Largest |m (rho² + x²) − I| the rounding of m, x, rho (and I itself) can explain."""
    dm, dx, drho = half_units
    m, x, rho = row.mass, row.com_distance, row.radius_of_gyration
    return (rho**2 + x**2) * dm + 2 * m * x * dx + 2 * m * rho * drho + 0.0005


# Half a unit of the last printed digit of (mass, com_distance, radius_of_gyration).
_ROWS = [
    pytest.param(paper.TABLE2_IDEAL, (0.005, 0.0005, 0.0005), id="table2-ideal"),
    pytest.param(paper.TABLE2_ESTIMATED, (0.005, 0.0005, 0.0005), id="table2-estimated"),
    pytest.param(paper.TABLE3_IDEAL, (0.005, 0.005, 0.0005), id="table3-ideal"),
    pytest.param(paper.TABLE3_ESTIMATED, (0.005, 0.005, 0.0005), id="table3-estimated"),
]


@pytest.mark.parametrize(("row", "half_units"), _ROWS)
def test_table_rows_satisfy_parallel_axis_theorem(row, half_units):
    computed = row.mass * (row.radius_of_gyration**2 + row.com_distance**2)
    assert abs(computed - row.inertia) <= _rounding_bound(row, half_units)


def test_table2_estimated_row_by_hand():
    # 2.81 (0.065² + 0.269²) = 2.81 * 0.076586 = 0.21521, printed 0.216: rounding, not an error.
    row = paper.TABLE2_ESTIMATED
    computed = row.mass * (row.radius_of_gyration**2 + row.com_distance**2)
    assert computed == pytest.approx(0.215207, abs=1e-6)
    assert row.inertia - computed == pytest.approx(0.0008, abs=1e-4)


def test_ideal_square_tube_reproduces_table2():
    g = paper.ATTACHMENT_GEOMETRY
    rho = paper.square_tube_radius_of_gyration(g["outer_edge"], g["inner_edge"], g["length"])
    # rho² = (A² + a² + l²)/12 = (0.0009 + 0.000676 + 0.2025)/12
    assert rho == pytest.approx(math.sqrt(0.204076 / 12), rel=1e-12)
    assert round(rho, 3) == paper.TABLE2_IDEAL.radius_of_gyration
    assert g["length"] / 2 == paper.TABLE2_IDEAL.com_distance
    inertia = paper.TABLE2_IDEAL.mass * (rho**2 + (g["length"] / 2) ** 2)
    assert round(inertia, 3) == paper.TABLE2_IDEAL.inertia


def test_table1_density_is_mass_over_volume():
    # Table 1 prints d = (A² l − a² l)/m, a volume per mass; taken literally the tube's rho is
    # off by orders of magnitude, so the density must be its reciprocal.
    g = paper.ATTACHMENT_GEOMETRY
    big, small, length, m = g["outer_edge"], g["inner_edge"], g["length"], 2.91
    printed_d = (big**2 * length - small**2 * length) / m
    literal = (
        printed_d * big**2 * length * (big**2 + length**2) / 12
        - printed_d * small**2 * length * (small**2 + length**2) / 12
    )
    assert math.sqrt(literal / m) < 0.01 * paper.TABLE2_IDEAL.radius_of_gyration
    density = 1.0 / printed_d
    cm = density * (
        big**2 * length * (big**2 + length**2) - small**2 * length * (small**2 + length**2)
    )
    assert math.sqrt(cm / 12 / m) == pytest.approx(
        paper.square_tube_radius_of_gyration(big, small, length), rel=1e-12
    )


def test_ideal_disk_reproduces_table3():
    rho = paper.solid_disk_radius_of_gyration(paper.WEIGHT_GEOMETRY["radius"])
    assert rho == pytest.approx(0.05 / math.sqrt(2), rel=1e-15)
    assert round(rho, 3) == paper.TABLE3_IDEAL.radius_of_gyration
    inertia = paper.TABLE3_IDEAL.mass * (rho**2 + paper.TABLE3_IDEAL.com_distance**2)
    assert inertia == pytest.approx(0.59495, abs=1e-5)
    assert round(inertia, 3) == paper.TABLE3_IDEAL.inertia


def test_attachment_estimate_sits_on_the_lower_box_bound_for_rho():
    assert paper.TABLE2_ESTIMATED.radius_of_gyration == pytest.approx(
        (1 - paper.BOX_SPREAD) * paper.TABLE2_IDEAL.radius_of_gyration, abs=1e-12
    )


# --- pooling over the three speeds --------------------------------------------------------------


def test_pooled_attachment_by_hand():
    p = paper.pooled(paper.ATTACHMENT_INERTIA)
    assert p.n == 30
    assert p.mean == pytest.approx(0.647 / 3, rel=1e-12)
    # within SS 9 (0.017² + 0.016² + 0.017²) = 0.007506; between SS 10 (2 (1/3000)² + (2/3000)²)
    within_ss = 9 * (0.017**2 + 0.016**2 + 0.017**2)
    between_ss = 10 * (2 * (1 / 3000) ** 2 + (2 / 3000) ** 2)
    assert p.sd == pytest.approx(math.sqrt((within_ss + between_ss) / 29), rel=1e-12)
    assert p.sd == pytest.approx(0.016095, abs=1e-6)
    assert p.within_sd == pytest.approx(math.sqrt(within_ss / 27), rel=1e-12)


@pytest.mark.parametrize(
    "summary", [paper.ATTACHMENT_INERTIA, paper.ATTACHMENT_WITH_WEIGHT_INERTIA], ids=["A", "B"]
)
def test_pooled_matches_the_thirty_values(summary):
    values = np.concatenate(_trials(summary))
    p = paper.pooled(summary)
    assert p.n == values.size == 30
    assert p.mean == pytest.approx(values.mean(), rel=1e-12)
    assert p.sd == pytest.approx(values.std(ddof=1), rel=1e-12)


def test_pooled_weight_condition_by_hand():
    p = paper.pooled(paper.ATTACHMENT_WITH_WEIGHT_INERTIA)
    assert p.mean == pytest.approx(2.468 / 3, rel=1e-12)
    assert p.sd == pytest.approx(0.053126, abs=1e-6)


def test_weight_by_subtraction_disagrees_with_printed_value():
    # 0.82267 − 0.21567 = 0.607, yet Section 3.2 prints 0.594 (Table 3's ideal is 0.595).
    assert paper.weight_inertia_by_subtraction() == pytest.approx(0.607, abs=1e-12)
    assert paper.weight_inertia_by_subtraction() - paper.WEIGHT_INERTIA == pytest.approx(
        0.013, abs=1e-12
    )


def test_weight_standard_error_by_hand():
    se = math.sqrt(0.0531256**2 / 30 + 0.0160953**2 / 30)
    assert paper.weight_inertia_standard_error() == pytest.approx(se, rel=1e-5)
    assert paper.weight_inertia_standard_error() == pytest.approx(0.010135, abs=1e-6)


# --- the ANOVA p-values cannot come from the printed summaries -----------------------------------


@pytest.mark.parametrize(
    "summary", [paper.ATTACHMENT_INERTIA, paper.ATTACHMENT_WITH_WEIGHT_INERTIA], ids=["A", "B"]
)
def test_anova_from_summary_matches_scipy_and_not_the_paper(summary):
    f_stat, p = paper.anova_from_summary(summary)
    reference = stats.f_oneway(*_trials(summary))
    assert f_stat == pytest.approx(reference.statistic, rel=1e-10)
    assert p == pytest.approx(reference.pvalue, rel=1e-10)
    assert p > 0.98
    assert summary.anova_p < 0.3


def test_no_rounding_of_the_printed_means_gives_the_printed_p():
    # Most spread-out means and smallest SDs the rounding allows, condition A.
    worst = paper.SpeedSummary(
        condition="A",
        speeds=paper.SPEEDS,
        mean=(0.2165, 0.2145, 0.2165),
        sd=(0.0165, 0.0155, 0.0165),
        n=(10, 10, 10),
        anova_p=math.nan,
        source="test",
    )
    assert paper.anova_from_summary(worst)[1] > 0.9


# --- gravitational moments implied by the estimated rows ----------------------------------------


def test_implied_gravity_moments():
    assert paper.implied_gravity_moment(paper.TABLE2_ESTIMATED) == pytest.approx(
        2.81 * 9.81 * 0.269, rel=1e-15
    )
    assert paper.implied_gravity_moment(paper.TABLE2_ESTIMATED) == pytest.approx(7.4153, abs=1e-4)
    assert paper.implied_gravity_moment(paper.TABLE3_ESTIMATED) == pytest.approx(
        12.80205, abs=1e-5
    )
    assert paper.implied_gravity_moment(paper.TABLE3_ESTIMATED, gravity=10.0) == pytest.approx(
        13.05, rel=1e-12
    )


def test_table_row_as_array_order():
    np.testing.assert_array_equal(paper.TABLE3_ESTIMATED.as_array(), [2.90, 0.45, 0.050])
