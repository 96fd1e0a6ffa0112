"""The numbers Son et al. report, as documented constants, and the arithmetic done with them.

Source: J. Son et al., "Determination of inertial parameters using a dynamometer" (the method
paper of this project, ``shared/seeds/000_e59c796d604afcc2.txt``). Section and table numbers
below are the paper's. Every value is in SI units (kg, m, kg m^2, N m, m/s^2); speeds in °/s.

What the paper gives and what it does not:

- Section 3.1 gives, per passive speed, the mean ± SD of ten trial values of the moment of
  inertia about the joint, for condition A (attachment alone) and condition B (attachment + 3 kg
  weight), and a one-way ANOVA p-value per condition. No gravitational moments are reported.
- Table 2 (attachment) and Table 3 (weight) give an "ideal" row (geometry and mass marked
  ``*`` as inputs; radius of gyration, CoM distance and inertia computed with Table 1's
  formulas) and an "estimated" row from the multi-start least squares of Eq. (4).
- Section 3.2 gives the weight's inertia ``I_w = 0.594`` kg m^2 "by subtracting the average of
  all I_a values from the average of all I_b values".

Three inconsistencies in the published numbers, kept as printed and exposed by helpers here
(``tests/test_paper.py`` pins each):

1. The means of Section 3.1 give ``I_b - I_a = 0.8227 - 0.2157 = 0.607`` kg m^2, not the
   ``0.594`` of Section 3.2 (which matches Table 3's ideal ``0.595``); see
   :func:`weight_inertia_by_subtraction`.
2. A one-way ANOVA on the printed means, SDs and ``n = 10`` gives ``p ≈ 0.99`` for both
   conditions, not ``0.287`` / ``0.276``; no rounding of the printed values brings it below
   0.9. See :func:`anova_from_summary`.
3. Table 1 prints the square tube's ``d = (A² l − a² l) / m``, a volume per mass; the formula
   only gives an inertia (and Table 2's ``rho = 0.130``) with the density
   ``d = m / (A² l − a² l)``. :func:`square_tube_radius_of_gyration` uses the density.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = [
    "ATTACHMENT_GEOMETRY",
    "ATTACHMENT_INERTIA",
    "ATTACHMENT_WITH_WEIGHT_INERTIA",
    "BOX_SPREAD",
    "GRAVITY",
    "QUASI_STATIC_SPEED",
    "SAMPLING_RATE",
    "SIGNIFICANCE_LEVEL",
    "SPEEDS",
    "TABLE2_ESTIMATED",
    "TABLE2_IDEAL",
    "TABLE3_ESTIMATED",
    "TABLE3_IDEAL",
    "TRIALS_PER_SPEED",
    "WEIGHT_GEOMETRY",
    "WEIGHT_INERTIA",
    "PooledSummary",
    "SpeedSummary",
    "TableRow",
    "anova_from_summary",
    "implied_gravity_moment",
    "pooled",
    "solid_disk_radius_of_gyration",
    "square_tube_radius_of_gyration",
    "weight_inertia_by_subtraction",
    "weight_inertia_standard_error",
]

#: Gravitational acceleration used throughout the paper (m/s^2), Section 2.1.
GRAVITY = 9.81

#: Passive angular speeds of the fast trials (°/s), Section 2.3.
SPEEDS = (240.0, 270.0, 300.0)

#: Fast trials per speed and condition, Section 2.3 ("Ten trials were performed for each speed").
TRIALS_PER_SPEED = 10

#: Sampling rate of the recordings (Hz), Section 2.3.
SAMPLING_RATE = 1000.0

#: Angular speed of the quasi-static passive moves (°/s), Section 2.3.
QUASI_STATIC_SPEED = 1.0

#: Significance level of the speed-effect tests, Section 2.3.
SIGNIFICANCE_LEVEL = 0.05


@dataclass(frozen=True)
class SpeedSummary:
    """Moment of inertia of one condition per passive speed, as the paper reports it.

    Attributes
    ----------
    condition : str
        ``"A"`` (attachment alone) or ``"B"`` (attachment + weight).
    speeds : tuple of float
        Passive speeds (°/s).
    mean, sd : tuple of float
        Mean and sample SD of the trial values at each speed (kg m^2).
    n : tuple of int
        Trials at each speed.
    anova_p : float
        p-value of the one-way ANOVA across speeds that the paper reports.
    source : str
        Where in the paper the numbers are.
    """

    condition: str
    speeds: tuple[float, ...]
    mean: tuple[float, ...]
    sd: tuple[float, ...]
    n: tuple[int, ...]
    anova_p: float
    source: str


#: Condition A, the elbow attachment alone: ``I_a`` per speed (kg m^2), Section 3.1 / Fig. 5a.
ATTACHMENT_INERTIA = SpeedSummary(
    condition="A",
    speeds=SPEEDS,
    mean=(0.216, 0.215, 0.216),
    sd=(0.017, 0.016, 0.017),
    n=(TRIALS_PER_SPEED,) * 3,
    anova_p=0.287,
    source="Son et al., Section 3.1 and Fig. 5a",
)

#: Condition B, attachment + 3 kg weight: ``I_b`` per speed (kg m^2), Section 3.1 / Fig. 5b.
ATTACHMENT_WITH_WEIGHT_INERTIA = SpeedSummary(
    condition="B",
    speeds=SPEEDS,
    mean=(0.821, 0.823, 0.824),
    sd=(0.054, 0.058, 0.053),
    n=(TRIALS_PER_SPEED,) * 3,
    anova_p=0.276,
    source="Son et al., Section 3.1 and Fig. 5b",
)

#: The weight's inertia about the joint as the paper states it (kg m^2), Section 3.2. The
#: printed means give 0.607 instead; see :func:`weight_inertia_by_subtraction`.
WEIGHT_INERTIA = 0.594


@dataclass(frozen=True)
class TableRow:
    """One row of Table 2 or Table 3: a body's inertial parameters.

    Attributes
    ----------
    label : str
        ``"ideal"`` or ``"estimated"``.
    mass : float
        ``m`` (kg).
    com_distance : float
        ``x``, joint to centre of mass (m).
    radius_of_gyration : float
        ``rho``, about the centre of mass (m).
    inertia : float
        ``I`` about the joint (kg m^2), as printed (3 decimals).
    source : str
        Table and row.
    """

    label: str
    mass: float
    com_distance: float
    radius_of_gyration: float
    inertia: float
    source: str

    def as_array(self) -> np.ndarray:
        """``(mass, com_distance, radius_of_gyration)`` as an array of shape ``(3,)``."""
        return np.array([self.mass, self.com_distance, self.radius_of_gyration])


#: Table 2 geometry of the ideal square tube (m); marked ``*`` (inputs) in the paper.
ATTACHMENT_GEOMETRY = {"outer_edge": 0.03, "inner_edge": 0.026, "length": 0.45}

#: Table 2, ideal row: the attachment as a square tube of mass 2.91 kg (``*``, input); rho,
#: x and I computed with Table 1 (``x = length / 2``).
TABLE2_IDEAL = TableRow(
    label="ideal",
    mass=2.91,
    com_distance=0.225,
    radius_of_gyration=0.130,
    inertia=0.197,
    source="Son et al., Table 2, ideal row",
)

#: Table 2, estimated row: the paper's multi-start fmincon answer for the attachment (Eq. (4)).
#: ``rho = 0.065`` is exactly the lower bound ``0.5 * 0.130`` of the optimisation box.
TABLE2_ESTIMATED = TableRow(
    label="estimated",
    mass=2.81,
    com_distance=0.269,
    radius_of_gyration=0.065,
    inertia=0.216,
    source="Son et al., Table 2, estimated row",
)

#: Table 3 geometry of the ideal solid disk (m); marked ``*`` (inputs) in the paper. ``length``
#: is the disk's thickness; the disk sits at 0.45 m from the joint.
WEIGHT_GEOMETRY = {"radius": 0.05, "length": 0.06}

#: Table 3, ideal row: the weight as a solid disk of mass 2.92 kg (``*``, input),
#: ``rho = r / sqrt(2)`` (rounded to 0.035 in print), CoM at 0.45 m.
TABLE3_IDEAL = TableRow(
    label="ideal",
    mass=2.92,
    com_distance=0.45,
    radius_of_gyration=0.035,
    inertia=0.595,
    source="Son et al., Table 3, ideal row",
)

#: Table 3, estimated row: the paper's multi-start fmincon answer for the weight (Eq. (4)).
TABLE3_ESTIMATED = TableRow(
    label="estimated",
    mass=2.90,
    com_distance=0.45,
    radius_of_gyration=0.050,
    inertia=0.594,
    source="Son et al., Table 3, estimated row",
)

#: Half-width of the optimisation box of Eq. (4) relative to the nominal (ideal) values:
#: ``0.5 p0 < p < 1.5 p0``; also the range of the multi-start grid (±50 % in steps of 1 %).
BOX_SPREAD = 0.5


# --- Table 1: ideal models --------------------------------------------------------------------


def square_tube_radius_of_gyration(outer_edge: float, inner_edge: float, length: float) -> float:
    """Radius of gyration (m) of a square tube about a transverse axis through its centre.

    Table 1 of the paper: ``I_cm = d A² l (A² + l²)/12 − d a² l (a² + l²)/12`` for outer edge
    ``A``, inner edge ``a`` and length ``l``; with the density ``d = m / ((A² − a²) l)`` (the
    paper prints its reciprocal) this is ``rho² = I_cm / m = (A² + a² + l²) / 12``, independent
    of the mass.

    Parameters
    ----------
    outer_edge, inner_edge, length : float
        ``A``, ``a``, ``l`` (m), ``0 <= a < A``.

    Returns
    -------
    float
        ``rho`` (m).
    """
    big, small = outer_edge**2, inner_edge**2
    # The tube is the solid A x A cuboid minus the a x a core, both of the same density.
    second_moment = big * (big + length**2) - small * (small + length**2)
    return math.sqrt(second_moment / (12.0 * (big - small)))


def solid_disk_radius_of_gyration(radius: float) -> float:
    """Radius of gyration (m) of a solid disk about its symmetry axis: ``r / sqrt(2)``.

    Table 1 of the paper: ``I_cm = m r² / 2``. The weight's symmetry axis is parallel to the
    dynamometer shaft, so this is the ``rho`` of Table 3.
    """
    return radius / math.sqrt(2.0)


# --- Section 3.1: pooling the per-speed summaries ----------------------------------------------


@dataclass(frozen=True)
class PooledSummary:
    """All trials of one condition taken together.

    Attributes
    ----------
    n : int
        Number of trials (30 in the paper).
    mean : float
        Mean of all trials (kg m^2).
    sd : float
        Sample SD (``ddof=1``) of all trials together (kg m^2), rebuilt exactly from the
        per-speed summaries: within-speed plus between-speed sum of squares over ``n - 1``.
    within_sd : float
        Pooled within-speed SD (kg m^2): ``sqrt(sum((n_i - 1) sd_i²) / (n - k))``, the ANOVA's
        error term; what one would use if the speeds had different true means.
    """

    n: int
    mean: float
    sd: float
    within_sd: float


def pooled(summary: SpeedSummary) -> PooledSummary:
    """Pool a condition's per-speed means and SDs into one sample of all its trials.

    Parameters
    ----------
    summary : SpeedSummary
        E.g. :data:`ATTACHMENT_INERTIA`.

    Returns
    -------
    PooledSummary
        ``n``, mean, SD of all trials together, and the pooled within-speed SD.
    """
    n = np.asarray(summary.n, dtype=float)
    mean = np.asarray(summary.mean, dtype=float)
    sd = np.asarray(summary.sd, dtype=float)
    total = n.sum()
    grand = float(np.sum(n * mean) / total)
    within_ss = float(np.sum((n - 1.0) * sd**2))
    between_ss = float(np.sum(n * (mean - grand) ** 2))
    return PooledSummary(
        n=int(total),
        mean=grand,
        sd=math.sqrt((within_ss + between_ss) / (total - 1.0)),
        within_sd=math.sqrt(within_ss / (total - len(n))),
    )


def anova_from_summary(summary: SpeedSummary) -> tuple[float, float]:
    """One-way ANOVA across speeds computed from the printed means, SDs and ``n``.

    Parameters
    ----------
    summary : SpeedSummary
        Per-speed summaries of one condition.

    Returns
    -------
    F, p : float
        The F statistic with ``(k − 1, n − k)`` degrees of freedom and its p-value. On the
        paper's numbers ``p ≈ 0.99`` for both conditions, not the printed 0.287 / 0.276.
    """
    n = np.asarray(summary.n, dtype=float)
    mean = np.asarray(summary.mean, dtype=float)
    sd = np.asarray(summary.sd, dtype=float)
    k, total = len(n), n.sum()
    grand = np.sum(n * mean) / total
    between = np.sum(n * (mean - grand) ** 2) / (k - 1)
    within = np.sum((n - 1.0) * sd**2) / (total - k)
    f_stat = float(between / within)
    return f_stat, float(stats.f.sf(f_stat, k - 1, total - k))


# --- Section 3.2: the weight by subtraction ---------------------------------------------------


def weight_inertia_by_subtraction() -> float:
    """Weight's inertia about the joint (kg m^2): mean of all ``I_b`` minus mean of all ``I_a``.

    The paper's recipe (Section 3.2) applied to its own Section 3.1 means gives 0.607, not the
    printed :data:`WEIGHT_INERTIA` = 0.594.
    """
    return pooled(ATTACHMENT_WITH_WEIGHT_INERTIA).mean - pooled(ATTACHMENT_INERTIA).mean


def weight_inertia_standard_error() -> float:
    """Give the standard error (kg m^2) of the weight's inertia obtained by subtraction.

    ``sqrt(sd_b² / n_b + sd_a² / n_a)`` with the pooled SDs and ``n = 30`` of each condition
    (:func:`pooled`); the two conditions are independent sets of trials.
    """
    a = pooled(ATTACHMENT_INERTIA)
    b = pooled(ATTACHMENT_WITH_WEIGHT_INERTIA)
    return math.sqrt(b.sd**2 / b.n + a.sd**2 / a.n)


# --- Gravitational moments the paper does not print -------------------------------------------


def implied_gravity_moment(row: TableRow, gravity: float = GRAVITY) -> float:
    """Gravitational moment ``m g x`` (N m) implied by a table row.

    The paper never prints the measured ``M_g``; the estimated rows satisfy ``m x = M_g / g``
    (Eq. (4)), so ``m g x`` of :data:`TABLE2_ESTIMATED` (7.415 N m) and
    :data:`TABLE3_ESTIMATED` (12.802 N m) stand in for them, to the printed rounding.
    """
    return row.mass * gravity * row.com_distance
