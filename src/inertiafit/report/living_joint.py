"""A living body's joint as a saved posterior carries it: passive moment, damping, hysteresis.

A study with a ``living = true`` body stores its joint fit in ``posterior.nc``'s ``living``
group (:func:`inertiafit.processing.living.living_datatree`): the Gaussian of the static
fit's coefficients (gravity ``A``, ``B`` per living condition, offsets, the passive curve's
and the hysteresis' coefficients), the columns' geometry, and a table of the joint's
parameters (the viscous damping ``b`` among them). :func:`living_joint` reads it back as a
:class:`LivingJoint`, which evaluates, at device angles ``theta`` (rad):

* the passive elastic moment ``P(theta)`` (N m, the moment the device applies against the
  joint's resistance; the joint's moment on the segment is ``-P``), **relative to its value
  at the middle of the swept range** (:attr:`LivingJoint.reference`): the fit's offsets
  absorb its constant, which no quasi-static sweep separates from the sensor's zero; the
  same convention as ``passive.csv``;
* the hysteresis ``h(theta)`` (N m; the direction-dependent moment ``h sgn(omega)``);
* with the viscous damping ``b`` (N m s/rad): the joint's moment ``P + b omega + h sgn(omega)``.

**Draws.** The fit's coefficients are correlated with its gravity moment: one posture's sweep
tells ``M_g sin(theta + phi)`` from a spring ``k theta`` poorly, so a larger ``M_g`` goes with
a smaller passive moment and their sum is measured better than either. A posterior draw of the
bodies fixes each living condition's ``M_g`` (the sum over its bodies of ``m g x``, times the
torque gain when one was sampled), and the passive and hysteresis coefficients of that draw
are drawn from the fit's Gaussian **conditioned on it** (``M_g`` linearised as ``hypot(A, B)``
is in the fit): ``beta | M = mu_beta + S_bM S_MM^-1 (M - M_hat)``, covariance
``S_bb - S_bM S_MM^-1 S_Mb``. ``b`` is drawn from its own Gaussian (the fast trials').
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.posterior import Posterior
from inertiafit.processing.living import (
    LIVING_GROUP,
    LivingStatics,
    PassiveBasis,
    PostureGeometry,
    SmoothPassive,
    living_tables_from_tree,
)

__all__ = ["LivingJoint", "condition_moments", "living_joint"]

#: The fit's attributes that place its columns (written since the passive export).
_GEOMETRY = ("joint", "joint_angle_at_zero", "stop_range", "stop_width", "angle_range")


@dataclass(frozen=True)
class LivingJoint:
    """A living body's joint fit, rebuilt from a saved posterior (see the module notes).

    Attributes
    ----------
    body : str
        The living body.
    statics : LivingStatics
        The joint fit: coefficients' names, mean and covariance, the passive columns.
    conditions : dict of str to tuple of str
        Each living condition and the bodies mounted in it.
    moments : dict of str to float
        Each living condition's ``M_g`` as the fit measured it (N m, observed scale).
    damping : (float, float)
        ``b``'s mean and SD (N m s/rad).
    """

    body: str
    statics: LivingStatics
    conditions: dict[str, tuple[str, ...]]
    moments: dict[str, float]
    damping: tuple[float, float]

    @property
    def zero(self) -> float:
        """The joint angle (rad) at the device's 0: ``theta_j = theta + zero``."""
        return self.statics.basis.zero

    @property
    def angle_range(self) -> tuple[float, float]:
        """The device angles (rad) the sweeps covered."""
        return self.statics.angle_range

    @property
    def reference(self) -> float:
        """The device angle (rad) where ``P`` is 0: the middle of the swept range."""
        lo, hi = self.angle_range
        return 0.5 * (lo + hi)

    @property
    def names(self) -> tuple[str, ...]:
        """The coefficients drawn: the passive curve's, then the hysteresis'."""
        smooth = self.statics.smooth
        shapes = smooth.hysteresis_names if smooth is not None else ()
        return (*self.statics.passive_names, "hysteresis", *shapes)

    @property
    def mean(self) -> NDArray:
        """The fit's mean of :attr:`names`."""
        return self.statics.coefficients[self._index]

    @property
    def _index(self) -> list[int]:
        return [self.statics.index(n) for n in self.names]

    def _split(self, coefficients: NDArray) -> tuple[NDArray, NDArray]:
        n = len(self.statics.passive_names)
        c = np.atleast_2d(np.asarray(coefficients, dtype=float))
        return c[:, :n], c[:, n:]

    def passive(self, theta: NDArray, coefficients: NDArray | None = None) -> NDArray:
        """``P(theta)`` (N m) at device angles ``theta`` (rad), relative to :attr:`reference`.

        ``coefficients``: rows of :attr:`names` (draws); default the fit's mean (one row).
        Returns ``(rows, angles)``.
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        columns = self.statics.passive_columns(theta) - self.statics.passive_columns(
            np.array([self.reference])
        )
        passive, _ = self._split(self.mean if coefficients is None else coefficients)
        return passive @ columns.T

    def hysteresis(self, theta: NDArray, coefficients: NDArray | None = None) -> NDArray:
        """``h(theta)`` (N m) at device angles ``theta`` (rad): ``(rows, angles)``."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        smooth = self.statics.smooth
        if smooth is None:
            columns = np.ones((theta.size, 1))
        else:
            columns = smooth.hysteresis_design(self.zero + theta)
        _, shape = self._split(self.mean if coefficients is None else coefficients)
        return shape @ columns.T

    def draws(
        self, rng: np.random.Generator, size: int, moments: Mapping[str, NDArray] | None = None
    ) -> NDArray:
        """``size`` draws of :attr:`names` (rows), each given its draw's conditions' ``M_g``.

        ``moments``: each living condition's ``M_g`` per draw (N m, observed scale;
        :func:`condition_moments`); without them (or for a condition they lack) the draws
        are the fit's marginal.
        """
        cov = self.statics.covariance
        index = self._index
        conds = [c for c in self.conditions if moments is not None and c in moments]
        mean = np.broadcast_to(self.mean, (size, len(index))).copy()
        var = cov[np.ix_(index, index)]
        if conds and moments is not None:
            grad = np.array([self.statics.moment_gradient(c) for c in conds])
            s_mm = grad @ cov @ grad.T
            s_bm = cov[index] @ grad.T
            gain = np.linalg.solve(s_mm, s_bm.T).T
            shift = np.column_stack(
                [np.asarray(moments[c], dtype=float) - self.moments[c] for c in conds]
            )
            mean = mean + shift @ gain.T
            var = var - gain @ s_bm.T
        var = 0.5 * (var + var.T)
        values, vectors = np.linalg.eigh(var)
        root = vectors * np.sqrt(np.clip(values, 0.0, None))
        return mean + rng.standard_normal((size, len(index))) @ root.T

    def damping_draws(self, rng: np.random.Generator, size: int) -> NDArray:
        """``size`` draws of ``b`` (N m s/rad) from its Gaussian."""
        mean, sd = self.damping
        return mean + (sd if math.isfinite(sd) else 0.0) * rng.standard_normal(size)


def _conditions(post: Posterior) -> dict[str, tuple[str, ...]]:
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    return {
        str(c): tuple(str(b) for b in bodies) for c, bodies in inputs.get("conditions", {}).items()
    }


def living_joint(post: Posterior, body: str | None = None) -> LivingJoint | None:
    """The living joint a posterior carries (``None`` for a rigid study).

    Parameters
    ----------
    post : Posterior
    body : str, optional
        Only this body's joint: ``None`` when ``body`` is not the living body.

    Raises
    ------
    InputError
        A ``living`` group written before the passive columns' geometry was saved (run the
        study again), or one that names a living condition the posterior does not hold.
    """
    tree = post.tree
    if LIVING_GROUP not in tree.children or "fit" not in tree[LIVING_GROUP].children:
        return None
    tables = living_tables_from_tree(tree)
    params = tables.get("passive_parameters")
    living = str(params["body"].iloc[0]) if params is not None and len(params) else ""
    if body is not None and body != living:
        return None
    fit: xr.Dataset = tree[LIVING_GROUP]["fit"].to_dataset()
    missing = [k for k in _GEOMETRY if k not in fit.attrs]
    if missing:
        raise InputError(
            f"posterior.nc: living/fit: no '{missing[0]}' (the passive curve's geometry, saved "
            "since inertiafit exports the passive moment); run the study again"
        )
    names = tuple(str(n) for n in fit["coefficient"].values)
    joint = str(fit.attrs["joint"])
    zero = float(fit.attrs["joint_angle_at_zero"])
    low, high = (float(v) for v in np.atleast_1d(fit.attrs["stop_range"]))
    lo, hi = (float(v) for v in np.atleast_1d(fit.attrs["angle_range"]))
    nan = (math.nan, math.nan)
    basis = PassiveBasis(
        joint=joint,
        zero=zero,
        stiffness=nan,
        stop_moment=nan,
        width=float(fit.attrs["stop_width"]),
        range_low=low,
        range_high=high,
        hysteresis=nan,
        curve_scale=nan if "curve_scale" in names else None,
        smooth=str(fit.attrs.get("curve", "smooth")) == "smooth",
    )
    smooth = SmoothPassive.over(zero + lo, zero + hi) if basis.smooth else None
    if smooth is not None and not set(smooth.names) <= set(names):
        raise InputError(
            "posterior.nc: living/fit: its smooth coefficients do not match the swept range; "
            "run the study again"
        )
    cov = np.asarray(fit["covariance"].values, dtype=float)
    postures = {
        str(p): PostureGeometry(str(p), math.radians(float(r)))
        for p, r in zip(fit["posture"].values, fit["rotation"].values, strict=True)
    }
    conditions = tuple(n.partition(":")[2] for n in names if n.startswith("A:"))
    statics = LivingStatics(
        names=names,
        coefficients=np.asarray(fit["mean"].values, dtype=float),
        covariance=cov,
        precision=np.linalg.pinv(cov),
        postures=postures,
        basis=basis,
        conditions=conditions,
        angle_range=(lo, hi),
        smooth=smooth,
    )
    rows = params.set_index("parameter") if params is not None else None
    known = _conditions(post)
    moments = {}
    for c in conditions:
        key = f"gravity_moment:{c}"
        if rows is None or key not in rows.index:
            raise InputError(f"posterior.nc: living/parameters: no row '{key}'")
        moments[c] = float(rows.loc[key, "mean"])
    damping = (
        (float(rows.loc["damping", "mean"]), float(rows.loc["damping", "sd"]))
        if rows is not None and "damping" in rows.index
        else (0.0, 0.0)
    )
    return LivingJoint(
        body=living,
        statics=statics,
        conditions={c: known[c] for c in conditions if c in known},
        moments=moments,
        damping=damping,
    )


def condition_moments(
    post: Posterior, joint: LivingJoint, index: NDArray | None = None
) -> dict[str, NDArray]:
    """Each living condition's ``M_g`` at posterior draws ``index`` (flat; default all).

    The sum over the condition's bodies of their ``gravity_moment`` draws, with the
    condition's added masses (``constant_data.added_first_moment``) and a moved body's
    ``m g d``, times the torque gain where one was sampled: the scale the fit measured.
    """
    tree = post.tree
    data = tree["constant_data"].to_dataset()
    gravity = float(data["gravity"])
    known = [str(c) for c in data["condition"].values] if "condition" in data.coords else []
    gain = (
        np.asarray(tree["posterior"]["torque_gain"].values).reshape(-1)
        if "torque_gain" in tree["posterior"].data_vars
        else 1.0
    )
    out = {}
    for cond, bodies in joint.conditions.items():
        total: NDArray = np.zeros(1)
        for b in bodies:
            total = total + post.draws(b, "gravity_moment").reshape(-1)
        if cond in known:
            at = data.sel(condition=cond)
            if "added_first_moment" in at:
                total = total + gravity * float(at["added_first_moment"])
            moved = str(at["offset_body"].values) if "offset_body" in at else ""
            if moved in bodies:
                mass = post.draws(moved, "mass").reshape(-1)
                total = total + gravity * float(at["offset"]) * mass
        total = total * gain
        out[cond] = total if index is None else total[index]
    return out
