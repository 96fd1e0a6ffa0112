"""Exceptions and warnings raised by inertiafit.

Every problem with a user's input is an :class:`InputError` whose message is one line naming
the file (or argument), the field and what was expected. The command line prints that line and
exits with status 2; library users can catch the exception.

Every warning inertiafit issues is an :class:`InertiafitWarning`, so a caller can silence or
collect inertiafit's warnings without catching every :class:`UserWarning`. Problems found in a
single trial are not warnings: they travel as ``flags`` in the returned estimate (and as lines
in a study's ``warnings``), one channel.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = [
    "ConvergenceWarning",
    "InertiafitWarning",
    "InputError",
    "PriorDataConflictWarning",
    "StudyRefused",
]


class InputError(ValueError):
    """Bad input: a file, argument or value that cannot be used as given.

    Parameters
    ----------
    message : str
        One line: where (file or argument), which field, what was expected. Library functions
        name their own arguments (``hdi_prob``); the command line shows them as its options
        (``--hdi-prob``).
    """

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split()))


class StudyRefused(InputError):
    """A study that cannot go on to its posterior: the one-line reason and what was gathered.

    Parameters
    ----------
    message : str
        One line, as for :class:`InputError`; it names the trials at fault.
    refused : mapping of str to str, optional
        The trials that caused the refusal: file (as in ``trials.csv``) -> the reason, one line.
    table : pandas.DataFrame, optional
        The per-trial table gathered so far (``diagnostics.csv``): a row per trial of the
        manifest, the columns of ``trials.csv`` and ``cause``; ``status`` ``"refused"`` for
        the trials in ``refused``, ``"not reached"`` for those the study stopped before.
    """

    def __init__(
        self, message: str, *, refused: Mapping[str, str] | None = None, table: Any = None
    ) -> None:
        super().__init__(message)
        self.refused: dict[str, str] = dict(refused or {})
        self.table = table


class InertiafitWarning(UserWarning):
    """Base class of every warning inertiafit issues."""


class ConvergenceWarning(InertiafitWarning):
    """The sampler stopped at its step bound before every convergence criterion was met."""


class PriorDataConflictWarning(InertiafitWarning):
    """A body's data lie where its prior puts almost no mass (a prior-data conflict).

    One line naming the body and the quantity (:mod:`inertiafit.posterior.conflict`).
    """
