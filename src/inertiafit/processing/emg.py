"""Was the muscle relaxed? Active stretches of a trial's EMG against its rest level.

A passive move measures inertia only while the muscles stay quiet: a stretch reflex in the
acceleration window reads as more (or less) inertia. :func:`emg_activity` finds the stretches
where a muscle's EMG rises above its resting level, the way the EMG literature does it:

1. **band-pass**, zero-lag Butterworth (:func:`scipy.signal.sosfiltfilt`, 2nd order run both
   ways), 20-450 Hz: SENIAM (Hermens et al. 2000) recommends a high-pass of 10-20 Hz (motion
   artefacts, cable sway) and a low-pass of about 500 Hz; the upper edge is clipped to
   ``NYQUIST_FRACTION`` of the Nyquist frequency (a 1 kHz recording keeps 450 Hz);
2. **RMS envelope** over a centred window of 50 ms (envelopes of 50-100 ms are common; the
   short end keeps onsets sharp): :func:`emg_envelope`;
3. **threshold** ``rest mean + k SD`` of the envelope with ``k = 3`` (Hodges & Bui 1996, who
   compared 1-3 SD with visual onsets), and, when an MVC trial is given, also
   ``mvc_fraction`` of the MVC's peak envelope (2 %: small involuntary responses of healthy
   people are 2-3 % MVC, Finley et al. 2008);
4. an **active stretch**: the muscle active for at least 10 ms (``min_duration``, the short
   end of the 10-50 ms Hodges & Bui 1996 compared), which is the envelope above the
   threshold for the RMS window plus ``min_duration`` (60 ms with the defaults): the window
   lifts the envelope for its own length around any event, however short, so one spike of
   the noise (a sample at 5-6 SD) lifts a 50 ms RMS for exactly 50 ms and is not activity;
   stretches closer than ``min_duration`` are one.

Every default lives in :class:`inertiafit.io.emg.EmgSettings` (the manifest's ``[emg]``
table); ``docs/processing.md`` cites them.

Timing: the envelope at ``t`` averages ``[t - w/2, t + w/2]``, so a step onset is found up to
``w/2`` early (a large burst) and never later than ``w/2``; an end likewise within ``w/2``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import NDArray
from scipy import signal
from scipy.ndimage import uniform_filter1d

from inertiafit.errors import InputError
from inertiafit.io.emg import EmgSettings, check_emg_band, check_emg_setting
from inertiafit.processing.filtering import sampling_rate, source_of

__all__ = [
    "ACTIVITY_COLUMNS",
    "BAND_ORDER",
    "NYQUIST_FRACTION",
    "emg_activity",
    "emg_envelope",
    "mvc_levels",
    "rest_level",
]

#: Columns of the table :func:`emg_activity` returns, in order.
ACTIVITY_COLUMNS = ("muscle", "start", "end", "peak_ratio")
#: Order of the Butterworth band-pass design (run forwards and backwards: zero lag, the
#: attenuation doubled).
BAND_ORDER = 2
#: The low-pass edge is at most this fraction of the Nyquist frequency.
NYQUIST_FRACTION = 0.95

#: What ``rest`` may be: a span (s), a rest Trial, or a level per muscle (checked at run time).
Rest = Any
#: What ``mvc`` may be: an MVC Trial, several, or each muscle's MVC level (checked at run time).
Mvc = Any


def _emg_of(trial: Any, muscles: Sequence[str] | None, what: str) -> xr.DataArray:
    if not isinstance(trial, xr.Dataset):
        raise InputError(f"{what}: expected a Trial (an xarray Dataset), got {type(trial)}")
    source = source_of(trial)
    if "emg" not in trial:
        raise InputError(
            f"{source}: {what} has no EMG channels; read it with emg = [...] (the EMG columns "
            "or analog labels)"
        )
    emg = trial["emg"]
    if muscles is None:
        return emg
    have = [str(m) for m in emg["muscle"].values]
    missing = [m for m in muscles if m not in have]
    if missing:
        raise InputError(
            f"{source}: {what} has no EMG channel {missing[0]!r} (channels: {', '.join(have)})"
        )
    return emg.sel(muscle=list(muscles))


def emg_envelope(
    trial: xr.Dataset,
    *,
    band: tuple[float, float] | None = None,
    rms_window: float | None = None,
    muscles: Sequence[str] | None = None,
) -> xr.DataArray:
    """The band-passed RMS envelope (V) of a Trial's EMG, at the trial's full rate.

    Parameters
    ----------
    trial : xarray.Dataset
        A Trial with a variable ``emg`` (:func:`inertiafit.io.read_trial` with ``emg=[...]``).
    band : (float, float), optional
        High-pass and low-pass edges (Hz); default ``EmgSettings.band`` (20, 450). The upper
        edge is clipped to ``NYQUIST_FRACTION`` of the Nyquist frequency.
    rms_window : float, optional
        Length (s) of the centred moving RMS; default ``EmgSettings.rms_window`` (0.05).
    muscles : sequence of str, optional
        The channels (default all).

    Returns
    -------
    xarray.DataArray
        Dims ``muscle``, ``time``; attrs ``units`` (V), ``band`` (the edges used, Hz) and
        ``rms_window`` (s).

    Raises
    ------
    InputError
        A trial without EMG or without a muscle asked for, a band that does not fit below the
        Nyquist frequency (or loses more than half of it there: EMG at 100 Hz is no EMG), a
        window shorter than two samples, or a trial too short to filter.
    """
    defaults = EmgSettings()
    lo, hi = check_emg_band(band, "band") if band is not None else defaults.band
    window = (
        check_emg_setting("rms_window", rms_window, "rms_window")
        if rms_window is not None
        else defaults.rms_window
    )
    emg = _emg_of(trial, muscles, "the trial")
    source = source_of(trial)
    rate = sampling_rate(trial)
    nyquist = rate / 2
    top = min(float(hi), NYQUIST_FRACTION * nyquist)
    if not (0 < lo < top and top >= hi / 2):
        raise InputError(
            f"{source}: EMG sampled at {rate:g} Hz cannot be band-passed to {lo:g}-{hi:g} Hz "
            f"(its Nyquist frequency is {nyquist:g} Hz); EMG needs about 1 kHz or more"
        )
    size = round(window * rate)
    if size < 2 or not math.isfinite(window):
        raise InputError(
            f"{source}: rms_window {window:g} s is under two samples at {rate:g} Hz; give a "
            "window of tens of milliseconds"
        )
    sos = signal.butter(BAND_ORDER, [lo, top], btype="bandpass", fs=rate, output="sos")
    raw = np.asarray(emg.values, dtype=np.float64)
    try:
        filtered = signal.sosfiltfilt(sos, raw - raw.mean(axis=-1, keepdims=True), axis=-1)
    except ValueError:
        raise InputError(
            f"{source}: {raw.shape[-1]} EMG samples are too few to band-pass; the trial is "
            "too short"
        ) from None
    mean_square = uniform_filter1d(filtered**2, size=size, axis=-1, mode="reflect")
    envelope = np.sqrt(np.maximum(mean_square, 0.0))
    return xr.DataArray(
        envelope,
        dims=("muscle", "time"),
        coords={"muscle": emg["muscle"].values, "time": trial["time"].values},
        attrs={"units": "V", "band": (float(lo), top), "rms_window": window},
        name="emg_envelope",
    )


def rest_level(envelope: xr.DataArray, *, trim: bool = True) -> dict[str, tuple[float, float]]:
    """Mean and SD (V) of each muscle's envelope over its whole length.

    ``trim`` leaves out half a window at each end (where the envelope's window leaves the
    recording), when the envelope is long enough.
    """
    values = np.asarray(envelope.values, dtype=np.float64)
    rate = 1.0 / float(np.median(np.diff(envelope["time"].values)))
    half = round(float(envelope.attrs.get("rms_window", 0.0)) * rate / 2)
    if trim and values.shape[-1] > 4 * half + 2:
        values = values[:, half : values.shape[-1] - half]
    return {
        str(m): (float(row.mean()), float(row.std()))
        for m, row in zip(envelope["muscle"].values, values, strict=True)
    }


def mvc_levels(
    mvc: xr.Dataset | Sequence[xr.Dataset],
    *,
    band: tuple[float, float] | None = None,
    rms_window: float | None = None,
    muscles: Sequence[str] | None = None,
) -> dict[str, float]:
    """Each muscle's MVC level (V): the peak of its RMS envelope over the MVC trials.

    The one definition of an MVC level in inertiafit: :func:`emg_activity` (``mvc=``) and a
    study's ``kind = "mvc"`` trials use it. With several trials (repeated attempts, or one
    contraction per muscle), a muscle's level is its largest peak over the trials that record
    it.

    Parameters
    ----------
    mvc : Trial or sequence of Trial
        Maximal voluntary contractions with EMG.
    band, rms_window : optional
        As :func:`emg_envelope`.
    muscles : sequence of str, optional
        The channels wanted (default: every channel of the trials). With several trials, each
        muscle must be in at least one of them; with one, in it.

    Returns
    -------
    dict of str to float
        Muscle -> peak envelope (V), in the order of ``muscles`` (else of first appearance).

    Raises
    ------
    InputError
        An MVC without EMG; a muscle no MVC trial records (naming the trial); a peak of 0 V;
        the problems of :func:`emg_envelope`.
    """
    trials = [mvc] if isinstance(mvc, xr.Dataset) else list(mvc)
    if not trials:
        raise InputError("mvc: expected an MVC Trial with EMG, got no trial")
    peaks: dict[str, float] = {}
    for trial in trials:
        emg = _emg_of(trial, None, "the MVC trial")
        have = [str(m) for m in emg["muscle"].values]
        wanted = have if muscles is None else [m for m in muscles if m in have]
        if len(trials) == 1 and muscles is not None:
            wanted = list(muscles)  # one trial: a muscle missing is its error
        if not wanted:
            continue
        env = emg_envelope(trial, band=band, rms_window=rms_window, muscles=wanted)
        for m, row in zip(wanted, env.values, strict=True):
            peaks[m] = max(peaks.get(m, 0.0), float(row.max()))
    order = list(muscles) if muscles is not None else list(peaks)
    for m in order:
        if m not in peaks:
            raise InputError(
                f"{source_of(trials[0])}: no MVC trial records EMG channel {m!r}; record every "
                "checked muscle in an MVC trial"
            )
        if not peaks[m] > 0:
            raise InputError(f"{source_of(trials[0])}: the MVC level of EMG channel {m!r} is 0 V")
    return {m: peaks[m] for m in order}


def _mvc_from_mapping(mvc: Mapping[str, Any], muscles: list[str]) -> dict[str, float]:
    """MVC levels given per muscle (V)."""
    out = {}
    for m in muscles:
        if m not in mvc:
            raise InputError(f"mvc: no level for muscle {m!r} (given: {', '.join(map(str, mvc))})")
        value = mvc[m]
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not (math.isfinite(value) and value > 0)
        ):
            raise InputError(
                f"mvc.{m}: expected the MVC's peak envelope in V (> 0), got {value!r}"
            )
        out[m] = float(value)
    return out


def _levels_from_mapping(
    rest: Mapping[str, Any], muscles: list[str], *, band: tuple[float, float], window: float
) -> dict[str, tuple[float, float]]:
    """Rest levels given per muscle: ``(mean, sd)`` or a mean alone (SD from noise theory)."""
    out = {}
    # A mean alone: the envelope of Gaussian noise in a band B averaged over T has about
    # nu = 2 B T degrees of freedom in its mean square, so the RMS's relative SD is
    # 1 / sqrt(2 nu) = 1 / (2 sqrt(B T)).
    relative_sd = 1.0 / (2.0 * math.sqrt((band[1] - band[0]) * window))
    for muscle in muscles:
        if muscle not in rest:
            raise InputError(
                f"rest: no level for muscle {muscle!r} (given: {', '.join(map(str, rest))})"
            )
        value = rest[muscle]
        if isinstance(value, int | float) and not isinstance(value, bool):
            mean, sd = float(value), float(value) * relative_sd
        elif (
            isinstance(value, Sequence)
            and not isinstance(value, str)
            and len(value) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        ):
            mean, sd = float(value[0]), float(value[1])
        else:
            raise InputError(
                f"rest.{muscle}: expected the rest envelope's level in V, or (mean, sd) in V, "
                f"got {value!r}"
            )
        if not (math.isfinite(mean) and math.isfinite(sd) and mean > 0 and sd >= 0):
            raise InputError(
                f"rest.{muscle}: expected a level > 0 V and an SD >= 0 V, got {value!r}"
            )
        out[muscle] = (mean, sd)
    return out


def _runs(above: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``(first, last)`` sample indices of each run of True."""
    padded = np.concatenate(([False], above, [False])).astype(np.int8)
    edges = np.diff(padded)
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def _stretches(above: NDArray[np.bool_], min_run: int, min_gap: int) -> list[tuple[int, int]]:
    """Runs at least ``min_run`` long; kept runs less than ``min_gap`` apart are merged."""
    kept = [(a, b) for a, b in _runs(above) if b - a + 1 >= min_run]
    merged: list[tuple[int, int]] = []
    for a, b in kept:
        if merged and a - merged[-1][1] - 1 < min_gap:
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    return merged


def emg_activity(
    trial: xr.Dataset,
    rest: Rest,
    *,
    mvc: Mvc = None,
    muscles: Sequence[str] | None = None,
    band: tuple[float, float] | None = None,
    rms_window: float | None = None,
    threshold_sd: float | None = None,
    min_duration: float | None = None,
    mvc_fraction: float | None = None,
    settings: EmgSettings | None = None,
) -> pd.DataFrame:
    """The stretches of a trial where a muscle's EMG is active, against its rest level.

    Parameters
    ----------
    trial : xarray.Dataset
        A Trial with EMG (``read_trial(..., emg=[...])``).
    rest : (start, end), Trial or mapping
        The muscles' rest: a span ``(start, end)`` (s, the trial's time) where they are known
        to be quiet; a rest Trial with the same EMG channels (processed the same way, its
        whole length, half a window trimmed at each end); or a level per muscle,
        ``{muscle: (mean, sd)}`` of the rest envelope in V, or ``{muscle: mean}`` (the SD of
        an RMS envelope of Gaussian noise then: ``mean / (2 sqrt(B T))``, B the band's width,
        T the window).
    mvc : Trial, sequence of Trial, or mapping, optional
        Maximal voluntary contractions with the same EMG channels (:func:`mvc_levels`: each
        muscle's peak envelope over them), or each muscle's MVC level ``{muscle: peak}`` in V.
        The threshold becomes the larger of ``rest mean + k SD`` and ``mvc_fraction`` of the
        MVC level.
    muscles : sequence of str, optional
        The channels to check (default all of the trial's).
    band, rms_window, threshold_sd, min_duration, mvc_fraction : optional
        Override ``settings`` (see :class:`inertiafit.io.emg.EmgSettings` for their meaning
        and the sources of the defaults).
    settings : EmgSettings, optional
        A study's ``[emg]`` table (default: the published defaults).

    Returns
    -------
    pandas.DataFrame
        One row per active stretch, ordered by muscle (the trial's order) then time:
        ``muscle`` (str), ``start`` and ``end`` (s, the first and last sample above the
        threshold), ``peak_ratio`` (the stretch's peak envelope over the rest mean). Empty
        (the same columns) when every muscle stays quiet. ``attrs``: ``rest_level``,
        ``rest_sd`` and ``threshold`` (V per muscle), ``band`` (Hz, the edges used),
        ``rms_window``, ``threshold_sd``, ``min_duration``, ``mvc_fraction`` and
        ``mvc_level`` (V per muscle; both ``None`` without an MVC).

    Raises
    ------
    InputError
        A trial (or rest or MVC trial) without EMG or without a muscle asked for, a rest span
        outside the trial or shorter than the window, a rest level that is not positive, a
        setting out of range, and the problems of :func:`emg_envelope`.
    """
    base = settings if settings is not None else EmgSettings()
    given = {
        "rms_window": rms_window,
        "threshold_sd": threshold_sd,
        "min_duration": min_duration,
        "mvc_fraction": mvc_fraction,
    }
    checked = {
        key: check_emg_setting(key, value, key) if value is not None else getattr(base, key)
        for key, value in given.items()
    }
    band = check_emg_band(band, "band") if band is not None else base.band
    window, k = checked["rms_window"], checked["threshold_sd"]
    duration, fraction = checked["min_duration"], checked["mvc_fraction"]

    envelope = emg_envelope(trial, band=band, rms_window=window, muscles=muscles)
    names = [str(m) for m in envelope["muscle"].values]
    used_band = envelope.attrs["band"]
    time = np.asarray(envelope["time"].values)
    source = source_of(trial)

    if isinstance(rest, xr.Dataset):
        rest_env = emg_envelope(rest, band=band, rms_window=window, muscles=names)
        levels = rest_level(rest_env)
    elif isinstance(rest, Mapping):
        levels = _levels_from_mapping(rest, names, band=used_band, window=window)
    elif (
        isinstance(rest, Sequence)
        and not isinstance(rest, str)
        and len(rest) == 2
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in rest)
        and rest[0] < rest[1]
    ):
        inside = (time >= rest[0]) & (time <= rest[1])
        if inside.sum() < max(2, round(window / float(np.median(np.diff(time))))):
            raise InputError(
                f"{source}: rest span ({rest[0]:g}, {rest[1]:g}) s holds {int(inside.sum())} "
                f"samples of a trial from {time[0]:g} to {time[-1]:g} s; it must lie in the "
                f"trial and be longer than the RMS window ({window:g} s)"
            )
        levels = rest_level(envelope.isel(time=np.flatnonzero(inside)), trim=False)
    else:
        raise InputError(
            f"rest: expected a span (start, end) in s, a rest Trial, or a level per muscle, "
            f"got {rest!r}"
        )
    for muscle, (mean, _) in levels.items():
        if not mean > 0:
            raise InputError(f"{source}: the rest level of EMG channel {muscle!r} is 0 V")

    thresholds = {m: levels[m][0] + k * levels[m][1] for m in names}
    peaks: dict[str, float] | None = None
    if isinstance(mvc, xr.Dataset) or (
        isinstance(mvc, Sequence) and not isinstance(mvc, str) and mvc
    ):
        peaks = mvc_levels(mvc, band=band, rms_window=window, muscles=names)
    elif isinstance(mvc, Mapping):  # after Dataset, which is a Mapping too
        peaks = _mvc_from_mapping(mvc, names)
    elif mvc is not None:
        raise InputError(
            f"mvc: expected an MVC Trial, a list of them, or a level per muscle, got {mvc!r}"
        )
    if peaks is not None:
        for m in names:
            thresholds[m] = max(thresholds[m], fraction * peaks[m])

    rate = sampling_rate(trial)
    min_samples = max(1, math.ceil(duration * rate - 1e-9))
    # the envelope's window lifts it for its own length around any event, however short (one
    # spike lifts a 50 ms RMS for 50 ms): activity lasting `duration` keeps it up for the
    # window plus `duration`
    min_run = round(window * rate) + math.ceil(duration * rate - 1e-9)
    rows = []
    for m, env in zip(names, envelope.values, strict=True):
        for a, b in _stretches(env > thresholds[m], min_run, min_samples):
            peak = float(env[a : b + 1].max())
            rows.append((m, float(time[a]), float(time[b]), peak / levels[m][0]))
    table = pd.DataFrame(rows, columns=list(ACTIVITY_COLUMNS))
    table = table.astype({"muscle": object, "start": float, "end": float, "peak_ratio": float})
    table.attrs = {
        "rest_level": {m: levels[m][0] for m in names},
        "rest_sd": {m: levels[m][1] for m in names},
        "threshold": thresholds,
        "band": tuple(used_band),
        "rms_window": window,
        "threshold_sd": k,
        "min_duration": duration,
        "mvc_fraction": fraction if peaks is not None else None,
        "mvc_level": peaks,
    }
    return table
