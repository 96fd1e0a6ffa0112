"""The ``[emg]`` table: the study's EMG activity check (:mod:`inertiafit.io.emg`)."""

from __future__ import annotations

from inertiafit.io.emg import read_emg_settings
from inertiafit.io.sections.base import Section, register_section

__all__: list[str] = []

register_section(
    Section(
        "emg",
        lambda value, ctx: (
            None if value is None else read_emg_settings(value, where=f"{ctx.where}: emg")
        ),
        "emg",
        40,
    )
)
