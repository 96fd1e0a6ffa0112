"""The posterior of a fit: an ArviZ DataTree with a table, a corner plot and a text report.

Groups of the tree (ArviZ 1.x conventions, walkers as chains):

``posterior``
    ``mass`` (kg), ``com_distance`` (m), ``radius_of_gyration`` (m), ``inertia`` (kg m^2,
    about the joint) and ``gravity_moment`` (N m), each ``(chain, draw, body)``.
``sample_stats``
    ``lp``: log posterior density of the sampled coordinates (up to a constant).
``log_likelihood``
    ``inertia`` and ``gravity_moment``: one term per condition's evidence.
``log_prior``
    ``body_prior`` ``(chain, draw, body)``: the prior's log density of each draw's
    ``(m, x, rho)``; ``torque_gain`` with a torque gain. What ``arviz_stats.psense`` scales.
``observed_data``
    The trial values (or the single summarised value) per condition.
``prior``
    Draws from the prior boxes, for prior-versus-posterior comparisons.
``constant_data``
    The prior box (``nominal``, ``lower``, ``upper`` per body and parameter), the evidence as
    used (``center``, ``scale``, ``df`` per condition and observable) and ``gravity``.

Root attributes hold the provenance: versions, seed, sampler settings and diagnostics, inputs.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from inertiafit._checks import check_path, check_probability
from inertiafit.errors import InputError
from inertiafit.formatting import mean_sd
from inertiafit.io.outputs import write_csv
from inertiafit.physics import PARAMETERS, REPORTED, SYMBOLS
from inertiafit.posterior import conflict, display, pins

__all__ = [
    "PREDICTIVE_COLUMNS",
    "SUMMARY_COLUMNS",
    "Posterior",
    "inputs_json",
    "open_posterior",
]
SUMMARY_COLUMNS = [
    "body",
    "parameter",
    "mean",
    "sd",
    "median",
    "hdi_lower",
    "hdi_upper",
    "hdi_prob",
    "ess_bulk",
    "ess_tail",
    "r_hat",
]
#: Columns of :meth:`Posterior.prior_predictive`.
PREDICTIVE_COLUMNS = [
    "body",
    "quantity",
    "source",
    "estimate",
    "se",
    "prior_low",
    "prior_median",
    "prior_high",
    "lower_tail",
    "tail_probability",
    "conflict",
]


class Posterior:
    """Result of a fit.

    Attributes
    ----------
    tree : xarray.DataTree
        Everything: draws, evidence, prior box, diagnostics, provenance (see module docs).
    bodies : tuple of str
        Body names, in order.
    """

    def __init__(self, tree: xr.DataTree) -> None:
        self.tree = tree
        self._cache: dict[tuple, pd.DataFrame] = {}  # tables are read-only views of the tree
        self._lines: list[str] = []  # the prior-data conflicts' warnings, with their table
        self.bodies = tuple(str(b) for b in np.asarray(tree["posterior"]["body"]).tolist())

    # -- access ---------------------------------------------------------------------------
    @property
    def attrs(self) -> dict[str, Any]:
        """Provenance attributes of the root of the tree."""
        return {str(k): v for k, v in self.tree.attrs.items()}

    @property
    def converged(self) -> bool:
        """Whether the sampler met every convergence criterion."""
        return bool(int(self.tree.attrs.get("converged", 0)))

    def draws(self, body: str, parameter: str, group: str = "posterior") -> np.ndarray:
        """Draws of one parameter of one body, shape ``(chain, draw)``.

        Raises
        ------
        InputError
            For a body, parameter or group the posterior does not hold.
        """
        if body not in self.bodies:
            raise InputError(f"body: {body!r} is not in this posterior ({', '.join(self.bodies)})")
        if group not in self.tree.children:
            raise InputError(f"group: no group {group!r} ({', '.join(self.tree.children)})")
        if parameter not in self.tree[group].data_vars:
            known = ", ".join(str(v) for v in self.tree[group].data_vars)
            raise InputError(f"parameter: {parameter!r} is not in the {group} ({known})")
        return np.asarray(self.tree[group][parameter].sel(body=body).values)

    def prior_values(self, body: str, key: str) -> dict[str, float]:
        """The prior's ``nominal``, ``lower`` or ``upper`` value of each parameter (SI units)."""
        cd = self.tree["constant_data"][key]
        return {p: float(cd.sel(body=body, parameter=p)) for p in PARAMETERS}

    def prior_box(self, body: str) -> dict[str, tuple[float, float]]:
        """The prior's bounds ``(lower, upper)`` of each parameter of ``body`` (SI units)."""
        lower, upper = self.prior_values(body, "lower"), self.prior_values(body, "upper")
        return {p: (lower[p], upper[p]) for p in PARAMETERS}

    def calibration_note(self) -> str:
        """One line: whether the torque channel's calibration uncertainty is in the intervals."""
        cd = self.tree["constant_data"]
        sd = float(cd["torque_gain_sd"]) if "torque_gain_sd" in cd else 0.0
        if sd <= 0 or "torque_gain" not in self.tree["posterior"]:
            return (
                "Calibration uncertainty is not included: no torque-gain uncertainty was "
                "declared (manifest [calibration] torque_gain_sd), so every interval assumes "
                "an exact torque calibration."
            )
        gain = np.asarray(self.tree["posterior"]["torque_gain"].values)
        return (
            f"Calibration uncertainty is included: torque gain relative SD {100 * sd:.3g} % "
            f"(prior), posterior {mean_sd(gain.mean(), gain.std())}; it scales every I and "
            "M_g together and is carried in every interval."
        )

    # -- tables ---------------------------------------------------------------------------
    def summary(self, hdi_prob: float = 0.95) -> pd.DataFrame:
        """Table of a row per body and parameter (columns as ``summary.csv``).

        Parameters
        ----------
        hdi_prob : float
            Probability mass of the highest-density interval.
        """
        check_probability(hdi_prob, "hdi_prob")
        key = ("summary", float(hdi_prob))
        if key not in self._cache:
            self._cache[key] = self._summary(hdi_prob)
        return self._cache[key].copy()

    def _summary(self, hdi_prob: float) -> pd.DataFrame:
        from arviz_stats import ess, hdi, rhat

        rows = []
        for body in self.bodies:
            for p in REPORTED:
                x = self.draws(body, p)
                lo, hi = (float(v) for v in hdi(x.ravel(), prob=hdi_prob))
                rows.append(
                    {
                        "body": body,
                        "parameter": p,
                        "mean": float(x.mean()),
                        "sd": float(x.std(ddof=1)),
                        "median": float(np.median(x)),
                        "hdi_lower": lo,
                        "hdi_upper": hi,
                        "hdi_prob": hdi_prob,
                        "ess_bulk": float(ess(x, method="bulk")),
                        "ess_tail": float(ess(x, method="tail", prob=(0.05, 0.95))),
                        "r_hat": float(rhat(x)),
                    }
                )
        return pd.DataFrame(rows, columns=SUMMARY_COLUMNS)

    def identification(self) -> pd.DataFrame:
        """Who decides each quantity: one verdict, the numbers behind it, the prior-data check.

        Columns: ``posterior_sd``, ``prior_sd`` (of the prior's exact draws,
        :func:`~inertiafit.posterior.conflict.prior_draws`) and their ``sd_ratio`` (near 0: the
        posterior is much narrower than the prior; near 1: as wide) with its Monte Carlo SE
        ``sd_ratio_se``; ``identified_by``, the verdict (``data``, ``data + prior``,
        ``prior``: :func:`~inertiafit.posterior.pins.verdict` of the SD ratio, with a margin
        so that other seeds give the same); ``prior_share``, ``d log(posterior SD) / d
        log(prior scale)`` of the body's prior (1: the prior alone sets the width, 0: the data
        do; see :mod:`inertiafit.posterior.pins`), with its Monte Carlo SE ``prior_share_se``;
        ``calibration_share``, the same for the torque gain's prior (``nan`` without one);
        ``psense_prior`` and ``psense_likelihood``, the power-scaling sensitivities of
        ``arviz_stats.psense`` (the prior's is ``nan`` for a box, which power-scaling leaves
        unchanged); ``pinned_by``, the same verdict with the sources named (``data``,
        ``weighed mass``, ``balance point``, ``second mounting``, ``... + prior``, the
        calibration prior's part); ``minimum_mass``, the bound ``(M_g/g)^2 / I`` at the
        posterior medians; ``prior_predictive_p``, the two-sided prior-predictive tail
        probability of the quantity's measurement (``nan`` where nothing measures it;
        :meth:`prior_predictive`) and ``prior_data_conflict``, whether it is below
        :data:`~inertiafit.posterior.conflict.CONFLICT_TAIL`.
        """
        if ("identification",) not in self._cache:
            self._cache[("identification",)] = self._identification()
        return self._cache[("identification",)].copy()

    def _identification(self) -> pd.DataFrame:
        rows = []
        g = float(self.tree["constant_data"]["gravity"])
        specs = pins.prior_specs(self.tree)
        cd, post_group = self.tree["constant_data"], self.tree["posterior"]
        gain_sd = float(cd["torque_gain_sd"]) if "torque_gain_sd" in cd else 0.0
        gain_draws = (
            np.asarray(post_group["torque_gain"].values) if "torque_gain" in post_group else None
        )
        checked = self._checked()
        for body in self.bodies:
            i_med = float(np.median(self.draws(body, "inertia")))
            mg_med = float(np.median(self.draws(body, "gravity_moment")))
            draws = {p: self.draws(body, p) for p in REPORTED}
            share = pins.prior_share(draws, specs[body])
            share_se = self._share_se(draws, specs[body])
            gain = pins.prior_share(draws, None, torque_gain=gain_draws, torque_gain_sd=gain_sd)
            gain_se = (
                self._gain_se(draws, gain_draws, gain_sd)
                if gain_draws is not None
                else dict.fromkeys(REPORTED, math.nan)
            )
            sens = self._sensitivities(body, specs[body])
            sources = pins.body_sources(self.tree, body)
            direct = pins.direct_sources(self.tree, body)
            exact = conflict.prior_draws(specs[body], g)
            for p in REPORTED:
                post = float(draws[p].std())
                prior = float(exact[p].std())
                ratio = post / prior
                ratio_se = pins.batch_se(lambda x, s=prior: float(x.std()) / s, [draws[p]])
                who = pins.verdict(ratio, ratio_se)
                calibration = (
                    pins.verdict(gain[p], gain_se[p]) if math.isfinite(gain[p]) else "data"
                )
                counted = pins.counted_sources(
                    sources, p, {s: sens.get((s, p), 1.0) for s in sources}, direct
                )
                p_value = checked.get((body, p), math.nan)
                rows.append(
                    {
                        "body": body,
                        "parameter": p,
                        "posterior_sd": post,
                        "prior_sd": prior,
                        "sd_ratio": ratio,
                        "sd_ratio_se": ratio_se,
                        "identified_by": who,
                        "prior_share": share[p],
                        "prior_share_se": share_se[p],
                        "calibration_share": gain[p],
                        "psense_prior": sens.get(("prior", p), np.nan),
                        "psense_likelihood": sens.get(("likelihood", p), np.nan),
                        "pinned_by": pins.pinned_by(who, counted, calibration),
                        "minimum_mass": (mg_med / g) ** 2 / i_med,
                        "prior_predictive_p": p_value,
                        "prior_data_conflict": bool(p_value < conflict.CONFLICT_TAIL),
                    }
                )
        return pd.DataFrame(rows)

    @staticmethod
    def _share_se(draws: dict[str, np.ndarray], spec: dict) -> dict[str, float]:
        """Monte Carlo SE of each quantity's prior share (batch means)."""
        names = list(draws)

        def statistic(*arrays):
            share = pins.prior_share(dict(zip(names, arrays, strict=True)), spec)
            return [share[n] for n in names]

        se = pins.batch_se(statistic, [draws[n] for n in names])
        return {n: float(v) for n, v in zip(names, se, strict=True)}

    @staticmethod
    def _gain_se(draws: dict[str, np.ndarray], gain: np.ndarray, sd: float) -> dict[str, float]:
        """Monte Carlo SE of each quantity's calibration share (batch means)."""
        names = list(draws)

        def statistic(t, *arrays):
            share = pins.prior_share(
                dict(zip(names, arrays, strict=True)), None, torque_gain=t, torque_gain_sd=sd
            )
            return [share[n] for n in names]

        se = pins.batch_se(statistic, [gain, *(draws[n] for n in names)])
        return {n: float(v) for n, v in zip(names, se, strict=True)}

    def prior_predictive(self) -> pd.DataFrame:
        """Each measured quantity of each body against its prior predictive (prior-data conflict).

        A row per check of :func:`~inertiafit.posterior.conflict.prior_data_checks`: ``body``
        (bodies measured only together are joined by ``+``), ``quantity`` (``inertia``,
        ``gravity_moment``, a weighed ``mass``, a balance point's ``com_distance``),
        ``source``, the data's own ``estimate`` and its ``se``, the prior's central 95 %
        (``prior_low``, ``prior_median``, ``prior_high``), ``lower_tail`` ``P(Y <=
        estimate)``, the two-sided ``tail_probability`` and ``conflict`` (below
        :data:`~inertiafit.posterior.conflict.CONFLICT_TAIL`). It reads the prior and the
        evidence, not the draws: the same for every sampler seed.
        """
        if ("prior_predictive",) not in self._cache:
            checks = conflict.prior_data_checks(self.tree)
            self._cache[("prior_predictive",)] = pd.DataFrame(
                [
                    {
                        "body": c.body,
                        "quantity": c.quantity,
                        "source": c.source,
                        "estimate": c.estimate,
                        "se": c.se,
                        "prior_low": c.prior_low,
                        "prior_median": c.prior_median,
                        "prior_high": c.prior_high,
                        "lower_tail": c.lower_tail,
                        "tail_probability": c.p,
                        "conflict": c.conflict,
                    }
                    for c in checks
                ],
                columns=PREDICTIVE_COLUMNS,
            )
            self._lines = [c.line() for c in checks if c.conflict]
        return self._cache[("prior_predictive",)].copy()

    def conflict_warnings(self) -> list[str]:
        """One line per quantity in prior-data conflict (names the body and the quantity).

        :func:`~inertiafit.inference.fit.fit_body` issues each as a
        :class:`~inertiafit.errors.PriorDataConflictWarning`; a study's lines are in its
        result's ``warnings``, and ``inertiafit run`` and ``fit`` print them.
        """
        self.prior_predictive()
        return list(self._lines)

    def _checked(self) -> dict[tuple[str, str], float]:
        """The smallest tail probability of each (body, quantity) a check covers."""
        out: dict[tuple[str, str], float] = {}
        table = self.prior_predictive()
        for r in table.itertuples(index=False):
            for body in str(r.body).split("+"):
                key = (body, str(r.quantity))
                out[key] = min(out.get(key, math.inf), float(r.tail_probability))
        return out

    def _sensitivities(self, body: str, specs: dict) -> dict[tuple[str, str], float]:
        """Psense of the body's quantities: to the prior, the whole likelihood, each source.

        Keys ``(what, quantity)``; ``what`` is ``prior`` (priors that are not a box),
        ``likelihood``, and with more than one source each source's name.
        """
        ds = xr.Dataset({p: self.tree["posterior"][p].sel(body=body, drop=True) for p in REPORTED})
        found: dict[tuple[str, str], float] = {}

        def add(what: str, term: xr.DataArray) -> None:
            for q, v in pins.sensitivity(ds, term).items():
                found[(what, q)] = v

        lp = self.tree["log_prior"].to_dataset() if "log_prior" in self.tree.children else None
        if (
            lp is not None
            and "body_prior" in lp
            and not all(not s["gaussian"] for s in specs.values())
        ):
            add("prior", lp["body_prior"].sel(body=body, drop=True))
        if "log_likelihood" in self.tree.children:
            ll = self.tree["log_likelihood"].to_dataset()
            total = sum(
                (ll[v].sum([d for d in ll[v].dims if d not in ("chain", "draw")]) for v in ll),
                xr.zeros_like(ds["mass"]),
            )
            add("likelihood", total)
            terms = pins.source_terms(self.tree, body)
            if len(terms) > 1:
                for name, term in terms.items():
                    add(name, term)
        return found

    def correlations(self) -> pd.DataFrame:
        """Posterior correlations of ``m``, ``x`` and ``rho``: a row per body.

        Columns ``body``, ``corr_m_x``, ``corr_m_rho``, ``corr_x_rho``. On one rotation axis
        the draws lie near the curve of constant ``m x`` and ``I``, so ``m`` and ``x`` are
        strongly anti-correlated unless more information pins them.
        """
        if ("correlations",) not in self._cache:
            self._cache[("correlations",)] = pd.DataFrame(
                pins.correlation_table(self.tree),
                columns=["body", "corr_m_x", "corr_m_rho", "corr_x_rho"],
            )
        return self._cache[("correlations",)].copy()

    def what_pins_what(self) -> dict[str, str]:
        """One line per body naming the information that pins each of its quantities.

        Built from :meth:`identification` (``pinned_by``, ``prior_share``), the sources the
        body has and its prior-data conflicts; e.g. ``"attachment: I and M_g pinned by the
        data; m, x and rho by the data and the prior together (prior share 0.95-1.10) - weigh
        it, ..."``. A living body is not told to weigh or remount it.
        """
        ident = self.identification()
        living = pins.living_bodies(self.tree)
        out = {}
        for body in self.bodies:
            rows = ident[ident.body == body]
            conflicts = [
                pins.SHORT[str(p)]
                for p, c in zip(rows["parameter"], rows["prior_data_conflict"], strict=True)
                if c
            ]
            out[body] = pins.pins_line(
                body,
                rows.to_dict("records"),
                pins.body_sources(self.tree, body),
                living=body in living,
                conflicts=conflicts,
                measured=pins.measured_quantities(self.tree, body),
            )
        return out

    def write_summary(self, path: str | Path, hdi_prob: float = 0.95) -> Path:
        """Write :meth:`summary` as CSV with fixed formatting (same draws → same bytes)."""
        path = Path(path)
        return write_csv(self.summary(hdi_prob), path)

    # -- files ----------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the whole tree to netCDF (HDF5 via h5netcdf)."""
        path = check_path(path)
        if path.is_dir():
            raise InputError(
                f"path: {path} is a folder; give a file name, such as {path / 'posterior.nc'}"
            )
        try:
            self.tree.to_netcdf(path, engine="h5netcdf")
        except OSError as err:
            raise InputError(f"{path}: cannot write it ({err.strerror or err})") from None
        return path

    # -- plots ----------------------------------------------------------------------------
    def corner(
        self,
        body: str | None = None,
        *,
        parameters: tuple[str, ...] = REPORTED,
        truths: dict[str, float] | None = None,
        ideal: dict[str, float] | None = None,
        quantiles: tuple[float, ...] = (0.16, 0.5, 0.84),
        prior_box: bool | str = "band",
        fig=None,
        width: str | float = "double",
        **corner_kwargs,
    ):
        """Corner plot of one body's posterior, in the house style of :mod:`inertiafit.plotting`.

        Parameters
        ----------
        body : str, optional
            Which body; required when there are several.
        parameters : tuple of str
            Quantities to show (default: the three parameters and ``inertia``,
            ``gravity_moment``).
        truths : dict of str to float, optional
            Known values (SI units) drawn as solid lines, e.g. a simulation's truth.
        ideal : dict of str to float, optional
            An ideal (textbook) body's values, drawn as dashed lines in another colour.
        quantiles : tuple of float
            Quantiles marked on the 1-D histograms.
        prior_box : {"band", True, False}
            ``"band"`` (default): the axes of ``mass``, ``com_distance`` and
            ``radius_of_gyration`` are zoomed to the posterior and the prior box is shaded on
            the diagonal, its edges dashed where they fall inside the axes; ``True``: those axes
            span the prior bounds exactly, so one sees where the posterior sits inside the box;
            ``False``: no box. The prior's marginals are drawn in grey on the diagonal.
        fig : matplotlib.figure.Figure, optional
            Figure to draw into (a new one, not managed by pyplot, by default).
        width : {"single", "double"} or float
            Width and height of a new figure: 3.5 in, 7.0 in or inches.
        **corner_kwargs
            Passed on to :func:`corner.corner`.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from inertiafit.plotting import axis_label, corner_figure
        from inertiafit.plotting.corner import posterior_range

        if body is None:
            if len(self.bodies) != 1:
                raise InputError(f"body: choose one of {', '.join(self.bodies)}")
            body = self.bodies[0]
        columns = [self.draws(body, p).ravel() for p in parameters]
        bounds = self.prior_box(body)
        ranges, boxes = [], []
        for p, x in zip(parameters, columns, strict=True):
            box = bounds[p] if prior_box and p in PARAMETERS else None
            ranges.append(
                box if box is not None and prior_box is True else posterior_range(x, box)
            )
            boxes.append(box)
        return corner_figure(
            columns,
            labels=[axis_label(p) for p in parameters],
            titles=[SYMBOLS[p] for p in parameters],
            ranges=ranges,
            boxes=boxes,
            priors=[self.draws(body, p, "prior").ravel() for p in parameters],
            truths=[truths.get(p) for p in parameters] if truths else None,
            ideals=[ideal.get(p) for p in parameters] if ideal else None,
            quantiles=quantiles,
            note=body,
            band=prior_box == "band",
            fig=fig,
            width=width,
            **corner_kwargs,
        )

    # -- display (text and HTML in inertiafit.posterior.display) -------------------------
    def report(self, hdi_prob: float = 0.95) -> str:
        """Readable text: the table with intervals, who identifies what, diagnostics."""
        return display.text_report(self, hdi_prob)

    def __str__(self) -> str:
        return self.report()

    def __repr__(self) -> str:
        return f"<inertiafit.Posterior bodies={list(self.bodies)} converged={self.converged}>"

    def _repr_html_(self) -> str:
        return display.html_table(self, 0.95)


def open_posterior(path: str | Path) -> Posterior:
    """Re-open a saved ``posterior.nc`` (fully loaded; the file is closed afterwards)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: posterior file not found")
    try:
        with xr.open_datatree(path, engine="h5netcdf") as tree:
            loaded = tree.load()
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not a readable posterior file ({exc})") from None
    if "posterior" not in loaded.children:
        raise InputError(f"{path}: no 'posterior' group; not written by inertiafit")
    return Posterior(loaded)


def inputs_json(value: Any) -> str:
    """Stable JSON text for provenance attributes."""
    return json.dumps(value, sort_keys=True, default=str)
