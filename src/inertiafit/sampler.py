"""Run emcee on a :class:`~inertiafit.model.Model` until it has converged.

The walkers explore ``(log a, log b)`` per body (see :mod:`inertiafit.model`), where the
posterior is close to Gaussian and axis-aligned. The default moves are 70 % independence
Metropolis-Hastings from heavy-tailed proposals around the Laplace approximation
(:class:`IndependenceMove`), 20 % differential evolution and 10 % DE-snooker; ``"de"`` (80/20
DE/snooker) and ``"stretch"`` remain available. Sampling runs in chunks; after each chunk the
integrated autocorrelation time ``tau`` of every coordinate is estimated, the first
``burn_factor * tau`` steps are dropped, and the run stops when

* the chain is longer than ``50 tau`` for every coordinate,
* the rank-normalised split R-hat of every reported parameter is at most ``r_hat_max``, and
* the bulk ESS of every reported parameter is at least ``ess_min``,

or when ``max_steps`` is reached, with a :class:`~inertiafit.errors.ConvergenceWarning`.
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.model import Model

REPORTED = ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment")


@dataclass
class SamplerSettings:
    """Knobs of :func:`sample`; the defaults are what the command line uses.

    Attributes
    ----------
    n_walkers : int
        emcee's ensemble size (raised to ``2 * ndim + 2`` if smaller), or the number of
        independent chains of the blocked sampler.
    chunk : int
        Steps (blocked sampler: sweeps) between convergence checks.
    max_steps : int
        Bound on the total number of steps.
    ess_min : float
        Target bulk effective sample size of every reported parameter.
    r_hat_max : float
        Largest acceptable rank-normalised R-hat.
    tau_factor : float
        The chain must be longer than ``tau_factor * tau``.
    burn_factor : float
        Steps dropped at the start, in units of ``tau``.
    moves : str
        ``"auto"`` (default): ``"blocked"`` for a model of two or more bodies that
        :func:`inertiafit.blocked.star_structure` decomposes (an attachment measured alone
        and with each segment), else ``"independent"``.
        ``"blocked"``: the two-block Gibbs sampler of :mod:`inertiafit.blocked` (chains are
        independent, ``n_walkers`` of them; cost linear in the number of segments).
        ``"independent"``: emcee with 70 % independence Metropolis-Hastings from a Student-t
        around the Laplace approximation, 20 % DE, 10 % DE-snooker. ``"de"`` (80 % DE,
        20 % DE-snooker) or ``"stretch"`` (emcee's default move).
    progress : bool or None
        Progress line on stderr; ``None`` shows it only on a terminal.
    """

    n_walkers: int = 32
    chunk: int = 250
    max_steps: int = 20_000
    ess_min: float = 1000.0
    r_hat_max: float = 1.01
    tau_factor: float = 50.0
    burn_factor: float = 3.0
    moves: str = "auto"
    progress: bool | None = None
    extra: dict = field(default_factory=dict)


@dataclass
class SamplerRun:
    """What :func:`sample` returns: kept draws and diagnostics.

    Attributes
    ----------
    chain : ndarray, shape (n_walkers, n_draws, ndim)
        Kept sampled coordinates ``(log a, log b)`` per body, walkers as chains.
    log_prob : ndarray, shape (n_walkers, n_draws)
        Log posterior density of the kept draws (sampled coordinates, up to a constant).
    parameters : dict of str to ndarray
        Physical parameters, each ``(n_walkers, n_draws, n_bodies)``.
    tau : ndarray, shape (ndim,)
        Integrated autocorrelation time of each sampled coordinate (steps).
    n_steps, burn : int
        Steps taken in all and steps dropped at the start.
    acceptance : float
        Mean acceptance fraction.
    converged : bool
        Whether every criterion was met before ``max_steps``.
    seconds : float
        Wall time of the sampling.
    moves : str
        The sampler that ran (``"auto"`` resolved).
    """

    chain: np.ndarray
    log_prob: np.ndarray
    parameters: dict[str, np.ndarray]
    tau: np.ndarray
    n_steps: int
    burn: int
    acceptance: float
    converged: bool
    seconds: float
    settings: SamplerSettings
    diagnostics: dict[str, float] = field(default_factory=dict)
    moves: str = ""


def _least_squares_start(model: Model) -> np.ndarray:
    """Bodies' ``(a, b)`` that reproduce the evidence, pulled weakly toward their nominals.

    The evidence is linear in ``(a, b)`` (sums over mounted bodies), so a ridge least-squares
    solve gives a start near the mode even for many bodies; where the evidence cannot tell bodies
    apart, the nominal values (weight 1 / (0.5 nominal)) decide.
    """
    k = len(model.bodies)
    rows, rhs = [], []
    for ci, cond in enumerate(model.conditions):
        w = model.membership[ci]
        if cond.gravity_moment is not None:
            obs = cond.gravity_moment
            rows.append(np.concatenate([model.gravity * w, np.zeros(k)]) / obs.scale)
            rhs.append(obs.center / obs.scale)
        if cond.inertia is not None:
            obs = cond.inertia
            rows.append(np.concatenate([np.zeros(k), w]) / obs.scale)
            rhs.append(obs.center / obs.scale)
    for j, body in enumerate(model.bodies):
        nom = model.priors[body].nominal
        a0 = nom["mass"] * nom["com_distance"]
        b0 = nom["mass"] * (nom["radius_of_gyration"] ** 2 + nom["com_distance"] ** 2)
        for col, value in ((j, a0), (k + j, b0)):
            row = np.zeros(2 * k)
            row[col] = 1 / (0.5 * value)
            rows.append(row)
            rhs.append(value / (0.5 * value))
    sol = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    sol = np.maximum(sol, 1e-9)
    z = np.empty(2 * k)
    z[0::2], z[1::2] = np.log(sol[:k]), np.log(sol[k:])
    return z


def _hessian(f, x: np.ndarray, h: float = 1e-4) -> np.ndarray:
    """Central-difference Hessian of a vectorised function ``f(rows) -> values``, one call."""
    d = len(x)
    eye = np.eye(d) * h
    iu, ju = np.triu_indices(d)
    pts = np.concatenate(
        [
            x + eye[iu] + eye[ju],
            x + eye[iu] - eye[ju],
            x - eye[iu] + eye[ju],
            x - eye[iu] - eye[ju],
        ]
    )
    v = f(pts).reshape(4, -1)
    hess = np.empty((d, d))
    hess[iu, ju] = (v[0] - v[1] - v[2] + v[3]) / (4 * h * h)
    hess[ju, iu] = hess[iu, ju]
    return hess


def _laplace(model: Model, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Mode of the posterior in sampled coordinates and the inverse curvature there."""
    from scipy import optimize

    prior = model.prior_draws(4000, rng)
    z0 = np.empty((prior["inertia"].shape[0], model.ndim))
    z0[:, 0::2] = np.log(prior["gravity_moment"] / model.gravity)
    z0[:, 1::2] = np.log(prior["inertia"])
    z0 = np.vstack([_least_squares_start(model), z0])
    lp = model.log_prob(z0)
    if not np.isfinite(lp).any():
        raise InputError("model: no draw from the prior boxes has a finite posterior density")
    best = z0[np.argsort(lp)[-3:]]

    def neg(z):
        v = model.log_prob(z)
        return np.where(np.isfinite(v), -v, 1e300)

    def neg_and_grad(z, h=1e-6):
        pts = np.vstack([z, z + np.eye(len(z)) * h])
        v = neg(pts)
        return v[0], (v[1:] - v[0]) / h

    fits = []
    for b in best:
        if model.ndim <= 4:
            fits.append(
                optimize.minimize(
                    lambda z: neg(z)[0],
                    b,
                    method="Nelder-Mead",
                    options={"xatol": 1e-9, "fatol": 1e-9, "maxiter": 4000},
                )
            )
        else:
            fits.append(optimize.minimize(neg_and_grad, b, jac=True, method="L-BFGS-B"))
    mode = min(fits, key=lambda f: f.fun).x
    if not np.isfinite(model.log_prob(mode)[0]):
        raise InputError("model: could not find a point of finite posterior density")
    hess = _hessian(neg, mode)
    try:
        cov = np.linalg.inv(hess)
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        cov = np.diag(np.full(model.ndim, 1e-6))
    return mode, cov


def _initial_walkers(
    model: Model, n_walkers: int, mode: np.ndarray, cov: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Walkers inside the support, spread like the posterior near its mode."""
    d = model.ndim
    walkers = np.empty((0, d))
    for _ in range(200):
        cand = rng.multivariate_normal(mode, cov, size=4 * n_walkers)
        walkers = np.vstack([walkers, cand[np.isfinite(model.log_prob(cand))]])
        if len(walkers) >= n_walkers:
            return walkers[:n_walkers]
        cov = cov / 4
    raise InputError("model: could not place the walkers inside the prior boxes")


class IndependenceMove:
    """Metropolis-Hastings with proposals drawn independently of the walker's position.

    Proposals come from a product of independent Student-t variables (``df`` degrees of
    freedom) along the Cholesky axes of the Laplace covariance (widened by ``inflate``), centred
    on the posterior mode. The posterior of the identified coordinates is close to Gaussian, so
    most proposals are accepted and successive draws are nearly independent. Independent
    heavy-tailed axes matter when the evidence is a Student-t from few trials: each condition's
    total then has heavy tails of its own, which one shared multivariate-t scale covers badly
    (measured: tau 25-30 steps against 5 with three trials per condition). The proposal is
    fixed before sampling starts, so detailed balance holds.
    """

    def __init__(self, mean: np.ndarray, cov: np.ndarray, *, df: float = 5.0, inflate=1.2):
        import emcee

        self.mean = np.asarray(mean, float)
        self.chol = np.linalg.cholesky(np.asarray(cov, float) * inflate**2)
        self.chol_inv = np.linalg.inv(self.chol)
        self.df = float(df)
        self._mh = emcee.moves.MHMove(self._proposal)

    def _log_q(self, x: np.ndarray) -> np.ndarray:
        r = (x - self.mean) @ self.chol_inv.T
        return (-0.5 * (self.df + 1) * np.log1p(r * r / self.df)).sum(1)

    def _proposal(self, coords, random):
        y = random.standard_t(self.df, size=coords.shape)
        new = self.mean + y @ self.chol.T
        return new, self._log_q(coords) - self._log_q(new)

    def propose(self, model, state):
        """Propose for every walker and accept by the Metropolis-Hastings rule (emcee API)."""
        return self._mh.propose(model, state)

    def tune(self, state, accepted):
        """Nothing to tune: the proposal is fixed (emcee API)."""


def _proposal_df(model: Model) -> float:
    """Degrees of freedom of the independence proposal: no lighter-tailed than the evidence.

    A Student-t likelihood from few trials (3 trials: 2 d.o.f.) has heavy tails; a proposal with
    lighter tails than the target visits them too rarely and mixes slowly there.
    """
    dfs = [
        obs.df
        for cond in model.conditions
        for obs in (cond.inertia, cond.gravity_moment)
        if obs is not None and not obs.is_gaussian
    ]
    return float(min([5.0, *dfs]))


def _moves(kind: str, mode: np.ndarray, cov: np.ndarray, df: float = 5.0):
    import emcee

    if kind == "de":
        return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    if kind == "independent":
        return [
            (IndependenceMove(mode, cov, df=df), 0.7),
            (emcee.moves.DEMove(), 0.2),
            (emcee.moves.DESnookerMove(), 0.1),
        ]
    assert kind == "stretch", kind  # names are checked by resolve_moves
    return [(emcee.moves.StretchMove(), 1.0)]


def _progress(enabled: bool, steps: int, max_steps: int, tau: float, ess: float, t0: float):
    if enabled:
        sys.stderr.write(
            f"\rsampling: {steps:>6d}/{max_steps} steps  tau {tau:5.1f}  "
            f"min ESS {ess:7.0f}  {time.perf_counter() - t0:5.1f} s"
        )
        sys.stderr.flush()


def _checks(params: dict[str, np.ndarray]) -> tuple[float, float]:
    """Smallest bulk ESS and largest R-hat over every reported quantity, in one pass each."""
    from arviz_stats.base import array_stats

    # (walkers, draws, bodies) per quantity -> (quantities * bodies, chains, draws)
    stack = np.concatenate([np.moveaxis(v, -1, 0) for v in params.values()])
    ess = array_stats.ess(stack, chain_axis=-2, draw_axis=-1, method="bulk")
    rhat = array_stats.rhat(stack, chain_axis=-2, draw_axis=-1)
    return float(np.min(ess)), float(np.max(rhat))


def resolve_moves(model: Model, moves: str) -> str:
    """The sampler ``moves`` stands for on this model (``"auto"`` decided, names checked)."""
    from inertiafit.blocked import star_structure

    if moves not in ("auto", "blocked", "independent", "de", "stretch"):
        raise InputError(
            f"sampler: unknown moves '{moves}' "
            "(expected 'auto', 'blocked', 'independent', 'de' or 'stretch')"
        )
    if moves not in ("auto", "blocked"):
        return moves
    if star_structure(model) is None:
        if moves == "blocked":
            raise InputError(
                "sampler: moves 'blocked' needs bodies mounted in one condition each beside "
                "shared bodies that are also measured on their own; this model has none"
            )
        return "independent"
    return "blocked" if moves == "blocked" or len(model.bodies) >= 2 else "independent"


class _EmceeChains:
    """emcee's ensemble with the joint moves (``independent``, ``de``, ``stretch``)."""

    def __init__(self, model: Model, moves: str, n_walkers: int, seed: int) -> None:
        import emcee

        rng = np.random.default_rng(seed)
        d = model.ndim
        n_walkers = max(n_walkers, 2 * d + 2)
        mode, cov = _laplace(model, rng)
        self.state = _initial_walkers(model, n_walkers, mode, cov, rng)
        self.sampler = emcee.EnsembleSampler(
            n_walkers,
            d,
            model.log_prob,
            moves=_moves(moves, mode, cov, _proposal_df(model)),
            vectorize=True,
        )
        # emcee draws from a copy of numpy's global RandomState taken at construction: seed it.
        self.sampler.random_state = np.random.RandomState(seed).get_state()

    def run(self, steps: int) -> None:
        self.state = self.sampler.run_mcmc(self.state, steps, progress=False)

    @property
    def n_steps(self) -> int:
        return int(self.sampler.iteration)

    def chain(self) -> np.ndarray:
        """Every step so far, ``(steps, walkers, ndim)``."""
        return self.sampler.get_chain()

    def log_prob(self, burn: int) -> np.ndarray:
        """Log density of the draws after ``burn``, ``(walkers, draws)`` (emcee stored it)."""
        return np.swapaxes(self.sampler.get_log_prob()[burn:], 0, 1)

    def acceptance(self) -> dict[str, float]:
        return {"acceptance": float(np.mean(self.sampler.acceptance_fraction))}


class _BlockedChains:
    """The blocked Gibbs sampler of :mod:`inertiafit.blocked`, chains as walkers."""

    def __init__(self, model: Model, star, n_walkers: int, seed: int) -> None:
        from inertiafit.blocked import BlockedGibbs

        if star.shared:
            shared = BlockedGibbs.shared_submodel(model, star)
            mode, cov = _laplace(shared, np.random.default_rng(seed))
            df = _proposal_df(shared)
        else:
            mode, cov, df = np.zeros(0), np.zeros((0, 0)), 5.0
        self.model = model
        self.gibbs = BlockedGibbs(model, star, mode, cov, df)
        self.random = np.random.default_rng([seed, 3])
        self.state = self.gibbs.start(n_walkers, self.random)
        self.steps: list[np.ndarray] = []
        self.n_steps = 0

    def run(self, steps: int) -> None:
        block = np.empty((steps, len(self.state[1]), self.model.ndim))
        for i in range(steps):
            self.state = self.gibbs.sweep(*self.state, self.random)
            block[i] = self.gibbs.joint_coordinates(*self.state)
        self.steps.append(block)
        self.n_steps += steps

    def chain(self) -> np.ndarray:
        """Every sweep so far, ``(sweeps, chains, ndim)``."""
        if len(self.steps) > 1:
            self.steps = [np.concatenate(self.steps)]
        return self.steps[0]

    def log_prob(self, burn: int) -> np.ndarray:
        """Log density of the draws after ``burn``, ``(chains, draws)`` (computed: none kept)."""
        kept = np.swapaxes(self.chain()[burn:], 0, 1)
        return self.model.log_prob(kept.reshape(-1, self.model.ndim)).reshape(kept.shape[:2])

    def acceptance(self) -> dict[str, float]:
        rates = self.gibbs.acceptance
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # nan for a block that never ran
            mean = float(np.nanmean(list(rates.values())))
        return {"acceptance": mean, **rates}


def sample(model: Model, *, seed: int = 0, settings: SamplerSettings | None = None) -> SamplerRun:
    """Sample the posterior of ``model`` until converged.

    Parameters
    ----------
    model : Model
        Bodies, priors and evidence.
    seed : int
        Seeds the walkers' start, the sampler's random state and the exact angle draws; the
        same seed and inputs give the same draws.
    settings : SamplerSettings, optional
        Walkers, chunk size, step bound, convergence targets and the sampler (``moves``).

    Returns
    -------
    SamplerRun
        Kept draws and diagnostics.

    Warns
    -----
    ConvergenceWarning
        When ``max_steps`` is reached before every criterion is met.
    """
    import emcee

    s = settings or SamplerSettings()
    moves = resolve_moves(model, s.moves)
    d = model.ndim
    chains: _EmceeChains | _BlockedChains
    if moves == "blocked":
        from inertiafit.blocked import star_structure

        chains = _BlockedChains(model, star_structure(model), s.n_walkers, seed)
    else:
        chains = _EmceeChains(model, moves, s.n_walkers, seed)
    show = sys.stderr.isatty() if s.progress is None else s.progress
    t0 = time.perf_counter()
    converged = False
    tau = np.full(d, np.nan)
    burn = 0
    params: dict[str, np.ndarray] = {}
    diag: dict[str, float] = {}
    while chains.n_steps < s.max_steps:
        # Chunks grow with the chain, so the diagnostics cost a bounded share of the run.
        steps = min(max(s.chunk, chains.n_steps // 4), s.max_steps - chains.n_steps)
        chains.run(steps)
        chain = chains.chain()  # (steps, walkers, dim)
        tau = emcee.autocorr.integrated_time(chain, quiet=True, tol=0)
        tau_max = float(np.max(tau))
        burn = min(math.ceil(s.burn_factor * tau_max), chains.n_steps // 2)
        kept = np.swapaxes(chain[burn:], 0, 1)  # (walkers, draws, dim)
        long_enough = chains.n_steps > s.tau_factor * tau_max
        if not long_enough and chains.n_steps < s.max_steps:
            # ESS and R-hat of every quantity cost more than the steps: wait for 50 tau.
            diag = {"ess_bulk_min": math.nan, "r_hat_max": math.nan, "tau_max": tau_max}
            _progress(show, chains.n_steps, s.max_steps, tau_max, math.nan, t0)
            continue
        params = model.parameters(kept, np.random.default_rng([seed, 1]))
        ess_min, rhat_max = _checks(params)
        diag = {"ess_bulk_min": ess_min, "r_hat_max": rhat_max, "tau_max": tau_max}
        _progress(show, chains.n_steps, s.max_steps, tau_max, ess_min, t0)
        if long_enough and rhat_max <= s.r_hat_max and ess_min >= s.ess_min:
            converged = True
            break
    if show:
        sys.stderr.write("\n")
    if not converged:
        warnings.warn(
            f"sampler stopped at max_steps={s.max_steps} before converging "
            f"(tau {diag.get('tau_max', math.nan):.1f} steps, min bulk ESS "
            f"{diag.get('ess_bulk_min', math.nan):.0f}, max R-hat "
            f"{diag.get('r_hat_max', math.nan):.3f}); treat the intervals with care",
            ConvergenceWarning,
            stacklevel=2,
        )
    log_prob = chains.log_prob(burn)
    accept = chains.acceptance()
    return SamplerRun(
        chain=kept,
        log_prob=log_prob,
        parameters=params,
        tau=np.asarray(tau),
        n_steps=chains.n_steps,
        burn=burn,
        acceptance=accept.pop("acceptance"),
        converged=converged,
        seconds=time.perf_counter() - t0,
        settings=s,
        diagnostics={**diag, **accept},
        moves=moves,
    )
