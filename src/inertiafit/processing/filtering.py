"""Zero-lag low-pass filtering of torque and velocity, and the angular acceleration.

Torque and velocity go through the same Butterworth low-pass filter, run forwards and
backwards (:func:`scipy.signal.sosfiltfilt`): no phase lag between the channels, and the
effective order is twice the design order (a 2nd-order design filters like a 4th-order one, with
the -3 dB point of the pair a little below the design cut-off, at 0.80 x cut-off for order 2).
The default, 2nd order at 20 Hz, is what studies of 100 Hz and 1 kHz dynamometer data use
(``docs/processing.md``).

The angular acceleration is the time derivative of the *filtered velocity*, not the second
derivative of the angle: the angle is quantised (0.1 deg or 1/16 deg), and differentiating a
staircase twice turns each step into a spike of about ``step * rate^2`` (1700 rad/s^2 for
0.1 deg at 1 kHz), while the velocity channel is measured directly and needs one derivative.
The derivative is spectral (:func:`derivative`): exact for the band-limited filtered
velocity, so the acceleration sees the same filter as the torque and nothing more. A central
difference (``numpy.gradient``) also averages the derivative over two sample periods, which the
torque is not: at 100 Hz that smooths the ramp's corners in the acceleration only, a bias of
+0.8 to +1.0 % on the inertia (``docs/processing.md``, "Processing bias").
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy import fft, signal

from inertiafit.errors import InputError

__all__ = [
    "CUTOFF",
    "MIN_PERIODS",
    "ORDER",
    "derivative",
    "design",
    "differentiator",
    "even_step",
    "lowpass",
    "lowpass_array",
    "lowpass_arrays",
    "lowpass_rows",
    "sampling_rate",
    "source_of",
    "spectral_derivative",
]

#: Default cut-off (Hz) and design order of the low-pass filter.
CUTOFF = 20.0
ORDER = 2
#: A trial must span at least this many periods of the cut-off to be filtered meaningfully.
MIN_PERIODS = 3.0


def source_of(trial: xr.Dataset) -> str:
    """The trial's file name for messages (``attrs["source"]``, else ``"<trial>"``)."""
    return str(trial.attrs.get("source", "<trial>"))


def sampling_rate(trial: xr.Dataset) -> float:
    """Sampling rate (Hz) from the median step of the ``time`` coordinate.

    Raises
    ------
    InputError
        If the trial has fewer than two samples or a non-increasing time.
    """
    t = np.asarray(trial.variables["time"].values, dtype=np.float64)
    if t.size < 2:
        raise InputError(f"{source_of(trial)}: time has {t.size} sample(s); need a recording")
    step = float(np.median(np.diff(t)))
    if not step > 0:
        raise InputError(f"{source_of(trial)}: time must be strictly increasing")
    return 1.0 / step


def design(
    rate: float, *, cutoff: float = CUTOFF, order: object = ORDER, source: str = ""
) -> NDArray:
    """Second-order sections of the Butterworth low-pass filter.

    Parameters
    ----------
    rate : float
        Sampling rate (Hz).
    cutoff : float
        Cut-off frequency (Hz) of one pass; must lie in ``(0, rate / 2)``.
    order : int
        Design order of one pass (the zero-lag filter has twice this order).
    source : str
        File named in errors.

    Returns
    -------
    ndarray[nsections, 6]
        The filter in ``sos`` form.

    Raises
    ------
    InputError
        If the cut-off is not below the Nyquist frequency or not positive, or the order is
        not a positive integer.
    """
    nyquist = rate / 2.0
    where = f"{source}: " if source else ""
    if not (isinstance(order, int | np.integer) and order >= 1):
        raise InputError(f"{where}filter order: expected a positive integer, got {order!r}")
    if not (math.isfinite(cutoff) and cutoff > 0):
        raise InputError(f"{where}filter cutoff: expected a positive frequency, got {cutoff!r}")
    if cutoff >= nyquist and cutoff == CUTOFF:
        # No manifest key or command-line option sets the cut-off: the recording's rate is what
        # a user can change (a library caller may pass another ``cutoff``).
        raise InputError(
            f"{where}sampling rate: {rate:g} Hz is too low for the {cutoff:g} Hz low-pass filter "
            f"(its Nyquist frequency {nyquist:g} Hz must lie above the cut-off): record at more "
            f"than {2 * cutoff:g} Hz; the cut-off is fixed for manifests and the command line "
            "(from Python, process_study's cutoff argument sets it)"
        )
    if cutoff >= nyquist:
        raise InputError(
            f"{where}filter cutoff: {cutoff:g} Hz is at or above the Nyquist frequency "
            f"{nyquist:g} Hz of this {rate:g} Hz recording; choose a cut-off below {nyquist:g} Hz"
        )
    return _butter(int(order), float(cutoff), float(rate)).copy()


@functools.lru_cache(maxsize=64)
def _butter(order: int, cutoff: float, rate: float) -> NDArray:
    # A study designs the same filter for every trial; design it once.
    return signal.butter(order, cutoff, btype="low", fs=rate, output="sos")


@functools.lru_cache(maxsize=64)
def _steady_state(order: int, cutoff: float, rate: float) -> NDArray:
    # The filter's step-response state (sosfilt_zi): it solves a linear system per section,
    # which cost more than filtering a fast trial's four channels.
    zi = signal.sosfilt_zi(_butter(order, cutoff, rate))
    zi.flags.writeable = False  # shared by every call
    return zi


def _filtfilt(sos: NDArray, zi: NDArray, x: NDArray, padlen: int) -> NDArray:
    """``scipy.signal.sosfiltfilt(sos, x, axis=-1, padlen=padlen)``, ``zi`` given, ``padlen > 0``.

    The same steps on the same numbers (odd extension by ``padlen``, forwards from the
    steady state of the first sample, backwards from that of the last, the extension cut
    off), so the same result to the last bit and the same memory layout (a reversed view);
    the filter's steady state ``zi = sosfilt_zi(sos)`` is computed once per design
    (:func:`_steady_state`) instead of once per call.
    """
    shape = [1] * x.ndim
    shape[-1] = 2
    state = zi.reshape([len(sos), *shape])
    ext = np.concatenate(
        (
            2 * x[..., :1] - x[..., padlen:0:-1],
            x,
            2 * x[..., -1:] - x[..., -2 : -(padlen + 2) : -1],
        ),
        axis=-1,
    )
    y, _ = signal.sosfilt(sos, ext, axis=-1, zi=state * ext[..., :1])
    y, _ = signal.sosfilt(sos, y[..., ::-1], axis=-1, zi=state * y[..., -1:])
    return y[..., ::-1][..., padlen:-padlen]


def lowpass_array(
    x: ArrayLike, rate: float, *, cutoff: float = CUTOFF, order: int = ORDER, source: str = ""
) -> NDArray:
    """Zero-lag Butterworth low-pass of a 1-D signal (numpy core of :func:`lowpass`).

    Parameters
    ----------
    x : array_like[nsamples]
        Signal sampled at ``rate``.
    rate, cutoff, order, source
        See :func:`design`.

    Returns
    -------
    ndarray[nsamples]
        The filtered signal.

    Raises
    ------
    InputError
        See :func:`design`; or if the signal is shorter than :data:`MIN_PERIODS` periods of
        the cut-off (or than the filter's edge padding).
    """
    x = np.asarray(x, dtype=np.float64)
    return lowpass_rows(x, rate, cutoff=cutoff, order=order, source=source)


def lowpass_rows(
    rows: ArrayLike, rate: float, *, cutoff: float = CUTOFF, order: int = ORDER, source: str = ""
) -> NDArray:
    """:func:`lowpass_array` of every row of a 2-D array (or of a 1-D signal), in one pass.

    The steps of one :func:`scipy.signal.sosfiltfilt` call over the last axis, with the
    filter's set-up done once per design (:func:`_filtfilt`): each row gets exactly the
    numbers a call of its own gives, at a ninth of the cost for four rows of a fast trial
    (the call's set-up, not the filtering, is most of a short trial's time).

    Parameters
    ----------
    rows : array_like[..., nsamples]
        Signals sampled at ``rate``, one per row.
    rate, cutoff, order, source
        See :func:`design`.

    Returns
    -------
    ndarray[..., nsamples]
        The filtered rows.

    Raises
    ------
    InputError
        As :func:`lowpass_array`.
    """
    sos = design(rate, cutoff=cutoff, order=order, source=source)
    x = np.asarray(rows, dtype=np.float64)
    padlen = 3 * (2 * len(sos) + 1)
    needed = max(padlen + 1, math.ceil(MIN_PERIODS * rate / cutoff))
    if x.shape[-1] < needed:
        where = f"{source}: " if source else ""
        raise InputError(
            f"{where}trial too short: {x.shape[-1]} samples; filtering at {cutoff:g} Hz needs "
            f"at least {needed} samples ({needed / rate:g} s at {rate:g} Hz)"
        )
    return _filtfilt(sos, _steady_state(int(order), float(cutoff), float(rate)), x, padlen)


def derivative(x: ArrayLike, time: ArrayLike) -> NDArray:
    """Time derivative of a smooth signal, spectrally.

    The signal less the straight line through its ends is extended to an odd periodic one
    (continuous, with a continuous derivative) and differentiated by FFT (``i omega``); the
    line's slope is added back. For a band-limited signal (a low-passed channel) this is exact
    up to the filter's leak above the Nyquist frequency, where a central difference
    (``numpy.gradient``) multiplies each frequency by ``sin(omega dt) / (omega dt)`` (0.76 at
    20 Hz for 100 Hz samples). Samples that are not evenly spaced (steps differing by more than
    0.1 %) fall back to ``numpy.gradient`` on ``time``.

    Parameters
    ----------
    x : array_like[nsamples]
        The signal.
    time : array_like[nsamples]
        Its sample times (s), increasing.

    Returns
    -------
    ndarray[nsamples]
        ``dx/dt``.
    """
    return differentiator(time)(x)


def differentiator(time: ArrayLike) -> Callable[[ArrayLike], NDArray]:
    """:func:`derivative` on one time line, whose steps are checked once.

    For a caller that differentiates several signals sampled at ``time``: spectrally
    (:func:`spectral_derivative`) when the steps are even (:func:`even_step`), else
    ``numpy.gradient``.
    """
    t = np.asarray(time, dtype=np.float64)
    step = even_step(t)
    if step is None:
        return lambda x: np.gradient(np.asarray(x, dtype=np.float64), t)
    return lambda x: spectral_derivative(x, step)


def even_step(time: ArrayLike) -> float | None:
    """The step (s) of evenly spaced samples, ``None`` when they are not.

    Evenly spaced: at least four samples, every step within 0.1 % of the median step (which
    is returned). :func:`derivative` differentiates spectrally only then.
    """
    t = np.asarray(time, dtype=np.float64)
    if t.size < 4:
        return None
    steps = np.diff(t)
    step = float(np.median(steps))
    if not np.allclose(steps, step, rtol=1e-3, atol=0.0):
        return None
    return step


def spectral_derivative(x: ArrayLike, step: float) -> NDArray:
    """:func:`derivative` of a signal sampled every ``step`` seconds (:func:`even_step`)."""
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    slope = (x[-1] - x[0]) / (n - 1)
    rest = x - x[0] - slope * np.arange(n)
    odd = np.concatenate([rest, -rest[-2:0:-1]])
    spectrum = fft.rfft(odd)
    spectrum *= 2j * np.pi * fft.rfftfreq(odd.size, step)
    if odd.size % 2 == 0:
        spectrum[-1] = 0.0  # the Nyquist term's derivative has no sign: leave it out
    return fft.irfft(spectrum, odd.size)[:n] + slope / step


def lowpass(trial: xr.Dataset, *, cutoff: float = CUTOFF, order: int = ORDER) -> xr.Dataset:
    """Filter torque and velocity identically and add the angular acceleration.

    Parameters
    ----------
    trial : xarray.Dataset
        A Trial (``time`` s, ``angle`` rad, ``velocity`` rad/s, ``torque`` N m).
    cutoff : float
        Cut-off (Hz) of each pass of the zero-lag Butterworth filter.
    order : int
        Design order (the forward-backward filter has twice this order).

    Returns
    -------
    xarray.Dataset
        A copy with ``torque`` and ``velocity`` filtered, a new variable ``acceleration``
        (rad/s^2, the time derivative of the filtered velocity, :func:`derivative`), the angle
        untouched, and attrs ``filter_cutoff`` (Hz) and ``filter_order``.

    Raises
    ------
    InputError
        If the cut-off is at or above the Nyquist frequency, or the trial is too short.
    """
    source = source_of(trial)
    rate = sampling_rate(trial)
    torque, velocity, alpha = lowpass_arrays(
        trial["time"].values,
        trial["torque"].values,
        trial["velocity"].values,
        rate,
        cutoff=cutoff,
        order=order,
        source=source,
    )
    # One Dataset built from its variables: copying the trial and assigning three variables
    # costs ten times the filtering (xarray aligns every assignment).
    filtered = {"torque": torque, "velocity": velocity}
    data_vars = {
        name: (
            array.variable.copy(deep=False, data=filtered[name])
            if name in filtered
            else array.variable
        )
        for name, array in trial.data_vars.items()
    }
    data_vars["acceleration"] = xr.Variable(
        "time",
        alpha,
        {"units": "rad/s^2", "long_name": "angular acceleration (filtered velocity)"},
    )
    attrs = {**trial.attrs, "filter_cutoff": float(cutoff), "filter_order": int(order)}
    return xr.Dataset(data_vars, coords=trial.coords, attrs=attrs)


def lowpass_arrays(
    time: ArrayLike,
    torque: ArrayLike,
    velocity: ArrayLike,
    rate: float,
    *,
    cutoff: float = CUTOFF,
    order: int = ORDER,
    source: str = "",
) -> tuple[NDArray, NDArray, NDArray]:
    """Filtered torque and velocity and the acceleration (numpy core of :func:`lowpass`).

    Parameters
    ----------
    time : array_like[nsamples]
        Sample times (s).
    torque, velocity : array_like[nsamples]
        Raw channels (N m, rad/s).
    rate, cutoff, order, source
        See :func:`design`.

    Returns
    -------
    torque, velocity, acceleration : ndarray[nsamples]
        Filtered torque and velocity, and the :func:`derivative` of the filtered velocity
        (rad/s^2).

    Raises
    ------
    InputError
        See :func:`lowpass_array`.
    """
    torque_f, velocity_f = lowpass_rows(
        np.stack([np.asarray(torque, dtype=np.float64), np.asarray(velocity, dtype=np.float64)]),
        rate,
        cutoff=cutoff,
        order=order,
        source=source,
    )
    return torque_f, velocity_f, derivative(velocity_f, time)
