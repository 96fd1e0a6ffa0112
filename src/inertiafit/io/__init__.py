"""Reading trials: dynamometer files and the study manifest into SI-unit Trial datasets.

- :func:`read_trial` reads one file with a registered reader (``csv``, ``biodex``, ``humac``,
  ``analog``); :func:`register_reader` adds a format.
- :func:`make_trial` builds and checks a Trial (``xarray.Dataset``: coordinate ``time`` in s;
  ``angle`` rad, ``velocity`` rad/s, ``torque`` N m; attrs ``source``, ``sampling_rate``,
  ``format``).
- :func:`load_study` parses a study manifest into a :class:`Study` of :class:`BodySpec` and
  :class:`TrialSpec`, with its :class:`Calibration` and a
  :class:`~inertiafit.mounting.Mounting` per condition (:attr:`Study.mountings`);
  :meth:`Study.read` reads one of its trials.

Units are converted to SI once, here (:mod:`inertiafit.io.units`). The formats are described
in ``docs/formats.md``.
"""

from __future__ import annotations

from inertiafit.io.manifest import (
    BodySpec,
    Calibration,
    Study,
    TrialSpec,
    load_study,
    read_trial_spec,
)
from inertiafit.io.readers import available_formats, read_trial, reader_options, register_reader
from inertiafit.io.trial import make_trial
from inertiafit.io.units import FT_LBF, IN_LBF, SI_UNITS, to_si, unit_factor

__all__ = [
    "FT_LBF",
    "IN_LBF",
    "SI_UNITS",
    "BodySpec",
    "Calibration",
    "Study",
    "TrialSpec",
    "available_formats",
    "load_study",
    "make_trial",
    "read_trial",
    "read_trial_spec",
    "reader_options",
    "register_reader",
    "to_si",
    "unit_factor",
]
