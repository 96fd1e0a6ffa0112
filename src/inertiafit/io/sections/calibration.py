"""The ``[calibration]`` table: the instrument's systematic errors."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from inertiafit.io.sections.base import (
    Section,
    as_table,
    check_keys,
    fail,
    number,
    register_section,
)

__all__ = [
    "CALIBRATION_KEYS",
    "MAX_LAG",
    "MAX_TORQUE_GAIN_SD",
    "Calibration",
    "read_calibration",
    "read_lag",
]

#: Keys of the top-level ``[calibration]`` table (:class:`Calibration`).
CALIBRATION_KEYS = ("torque_gain_sd", "angle_offset_sd", "lag", "lag_bounds", "max_lag_spread")
#: Largest lag (s) a manifest may state or search: a lag is milliseconds, not seconds.
MAX_LAG = 1.0
#: Largest relative SD of the torque gain (``[calibration] torque_gain_sd``) the model takes:
#: beyond 50 % a "calibration" is no calibration.
MAX_TORQUE_GAIN_SD = 0.5


@dataclass(frozen=True)
class Calibration:
    """Systematic errors of the instrument: the manifest's optional ``[calibration]`` table.

    Attributes
    ----------
    torque_gain_sd : float
        Relative standard deviation of the torque channel's gain (0.01 = 1 %), from the
        manufacturer's specification or a calibration certificate. A gain error multiplies
        every inertia and gravity moment of the study together. Default 0: not included (the
        reports say so in one line).
    angle_offset_sd : float
        Standard deviation (deg) of the angle channel's zero. Accepted so that a lab can
        declare it, but it changes nothing: an angle offset ``d`` turns the gravity model
        ``M_g sin(theta + phi)`` into ``M_g sin(theta + d + phi)``, which the fitted phase
        absorbs exactly (``phi' = phi + d``), and the inertia does not depend on the angle's
        zero. Default 0.
    lag : float or "estimate"
        Seconds the torque channel lags the angle and velocity channels. ``"estimate"`` (the
        default): estimated in every fast trial
        (:func:`inertiafit.processing.lag.estimate_lag`); a number fixes it for every trial
        (a trial's own ``lag`` key, or ``[defaults] lag``, still wins).
    lag_bounds : (float, float)
        Search range (s) of the estimated lag, lower < upper.
    max_lag_spread : float
        Seconds by which a trial's estimated lag may differ from the study's median before it
        is flagged (more, if its own standard error is larger: ``3 x lag_se``).
    """

    torque_gain_sd: float = 0.0
    angle_offset_sd: float = 0.0
    lag: float | str = "estimate"
    lag_bounds: tuple[float, float] = (-0.02, 0.02)
    max_lag_spread: float = 0.001


def read_lag(value: object, *, where: str) -> float:
    """A lag in seconds, below :data:`MAX_LAG`."""
    lag = number(value, where=where, what="a lag in seconds (0.003 = 3 ms)")
    if abs(lag) >= MAX_LAG:
        raise fail(where, f"a lag in seconds must be below {MAX_LAG:g} s, got {value!r}")
    return lag


def read_calibration(value: object, *, where: str) -> Calibration:
    """Check the top-level ``[calibration]`` table."""
    here = f"{where}: calibration"
    table = as_table(value, where=here, what="torque_gain_sd, angle_offset_sd, lag, ...")
    check_keys(table, CALIBRATION_KEYS, where=here)
    out: dict[str, Any] = {}
    if "torque_gain_sd" in table:
        sd = number(
            table["torque_gain_sd"],
            where=f"{here}.torque_gain_sd",
            what="a relative SD (0.01 = 1 %)",
        )
        if not 0 <= sd < MAX_TORQUE_GAIN_SD:
            raise fail(
                f"{here}.torque_gain_sd",
                f"expected a relative SD in [0, {MAX_TORQUE_GAIN_SD:g}) (0.01 = 1 %), "
                f"got {table['torque_gain_sd']!r}",
            )
        out["torque_gain_sd"] = sd
    if "angle_offset_sd" in table:
        sd = number(table["angle_offset_sd"], where=f"{here}.angle_offset_sd", what="an SD in deg")
        if sd < 0:
            raise fail(f"{here}.angle_offset_sd", f"expected an SD >= 0 (deg), got {sd!r}")
        out["angle_offset_sd"] = sd
    if "lag" in table:
        lag = table["lag"]
        out["lag"] = "estimate" if lag == "estimate" else read_lag(lag, where=f"{here}.lag")
    if "lag_bounds" in table:
        bounds = table["lag_bounds"]
        ok = (
            isinstance(bounds, list)
            and len(bounds) == 2
            and all(
                isinstance(b, int | float) and not isinstance(b, bool) and math.isfinite(b)
                for b in bounds
            )
        )
        if not ok or not bounds[0] < bounds[1]:
            raise fail(
                f"{here}.lag_bounds",
                f"expected two increasing numbers [lower, upper] in s, got {bounds!r}",
            )
        if max(abs(bounds[0]), abs(bounds[1])) >= MAX_LAG:
            raise fail(
                f"{here}.lag_bounds",
                f"lags in seconds must be below {MAX_LAG:g} s, got {bounds!r}",
            )
        out["lag_bounds"] = (float(bounds[0]), float(bounds[1]))
    if "max_lag_spread" in table:
        spread = number(
            table["max_lag_spread"], where=f"{here}.max_lag_spread", what="a time in seconds"
        )
        if spread < 0:
            raise fail(f"{here}.max_lag_spread", f"expected a time >= 0 (s), got {spread!r}")
        out["max_lag_spread"] = spread
    return Calibration(**out)


register_section(
    Section(
        "calibration",
        lambda value, ctx: read_calibration({} if value is None else value, where=ctx.where),
        "calibration",
        10,
    )
)
