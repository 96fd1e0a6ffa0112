"""Reading trials: dynamometer files and the study manifest into SI-unit Trial datasets.

- :func:`read_trial` reads one file with a registered reader (``csv``, ``biodex``, ``humac``,
  ``analog``); :func:`register_reader` adds a format.
- :func:`make_trial` builds and checks a Trial (``xarray.Dataset``: coordinate ``time`` in s;
  ``angle`` rad, ``velocity`` rad/s, ``torque`` N m; attrs ``source``, ``sampling_rate``,
  ``format``).
- :func:`load_study` parses a study manifest into a :class:`Study` of :class:`BodySpec` and
  :class:`TrialSpec`, with its :class:`Calibration` and a
  :class:`~inertiafit.mounting.Mounting` per condition (:attr:`Study.mountings`);
  :meth:`Study.read` reads one of its trials. A living body's joint is a
  :class:`PassivePrior` (:attr:`Study.passive`); each setup of a trial is a :class:`Posture`.
- :func:`shipped_dirs` finds the shipped ``priors/`` folder; :func:`load_passive_prior` reads a
  joint's passive prior file from it.

Units are converted to SI once, here (:mod:`inertiafit.io.units`). The formats are described
in ``docs/formats.md``.
"""

from __future__ import annotations

from inertiafit.io.manifest import (
    BodySpec,
    Calibration,
    PassivePrior,
    Posture,
    Study,
    TrialSpec,
    load_study,
    read_trial_spec,
)
from inertiafit.io.readers import available_formats, read_trial, reader_options, register_reader
from inertiafit.io.shipped import load_passive_prior, shipped_dirs
from inertiafit.io.trial import make_trial
from inertiafit.io.units import FT_LBF, IN_LBF, SI_UNITS, to_si, unit_factor

__all__ = [
    "FT_LBF",
    "IN_LBF",
    "SI_UNITS",
    "BodySpec",
    "Calibration",
    "PassivePrior",
    "Posture",
    "Study",
    "TrialSpec",
    "available_formats",
    "load_passive_prior",
    "load_study",
    "make_trial",
    "read_trial",
    "read_trial_spec",
    "reader_options",
    "register_reader",
    "shipped_dirs",
    "to_si",
    "unit_factor",
]
