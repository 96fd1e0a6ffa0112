"""The manifest's ``[emg]`` table: the study's EMG channels and how their activity is judged.

::

    [emg]
    columns = ["biceps", "triceps"]     # EMG columns (or analog labels) of every trial
    unit = "mV"                         # V (default), mV, or µV ("uV"), where the file is silent
    band = [20, 450]                    # Hz, band-pass (SENIAM)
    rms_window = 0.05                   # s, RMS envelope
    threshold_sd = 3                    # rest mean + k SD of the envelope (Hodges & Bui 1996)
    min_duration = 0.01                 # s of activity (the envelope above: the window + this)
    mvc_fraction = 0.02                 # and above this fraction of an MVC's peak envelope
    on_activity = "exclude"             # or "flag", "stop": what an active trial does

Each default and its source is in ``docs/processing.md`` (the EMG activity check);
:class:`EmgSettings` holds them, :func:`read_emg_settings` checks a table.
:func:`inertiafit.processing.emg.emg_activity` takes its defaults from here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from inertiafit._checks import (
    check_increasing_pair,
    check_interval,
    check_positive,
)
from inertiafit.errors import InputError
from inertiafit.io.readers.validation import check_emg
from inertiafit.io.units import emg_unit

__all__ = [
    "EMG_KEYS",
    "MAX_EMG_WINDOW",
    "ON_ACTIVITY",
    "EmgSettings",
    "check_emg_band",
    "check_emg_setting",
    "read_emg_settings",
]

#: Keys of the ``[emg]`` table.
EMG_KEYS = (
    "columns",
    "unit",
    "band",
    "rms_window",
    "threshold_sd",
    "min_duration",
    "mvc_fraction",
    "on_activity",
)
#: What a trial with an active stretch does to the study: leave the evidence (``"exclude"``,
#: the default), stay with a flag (``"flag"``), or refuse the study (``"stop"``).
ON_ACTIVITY = ("exclude", "flag", "stop")
#: Longest ``rms_window`` and ``min_duration`` (s) a manifest may give: an EMG window is tens of
#: milliseconds; a second would smear a reflex over the whole acceleration.
MAX_EMG_WINDOW = 1.0


@dataclass(frozen=True)
class EmgSettings:
    """The ``[emg]`` table, with the defaults of published practice.

    Attributes
    ----------
    columns : tuple of str
        EMG columns (or analog labels) read from every trial whose own ``emg`` (or
        ``[defaults] emg``) does not say otherwise; empty: none here.
    unit : str or None
        ``V``, ``mV`` or ``µV`` of the EMG channels where the file does not state it
        (``None``: volts).
    band : (float, float)
        Band-pass (Hz): high-pass 20 Hz, low-pass 450 Hz (SENIAM, Hermens et al. 2000:
        high-pass 10-20 Hz, low-pass about 500 Hz), the upper edge clipped below the Nyquist
        frequency.
    rms_window : float
        Length (s) of the centred moving RMS envelope: 0.05 (RMS envelopes of 50-100 ms are
        common; the shorter end keeps onsets sharp).
    threshold_sd : float
        ``k`` of the threshold ``rest mean + k SD`` of the envelope: 3 (Hodges & Bui 1996).
    min_duration : float
        Seconds a muscle must be active for a stretch to count: 0.01, the short end of the
        10-50 ms Hodges & Bui (1996) compared. The envelope must stay above the threshold for
        the RMS window plus this (60 ms with the defaults): a moving RMS lifts its envelope
        for its own window around any event, however short. On a real Vicon recording
        (16.85 s, 14 silent channels) the silent channels' only crossings of ``mean + 3 SD``
        of 50 ms or more were runs of exactly 50-53 ms, each around one noise spike of
        5.4-5.7 SD (the noise's kurtosis is 3.7-3.9, heavier-tailed than Gaussian); none
        lasted 60 ms. A burst well above the threshold keeps the envelope above it for about
        its length plus the window, so a 20 ms reflex burst at 8 x rest still counts.
    mvc_fraction : float
        With an MVC trial (``kind = "mvc"``, or ``emg_activity(mvc=...)``), a stretch must also
        exceed this fraction of the MVC's peak envelope: 0.02 (small involuntary responses of
        healthy people are 2-3 % MVC, Finley et al. 2008). A manifest that sets it without a
        ``kind = "mvc"`` trial is refused (:func:`inertiafit.io.load_study`).
    on_activity : {"exclude", "flag", "stop"}
        What a trial with an active stretch does in a study (default ``"exclude"``).
    """

    columns: tuple[str, ...] = ()
    unit: str | None = None
    band: tuple[float, float] = (20.0, 450.0)
    rms_window: float = 0.05
    threshold_sd: float = 3.0
    min_duration: float = 0.01
    mvc_fraction: float = 0.02
    on_activity: str = "exclude"


def check_emg_band(value: object, where: str) -> tuple[float, float]:
    """The ``band`` setting checked: ``[high-pass, low-pass]`` in Hz, increasing, positive."""
    low, high = check_increasing_pair(
        value, where, "frequencies [high-pass, low-pass] in Hz such as [20, 450]"
    )
    check_positive(low, f"{where}[0]", "Hz")
    return low, high


def check_emg_setting(key: str, value: object, where: str) -> float:
    """One scalar ``[emg]`` setting checked; ``where`` starts the message.

    ``rms_window`` and ``min_duration`` (s), ``threshold_sd``, ``mvc_fraction``. With
    :func:`check_emg_band`, the one check of these settings, for the manifest
    (:func:`read_emg_settings`) and the keyword arguments of
    :func:`inertiafit.processing.emg.emg_activity`.
    """
    if key == "threshold_sd":
        return check_positive(value, where, "SDs of the rest envelope")
    if key == "mvc_fraction":
        return check_interval(value, where, 0.0, 1.0, "of the MVC", upper_closed=True)
    if key in ("rms_window", "min_duration"):
        return check_interval(
            value,
            where,
            0.0,
            MAX_EMG_WINDOW,
            "s",
            upper_closed=True,
            lower_closed=key == "min_duration",
        )
    raise ValueError(f"check_emg_setting: not a scalar [emg] setting: {key!r}")


def read_emg_settings(value: object, *, where: str) -> EmgSettings:
    """Check an ``[emg]`` table and return its :class:`EmgSettings` (defaults filled in).

    Parameters
    ----------
    value : mapping
        The table as TOML gives it.
    where : str
        ``"<manifest>: emg"``, the start of every message.

    Returns
    -------
    EmgSettings

    Raises
    ------
    InputError
        One line naming the key: not a table, an unknown key, ``columns`` not a list of
        distinct names, an unknown ``unit``, ``band`` not two increasing positive numbers (Hz),
        ``rms_window`` not in (0, 1] s, ``threshold_sd`` not positive, ``min_duration`` not in
        [0, 1] s, ``mvc_fraction`` not in (0, 1], an unknown ``on_activity``.
    """
    if not isinstance(value, Mapping):
        raise InputError(
            f"{where}: expected a table (columns, unit, band, rms_window, ...), got {value!r}"
        )
    for key in value:
        if key not in EMG_KEYS:
            raise InputError(f"{where}.{key}: unknown key (allowed: {', '.join(EMG_KEYS)})")
    out: dict[str, object] = {}
    if "columns" in value:
        out["columns"] = check_emg(value["columns"], where=f"{where}.columns")
    if "unit" in value:
        out["unit"] = emg_unit(value["unit"], where=f"{where}.unit")
    if "band" in value:
        out["band"] = check_emg_band(value["band"], f"{where}.band")
    for key in ("rms_window", "threshold_sd", "min_duration", "mvc_fraction"):
        if key in value:
            out[key] = check_emg_setting(key, value[key], f"{where}.{key}")
    if "on_activity" in value:
        action = value["on_activity"]
        if action not in ON_ACTIVITY:
            raise InputError(
                f'{where}.on_activity: expected "exclude", "flag" or "stop", got {action!r}'
            )
        out["on_activity"] = action
    return EmgSettings(**out)  # type: ignore[arg-type]
