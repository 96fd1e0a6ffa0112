"""Run emcee on a :class:`~inertiafit.inference.model.Model` until it has converged.

The walkers explore ``(log a, log b)`` per body (see :mod:`inertiafit.inference.model`), where the
posterior is close to Gaussian and axis-aligned. The default moves are 70 % independence
Metropolis-Hastings from heavy-tailed proposals around the Laplace approximation
(:class:`~inertiafit.inference.moves.IndependenceMove`), 20 % differential evolution and 10 %
DE-snooker; ``"de"`` (80/20 DE/snooker) and ``"stretch"`` remain available. The proposals and
the Laplace fit live in :mod:`inertiafit.inference.moves`. Sampling runs in chunks; after each
chunk the integrated autocorrelation time ``tau`` of every coordinate is estimated, the first
``burn_factor * tau`` steps are dropped, and the run stops when

* the chain is longer than ``50 tau`` for every coordinate,
* the rank-normalised split R-hat of every reported parameter is at most ``r_hat_max``, and
* the bulk ESS of every reported parameter is at least ``ess_min``,

or when ``max_steps`` is reached, with a :class:`~inertiafit.errors.ConvergenceWarning`. Where
``tau`` cannot be estimated (a coordinate that never moved), the chain counts as too short and
the first half is dropped. The blocked sampler re-fits its proposal once, the first time the
chain is too short (see :class:`_BlockedChains`).
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from inertiafit._checks import (
    check_interval,
    check_non_negative,
    check_positive,
    check_seed,
    check_whole,
)
from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.inference.blocked import BlockedGibbs
from inertiafit.inference.model import Model
from inertiafit.inference.moves import (
    MOVES,
    IndependenceMove,
    emcee_moves,
    laplace_fit,
    proposal_df,
    run_steps,
)
from inertiafit.inference.star import Star, star_structure

__all__ = [
    "SAMPLERS",
    "SamplerRun",
    "SamplerSettings",
    "convergence_check",
    "resolve_moves",
    "sample",
    "sampler_settings",
]

#: Names :attr:`SamplerSettings.moves` accepts.
SAMPLERS = ("auto", "blocked", *MOVES)


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
        :func:`inertiafit.inference.star.star_structure` decomposes (an attachment measured alone
        and with each segment), else ``"independent"``.
        ``"blocked"``: the two-block Gibbs sampler of :mod:`inertiafit.inference.blocked` (chains are
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

    def __post_init__(self) -> None:
        self.n_walkers = check_whole(self.n_walkers, "n_walkers", 2)
        self.chunk = check_whole(self.chunk, "chunk", 1)
        self.max_steps = check_whole(self.max_steps, "max_steps", 1)
        self.ess_min = check_positive(self.ess_min, "ess_min")
        self.r_hat_max = check_positive(self.r_hat_max, "r_hat_max")
        self.tau_factor = check_positive(self.tau_factor, "tau_factor")
        self.burn_factor = check_non_negative(self.burn_factor, "burn_factor")


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
        Steps taken in all and steps dropped at the start (the blocked sampler's warm-up, if
        any, not counted: ``diagnostics["warmup"]``).
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


def _progress(enabled: bool, steps: int, max_steps: int, tau: float, ess: float, t0: float):
    if enabled:
        sys.stderr.write(
            f"\rsampling: {steps:>6d}/{max_steps} steps  tau {tau:5.1f}  "
            f"min ESS {ess:7.0f}  {time.perf_counter() - t0:5.1f} s"
        )
        sys.stderr.flush()


def convergence_check(
    params: dict[str, np.ndarray],
    ess_min: float,
    r_hat_max: float,
    first: int = 0,
    *,
    early: bool = True,
    superchains: int | None = None,
) -> tuple[float, float, int | None]:
    """Smallest bulk ESS and largest R-hat over every reported quantity, and which failed.

    The quantities are checked one by one, from ``first`` (the one that failed last time: it
    usually fails again) on; the index returned is the first that misses ``ess_min`` or
    ``r_hat_max`` in that order, ``None`` when every one passes. With ``early`` the check
    stops there and returns that quantity's ESS and R-hat (the chain is not converged whatever
    the others say); otherwise, and when every quantity passes, the ESS and R-hat are the
    minimum and maximum over all of them. The rank normalisation of every quantity's draws is
    most of a check's cost (a third of a slow living fit's time when every check did all).

    With ``superchains`` the R-hat is nested R-hat (Margossian et al. 2024, Bayesian Analysis,
    doi:10.1214/24-BA1453; ``arviz_stats.rhat_nested``) over that many groups of walkers
    (walker ``w`` in group ``w % superchains``): it compares the groups' means, where R-hat
    with each walker a chain compares the walkers', which stay apart by their own Monte Carlo
    error, so that 64 half-walkers need a bulk ESS of about 1600 to reach R-hat 1.02 however
    well the ensemble has mixed.
    """
    from arviz_stats.base import array_stats

    # (walkers, draws, bodies) per quantity -> (quantities * bodies, chains, draws); the
    # torque gain is (walkers, draws)
    stack = np.concatenate(
        [np.moveaxis(v, -1, 0) if v.ndim == 3 else v[None] for v in params.values()]
    )
    n = len(stack)
    ess = np.empty(n)
    rhat = np.empty(n)
    culprit = None
    groups = None if superchains is None else np.arange(stack.shape[1]) % superchains
    for i in (np.arange(n) + first) % n:
        row = stack[i : i + 1]
        ess[i] = array_stats.ess(row, chain_axis=-2, draw_axis=-1, method="bulk")[0]
        if groups is None:
            rhat[i] = array_stats.rhat(row, chain_axis=-2, draw_axis=-1)[0]
        else:
            rhat[i] = array_stats.rhat_nested(
                row, chain_axis=-2, draw_axis=-1, superchain_ids=groups
            )[0]
        if culprit is None and not (ess[i] >= ess_min and rhat[i] <= r_hat_max):
            culprit = int(i)
            if early:
                return float(ess[i]), float(rhat[i]), culprit
    return float(np.min(ess)), float(np.max(rhat)), culprit


#: The bulk ESS a study may ask its sampler for (``ess_min``): from 100 (an interval's ends then
#: carry a Monte Carlo error of several % of its width) to 100 000 (about what 20 000 steps of
#: 32 walkers give at two steps of autocorrelation).
ESS_MIN_RANGE = (100.0, 100_000.0)


def sampler_settings(ess_min: float | None = None) -> SamplerSettings | None:
    """The settings of a study's sampler asked for a bulk ESS of ``ess_min`` (None: defaults).

    Raises
    ------
    InputError
        ``ess_min`` not a number in :data:`ESS_MIN_RANGE`.
    """
    if ess_min is None:
        return None
    low, high = ESS_MIN_RANGE
    value = check_interval(ess_min, "ess_min", low, high, lower_closed=True, upper_closed=True)
    return SamplerSettings(ess_min=value)


def resolve_moves(model: Model, moves: str) -> str:
    """The sampler ``moves`` stands for on this model (``"auto"`` decided, names checked)."""
    if moves not in SAMPLERS:
        raise InputError(
            f"sampler: unknown moves '{moves}' "
            "(expected 'auto', 'blocked', 'independent', 'de' or 'stretch')"
        )
    if moves not in ("auto", "blocked"):
        return moves
    star = star_structure(model)
    # the torque gain moves with the shared bodies: without them, the joint sampler
    if star is None or (model.has_gain and not star.shared):
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
        mode, cov = laplace_fit(model, rng)
        self.state = _initial_walkers(model, n_walkers, mode, cov, rng)
        move_set = emcee_moves(moves, mode, cov, proposal_df(model))
        # the independence move, whose proposal warm_up may re-fit (None for other move sets)
        self.independence = next((m for m, _ in move_set if isinstance(m, IndependenceMove)), None)
        self.sampler = emcee.EnsembleSampler(
            n_walkers,
            d,
            model.log_prob,
            moves=move_set,
            vectorize=True,
        )
        # emcee draws from a copy of numpy's global RandomState taken at construction: seed it.
        self.sampler.random_state = np.random.RandomState(seed).get_state()
        self.tuned = moves != "independent"
        self.warmup = 0

    def run(self, steps: int) -> None:
        self.state = run_steps(self.sampler, self.state, steps)

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
        return {
            "acceptance": float(np.mean(self.sampler.acceptance_fraction)),
            "warmup": float(self.warmup),
        }

    def warm_up(self, kept: np.ndarray) -> bool:
        """Once: re-fit the independence proposal to ``kept`` draws and drop the chain so far.

        The Laplace fit can be far too narrow where a box edge cuts the posterior (measured:
        a leaf's ``log I`` proposed with a third of its posterior SD, tau ~ 200 steps and
        tails under-sampled). As for :class:`_BlockedChains`, the first slow check re-centres
        the proposal on the draws so far and matches their covariance (fixed from then on);
        those steps become warm-up. Other move sets have nothing to re-fit.
        """
        if self.tuned:
            return False
        self.tuned = True
        flat = kept.reshape(-1, kept.shape[-1])
        if (
            self.independence is None
            or len(flat) <= flat.shape[1]
            or not np.all(np.isfinite(flat))
        ):
            return False
        try:
            self.independence.refit(flat.mean(0), np.atleast_2d(np.cov(flat, rowvar=False)))
        except np.linalg.LinAlgError:
            return False
        self.warmup += self.n_steps
        self.sampler.reset()
        return True


class _BlockedChains:
    """The blocked Gibbs sampler of :mod:`inertiafit.inference.blocked`, chains as walkers.

    The shared proposal is first fitted to the shared bodies' own posterior (a Laplace fit).
    That can be a poor guess of their posterior given every condition: a small segment measured
    tightly on a heavy, noisily measured attachment bounds the attachment's inertia through the
    segment's box, and the Laplace fit of a posterior cut by a box edge is too narrow. Then few
    proposals are accepted and some chains stall in a tail. So the first time a check finds the
    chain shorter than ``tau_factor * tau`` (at the first check: tau above 5 sweeps, where the
    sampler is built for 1-3), :meth:`warm_up` re-fits the proposal to the kept shared draws
    (mean and covariance; fixed from then on) and the chain so far becomes warm-up: dropped,
    not counted in ``n_steps``, its length kept in ``warmup``.
    """

    def __init__(self, model: Model, star: Star, n_walkers: int, seed: int) -> None:
        if star.shared:
            shared = BlockedGibbs.shared_submodel(model, star)
            mode, cov = laplace_fit(shared, np.random.default_rng(seed))
            df = proposal_df(shared)
        else:
            mode, cov, df = np.zeros(0), np.zeros((0, 0)), 5.0
        self.model = model
        self.gibbs = BlockedGibbs(model, star, mode, cov, df)
        self.random = np.random.default_rng([seed, 3])
        self.state = self.gibbs.start(n_walkers, self.random)
        self.steps: list[np.ndarray] = []
        self.n_steps = 0
        self.warmup = 0
        self.tuned = not star.shared  # nothing to re-fit without shared bodies

    def run(self, steps: int) -> None:
        block = np.empty((steps, len(self.state[1]), self.model.ndim))
        for i in range(steps):
            self.state = self.gibbs.sweep(*self.state, self.random)
            block[i] = self.gibbs.joint_coordinates(*self.state)
        self.steps.append(block)
        self.n_steps += steps

    def warm_up(self, kept: np.ndarray) -> bool:
        """Once: re-fit the shared proposal to ``kept`` draws and drop the chain so far.

        ``kept`` is ``(chains, draws, ndim)``. Returns whether it did (the chains go on from
        their current state).
        """
        if self.tuned:
            return False
        self.tuned = True
        shared = BlockedGibbs.shared_columns(self.model, self.gibbs.star)
        if not self.gibbs.refit_shared_proposal(kept[..., shared]):
            return False
        self.gibbs.reset_acceptance()
        self.warmup += self.n_steps
        self.steps, self.n_steps = [], 0
        return True

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
        return {"acceptance": mean, **rates, "warmup": float(self.warmup)}


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

    seed = check_seed(seed)
    s = settings or SamplerSettings()
    moves = resolve_moves(model, s.moves)
    d = model.ndim
    chains: _EmceeChains | _BlockedChains
    if moves == "blocked":
        star = star_structure(model)
        assert star is not None  # resolve_moves chose "blocked" because there is one
        chains = _BlockedChains(model, star, s.n_walkers, seed)
    else:
        chains = _EmceeChains(model, moves, s.n_walkers, seed)
    show = sys.stderr.isatty() if s.progress is None else s.progress
    t0 = time.perf_counter()
    converged = False
    tau = np.full(d, np.nan)
    burn = 0
    params: dict[str, np.ndarray] = {}
    diag: dict[str, float] = {}
    failing = 0  # the quantity that failed the last check
    while chains.n_steps < s.max_steps:
        # Chunks grow with the chain, so the diagnostics cost a bounded share of the run.
        steps = min(max(s.chunk, chains.n_steps // 4), s.max_steps - chains.n_steps)
        chains.run(steps)
        chain = chains.chain()  # (steps, walkers, dim)
        with np.errstate(invalid="ignore", divide="ignore"):  # a still coordinate: nan, below
            tau = emcee.autocorr.integrated_time(chain, quiet=True, tol=0)
        # tau is nan where a coordinate never moved in any walker (or a draw is not finite):
        # no estimate, so not converged yet; keep sampling, dropping the first half.
        tau_max = float(np.max(tau)) if np.all(np.isfinite(tau)) else math.inf
        burn = chains.n_steps // 2
        if math.isfinite(tau_max):
            burn = min(math.ceil(s.burn_factor * tau_max), burn)
        kept = np.swapaxes(chain[burn:], 0, 1)  # (walkers, draws, dim)
        long_enough = chains.n_steps > s.tau_factor * tau_max
        if not long_enough and chains.n_steps < s.max_steps:
            # ESS and R-hat of every quantity cost more than the steps: wait for 50 tau.
            diag = {"ess_bulk_min": math.nan, "r_hat_max": math.nan, "tau_max": tau_max}
            _progress(show, chains.n_steps, s.max_steps, tau_max, math.nan, t0)
            # Slow at the first check: the sampler re-fits its independence proposal to these
            # draws and the chain so far becomes warm-up (once).
            chains.warm_up(kept)
            continue
        params = model.parameters(kept, np.random.default_rng([seed, 1]))
        # the last check (at max_steps) looks at every quantity, for the record
        last = chains.n_steps >= s.max_steps
        ess_min, rhat_max, culprit = convergence_check(
            params, s.ess_min, s.r_hat_max, failing, early=not last
        )
        failing = culprit if culprit is not None else failing
        diag = {"ess_bulk_min": ess_min, "r_hat_max": rhat_max, "tau_max": tau_max}
        _progress(show, chains.n_steps, s.max_steps, tau_max, ess_min, t0)
        if long_enough and rhat_max <= s.r_hat_max and ess_min >= s.ess_min:
            converged = True
            break
    if show:
        sys.stderr.write("\n")
    if not converged:
        last_tau = diag.get("tau_max", math.nan)
        tau_text = f"{last_tau:.1f} steps" if math.isfinite(last_tau) else "not estimable"
        warnings.warn(
            f"sampler stopped at max_steps={s.max_steps} before converging "
            f"(tau {tau_text}, min bulk ESS "
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
