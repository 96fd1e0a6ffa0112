"""Exceptions and warnings raised by inertiafit.

Every problem with a user's input is an :class:`InputError` whose message is one line naming
the file (or option), the field and what was expected. The command line prints that line and
exits with status 2; library users can catch the exception.
"""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: a file, option or value that cannot be used as given.

    Parameters
    ----------
    message : str
        One line: where (file or option), which field, what was expected.
    """

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split()))


class ConvergenceWarning(UserWarning):
    """The sampler stopped at its step bound before every convergence criterion was met."""


class TrialWarning(UserWarning):
    """A trial was processed but something about it deserves a look (see its flags)."""
