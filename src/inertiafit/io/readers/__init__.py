"""Readers that turn a trial file into a Trial dataset, behind one interface.

Every reader is a function registered under a format name::

    @register_reader("myformat")
    def read_myformat(path, *, columns=None, units=None, calibration=None, my_option=1):
        ...
        return make_trial(time, angle, velocity, torque, source=str(path), format="myformat")

and :func:`read_trial` dispatches on ``format``. A reader receives the ``columns``, ``units`` and
``calibration`` mappings of the manifest (or ``None``) and its own keyword options; it converts
every channel to SI once (with :mod:`inertiafit.io.units`) and builds the Trial with
:func:`~inertiafit.io.trial.make_trial`. Formats shipped: ``csv``, ``biodex``, ``humac``,
``analog``, ``c3d`` (binary), ``vicon`` and ``isomed``; their layouts are described in
``docs/formats.md`` and ``docs/devices/``.

The package's modules:

- :mod:`~inertiafit.io.readers.registry`: :func:`register_reader`, :func:`read_trial`,
  :func:`available_formats`, :func:`binary_formats`, :func:`reader_options` and the registry
  ``READERS``;
- :mod:`~inertiafit.io.readers.validation`: the checks of the ``columns``, ``units`` and
  ``calibration`` tables (also used by the manifest) and the resolution of each channel's unit;
- :mod:`~inertiafit.io.readers.tables`: delimited text through pandas;
- one module per format: :mod:`~inertiafit.io.readers.csv`,
  :mod:`~inertiafit.io.readers.analog`, :mod:`~inertiafit.io.readers.humac`,
  :mod:`~inertiafit.io.readers.biodex`, :mod:`~inertiafit.io.readers.c3d`,
  :mod:`~inertiafit.io.readers.vicon`, :mod:`~inertiafit.io.readers.isomed`. Importing this
  package imports them, which registers the formats.
"""

from __future__ import annotations

from inertiafit.io.readers.registry import (
    Reader,
    available_formats,
    binary_formats,
    read_trial,
    reader_options,
    register_reader,
)
from inertiafit.io.readers.validation import (
    CALIBRATION_KEYS,
    DEFAULT_UNITS,
    check_calibration,
    check_columns,
    check_units,
)

# Importing a format's module registers it. The order is the order of available_formats() and
# of the formats listed in error messages: csv first, as before the split.
# isort: off
from inertiafit.io.readers.csv import read_csv
from inertiafit.io.readers.analog import read_analog
from inertiafit.io.readers.humac import HUMAC_NOT_MEASURED, read_humac
from inertiafit.io.readers.biodex import read_biodex
from inertiafit.io.readers.c3d import read_c3d
from inertiafit.io.readers.vicon import read_vicon
from inertiafit.io.readers.isomed import read_isomed

# isort: on

__all__ = [
    "CALIBRATION_KEYS",
    "DEFAULT_UNITS",
    "HUMAC_NOT_MEASURED",
    "Reader",
    "available_formats",
    "binary_formats",
    "check_calibration",
    "check_columns",
    "check_units",
    "read_analog",
    "read_biodex",
    "read_c3d",
    "read_csv",
    "read_humac",
    "read_isomed",
    "read_trial",
    "read_vicon",
    "reader_options",
    "register_reader",
]
