"""Per-trial processing: filter, gravity model, acceleration window, inertia, speed effect.

The steps, in the order a study runs them (``docs/processing.md`` explains each choice):

1. :func:`lowpass`: zero-lag Butterworth low-pass of torque and velocity (2nd order, 20 Hz)
   and the angular acceleration as the derivative of the filtered velocity;
2. :func:`fit_gravity`: ``M_g``, ``phi`` and the offset of a condition from its quasi-static
   trial, with standard errors corrected for autocorrelated residuals (:class:`GravityFit`);
3. :func:`find_window`: the uniform-acceleration window of a fast trial
   (:class:`AccelerationWindow`), or a manual one;
4. :func:`estimate_inertia`: the inertia of a fast trial by least squares and by the paper's
   frame mean (:class:`InertiaEstimate`), after removing the lag of the torque channel behind
   the velocity (:func:`estimate_lag`, :class:`LagEstimate`, or fixed by the manifest), with
   its sensitivity to the gravity model and standard errors from the torque's noise model
   (:class:`TorqueNoise`: white noise and a drift);
5. :func:`speed_effect`: per-speed summaries, one-way ANOVA and Tukey HSD per condition.

:func:`emg_activity` finds the stretches of a trial where a muscle's EMG is active against its
rest level (band-pass, RMS envelope :func:`emg_envelope`, rest mean + k SD held for a minimum
duration).

:func:`process_study` runs steps 1-4 over every trial of a study manifest
(:class:`ProcessedStudy`: a row per trial, the gravity model per condition, the filtered traces).
Problems found in a trial travel as ``flags`` in what these functions return, never as warnings.
"""

from __future__ import annotations

from inertiafit.processing.emg import emg_activity, emg_envelope, mvc_levels
from inertiafit.processing.filtering import lowpass, lowpass_array, sampling_rate
from inertiafit.processing.gravity import (
    GravityFit,
    TorqueNoise,
    fit_gravity,
    fit_gravity_arrays,
)
from inertiafit.processing.inertia import InertiaEstimate, estimate_inertia
from inertiafit.processing.lag import LagEstimate, estimate_lag
from inertiafit.processing.speed import speed_effect
from inertiafit.processing.study import ProcessedStudy, process_study
from inertiafit.processing.window import AccelerationWindow, find_window

__all__ = [
    "AccelerationWindow",
    "GravityFit",
    "InertiaEstimate",
    "LagEstimate",
    "ProcessedStudy",
    "TorqueNoise",
    "emg_activity",
    "emg_envelope",
    "estimate_inertia",
    "estimate_lag",
    "find_window",
    "fit_gravity",
    "fit_gravity_arrays",
    "lowpass",
    "lowpass_array",
    "mvc_levels",
    "process_study",
    "sampling_rate",
    "speed_effect",
]
