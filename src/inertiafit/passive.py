"""The passive elastic moment of a living joint, as the dynamometer sees it.

A living segment on the dynamometer's shaft is held by a joint whose muscles, tendons and
capsule resist being stretched. Moving it takes, besides the rigid-body moments, the passive
elastic moment ``P(theta_j)`` (N m): the moment the device must apply against that
resistance at the joint angle ``theta_j``. It rises with the joint angle — a spring about a
relaxed angle, stiffening into exponential stops toward either end of the range:

    P(theta_j) = scale * P0(theta_j) + k (theta_j - theta_rel)
                 + a_hi exp((theta_j - theta_hi) / width) - a_lo exp((theta_lo - theta_j) / width)

``P0`` is a joint's literature curve (the knee's and the ankle's of Riener & Edrich 1999),
zero for the elbow and a generic joint. Angles here are joint angles in radians, flexion
(for the ankle, plantarflexion) positive.

Riener R, Edrich T (1999). Identification of passive elastic joint moments in the lower
extremities. J Biomech 32:539-544. Their moments are those the tissues apply to the limb
(flexing positive); the device applies the opposite, so ``P0 = -M``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "JOINTS",
    "literature_curve",
    "passive_moment",
    "riener_edrich_ankle",
    "riener_edrich_knee",
]

#: Joints with shipped passive priors (``priors/passive/<joint>.toml``).
JOINTS = ("elbow", "knee", "ankle", "generic")
#: The other joints' angles (deg) at which the lower-limb curves are taken: a seated subject
#: (hip flexed 90 deg), ankle neutral, knee flexed 90 deg for the ankle's curve.
_SEATED_HIP_DEG = 90.0
_NEUTRAL_ANKLE_DEG = 0.0
_SEATED_KNEE_DEG = 90.0


def riener_edrich_knee(
    knee_deg: ArrayLike, *, hip_deg: float = _SEATED_HIP_DEG, ankle_deg: float = _NEUTRAL_ANKLE_DEG
) -> NDArray:
    """Passive elastic knee moment of Riener & Edrich (1999), N m, flexing positive.

    Knee flexion ``knee_deg`` (0 = full extension), hip flexion and ankle plantarflexion in
    degrees; 47 N m at full extension, about -3.5 N m at 90 deg of flexion (hip at 90 deg).
    """
    k = np.asarray(knee_deg, dtype=np.float64)
    return (
        np.exp(1.800 - 0.0460 * ankle_deg - 0.0352 * k + 0.0217 * hip_deg)
        - np.exp(-3.971 - 0.0004 * ankle_deg + 0.0495 * k - 0.0128 * hip_deg)
        - 4.820
        + np.exp(2.220 - 0.150 * k)
    )


def riener_edrich_ankle(ankle_deg: ArrayLike, *, knee_deg: float = _SEATED_KNEE_DEG) -> NDArray:
    """Passive elastic ankle moment of Riener & Edrich (1999), N m, plantarflexing positive.

    Ankle plantarflexion ``ankle_deg`` (0 = neutral) and knee flexion in degrees.
    """
    a = np.asarray(ankle_deg, dtype=np.float64)
    return (
        np.exp(2.1016 - 0.0843 * a - 0.0176 * knee_deg)
        - np.exp(-7.9763 + 0.1949 * a + 0.0008 * knee_deg)
        - 1.792
    )


def literature_curve(
    joint: str,
    theta_j: ArrayLike,
    *,
    hip_deg: float = _SEATED_HIP_DEG,
    ankle_deg: float = _NEUTRAL_ANKLE_DEG,
    knee_deg: float = _SEATED_KNEE_DEG,
) -> NDArray:
    """``P0``: the joint's literature curve as the device's moment (N m) at ``theta_j`` (rad).

    The negative of Riener & Edrich's tissue moment for the knee and the ankle; zero for the
    elbow and a generic joint (no shape is published for them; their prior is a spring with
    end stops). The other joints' angles (deg) default to the seated subject the prior files
    assume: hip and ankle for the knee's curve, knee for the ankle's.

    Raises
    ------
    ValueError
        If ``joint`` is not one of :data:`JOINTS`.
    """
    if joint not in JOINTS:
        msg = f"joint must be one of {', '.join(JOINTS)}, got {joint!r}"
        raise ValueError(msg)
    deg = np.degrees(np.asarray(theta_j, dtype=np.float64))
    if joint == "knee":
        return -riener_edrich_knee(deg, hip_deg=hip_deg, ankle_deg=ankle_deg)
    if joint == "ankle":
        return -riener_edrich_ankle(deg, knee_deg=knee_deg)
    return np.zeros_like(deg)


def passive_moment(
    theta_j: ArrayLike,
    *,
    stiffness: float,
    relaxed: float,
    stop_low: float = 0.0,
    stop_high: float = 0.0,
    range_low: float = -np.inf,
    range_high: float = np.inf,
    width: float = 1.0,
    scale: float = 0.0,
    joint: str = "generic",
) -> NDArray:
    """``P(theta_j)`` (N m) at joint angles ``theta_j`` (rad), the formula of the module.

    Parameters
    ----------
    theta_j : array_like
        Joint angles (rad).
    stiffness : float
        ``k`` (N m/rad) of the spring about ``relaxed`` (rad).
    stop_low, stop_high : float
        ``a_lo``, ``a_hi``: the end stops' moments (N m) at ``range_low`` and ``range_high``
        (rad), growing by ``e`` every ``width`` (rad) beyond them.
    scale : float
        Multiplies the joint's literature curve (:func:`literature_curve`).
    joint : str
        Which literature curve.
    """
    t = np.asarray(theta_j, dtype=np.float64)
    out = stiffness * (t - relaxed)
    if stop_high:
        out = out + stop_high * np.exp((t - range_high) / width)
    if stop_low:
        out = out - stop_low * np.exp((range_low - t) / width)
    if scale:
        out = out + scale * literature_curve(joint, t)
    return out
