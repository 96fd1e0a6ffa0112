"""Synthetic dynamometer trials and studies with a known truth.

Every trial follows the rigid-body model of ``docs/method.md``::

    tau(t) = I alpha(t) + M_g sin(theta(t) + phi) + c

sampled at 1 kHz by default, with the imperfections of a real recording: a trapezoidal velocity
profile (uniform acceleration up to the preset speed, an optional small isokinetic overshoot,
uniform deceleration), a small servo ripple on the velocity, Gaussian torque and velocity
noise, a slowly drifting torque disturbance, an angle quantised like a device's encoder, a
constant offset ``c`` and a phase ``phi`` between the device's angle zero and the gravity
vertical. ``docs/processing.md`` ("Simulated trials") gives the numbers.

- :func:`simulate_trial` makes one Trial (``xarray.Dataset``, SI units);
- :func:`simulate_study` writes a whole study (CSV files and a ``study.toml`` manifest);
- :func:`paper_study` writes the experiment of Son et al. (62 trials);
- :func:`simulate_living_study` writes a study of a living limb (a joint's passive elastic
  moment, damping and hysteresis; postures; rest trials), its joint's truth a
  :class:`PassiveTruth`;
- both write EMG channels with ``emg=EmgSimulation(...)``: rest noise and stretch reflexes
  (burst and torque) in chosen fast trials (:mod:`~inertiafit.simulate.emg`).

Seeding: every function takes a seed or a :class:`numpy.random.Generator`; the same seed gives
the same files, byte for byte. :func:`simulate_study` gives each trial its own child seed
(:class:`numpy.random.SeedSequence`), so adding a speed does not change the other trials.

The package's modules: :mod:`~inertiafit.simulate.signals` (the signal model,
:class:`Noise`, :class:`Motion`, :class:`Body`, :func:`simulate_trial`),
:mod:`~inertiafit.simulate.files` (the hand-written CSV and TOML),
:mod:`~inertiafit.simulate.study` (:func:`simulate_study` and its ``truth.toml``),
:mod:`~inertiafit.simulate.living` (:func:`simulate_living_study`) and
:mod:`~inertiafit.simulate.paper` (:data:`PAPER_TRUTH`, :data:`PAPER_PRIORS`,
:func:`paper_study`).
"""

from __future__ import annotations

from inertiafit.io.units import FT_LBF
from inertiafit.simulate.emg import EmgSimulation
from inertiafit.simulate.living import PassiveTruth, rigid_view, simulate_living_study
from inertiafit.simulate.paper import PAPER_PRIORS, PAPER_TRUTH, paper_study
from inertiafit.simulate.signals import KINDS, Body, Motion, Noise, simulate_trial
from inertiafit.simulate.study import simulate_study

__all__ = [
    "FT_LBF",
    "KINDS",
    "PAPER_PRIORS",
    "PAPER_TRUTH",
    "Body",
    "EmgSimulation",
    "Motion",
    "Noise",
    "PassiveTruth",
    "paper_study",
    "rigid_view",
    "simulate_living_study",
    "simulate_study",
    "simulate_trial",
]
