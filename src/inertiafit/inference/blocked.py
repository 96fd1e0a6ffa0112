"""A blocked Gibbs sampler for studies of many segments on one attachment.

Structure it uses
-----------------
A *leaf* body is mounted in exactly one condition, with no other leaf, and that condition has
both observables; every other body is *shared* (the attachment). Given the shared bodies, the
leaves are independent of each other. Write each leaf condition's totals
``T_k = (a, b)_shared in k + (a_k, b_k)``; in coordinates ``(S, T_1..T_L)`` the posterior is

    p(S, T) ~ pi_S(S) L_shared(S) * prod_k L_k(T_k) pi_k(T_k - S_k)

with ``pi_k(a, b) = |Psi_k(a, b)| / a`` the leaf's prior in ``(a, b)`` for a box, the prior
integrated along the curve over ``a`` otherwise (see :mod:`inertiafit.inference.model`) and ``L_k`` the evidence of leaf condition ``k``. Where the data say
more than the prior boxes, ``T_k`` is nearly independent of ``S`` — the slow direction of a
Gibbs sampler in the original coordinates (moving the attachment while every segment holds
still) becomes a direction of nearly independent draws. Each sweep, vectorised over chains:

1. ``S | T``: independence Metropolis-Hastings from a product of Student-t variables around the
   Laplace fit of the shared bodies' own posterior (``pi_S L_shared``; the
   :class:`~inertiafit.inference.moves.StudentTProposal` of the joint sampler); the leaves'
   priors ``prod_k pi_k(T_k - S_k)`` enter the acceptance ratio.
2. ``T_k | S`` for every leaf at once: independence Metropolis-Hastings proposing ``T_k`` from
   the leaf condition's evidence itself (Student-t or Gaussian in the totals), so the
   acceptance ratio is just ``pi_k(T'_k - S_k) / pi_k(T_k - S_k)``.

With a torque gain (:mod:`inertiafit.inference.model`, "Systematic errors") the coordinates
are observed-scale, ``log gain`` is the last shared coordinate (moved with the shared bodies),
and a leaf's prior is taken at its true values, ``(T_k - S_k) / gain``. Where a condition's
inertia evidence is coupled to its gravity moment (``Condition.coupling``), the leaf proposal
still draws exactly from the leaf condition's evidence: ``M_g`` first, then ``I`` given it.

One sweep costs ``O(K)`` and its mixing does not depend on ``K``: the whole run is linear in the
number of segments. The draws are exact MCMC for the same posterior as the joint sampler's.
Every chain starts inside the support (:meth:`BlockedGibbs.start`), so every state it visits
has a finite density and finite coordinates; the shared proposal can be re-fitted to a warm-up
run's draws (:meth:`BlockedGibbs.refit_shared_proposal`).
"""

from __future__ import annotations

import numpy as np

from inertiafit.inference.model import Model, feasible_measure
from inertiafit.inference.moves import StudentTProposal
from inertiafit.inference.observations import Observation
from inertiafit.inference.star import Star
from inertiafit.stats import student_t_draws, student_t_logpdf

__all__ = ["BlockedGibbs"]


class _Boxes:
    """Prior bounds of several bodies as arrays, so one call covers every leaf."""

    def __init__(self, priors) -> None:
        keys = ("mass", "com_distance", "radius_of_gyration")
        self.lower = {k: np.array([p.lower[k] for p in priors]) for k in keys}
        self.upper = {k: np.array([p.upper[k] for p in priors]) for k in keys}


def _evidence_arrays(
    observations: list[Observation],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    center = np.array([o.center for o in observations])
    scale = np.array([o.scale for o in observations])
    df = np.array([o.df for o in observations])
    return center, scale, df


class BlockedGibbs:
    """The two-block sampler of the module docstring, run on ``n_chains`` chains at once.

    Parameters
    ----------
    model : Model
        The full model; :func:`star_structure` must not be ``None`` for it.
    star : Star
        Its decomposition.
    shared_mode, shared_cov : ndarray
        Laplace fit of the shared bodies' own posterior in ``(log a, log b)``
        (:func:`~inertiafit.inference.moves.laplace_fit` of :meth:`shared_submodel`).
    df : float
        Degrees of freedom of the shared proposal
        (:func:`~inertiafit.inference.moves.proposal_df` of the same).
    """

    def __init__(self, model: Model, star: Star, shared_mode, shared_cov, df: float) -> None:
        self.model = model
        self.star = star
        self.g = model.gravity
        self.shared_model = self.shared_submodel(model, star) if star.shared else None
        self.proposal = StudentTProposal(shared_mode, shared_cov, df)
        leaf_conds = [model.conditions[ci] for ci in star.leaf_conditions]
        self.leaf_conditions = leaf_conds
        self.inertia = _evidence_arrays([c.inertia for c in leaf_conds])  # type: ignore[misc]
        self.inertia_shared = np.array([c.inertia.shared_sd for c in leaf_conds])  # type: ignore[union-attr]
        self.coupling = np.array([c.coupling for c in leaf_conds])
        self.gravity = _evidence_arrays([c.gravity_moment for c in leaf_conds])  # type: ignore[misc]
        self.n_shared = len(star.shared)
        self.has_gain = model.has_gain
        self.leaf_priors = [model.priors[model.bodies[j]] for j in star.leaves]
        self.boxes = _Boxes(self.leaf_priors)
        self.all_boxes = all(p.is_box for p in self.leaf_priors) and not any(
            j in model.curve_bodies for j in star.leaves
        )
        self.accepted = np.zeros(3)
        self.proposed = np.zeros(3)

    @staticmethod
    def shared_submodel(model: Model, star: Star) -> Model:
        """The shared bodies with the conditions and terms that hold only them: ``pi_S L_shared``."""
        shared = {model.bodies[j] for j in star.shared}
        return Model(
            {model.bodies[j]: model.priors[model.bodies[j]] for j in star.shared},
            [model.conditions[ci] for ci in star.shared_conditions],
            gravity=model.gravity,
            torque_gain_sd=model.torque_gain_sd,
            terms=[t for t in model.extra_terms if shared.issuperset(t.bodies)],
        )

    @staticmethod
    def shared_columns(model: Model, star: Star) -> list[int]:
        """Columns of the model's coordinates held in the shared state (``log gain`` last)."""
        cols = [2 * j + c for j in star.shared for c in (0, 1)]
        return [*cols, model.ndim - 1] if model.has_gain else cols

    def _log_gain(self, s_log) -> np.ndarray:
        """``log gain`` of each state, ``(...,)`` (zeros without a gain)."""
        if self.has_gain:
            return s_log[..., -1]
        return np.zeros(np.shape(s_log)[:-1])

    def _leaf_draws(self, lead: tuple[int, ...], random: np.random.Generator):
        """Leaf totals drawn from their conditions' evidence: ``M_g``, then ``I`` given it."""
        ta = student_t_draws(*self.gravity, lead, random) / self.g
        tb = student_t_draws(*self.inertia, lead, random)
        if self.inertia_shared.any():
            tb = tb + self.inertia_shared * random.standard_normal(np.shape(tb))
        if self.coupling.any():
            tb = tb - self.coupling * (self.gravity[0] - self.g * ta)
        return ta, tb

    # -- densities ---------------------------------------------------------------------------
    def _leaf_log_prior(self, a, b, log_gain=None) -> np.ndarray:
        """``log pi_k(a, b)`` for every leaf, ``(..., L)``; ``-inf`` outside the boxes.

        ``a``, ``b`` are observed-scale; with ``log_gain`` (``(...,)``) the density is that of
        the observed-scale values, ``pi_k(a / gain, b / gain) / gain^2``.
        """
        shift: float | np.ndarray = 0.0
        if log_gain is not None and self.has_gain:
            inv = np.exp(-np.asarray(log_gain))[..., None]
            a, b = a * inv, b * inv
            shift = -2.0 * np.asarray(log_gain)[..., None]
        ok = (a > 0) & (b > 0)
        a_ok, b_ok = np.where(ok, a, 1.0), np.where(ok, b, 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.all_boxes:
                log_meas = np.log(feasible_measure(a_ok, b_ok, self.boxes))
            else:  # a leaf that is not a box: its prior integrated along the curve
                log_meas = np.empty(np.shape(a_ok))
                for i, j in enumerate(self.star.leaves):
                    log_meas[..., i] = self.model.body_log_curve(j, a_ok[..., i], b_ok[..., i])
            return np.where(ok, log_meas - np.log(a_ok) + shift, -np.inf)

    def _shared_totals(self, s_log) -> tuple[np.ndarray, np.ndarray]:
        """Shared bodies' contribution to each leaf condition: ``(..., L)`` in ``a`` and ``b``."""
        if not self.star.shared:
            shape = (*np.shape(s_log)[:-1], len(self.star.leaves))
            return np.zeros(shape), np.zeros(shape)
        w = self.star.weights.T
        k2 = 2 * self.n_shared
        return np.exp(s_log[..., 0:k2:2]) @ w, np.exp(s_log[..., 1:k2:2]) @ w

    def _shared_log_target(self, s_log, ta, tb) -> np.ndarray:
        assert self.shared_model is not None
        own = self.shared_model.log_prob(s_log)
        sa, sb = self._shared_totals(s_log)
        return own + self._leaf_log_prior(ta - sa, tb - sb, self._log_gain(s_log)).sum(-1)

    # -- start and sweeps --------------------------------------------------------------------
    def start(
        self, n_chains: int, random: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Chains started inside the support: every body in its box, every density finite.

        The shared bodies are drawn from their proposal and each leaf's total from its evidence,
        redrawn until inside the leaf's box. Where a leaf's box and its evidence leave no room
        for those shared draws (a tight leaf total minus a shared draw from the wide evidence of
        the attachment alone, below the smallest inertia the leaf's box allows), the chain
        starts again from new shared draws; failing that, from the Laplace fit of the whole
        model. A chain is never started outside the support.
        """
        s_log = self._shared_draws(n_chains, random)
        ta, tb = self._leaf_draws((n_chains,), random)
        ta, tb = self.fit_leaves(s_log, ta, tb, random)
        for _ in range(50):
            bad = ~self.in_support(s_log, ta, tb)
            if not bad.any():
                return s_log, ta, tb
            n_bad = int(bad.sum())
            s_new = self._shared_draws(n_bad, random)
            na, nb = self._leaf_draws((n_bad,), random)
            na, nb = self.fit_leaves(s_new, na, nb, random, tries=20)
            s_log[bad], ta[bad], tb[bad] = s_new, na, nb
        bad = ~self.in_support(s_log, ta, tb)
        if bad.any():
            s_new, na, nb = self._laplace_draws(int(bad.sum()), random)
            s_log[bad], ta[bad], tb[bad] = s_new, na, nb
        return s_log, ta, tb

    def _shared_draws(self, n: int, random: np.random.Generator) -> np.ndarray:
        """``n`` draws of the shared bodies from their proposal, each inside its own box."""
        n_shared = 2 * len(self.star.shared) + int(self.has_gain)
        s_log = np.empty((n, n_shared))
        if n_shared:
            filled = 0
            for _ in range(200):
                cand = self.proposal.draw(4 * n, random)
                cand = cand[np.isfinite(self.shared_model.log_prob(cand))]  # type: ignore[union-attr]
                take = min(len(cand), n - filled)
                s_log[filled : filled + take] = cand[:take]
                filled += take
                if filled == n:
                    break
            else:
                raise RuntimeError("blocked sampler: could not start the shared bodies")
        return s_log

    def _laplace_draws(self, n: int, random: np.random.Generator):
        """``n`` states inside the support, from the Laplace fit of the whole model.

        The last resort of :meth:`start`: a Gaussian around the joint mode, narrowed until
        enough draws land inside every box.
        """
        from inertiafit.inference.moves import laplace_fit

        mode, cov = laplace_fit(self.model, random)
        z = np.empty((0, self.model.ndim))
        for _ in range(60):
            cand = random.multivariate_normal(mode, cov, size=4 * n)
            z = np.vstack([z, cand[np.isfinite(self.model.log_prob(cand))]])
            if len(z) >= n:
                return self.from_joint_coordinates(z[:n])
            cov = cov / 4
        return self.from_joint_coordinates(np.repeat(mode[None, :], n, 0))

    def refit_shared_proposal(self, s_draws) -> bool:
        """Centre the shared proposal on draws of the shared bodies and match their covariance.

        ``s_draws`` is ``(..., 2 * n_shared)``: shared coordinates from a warm-up run of the
        sampler, whose posterior (shared bodies given every condition) the leaves' boxes can
        make narrower than, or shift away from, the shared bodies' own posterior
        ``pi_S L_shared`` that the proposal was first fitted to. The degrees of freedom and the
        widening stay. Returns ``False`` (proposal unchanged) where the draws' covariance is
        not positive definite.
        """
        flat = np.reshape(s_draws, (-1, np.shape(s_draws)[-1]))
        if len(flat) <= flat.shape[1] or not np.all(np.isfinite(flat)):
            return False
        cov = np.atleast_2d(np.cov(flat, rowvar=False))
        try:
            proposal = StudentTProposal(flat.mean(0), cov, self.proposal.df)
        except np.linalg.LinAlgError:
            return False
        self.proposal = proposal
        return True

    def reset_acceptance(self) -> None:
        """Start the acceptance counts of :attr:`acceptance` afresh."""
        self.accepted[:] = 0
        self.proposed[:] = 0

    def in_support(self, s_log, ta, tb) -> np.ndarray:
        """Whether each chain's state has a finite density: shared and leaf boxes, ``(...,)``."""
        sa, sb = self._shared_totals(s_log)
        ok = np.isfinite(self._leaf_log_prior(ta - sa, tb - sb, self._log_gain(s_log))).all(-1)
        if self.star.shared:
            ok &= np.isfinite(self.shared_model.log_prob(s_log))  # type: ignore[union-attr]
        return ok

    def fit_leaves(self, s_log, ta, tb, random: np.random.Generator, tries: int = 200):
        """Redraw, from the evidence, the leaf totals that leave a leaf outside its box."""
        sa, sb = self._shared_totals(s_log)
        log_gain = self._log_gain(s_log)
        for _ in range(tries):
            bad = ~np.isfinite(self._leaf_log_prior(ta - sa, tb - sb, log_gain))
            if not bad.any():
                break
            na, nb = self._leaf_draws(np.shape(ta)[:-1], random)
            ta, tb = np.where(bad, na, ta), np.where(bad, nb, tb)
        return ta, tb

    def sweep(self, s_log, ta, tb, random: np.random.Generator, n_sub: int = 2):
        """One Gibbs sweep (``n_sub`` Metropolis-Hastings steps per block) on every chain."""
        n = len(ta)
        if self.star.shared:
            cur = self._shared_log_target(s_log, ta, tb)
            for _ in range(n_sub):
                new = self.proposal.draw(n, random)
                lp_new = self._shared_log_target(new, ta, tb)
                with np.errstate(invalid="ignore"):
                    log_r = (
                        lp_new
                        - cur
                        + self.proposal.log_density(s_log)
                        - self.proposal.log_density(new)
                    )
                acc = np.log(random.uniform(size=n)) < np.where(
                    np.isfinite(lp_new), log_r, -np.inf
                )
                acc |= ~np.isfinite(cur) & np.isfinite(lp_new)
                s_log = np.where(acc[:, None], new, s_log)
                cur = np.where(acc, lp_new, cur)
                self.accepted[0] += acc.sum()
                self.proposed[0] += n
            s_log, ta, tb = self._shared_step_leaves_fixed(s_log, ta, tb, random)
        sa, sb = self._shared_totals(s_log)
        log_gain = self._log_gain(s_log)
        cur_l = self._leaf_log_prior(ta - sa, tb - sb, log_gain)
        for _ in range(n_sub):
            na, nb = self._leaf_draws((n,), random)
            new_l = self._leaf_log_prior(na - sa, nb - sb, log_gain)
            with np.errstate(invalid="ignore"):
                log_r = np.where(np.isfinite(new_l), new_l - cur_l, -np.inf)
            acc = np.log(random.uniform(size=log_r.shape)) < log_r
            acc |= ~np.isfinite(cur_l) & np.isfinite(new_l)
            ta, tb = np.where(acc, na, ta), np.where(acc, nb, tb)
            cur_l = np.where(acc, new_l, cur_l)
            self.accepted[1] += acc.sum()
            self.proposed[1] += acc.size
        return s_log, ta, tb

    def _leaf_log_likelihood(self, ta, tb) -> np.ndarray:
        """Log evidence of every leaf condition at totals ``(ta, tb)``, summed over leaves."""
        out = student_t_logpdf(self.g * ta, *self.gravity, normalised=False).sum(-1)
        if not (self.inertia_shared.any() or self.coupling.any()):
            return out + student_t_logpdf(tb, *self.inertia, normalised=False).sum(-1)
        for i, cond in enumerate(self.leaf_conditions):
            at = cond.inertia_at(tb[..., i], self.g * ta[..., i])
            out = out + cond.inertia.logpdf(at)  # type: ignore[union-attr]
        return out

    def _shared_step_leaves_fixed(self, s_log, ta, tb, random: np.random.Generator):
        """Move the shared bodies with every leaf body held still (the totals follow).

        The step of the other parametrisation, ``(S, s_1..s_L)``: where a leaf's prior box
        ties its total to the shared bodies (a chain in a far tail), ``S | T`` and ``T | S``
        both hold still and only a joint move gets out.
        """
        n = len(ta)
        sa, sb = self._shared_totals(s_log)
        cur = self.shared_model.log_prob(s_log) + self._leaf_log_likelihood(ta, tb)  # type: ignore[union-attr]
        new = self.proposal.draw(n, random)
        na, nb = self._shared_totals(new)
        ta_new, tb_new = ta + (na - sa), tb + (nb - sb)
        lp_new = self.shared_model.log_prob(new) + self._leaf_log_likelihood(ta_new, tb_new)  # type: ignore[union-attr]
        if self.has_gain:  # the leaves' true values move with the gain: their priors change
            cur = cur + self._leaf_log_prior(ta - sa, tb - sb, self._log_gain(s_log)).sum(-1)
            lp_new = lp_new + self._leaf_log_prior(ta - sa, tb - sb, self._log_gain(new)).sum(-1)
        with np.errstate(invalid="ignore"):
            log_r = (
                lp_new - cur + self.proposal.log_density(s_log) - self.proposal.log_density(new)
            )
        acc = np.log(random.uniform(size=n)) < np.where(np.isfinite(lp_new), log_r, -np.inf)
        acc |= ~np.isfinite(cur) & np.isfinite(lp_new)
        self.accepted[2] += acc.sum()
        self.proposed[2] += n
        keep = acc[:, None]
        return np.where(keep, new, s_log), np.where(keep, ta_new, ta), np.where(keep, tb_new, tb)

    def from_joint_coordinates(self, z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The state ``(S, T_a, T_b)`` of joint coordinates ``z`` (inverse of the next)."""
        z = np.asarray(z, float)
        s_log = z[..., self.shared_columns(self.model, self.star)]
        sa, sb = self._shared_totals(s_log)
        leaves = list(self.star.leaves)
        ta = sa + np.exp(z[..., [2 * j for j in leaves]])
        tb = sb + np.exp(z[..., [2 * j + 1 for j in leaves]])
        return s_log, ta, tb

    def joint_coordinates(self, s_log, ta, tb) -> np.ndarray:
        """``(log a, log b)`` of every body in the model's order, ``(..., 2 * n_bodies)``."""
        sa, sb = self._shared_totals(s_log)
        lead = np.shape(ta)[:-1]
        z = np.empty((*lead, self.model.ndim))
        for i, j in enumerate(self.star.shared):
            z[..., 2 * j] = s_log[..., 2 * i]
            z[..., 2 * j + 1] = s_log[..., 2 * i + 1]
        if self.has_gain:
            z[..., -1] = s_log[..., -1]
        with np.errstate(divide="ignore", invalid="ignore"):
            for i, j in enumerate(self.star.leaves):
                z[..., 2 * j] = np.log(ta[..., i] - sa[..., i])
                z[..., 2 * j + 1] = np.log(tb[..., i] - sb[..., i])
        return z

    @property
    def acceptance(self) -> dict[str, float]:
        """Acceptance fractions of the three updates (``nan`` for one that never ran)."""
        with np.errstate(invalid="ignore"):
            rates = self.accepted / self.proposed
        return dict(
            zip(
                ("acceptance_shared", "acceptance_leaves", "acceptance_joint"),
                map(float, rates),
                strict=True,
            )
        )
