"""The samplers' proposals: the Laplace fit, the Student-t proposal around it, emcee's moves.

Both samplers propose from the same place. :func:`laplace_fit` finds the posterior mode of a
model in its sampled coordinates ``(log a, log b)`` per body (see
:mod:`inertiafit.inference.model`) and the inverse curvature there; :class:`StudentTProposal`
draws around it from a product of independent Student-t variables along the Cholesky axes of
that covariance, widened by :data:`PROPOSAL_INFLATION`, with :func:`proposal_df` degrees of
freedom. The joint sampler (:mod:`inertiafit.inference.sampler`) uses it through emcee
(:class:`IndependenceMove`, mixed with differential evolution by :func:`emcee_moves`); the
blocked sampler (:mod:`inertiafit.inference.blocked`) for the shared bodies. See
docs/method.md, "Sampler".
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np

from inertiafit.errors import InputError
from inertiafit.inference.model import Model
from inertiafit.io.stops import signals_deferred, stop_point
from inertiafit.physics import inertia
from inertiafit.stats import student_t_logpdf

__all__ = [
    "KINK_RATIO",
    "MOVES",
    "PROPOSAL_INFLATION",
    "IndependenceMove",
    "StudentTProposal",
    "emcee_moves",
    "laplace_fit",
    "proposal_df",
]

#: The Laplace covariance is widened by this factor (in standard deviations) for proposing:
#: a proposal a little wider than the target keeps its tails covered.
PROPOSAL_INFLATION = 1.2

#: The emcee move sets :func:`emcee_moves` builds.
MOVES = ("independent", "de", "stretch")


def _least_squares_start(model: Model) -> np.ndarray:
    """Bodies' ``(a, b)`` that reproduce the evidence, pulled weakly toward their nominals.

    The evidence is linear in ``(a, b)`` (sums over mounted bodies), so a ridge least-squares
    solve gives a start near the mode even for many bodies; where the evidence cannot tell bodies
    apart, the nominal values (weight 1 / (0.5 nominal)) decide. Known added masses are taken
    off the evidence; a condition with a moved body is left out (its evidence involves the
    mass, not only ``(a, b)``).
    """
    k = len(model.bodies)
    rows, rhs = [], []
    for ci, cond in enumerate(model.conditions):
        if cond.offset_body:
            continue
        w = model.membership[ci]
        if cond.gravity_moment is not None:
            obs = cond.gravity_moment
            rows.append(np.concatenate([model.gravity * w, np.zeros(k)]) / obs.scale)
            rhs.append((obs.center - model.gravity * cond.added_first_moment) / obs.scale)
        if cond.inertia is not None:
            obs = cond.inertia
            rows.append(np.concatenate([np.zeros(k), w]) / obs.scale)
            rhs.append((obs.center - cond.added_inertia) / obs.scale)
    for j, body in enumerate(model.bodies):
        nom = model.priors[body].nominal
        a0 = nom["mass"] * nom["com_distance"]
        b0 = float(inertia(nom["mass"], nom["radius_of_gyration"], nom["com_distance"]))
        for col, value in ((j, a0), (k + j, b0)):
            row = np.zeros(2 * k)
            row[col] = 1 / (0.5 * value)
            rows.append(row)
            rhs.append(value / (0.5 * value))
    sol = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    sol = np.maximum(sol, 1e-9)
    return model.coordinates(sol[:k], sol[k:])


def _hessian(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, h=1e-4) -> np.ndarray:
    """Central-difference Hessian of a vectorised function ``f(rows) -> values``, one call.

    ``h`` is one step for every coordinate or an array of steps, one per coordinate.
    """
    d = len(x)
    eye = np.eye(d) * h
    iu, ju = np.triu_indices(d)
    step2 = h * h if np.ndim(h) == 0 else np.asarray(h)[iu] * np.asarray(h)[ju]
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
    hess[iu, ju] = (v[0] - v[1] - v[2] + v[3]) / (4 * step2)
    hess[ju, iu] = hess[iu, ju]
    return hess


def laplace_fit(model: Model, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The Laplace approximation of ``model``'s posterior in its sampled coordinates.

    Starts from a ridge least-squares fit of the evidence and 4000 draws from the prior boxes,
    polishes the three best (the best one with extra information; Nelder-Mead up to 4
    coordinates, else L-BFGS-B) and takes the central-difference Hessian at the best mode.

    Parameters
    ----------
    model : Model
        Bodies, priors and evidence.
    rng : numpy.random.Generator
        Source of the prior draws the search starts from.

    Returns
    -------
    mode : ndarray, shape (ndim,)
        Posterior mode in ``(log a, log b)`` per body.
    cov : ndarray, shape (ndim, ndim)
        Inverse of the negative log posterior's Hessian there (``1e-6`` on the diagonal where
        the Hessian is not positive definite), measured again across one standard deviation
        where the mode sits on a kink of the prior density (see :data:`KINK_RATIO`); the
        torque gain's axis centred on its prior, at least as wide, uncorrelated.

    Raises
    ------
    InputError
        When no start, or no polished point, has a finite posterior density.
    """
    from scipy import optimize

    prior = model.prior_draws(4000, rng)
    z0 = model.coordinates(
        prior["gravity_moment"] / model.gravity, prior["inertia"], prior.get("torque_gain")
    )
    z0 = np.vstack([_least_squares_start(model), z0])
    lp = model.log_prob(z0)
    if not np.isfinite(lp).any():
        raise InputError("model: no draw from the prior boxes has a finite posterior density")
    # Polish the three best starts; with extra information (whose density costs an integral
    # over the angle per call) the best one, which the least-squares start usually is.
    best = z0[np.argsort(lp)[-1:]] if model.has_extra else z0[np.argsort(lp)[-3:]]

    def neg(z):
        v = model.log_prob(z)
        return np.where(np.isfinite(v), -v, 1e300)

    def neg_and_grad(z, h=1e-6):
        pts = np.vstack([z, z + np.eye(len(z)) * h])
        v = neg(pts)
        return v[0], (v[1:] - v[0]) / h

    # The mode only centres the proposal: 1e-5 in log a, log b is under 0.001 posterior SD
    # (measured on the SBC designs, against 1e-9: modes 7e-4 SD apart, SDs within 1e-4) and
    # takes 45 % fewer evaluations, each an integral over the angle with extra information.
    fits = []
    for b in best:
        if model.ndim <= 4:
            fits.append(
                optimize.minimize(
                    lambda z: neg(z)[0],
                    b,
                    method="Nelder-Mead",
                    options={"xatol": 1e-5, "fatol": 1e-6, "maxiter": 4000},
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
    cov = _widened_at_a_kink(neg, mode, cov)
    if model.has_gain:
        # The evidence never involves the gain (the other coordinates are observed-scale): its
        # posterior is its Normal prior times the slowly varying box density, nearly
        # independent of the rest. A mode and curvature found on a kink of that density can sit
        # two prior SDs off and be far too narrow (measured: a proposal centred at +2 SD left
        # the chains' gain SD 14 % short). Centre the gain's axis on its prior, at least as
        # wide, uncorrelated.
        sd = max(model.torque_gain_sd, math.sqrt(max(cov[-1, -1], 0.0)))
        mode = mode.copy()
        mode[-1] = 0.0
        cov = cov.copy()
        cov[-1, :] = 0.0
        cov[:, -1] = 0.0
        cov[-1, -1] = sd * sd
    return mode, cov


#: :func:`laplace_fit` re-measures the curvature across the posterior's width where that widens
#: some coordinate's standard deviation by more than this factor: the mode sits on a kink.
KINK_RATIO = 1.5


def _widened_at_a_kink(neg: Callable[[np.ndarray], np.ndarray], mode, cov) -> np.ndarray:
    """The covariance from the curvature across one standard deviation, if the mode is a kink.

    The prior density ``|Psi(a, b)| / a`` is continuous but has kinks where the bound that cuts
    ``Psi`` changes, and a posterior mode often sits on one (flat on one side, falling on the
    other). The curvature there over ``1e-4`` is that of the kink, not of the posterior: one
    case measured a standard deviation of ``log I`` 8 times too small, and an independence
    proposal that narrow leaves chains stuck in the tails. So the Hessian is measured again
    with steps of one standard deviation, and again with the new ones, until they settle (at
    most 8 rounds). A smooth posterior changes by a few per cent (at most ``KINK_RATIO``) and
    keeps ``cov`` as it was; a result that is not positive definite, or narrower than ``cov``
    by more than that factor in any coordinate, is not used.
    """
    sd = np.sqrt(np.diag(cov))
    out = cov
    for _ in range(8):
        hess = _hessian(neg, mode, sd)
        if not np.all(np.abs(hess) < 1e250):  # a step left the support (or nan)
            break
        try:
            new = np.linalg.inv(hess)
            np.linalg.cholesky(new)
        except np.linalg.LinAlgError:
            break
        new_sd = np.sqrt(np.diag(new))
        if np.all(new_sd < KINK_RATIO * sd) and np.all(new_sd > sd / KINK_RATIO):
            if out is not cov:
                out = new
            break
        out, sd = new, new_sd
    narrower = np.sqrt(np.diag(out)) < np.sqrt(np.diag(cov)) / KINK_RATIO
    return cov if narrower.any() else out


def proposal_df(model: Model) -> float:
    """Degrees of freedom of the Student-t proposal: no lighter-tailed than the evidence.

    A Student-t likelihood from few trials (3 trials: 2 d.o.f.) has heavy tails; a proposal with
    lighter tails than the target visits them too rarely and mixes slowly there. At most 5.
    """
    dfs = [
        obs.df
        for cond in model.conditions
        for obs in (cond.inertia, cond.gravity_moment)
        if obs is not None and not obs.is_gaussian
    ]
    return float(min([5.0, *dfs]))


class StudentTProposal:
    """A fixed proposal: independent Student-t variables along the axes of a covariance.

    ``x = mean + L y`` with ``y`` independent standard Student-t (``df`` degrees of freedom)
    and ``L`` the Cholesky factor of ``cov * inflate**2``. Independent heavy-tailed axes matter
    when the evidence is a Student-t from few trials: each condition's total then has heavy
    tails of its own, which one shared multivariate-t scale covers badly (measured: tau 25-30
    steps against 5 with three trials per condition).

    Parameters
    ----------
    mean : ndarray, shape (d,)
        Centre, usually the mode of :func:`laplace_fit`.
    cov : ndarray, shape (d, d)
        Covariance of the axes before widening, usually the Laplace covariance.
    df : float
        Degrees of freedom (see :func:`proposal_df`).
    inflate : float
        Widening of ``cov``, in standard deviations.
    """

    def __init__(self, mean, cov, df: float = 5.0, *, inflate: float = PROPOSAL_INFLATION) -> None:
        self.mean = np.asarray(mean, float)
        self.chol = np.linalg.cholesky(np.asarray(cov, float) * inflate**2)
        self.chol_inv = np.linalg.inv(self.chol)
        self.df = float(df)

    @property
    def ndim(self) -> int:
        """Number of coordinates ``d``."""
        return len(self.mean)

    def draw(self, n: int, random: np.random.Generator | np.random.RandomState) -> np.ndarray:
        """``n`` proposals, ``(n, d)``, from ``random`` (a Generator or emcee's RandomState)."""
        y = random.standard_t(self.df, size=(n, self.ndim))
        return self.mean + y @ self.chol.T

    def log_density(self, x) -> np.ndarray:
        """Log density at points ``x`` (``(..., d)``), up to a constant."""
        r = (x - self.mean) @ self.chol_inv.T
        return student_t_logpdf(r, 0.0, 1.0, self.df, normalised=False).sum(-1)


class IndependenceMove:
    """emcee move: Metropolis-Hastings from a :class:`StudentTProposal`, whatever the walker.

    Proposals are drawn independently of the walker's position, centred on the posterior mode.
    The posterior of the identified coordinates is close to Gaussian, so most proposals are
    accepted and successive draws are nearly independent. The proposal is fixed before
    sampling starts, so detailed balance holds.

    Parameters
    ----------
    mean, cov : ndarray
        The Laplace fit (see :func:`laplace_fit`).
    df : float
        Degrees of freedom of the proposal.
    inflate : float
        Widening of ``cov`` (see :class:`StudentTProposal`).
    """

    def __init__(self, mean, cov, *, df: float = 5.0, inflate: float = PROPOSAL_INFLATION) -> None:
        import emcee

        self.inflate = inflate
        self.proposal = StudentTProposal(mean, cov, df, inflate=inflate)
        self._mh = emcee.moves.MHMove(self._propose_coords)

    def refit(self, mean, cov) -> None:
        """Replace the proposal's centre and covariance (before sampling proper starts)."""
        self.proposal = StudentTProposal(mean, cov, self.proposal.df, inflate=self.inflate)

    def _propose_coords(self, coords, random):
        new = self.proposal.draw(len(coords), random)
        return new, self.proposal.log_density(coords) - self.proposal.log_density(new)

    def propose(self, model, state):
        """Propose for every walker and accept by the Metropolis-Hastings rule (emcee API)."""
        return self._mh.propose(model, state)

    def tune(self, state, accepted):
        """Nothing to tune: the proposal is fixed (emcee API)."""


@functools.cache
def _snooker_class() -> type:
    """The DE-snooker move class (defined on first use: emcee is imported lazily)."""
    import emcee

    class SnookerMove(emcee.moves.RedBlueMove):
        """DE-snooker (ter Braak and Vrugt 2008), vectorised, on emcee's two half-ensembles.

        For each walker ``x`` of the active half, three distinct walkers ``z, z1, z2`` of the
        other half; with ``e`` the unit vector from ``z`` to ``x``, the proposal is
        ``x + gamma e e'(z1 - z2)`` (the difference of ``z1`` and ``z2`` projected on the line
        through ``x`` and ``z``), accepted with the extra factor ``(|x* - z| / |x - z|)^(d-1)``.

        Replaces ``emcee.moves.DESnookerMove`` (emcee 3.1.6), which does not leave the target
        invariant: it scales the step by ``|x - z|`` (``u = delta / sqrt(|delta|)``, so ``u u'``
        is ``|delta| e e'``) and takes half the exponent of the factor; alone on a standard
        normal it samples a variance of 0.89 in 2 dimensions and 0.74 in 4 (this move: 1.00).
        It also loops over the walkers in Python and splits the ensemble in four (four density
        calls per step): a tenth of the steps took a third of a fit's sampling time.
        """

        def __init__(self, gamma: float = 1.7) -> None:
            self.gamma = gamma
            super().__init__(nsplits=2)

        def get_proposal(self, s, c, random):
            c = np.concatenate(c, axis=0)
            ns, ndim = s.shape
            # three distinct walkers of the other half per walker: a random permutation's first
            # three (emcee's RandomState: rand)
            pick = np.argsort(random.rand(ns, len(c)), axis=1)[:, :3]
            z, z1, z2 = c[pick[:, 0]], c[pick[:, 1]], c[pick[:, 2]]
            delta = s - z
            norm = np.linalg.norm(delta, axis=1)
            # x on top of z (a stuck ensemble): no direction, the walker stays (factor 0)
            moves = norm > 0
            safe = np.where(moves, norm, 1.0)
            e = delta / safe[:, None]
            step = np.where(moves, self.gamma * np.einsum("ij,ij->i", e, z1 - z2), 0.0)
            q = s + step[:, None] * e
            with np.errstate(divide="ignore"):  # q on top of z: log 0, never accepted
                factor = (ndim - 1.0) * (np.log(np.linalg.norm(q - z, axis=1)) - np.log(safe))
            return q, np.where(moves, factor, 0.0)

    return SnookerMove


def _snooker_move():
    """A new DE-snooker move for emcee (see ``_snooker_class``)."""
    return _snooker_class()()


def emcee_moves(kind: str, mode: np.ndarray, cov: np.ndarray, df: float = 5.0) -> list:
    """The emcee ``moves`` of a joint sampler named in :data:`MOVES`.

    ``"independent"``: 70 % :class:`IndependenceMove` around ``(mode, cov)``, 20 %
    differential evolution, 10 % DE-snooker; ``"de"``: 80 % DE, 20 % DE-snooker;
    ``"stretch"``: emcee's default stretch move. The DE-snooker is this module's own (see
    ``_snooker_class``), not emcee's.
    """
    import emcee

    if kind == "de":
        return [(emcee.moves.DEMove(), 0.8), (_snooker_move(), 0.2)]
    if kind == "independent":
        return [
            (IndependenceMove(mode, cov, df=df), 0.7),
            (emcee.moves.DEMove(), 0.2),
            (_snooker_move(), 0.1),
        ]
    if kind != "stretch":
        raise ValueError(f"emcee_moves: unknown moves {kind!r} (expected one of {MOVES})")
    return [(emcee.moves.StretchMove(), 1.0)]


def run_steps(sampler, start, steps: int):
    """Run an emcee sampler ``steps`` steps from ``start``, stoppable between steps.

    It is ``sampler.run_mcmc(start, steps)``, except for signals:

    emcee prints a traceback for any exception raised in the log density, a Ctrl-C or SIGTERM
    among them; the steps run inside :func:`inertiafit.io.stops.signals_deferred` instead, so
    a stop takes effect after the step under way, silently. Returns the last state.
    """
    state = start
    with signals_deferred():
        for state in sampler.sample(start, iterations=steps):  # noqa: B007 (the last is kept)
            stop_point()
    return state
