"""
A trial format of your own
==========================

Our (made-up) lab software writes each trial as plain text: two comment lines, then one sample
per line with time in ms, angle in degrees, velocity in °/s and torque in ft·lbf, separated by
spaces. This script registers a reader for it with :func:`inertiafit.io.register_reader`,
writes such a file from a simulated trial, reads it back in SI units, and runs the gravity and
inertia steps on it. The full contract is in the docs' "Trial files and the study manifest".
"""

from pathlib import Path

import numpy as np

from inertiafit.errors import InputError
from inertiafit.io import FT_LBF, make_trial, read_trial, register_reader, to_si
from inertiafit.processing import estimate_inertia, fit_gravity
from inertiafit.simulate import simulate_trial

OUT = Path("examples-output") / "custom-format"
OUT.mkdir(parents=True, exist_ok=True)

# %%
# The reader
# ----------
# One function: read the file, convert each channel to SI once with ``to_si``, hand the arrays
# to ``make_trial`` (which checks finiteness, increasing time, gaps and length). Any problem is
# one ``InputError`` line naming the file and what was expected.

CHANNELS = ("time", "angle", "velocity", "torque")


@register_reader("labtext")
def read_labtext(path, *, columns=None, units=None, calibration=None, skip=2):
    """Lab text export: ``skip`` comment lines, then time, angle, velocity, torque columns."""
    if columns:
        raise InputError(f"{path}: columns: the labtext format has no column names to map")
    if calibration:
        raise InputError(f"{path}: calibration: the labtext format holds calibrated values")
    try:
        table = np.loadtxt(path, skiprows=skip, ndmin=2)
    except ValueError as err:
        raise InputError(f"{path}: not a labtext export ({err})") from None
    if table.shape[1] != len(CHANNELS):
        raise InputError(f"{path}: expected {len(CHANNELS)} columns, found {table.shape[1]}")
    file_units = {"time": "ms", "angle": "deg", "velocity": "deg/s", "torque": "ft*lbf"}
    file_units.update(units or {})
    si = {
        ch: to_si(table[:, i], ch, file_units[ch], where=f"{path}: column {i + 1} ({ch})")
        for i, ch in enumerate(CHANNELS)
    }
    return make_trial(
        si["time"], si["angle"], si["velocity"], si["torque"], source=str(path), format="labtext"
    )


# %%
# Write two trials in that format
# -------------------------------
# A quasi-static trial (1 °/s) and one fast trial (240 °/s) of the paper's attachment, simulated
# with a known truth (``I`` = 0.2052 kg m², ``M_g`` = 6.71 N m), then written the way the lab
# software would: ms, degrees, ft·lbf.

rng = np.random.default_rng(4)
truth = {"inertia": 0.2052, "gravity_moment": 6.71}
files = {}
for kind, speed in (("quasi-static", 1.0), ("fast", 240.0)):
    trial = simulate_trial(**truth, kind=kind, speed_deg_s=speed, rng=rng)
    columns = np.column_stack(
        [
            trial["time"].values * 1000.0,
            np.degrees(trial["angle"].values),
            np.degrees(trial["velocity"].values),
            trial["torque"].values / FT_LBF,
        ]
    )
    path = OUT / f"attachment_{kind}.txt"
    np.savetxt(
        path,
        columns,
        fmt="%.6f",
        header=f"lab export v2, {kind} trial\ntime_ms angle_deg velocity_dps torque_ftlbf",
    )
    files[kind] = path
print(files["fast"].read_text().splitlines()[:4])

# %%
# Read them back
# --------------
# ``read_trial`` finds the reader by its format name; options are passed by keyword. The same
# name works as ``format = "labtext"`` in a study manifest once this module has been imported.

qs = read_trial(files["quasi-static"], format="labtext", skip=2)
fast = read_trial(files["fast"], format="labtext")
print(fast)

# %%
# And process them: the gravity model from the quasi-static trial, the inertia of the fast one.

gravity = fit_gravity(qs)
estimate = estimate_inertia(fast, gravity, speed_deg_s=240.0)
print(
    f"M_g = {gravity.gravity_moment:.3f} ± {gravity.gravity_moment_se:.3f} N m "
    f"(truth {truth['gravity_moment']})"
)
print(
    f"I   = {estimate.inertia:.4f} ± {estimate.inertia_se:.4f} kg m^2 (truth {truth['inertia']})"
)

# %%
# A bad file is one line, not a traceback
# ---------------------------------------

broken = OUT / "broken.txt"
broken.write_text("# header\n# header\n0 10 0\n10 10.1 5\n", encoding="utf-8")
try:
    read_trial(broken, format="labtext")
except InputError as err:
    print(f"InputError: {err}")
