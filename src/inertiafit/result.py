"""The posterior of a fit: an ArviZ DataTree with a table, a corner plot and a text report.

Groups of the tree (ArviZ 1.x conventions, walkers as chains):

``posterior``
    ``mass`` (kg), ``com_distance`` (m), ``radius_of_gyration`` (m), ``inertia`` (kg m^2,
    about the joint) and ``gravity_moment`` (N m), each ``(chain, draw, body)``.
``sample_stats``
    ``lp``: log posterior density of the sampled coordinates (up to a constant).
``log_likelihood``
    ``inertia`` and ``gravity_moment``: one term per condition's evidence.
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

from inertiafit.physics import PARAMETERS, SYMBOLS, UNITS

REPORTED = (*PARAMETERS, "inertia", "gravity_moment")
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


def identification_verdict(ratio: float) -> str:
    """Who decides a parameter: ``data`` (posterior SD < 0.3 prior SD), ``prior`` (> 0.7), or both."""
    if ratio < 0.3:
        return "data"
    if ratio > 0.7:
        return "prior"
    return "data + prior"


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
        """Draws of one parameter of one body, shape ``(chain, draw)``."""
        return np.asarray(self.tree[group][parameter].sel(body=body).values)

    def _prior_box(self, body: str, parameter: str) -> tuple[float, float]:
        cd = self.tree["constant_data"]
        sel = {"body": body, "parameter": parameter}
        return float(cd["lower"].sel(sel)), float(cd["upper"].sel(sel))

    # -- tables ---------------------------------------------------------------------------
    def summary(self, hdi_prob: float = 0.95) -> pd.DataFrame:
        """Table of a row per body and parameter (columns as ``summary.csv``).

        Parameters
        ----------
        hdi_prob : float
            Probability mass of the highest-density interval.
        """
        if not 0 < hdi_prob < 1:
            from inertiafit.errors import InputError

            raise InputError(f"--hdi-prob: expected a probability in (0, 1), got {hdi_prob}")
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
        """Posterior SD over prior SD per body and parameter, with who decides it.

        A ratio near 0 means the data pin the parameter; near 1 the posterior is as wide as
        the prior box, so only the prior speaks. ``minimum_mass`` is the bound
        ``(M_g/g)^2 / I`` at the posterior medians.
        """
        if ("identification",) not in self._cache:
            self._cache[("identification",)] = self._identification()
        return self._cache[("identification",)].copy()

    def _identification(self) -> pd.DataFrame:
        rows = []
        g = float(self.tree["constant_data"]["gravity"])
        for body in self.bodies:
            i_med = float(np.median(self.draws(body, "inertia")))
            mg_med = float(np.median(self.draws(body, "gravity_moment")))
            for p in REPORTED:
                post = float(self.draws(body, p).std())
                prior = float(self.draws(body, p, "prior").std())
                ratio = post / prior
                rows.append(
                    {
                        "body": body,
                        "parameter": p,
                        "posterior_sd": post,
                        "prior_sd": prior,
                        "sd_ratio": ratio,
                        "identified_by": identification_verdict(ratio),
                        "minimum_mass": (mg_med / g) ** 2 / i_med,
                    }
                )
        return pd.DataFrame(rows)

    def write_summary(self, path: str | Path, hdi_prob: float = 0.95) -> Path:
        """Write :meth:`summary` as CSV with fixed formatting (same draws → same bytes)."""
        path = Path(path)
        self.summary(hdi_prob).to_csv(path, index=False, float_format="%.8g", lineterminator="\n")
        return path

    # -- files ----------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the whole tree to netCDF (HDF5 via h5netcdf)."""
        path = Path(path)
        self.tree.to_netcdf(path, engine="h5netcdf")
        return path

    # -- plots ----------------------------------------------------------------------------
    def corner(
        self,
        body: str | None = None,
        *,
        parameters: tuple[str, ...] = REPORTED,
        truths: dict[str, float] | None = None,
        quantiles: tuple[float, ...] = (0.16, 0.5, 0.84),
        prior_box: bool = True,
        fig=None,
        width: str | float = "double",
        **corner_kwargs,
    ):
        """Corner plot of one body's posterior, in the house style of :mod:`inertiafit.plots`.

        Parameters
        ----------
        body : str, optional
            Which body; required when there are several.
        parameters : tuple of str
            Quantities to show (default: the three parameters and ``inertia``,
            ``gravity_moment``).
        truths : dict of str to float, optional
            Known values (SI units) drawn as lines, e.g. an ideal body's.
        quantiles : tuple of float
            Quantiles marked on the 1-D histograms.
        prior_box : bool
            Set the axes of ``mass``, ``com_distance`` and ``radius_of_gyration`` to the prior
            bounds, so one sees where the posterior sits inside the box; the box edges are
            drawn dashed (on the frame unless ``range=`` widens the axes) and the prior's
            marginals in grey on the diagonal.
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
        from inertiafit.plots import axis_label, corner_figure

        if body is None:
            if len(self.bodies) != 1:
                raise ValueError(f"choose a body: one of {', '.join(self.bodies)}")
            body = self.bodies[0]
        columns = [self.draws(body, p).ravel() for p in parameters]
        ranges, boxes = [], []
        for p, x in zip(parameters, columns, strict=True):
            box = self._prior_box(body, p) if prior_box and p in PARAMETERS else None
            if box is None:
                lo, hi = np.quantile(x, [0.001, 0.999])
                pad = 0.1 * (hi - lo)
                ranges.append((float(lo - pad), float(hi + pad)))
            else:
                ranges.append(box)
            boxes.append(box)
        return corner_figure(
            columns,
            labels=[axis_label(p) for p in parameters],
            titles=[SYMBOLS[p] for p in parameters],
            ranges=ranges,
            boxes=boxes,
            priors=[self.draws(body, p, "prior").ravel() for p in parameters],
            truths=[truths.get(p) for p in parameters] if truths else None,
            quantiles=quantiles,
            note=body,
            fig=fig,
            width=width,
            **corner_kwargs,
        )

    # -- display --------------------------------------------------------------------------
    def _table_rows(self, hdi_prob: float) -> list[dict[str, Any]]:
        s = self.summary(hdi_prob)
        ident = self.identification()
        rows = []
        for (_, r), (_, q) in zip(s.iterrows(), ident.iterrows(), strict=True):
            rows.append(
                {**r.to_dict(), "identified_by": q["identified_by"], "sd_ratio": q["sd_ratio"]}
            )
        return rows

    def report(self, hdi_prob: float = 0.95) -> str:
        """Readable text: the table with intervals, who identifies what, diagnostics."""
        a = self.tree.attrs
        pct = f"{100 * hdi_prob:g}% HDI"
        width = max(6, *(len(b) for b in self.bodies)) + 2
        lines = [
            f"inertiafit posterior: {len(self.bodies)} body(ies); {a.get('n_walkers')} walkers x "
            f"{self.tree['posterior'].sizes['draw']} draws kept of {a.get('n_steps')} steps; "
            f"tau {float(a.get('tau_max', math.nan)):.1f} steps; seed {a.get('seed')}; "
            + ("converged" if self.converged else "NOT CONVERGED"),
            (
                f"{'body':<{width}}{'parameter':<28}{'median':>10}  {pct:<24}{'sd':>10}  "
                f"{'R-hat':>6} {'ESS':>6}  identified by (post/prior SD)"
            ),
        ]
        for r in self._table_rows(hdi_prob):
            p = r["parameter"]
            name = f"{p} [{UNITS[p]}]"
            interval = f"[{r['hdi_lower']:.4g}, {r['hdi_upper']:.4g}]"
            lines.append(
                f"{r['body']:<{width}}{name:<28}{r['median']:>10.4g}  {interval:<24}{r['sd']:>10.3g}  "
                f"{r['r_hat']:>6.3f} {r['ess_bulk']:>6.0f}  {r['identified_by']} "
                f"({r['sd_ratio']:.2f})"
            )
        ident = self.identification()
        for body in self.bodies:
            mmin = float(ident.loc[ident.body == body, "minimum_mass"].iloc[0])
            lines.append(
                f"{body}: the data identify m x and I; physical consistency needs "
                f"m >= (M_g/g)^2/I = {mmin:.4g} kg"
            )
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.report()

    def __repr__(self) -> str:
        return f"<inertiafit.Posterior bodies={list(self.bodies)} converged={self.converged}>"

    def _repr_html_(self) -> str:
        import html

        rows = self._table_rows(0.95)
        head = "".join(
            f"<th>{h}</th>"
            for h in (
                "body",
                "parameter",
                "unit",
                "median",
                "95% HDI",
                "sd",
                "R-hat",
                "ESS bulk",
                "identified by",
            )
        )
        body = "".join(
            "<tr>"
            + "".join(
                f"<td>{html.escape(str(v))}</td>"
                for v in (
                    r["body"],
                    r["parameter"],
                    UNITS[r["parameter"]],
                    f"{r['median']:.4g}",
                    f"[{r['hdi_lower']:.4g}, {r['hdi_upper']:.4g}]",
                    f"{r['sd']:.3g}",
                    f"{r['r_hat']:.3f}",
                    f"{r['ess_bulk']:.0f}",
                    f"{r['identified_by']} ({r['sd_ratio']:.2f})",
                )
            )
            + "</tr>"
            for r in rows
        )
        status = "converged" if self.converged else "<b>not converged</b>"
        return (
            f"<div><p><b>inertiafit posterior</b> ({status}, seed {self.tree.attrs.get('seed')})"
            f"</p><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>"
        )


def open_posterior(path: str | Path) -> Posterior:
    """Re-open a saved ``posterior.nc`` (fully loaded; the file is closed afterwards)."""
    from inertiafit.errors import InputError

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
