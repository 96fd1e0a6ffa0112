"""Likelihood of one observable of one condition, from trial values or a reported summary.

Repeated trial values ``y_1..y_n`` with unknown noise ``sigma`` under a Jeffreys prior
``p(sigma) ~ 1/sigma``: integrating ``sigma`` out leaves a Student-t for the true value ``mu``
with ``n - 1`` degrees of freedom, location ``mean(y)`` and scale ``sd(y)/sqrt(n)``. A mean
reported with its SD and ``n`` carries exactly the same information (they are sufficient
statistics), so it gives the same Student-t. A single value with a known standard error (a
quasi-static fit, or a value quoted with its SE) gives a Gaussian.

An error shared by every trial of the observable (the gravity model subtracted from all fast
trials of a condition) does not show in their scatter: it is added as an independent Gaussian
of known SD ``shared_sd`` (:meth:`Observation.with_shared_error`), and the likelihood is the
Student-t convolved with it (:class:`inertiafit.stats.SmearedStudentT`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from inertiafit._checks import (
    check_finite,
    check_non_negative,
    check_number,
    check_positive,
    check_whole,
)
from inertiafit.errors import InputError
from inertiafit.stats import SmearedStudentT

__all__ = ["MIN_RELATIVE_SE", "Observation", "check_resolvable"]

#: Smallest standard error (or SD) of a reported value accepted, as a fraction of the value.
#: No moment is measured to nine digits; far below that the posterior's spread nears float64's
#: resolution (1e-16 of the value: every draw equal, R-hat 0/0), and an SE of 1e-300 overflows
#: the Gaussian's exponent ((mu - value) / se)^2 over the prior boxes: no density is finite.
MIN_RELATIVE_SE = 1e-9


def check_resolvable(spread: float, value: float, where: str) -> float:
    """``spread`` (a standard error or SD of ``value``) if it is no less than that value allows.

    At least :data:`MIN_RELATIVE_SE` of ``|value|``.

    Parameters
    ----------
    spread : float
        The standard error or SD (positive, checked already).
    value : float
        The value it belongs to.
    where : str
        The argument's name, which starts the message (``inertia_se``).

    Raises
    ------
    InputError
        One line naming ``where``, the least SE accepted and the value given.
    """
    floor = MIN_RELATIVE_SE * abs(value)
    if not spread >= floor:
        raise InputError(
            f"{where}: expected at least {floor:.3g} ({MIN_RELATIVE_SE:g} of the value "
            f"{value:.6g}), got {spread:.3g}: no measurement is that precise, and the "
            "posterior density cannot be evaluated"
        )
    return spread


@functools.lru_cache(maxsize=256)
def _isf(q: float, df: float) -> float:
    """Upper ``q`` quantile of a Student-t with ``df`` degrees of freedom (``inf``: Gaussian)."""
    from scipy import stats

    return float(stats.norm.isf(q) if math.isinf(df) else stats.t.isf(q, df))


@dataclass(frozen=True)
class Observation:
    """Evidence about the true value ``mu`` of one observable.

    Attributes
    ----------
    center : float
        Location: the mean of the values (same unit as the observable).
    scale : float
        Standard error of the mean, ``sd/sqrt(n)``, or the given standard error.
    df : float
        Degrees of freedom of the Student-t; ``inf`` for a Gaussian.
    n : int
        Number of trials behind the value (1 for a single value with its SE).
    values : tuple of float
        The trial values when they were given one by one, else empty.
    shared_sd : float
        SD of a Gaussian error common to every trial (0: none), added to the Student-t.
    """

    center: float
    scale: float
    df: float
    n: int
    values: tuple[float, ...] = ()
    shared_sd: float = 0.0

    def __post_init__(self) -> None:
        # A zero or infinite scale, or a df <= 0, makes every density nan or infinite.
        object.__setattr__(self, "center", check_finite(self.center, "Observation: center"))
        object.__setattr__(self, "scale", check_positive(self.scale, "Observation: scale"))
        df = check_number(self.df, "Observation: df")
        if not df > 0:  # inf (a Gaussian) allowed; nan refused
            raise InputError(f"Observation: df: must be positive (or inf), got {self.df!r}")
        object.__setattr__(self, "df", df)
        object.__setattr__(self, "n", check_whole(self.n, "Observation: n", 1))
        object.__setattr__(
            self, "shared_sd", check_non_negative(self.shared_sd, "Observation: shared_sd")
        )

    @classmethod
    def from_values(cls, values: Sequence[float], *, se: float | None = None, where="values"):
        """Evidence from trial values; a single value needs its standard error ``se``."""
        vals = [check_positive(v, f"{where}[{i}]") for i, v in enumerate(values)]
        if not vals:
            raise InputError(f"{where}: no values given")
        if len(vals) == 1:
            if se is None:
                raise InputError(
                    f"{where}: one value needs its standard error (or give its SD and n, "
                    "or the repeated trial values)"
                )
            return cls.from_mean_se(vals[0], se, where=where)
        if se is not None:
            raise InputError(f"{where}: give repeated values or one value with its SE, not both")
        arr = np.asarray(vals)
        sd = float(arr.std(ddof=1))
        if sd == 0:
            raise InputError(
                f"{where}: the {len(vals)} values are identical; their spread is zero"
            )
        return cls(
            float(arr.mean()), sd / math.sqrt(len(vals)), len(vals) - 1.0, len(vals), tuple(vals)
        )

    @classmethod
    def from_mean_se(cls, mean: float, se: float, *, where="value"):
        """A single value with a known standard error: a Gaussian."""
        return cls(
            check_positive(mean, where),
            check_positive(se, f"{where} standard error"),
            math.inf,
            1,
        )

    @classmethod
    def from_mean_sd(cls, mean: float, sd: float, n: int, *, where="value"):
        """A mean of ``n`` trials with their SD: the same Student-t as the trial values."""
        m = check_positive(mean, where)
        s = check_positive(sd, f"{where} SD")
        if isinstance(n, bool) or float(n) != int(n) or int(n) < 2:
            raise InputError(f"{where}: number of trials n must be an integer >= 2, got {n!r}")
        n = int(n)
        return cls(m, s / math.sqrt(n), n - 1.0, n)

    def with_shared_error(self, sd: float) -> Observation:
        """The same evidence with a Gaussian error of SD ``sd`` common to all its trials."""
        return dataclasses.replace(self, shared_sd=check_non_negative(sd, "shared error"))

    def scaled(self, factor: float) -> Observation:
        """The evidence with every scale (``scale``, ``shared_sd``) multiplied by ``factor``."""
        return dataclasses.replace(
            self, scale=self.scale * factor, shared_sd=self.shared_sd * factor
        )

    @cached_property
    def density(self) -> SmearedStudentT:
        """The likelihood as a distribution of the observed value around ``mu``."""
        return SmearedStudentT(self.center, self.scale, self.df, self.shared_sd)

    @property
    def total_scale(self) -> float:
        """``sqrt(scale^2 + shared_sd^2)``."""
        return math.hypot(self.scale, self.shared_sd)

    @property
    def is_gaussian(self) -> bool:
        """Whether the likelihood is Gaussian (a value with a known SE)."""
        return math.isinf(self.df)

    def logpdf(self, mu):
        """Log-likelihood of true values ``mu`` (array), normalised as a density in ``mu``.

        The Student-t (or Gaussian) density, convolved with the shared error's Gaussian
        (:class:`inertiafit.stats.SmearedStudentT`; symmetric, so the same in ``mu``).
        """
        return self.density.logpdf(mu)

    def draws(self, size: tuple[int, ...], rng: np.random.Generator) -> np.ndarray:
        """Draws of ``mu`` from the likelihood taken as a density in ``mu``."""
        return self.density.draws(size, rng)

    def quantile_halfwidth(self, tail: float = 1e-4) -> float:
        """Half-width around ``center`` that holds all but ``tail`` of the likelihood's mass."""
        normal = _isf(tail / 2, math.inf)
        shared = normal * self.shared_sd
        return _isf(tail / 2, self.df) * self.scale + shared

    def describe(self, unit: str = "") -> str:
        """Short text such as ``0.216 +- 0.0031 kg m^2 (Student-t, 30 trials)``."""
        kind = "Gaussian" if self.is_gaussian else f"Student-t, {self.n} trials"
        if self.shared_sd:
            kind += f", shared error ± {self.shared_sd:.2g}"
        return f"{self.center:.4g} ± {self.scale:.2g} {unit} ({kind})".replace("  ", " ")
