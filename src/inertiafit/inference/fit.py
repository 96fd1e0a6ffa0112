"""Where the posterior is sampled: a model's evidence → a :class:`~inertiafit.posterior.Posterior`.

:func:`fit` checks the model, runs the sampler (:mod:`inertiafit.inference.sampler`) and
packages the draws, the evidence, the prior and the provenance as an ArviZ DataTree
(:func:`build_tree`); :func:`fit_body` does it for one body from reported numbers.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Sequence
from importlib.metadata import version

import numpy as np
import xarray as xr

from inertiafit._checks import check_seed
from inertiafit.errors import PriorDataConflictWarning
from inertiafit.inference.evidence import evidence_from_numbers, measurement_observations
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.priors import Prior, load_prior
from inertiafit.inference.sampler import SamplerSettings, sample
from inertiafit.inference.terms import TERM_KINDS, Term
from inertiafit.measured import Measurement, measurements
from inertiafit.physics import GRAVITY, PARAMETERS, REPORTED, UNITS
from inertiafit.posterior import Posterior, inputs_json

__all__ = ["N_PRIOR_DRAWS", "build_tree", "fit", "fit_body"]

N_PRIOR_DRAWS = 4000


def _versions() -> dict[str, str]:
    return dict(_installed_versions())


@functools.cache
def _installed_versions() -> dict[str, str]:
    # Reading the installed packages' metadata costs a tenth of a small fit; they do not
    # change while the process runs.
    out = {}
    for pkg in ("inertiafit", "emcee", "arviz", "numpy", "scipy", "xarray"):
        try:
            out[pkg] = version(pkg)
        except Exception:  # noqa: BLE001 - provenance only
            out[pkg] = "unknown"
    return out


def _term_data(model: Model) -> tuple[dict[str, xr.DataArray], dict[str, xr.DataArray]]:
    """The ``observed_data`` and ``constant_data`` variables, as every kind of term gives them.

    Each registered kind (:data:`~inertiafit.inference.terms.TERM_KINDS`, in its order) is
    asked once for its terms of the model (:meth:`~inertiafit.inference.terms.Term.data`).
    """
    observed: dict[str, xr.DataArray] = {}
    constant: dict[str, xr.DataArray] = {}
    for kind in TERM_KINDS.values():
        data = kind.data([t for t in model.terms if isinstance(t, kind)], model.bodies)
        for out, group in ((observed, data.observed), (constant, data.constant)):
            for name, d in group.items():
                if name in observed or name in constant:
                    raise ValueError(f"{kind.kind} term: variable '{name}' is written twice")
                out[name] = xr.DataArray(
                    d.values,
                    dims=d.dims,
                    coords=dict(d.coords),
                    attrs={"units": d.units} if d.units else {},
                )
    return observed, constant


def _sources(model: Model) -> dict[str, dict[str, str]]:
    """Each ``log_likelihood`` variable's attributes: its term kind's :class:`Source`."""
    out: dict[str, dict[str, str]] = {}
    for t in model.terms:
        for var in t.variables:
            out.setdefault(var, type(t).SOURCES[var].attrs())
    return out


def _log_prior(model: Model, run, coords: dict) -> xr.Dataset:
    """The ``log_prior`` group: the prior's log density at every posterior draw.

    ``body_prior`` ``(chain, draw, body)`` is :meth:`Prior.log_density` of the body's drawn
    ``(m, x, rho)`` (up to a constant per body; constant on a box); ``torque_gain``
    ``(chain, draw)``, with a torque gain, the normal log density of ``log gain`` (how the model
    states that prior). ``arviz_stats.psense`` (``group="prior"``) sums every variable.
    """
    params = run.parameters
    body_prior = np.stack(
        [
            model.priors[body].log_density(
                params["mass"][..., k],
                params["com_distance"][..., k],
                params["radius_of_gyration"][..., k],
            )
            for k, body in enumerate(model.bodies)
        ],
        -1,
    )
    out = {
        "body_prior": xr.DataArray(
            body_prior,
            dims=("chain", "draw", "body"),
            attrs={"description": "log p(m, x, rho) of the body's prior, up to a constant"},
        )
    }
    if model.has_gain:
        sd = model.torque_gain_sd
        z = np.log(params["torque_gain"]) / sd
        out["torque_gain"] = xr.DataArray(
            -0.5 * z * z - math.log(sd) - 0.5 * math.log(2 * math.pi),
            dims=("chain", "draw"),
            attrs={"description": "log density of log(torque gain) ~ N(0, torque_gain_sd^2)"},
        )
    return xr.Dataset(out, coords=coords)


def build_tree(
    model: Model,
    run,
    *,
    seed: int,
    inputs: dict | None = None,
    provenance: dict | None = None,
) -> xr.DataTree:
    """Package a sampler run and its model as an ArviZ DataTree (see :mod:`inertiafit.posterior`).

    ``inputs`` and ``provenance`` are stored as JSON in the root attributes of those names.
    """
    bodies = list(model.bodies)
    n_chain, n_draw = run.chain.shape[:2]
    coords = {"chain": np.arange(n_chain), "draw": np.arange(n_draw), "body": bodies}
    posterior = xr.Dataset(
        {
            p: xr.DataArray(
                run.parameters[p], dims=("chain", "draw", "body"), attrs={"units": UNITS[p]}
            )
            for p in REPORTED
        },
        coords=coords,
    )
    if model.has_gain:
        posterior["torque_gain"] = xr.DataArray(
            run.parameters["torque_gain"], dims=("chain", "draw"), attrs={"units": "1"}
        )
    prior_rng = np.random.default_rng([seed, 2])
    pd_ = model.prior_draws(N_PRIOR_DRAWS, prior_rng)
    prior = xr.Dataset(
        {
            p: xr.DataArray(
                pd_[p][None], dims=("chain", "draw", "body"), attrs={"units": UNITS[p]}
            )
            for p in REPORTED
        },
        coords={"chain": [0], "draw": np.arange(N_PRIOR_DRAWS), "body": bodies},
    )
    if model.has_gain:
        prior["torque_gain"] = xr.DataArray(
            pd_["torque_gain"][None], dims=("chain", "draw"), attrs={"units": "1"}
        )
    terms = model.log_likelihood_terms(
        run.chain, run.parameters["mass"] if model.has_extra else None
    )
    sources = _sources(model)
    ll_vars = {
        var: xr.DataArray(
            terms[var], dims=("chain", "draw", dim), coords={dim: labels}, attrs=sources[var]
        )
        for var, (dim, labels) in model.likelihood_coords().items()
    }
    log_likelihood = xr.Dataset(ll_vars, coords={"chain": coords["chain"], "draw": coords["draw"]})
    sample_stats = xr.Dataset(
        {"lp": xr.DataArray(run.log_prob, dims=("chain", "draw"))},
        coords={"chain": coords["chain"], "draw": coords["draw"]},
    )
    box = {
        key: xr.DataArray(
            np.array([[getattr(model.priors[b], key)[p] for p in PARAMETERS] for b in bodies]),
            dims=("body", "parameter"),
        )
        for key in ("nominal", "lower", "upper")
    }
    observed, term_constants = _term_data(model)
    # One constructor: adding variables one at a time (or merging) aligns them each time.
    constant = xr.Dataset(
        {
            **box,
            "gravity": xr.DataArray(model.gravity, attrs={"units": "m s-2"}),
            "torque_gain_sd": xr.DataArray(model.torque_gain_sd, attrs={"units": "1"}),
            **term_constants,
        },
        coords={
            "body": bodies,
            "parameter": list(PARAMETERS),
            "condition": [c.label for c in model.conditions],
        },
    )
    attrs = {
        "inertiafit_version": _versions()["inertiafit"],
        "versions": inputs_json(_versions()),
        "seed": int(seed),
        "converged": int(run.converged),
        "n_walkers": int(n_chain),
        "n_steps": int(run.n_steps),
        "burn": int(run.burn),
        "tau": inputs_json([float(t) for t in run.tau]),
        "tau_max": float(np.max(run.tau)),
        "acceptance": float(run.acceptance),
        **{  # the blocked sampler's rate per update (shared, leaves, joint)
            key: float(value)
            for key, value in run.diagnostics.items()
            if key.startswith("acceptance_") and math.isfinite(value)
        },
        "sampling_seconds": float(run.seconds),
        "moves": run.moves or run.settings.moves,
        "ess_min_target": float(run.settings.ess_min),
        "r_hat_max_target": float(run.settings.r_hat_max),
        "priors": inputs_json(
            {
                b: {
                    "source": model.priors[b].source,
                    "description": model.priors[b].description,
                    "name": model.priors[b].name,
                    "reference": model.priors[b].reference,
                    "distribution": model.priors[b].distribution,
                    "anthropometric": model.priors[b].anthropometric,
                }
                for b in bodies
            }
        ),
        "inputs": inputs_json(inputs or {}),
        "provenance": inputs_json(provenance or {}),
        "sampled_coordinates": (
            "log(m·x), log(I) per body (observed scale: times the torque gain), then log gain "
            "when torque_gain_sd > 0; psi = atan(x / rho) drawn exactly"
            if model.has_gain
            else "log(m·x), log(I) per body; psi = atan(x / rho) drawn exactly"
        ),
    }
    return xr.DataTree.from_dict(
        {
            "/": xr.Dataset(attrs=attrs),
            "posterior": posterior,
            "sample_stats": sample_stats,
            "log_likelihood": log_likelihood,
            "log_prior": _log_prior(model, run, coords),
            "observed_data": xr.Dataset(observed),
            "prior": prior,
            "constant_data": constant,
        }
    )


def fit(
    model: Model,
    *,
    seed: int = 0,
    settings: SamplerSettings | None = None,
    inputs: dict | None = None,
    provenance: dict | None = None,
) -> Posterior:
    """Sample the posterior of a model and return it as a :class:`Posterior`.

    Parameters
    ----------
    model : Model
        Bodies, prior boxes and evidence.
    seed : int
        Seed for every random draw; same seed and inputs give the same result.
    settings : SamplerSettings, optional
        Sampler knobs.
    inputs : dict, optional
        What the evidence came from, stored in the result's ``inputs`` attribute (JSON).
    provenance : dict, optional
        Input files' SHA-256 and reader settings, stored in the ``provenance`` attribute
        (JSON; see :func:`inertiafit.pipeline.study.study_provenance`).
    """
    seed = check_seed(seed)
    model.check_feasible()
    run = sample(model, seed=seed, settings=settings)
    return Posterior(build_tree(model, run, seed=seed, inputs=inputs, provenance=provenance))


def fit_body(
    prior: Prior | str,
    *,
    inertia: float | Sequence[float],
    gravity_moment: float | Sequence[float],
    inertia_se: float | None = None,
    inertia_sd: float | None = None,
    inertia_n: int | None = None,
    gravity_moment_se: float | None = None,
    gravity_moment_sd: float | None = None,
    gravity_moment_n: int | None = None,
    gravity: float = GRAVITY,
    torque_gain_sd: float = 0.0,
    seed: int = 0,
    settings: SamplerSettings | None = None,
    mass: float | None = None,
    mass_sd: float | None = None,
    com_distance: float | None = None,
    com_distance_sd: float | None = None,
    terms: Sequence[Term] = (),
    measured: Sequence[Measurement] = (),
) -> Posterior:
    """Posterior of one body from reported numbers.

    Parameters
    ----------
    prior : Prior or str
        The body's prior box, or a shipped prior's name or a file path.
    inertia : float or sequence of float
        Moment of inertia about the joint (kg m^2): repeated trial values, or one value with
        ``inertia_se`` (its standard error) or with ``inertia_sd`` and ``inertia_n`` (a mean of
        ``n`` trials with their SD).
    gravity_moment : float or sequence of float
        Gravitational moment ``m g x`` (N m), given the same ways.
    gravity : float
        m/s^2.
    torque_gain_sd : float
        Relative SD of the torque channel's gain (calibration), carried as a nuisance
        parameter; 0 leaves it out (the result says so).
    seed : int
        Seed of every random draw.
    mass, mass_sd : float, optional
        The body weighed on a scale (kg) and that reading's SD (kg; a reading rounded to a
        step ``q`` alone has the SD ``q / sqrt(12)``): a Gaussian term of the posterior.
        The same as ``measured=measurements(mass=(mass, mass_sd))``.
    com_distance, com_distance_sd : float, optional
        A balance point: the centre of mass's distance from the joint axis (m) and its SD (m).
    terms : sequence of Term, optional
        Further evidence (:mod:`inertiafit.inference.terms`, any registered kind), on the
        body named after the prior.
    measured : sequence of Measurement, optional
        Direct measurements of the body (:class:`~inertiafit.measured.Measurement`, any
        quantity of :data:`~inertiafit.measured.MEASURED_QUANTITIES`), each a Gaussian term;
        with the keyword pairs above, each quantity once.

    Returns
    -------
    Posterior
        The body is named after the prior.

    Warns
    -----
    PriorDataConflictWarning
        One per quantity the data put where the prior allows almost nothing
        (:meth:`~inertiafit.posterior.Posterior.conflict_warnings`; :func:`fit` leaves them to
        its caller, and a study keeps them in its result's ``warnings``).
    """
    seed = check_seed(seed)
    prior = load_prior(prior)
    given = measurements(mass=(mass, mass_sd), com_distance=(com_distance, com_distance_sd))
    readings = measurement_observations((*measured, *given))
    obs_i = evidence_from_numbers("inertia", inertia, inertia_se, inertia_sd, inertia_n)
    obs_g = evidence_from_numbers(
        "gravity_moment", gravity_moment, gravity_moment_se, gravity_moment_sd, gravity_moment_n
    )
    model = Model(
        {prior.name: prior},
        [Condition((prior.name,), obs_i, obs_g)],
        gravity=gravity,
        torque_gain_sd=torque_gain_sd,
        measured={prior.name: readings} if readings else None,
        terms=terms,
    )
    inputs = {
        "prior": prior.name,
        "inertia": {
            "center": obs_i.center,
            "scale": obs_i.scale,
            "df": obs_i.df,
            "values": list(obs_i.values),
        },
        "gravity_moment": {
            "center": obs_g.center,
            "scale": obs_g.scale,
            "df": obs_g.df,
            "values": list(obs_g.values),
        },
        "gravity": gravity,
        "torque_gain_sd": torque_gain_sd,
    }
    if readings:
        inputs["measured"] = {k: [obs.center, obs.scale] for k, obs in readings.items()}
    post = fit(model, seed=seed, settings=settings, inputs=inputs)
    for line in post.conflict_warnings():
        warnings.warn(line, PriorDataConflictWarning, stacklevel=2)
    return post
