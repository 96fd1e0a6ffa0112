"""Simulation-based calibration (Talts et al. 2018): the posterior is right on average.

Draw a truth from the prior boxes, data from the model's own likelihood, fit, and note the rank
of the truth among ``L`` posterior draws. Over many simulated studies the ranks of a correct
posterior are uniform on ``0..L``, and every 95 % interval holds the truth in 95 % of studies;
a wrong likelihood, prior or sampler shows up as a histogram that is not flat.

What "the model's own likelihood" is
------------------------------------
* ``mean_se`` (a value with its standard error): ``y ~ N(mu, se^2)``, ``se`` known. It is
  drawn log-uniformly from a fixed range (a design constant, independent of the truth).
* ``values`` (repeated trials) and ``mean_sd`` (their mean, SD and ``n``): the model's
  Student-t is what ``y_k ~ N(mu, sigma^2)`` gives after integrating ``sigma`` out under the
  Jeffreys prior ``p(sigma) ~ 1/sigma``. That prior is improper, so no simulation draws from it;
  the simulations draw ``sigma`` log-uniformly from ``[sigma_lo, sigma_hi]`` — the Jeffreys
  prior truncated to a proper one — and the exact posterior under that prior is the model's
  posterior times, per such observation,

      w(mu) = P(n/2, Q(mu) / (2 sigma_lo^2)) - P(n/2, Q(mu) / (2 sigma_hi^2)),
      Q(mu) = (n - 1) s^2 + n (ybar - mu)^2,

  with ``P`` the regularised lower incomplete gamma function (``Q`` is the sum of squares
  ``sum_k (y_k - mu)^2``; ``w -> 1`` as the range grows). The ranks use the posterior draws
  reweighted by ``w`` (:func:`truncation_log_weights`), which makes the check exact. Without
  it the check is approximate: the Student-t has heavier tails than a truncated noise prior
  gives (in a one-parameter check with 10^5 studies, three trials and noise up to 30 % of the
  prior's width, 5-7 % too many ranks fell in each extreme tenth; at the sizes of
  ``benchmarks/sbc.py`` the difference does not show, ``ranks_unweighted``). ``mean_sd`` is
  simulated through its sufficient statistics (``ybar ~ N(mu, sigma^2/n)``,
  ``(n-1) s^2 / sigma^2 ~ chi^2_{n-1}``), ``values`` trial by trial.

Systematic errors (:class:`Design` ``torque_gain_sd``, ``shared``, ``coupling``): a gain
``gamma = exp(torque_gain_sd z)`` multiplies every observed value (its truth is ranked as
``calibration / torque_gain``); with ``coupling`` or ``shared`` (``mean_se`` evidence only) each
condition's gravity moment is off by ``v ~ N(0, se_g^2)`` and its inertia by
``coupling v + shared se_i z'``, as the model's coupled evidence says.

Every noise SD is at most ``noise`` (default 0.15) times the smallest value the observable
can take inside the boxes, so a trial value is positive (more than 6.6 SDs from zero).

Ranks
-----
``L`` draws are taken with replacement from all kept draws (with probabilities ``w``): they
are independent draws from the sampler's empirical posterior, so the rank of the truth is
exactly uniform on ``0..L`` when that posterior is right; the chains' autocorrelation enters
only through the noise of the empirical distribution (its ESS, hundreds or more). The 95 %
HDI is the shortest interval holding 95 % of the (weighted) kept draws.

Tests (:func:`calibration_table`, :func:`calibrated`): per quantity, a chi-square test of
the binned ranks against uniform, and a two-sided binomial test of the coverage of the central
95 % interval (ranks ``5..194`` of ``0..199``: exactly 95 % under calibration) and of the HDI.
A set of quantities passes when no p-value is below ``alpha`` divided by the number of tests
(Bonferroni: the chance that a calibrated posterior fails is at most ``alpha``).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from inertiafit import physics
from inertiafit._checks import check_positive, check_probability
from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.inference.fit import fit
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior, anthropometric_prior
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.measured import measured_quantity
from inertiafit.mounting import Mounting
from inertiafit.physics import GRAVITY, REPORTED

__all__ = [
    "EVIDENCE",
    "EXTRA_KINDS",
    "SBC_SETTINGS",
    "Design",
    "SBCResult",
    "Simulation",
    "attachment_design",
    "calibrated",
    "calibration_table",
    "draw_truth_and_data",
    "extra_design",
    "hdi_contains",
    "run_sbc",
    "sbc_ranks",
    "truncation_log_weights",
]

#: Kinds of evidence a design simulates (the three routes into :class:`Observation`).
EVIDENCE = ("values", "mean_sd", "mean_se")
OBSERVABLES = ("inertia", "gravity_moment")

#: Sampler settings for calibration runs: the default sampler and convergence checks, with a
#: few hundred effective draws (the ranks use 199 of them) and R-hat <= 1.02 instead of 1.01,
#: for a fraction of the default run's cost; a step bound keeps a slowly mixing study from
#: holding up a run (it is counted in ``SBCResult.unconverged`` and its draws are kept).
SBC_SETTINGS = SamplerSettings(
    n_walkers=32,
    chunk=60,
    ess_min=400.0,
    r_hat_max=1.02,
    tau_factor=30.0,
    max_steps=3000,
    progress=False,
)


@dataclass(frozen=True)
class Design:
    """What is simulated: the bodies' prior boxes, the conditions, the kind of evidence.

    Attributes
    ----------
    priors : mapping of str to Prior
        The boxes truths are drawn from (uniformly in ``m``, ``x``, ``rho``).
    conditions : tuple of (tuple of str or Mounting)
        The bodies mounted together in each condition (a :class:`~inertiafit.mounting.Mounting`
        for a moved body, at a positive offset, or known added masses); each has both
        observables.
    evidence : str
        ``"values"`` (``n_trials`` trial values), ``"mean_sd"`` (their mean, SD and ``n``) or
        ``"mean_se"`` (one value with a known standard error), for both observables.
    n_trials : int
        Trials per condition and observable (``mean_se``: the SE is a trial SD over
        ``sqrt(n_trials)``).
    noise : float
        Largest trial SD as a fraction of the smallest value the observable takes in the boxes.
    noise_ratio : float
        Largest over smallest trial SD; SDs are drawn log-uniformly in between.
    gravity : float
        m/s^2.
    torque_gain_sd : float
        SD of the log torque gain of every simulated study (0: none).
    shared : float
        SD of the inertia's shared error, in units of its standard error (``mean_se`` only).
    coupling : float
        ``Condition.coupling`` of every condition, kg m^2 per N m (``mean_se`` only).
    measured : mapping of str to mapping of str to float
        Direct measurements simulated per body: ``{"disk": {"mass": 0.01}}`` reads the true
        ``mass`` (kg) or ``com_distance`` (m) with a Gaussian error of that SD (a design
        constant), which the model takes as known.
    """

    priors: Mapping[str, Prior]
    conditions: tuple[tuple[str, ...] | Mounting, ...]
    evidence: str = "values"
    n_trials: int = 5
    noise: float = 0.15
    noise_ratio: float = 30.0
    gravity: float = GRAVITY
    torque_gain_sd: float = 0.0
    shared: float = 0.0
    coupling: float = 0.0
    measured: Mapping[str, Mapping[str, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.evidence not in EVIDENCE:
            raise InputError(
                f"evidence: expected one of {', '.join(EVIDENCE)}, got {self.evidence!r}"
            )
        if (
            isinstance(self.n_trials, bool)
            or int(self.n_trials) != self.n_trials
            or self.n_trials < 2
        ):
            raise InputError(f"n_trials: expected an integer >= 2, got {self.n_trials!r}")
        if not 0 < check_positive(self.noise, "noise") <= 0.15:
            raise InputError(f"noise: expected a fraction in (0, 0.15], got {self.noise}")
        if not check_positive(self.noise_ratio, "noise_ratio") > 1:
            raise InputError(f"noise_ratio: expected a number > 1, got {self.noise_ratio}")
        if (self.shared or self.coupling) and self.evidence != "mean_se":
            raise InputError("shared, coupling: need evidence 'mean_se' (a Gaussian M_g)")
        if not (0 <= self.torque_gain_sd < 0.5 and self.shared >= 0):
            raise InputError("torque_gain_sd: expected [0, 0.5); shared: expected >= 0")
        for m in self.mountings():
            # a positive offset keeps the simulated values above the unmoved totals' noise floor
            if m.offset_body and not m.offset > 0:
                raise InputError(f"mounting offset: expected a positive distance, got {m.offset}")
        for body, table in self.measured.items():
            for key, sd in table.items():
                q = measured_quantity(key, where=f"measured: {body}")
                check_positive(sd, f"measured: {body}.{key}", q.unit)

    @property
    def label(self) -> str:
        """Short name: bodies and evidence (``1 body, values`` or ``attachment + 3, mean_se``)."""
        n = len(self.priors)
        shape = "1 body" if n == 1 else f"attachment + {n - 1}"
        extra = ""
        if self.shared or self.coupling:
            extra += ", coupled"
        if self.torque_gain_sd:
            extra += f", gain {100 * self.torque_gain_sd:g}%"
        kinds = sorted({k for table in self.measured.values() for k in table})
        if kinds:
            extra += ", measured " + "+".join(kinds)
        if any(isinstance(c, Mounting) and c.offset_body for c in self.conditions):
            extra += ", second mounting"
        if any(isinstance(c, Mounting) and c.added for c in self.conditions):
            extra += ", added mass"
        return f"{shape}, {self.evidence}{extra}"

    def mountings(self) -> list[Mounting]:
        """Every condition as a :class:`Mounting`."""
        return [c if isinstance(c, Mounting) else Mounting(tuple(c)) for c in self.conditions]

    def noise_range(self, bodies: Sequence[str], observable: str) -> tuple[float, float]:
        """``(sigma_lo, sigma_hi)`` of one trial of ``observable`` on these bodies."""
        low = 0.0
        for body in bodies:
            lo = self.priors[body].lower
            m, x, rho = lo["mass"], lo["com_distance"], lo["radius_of_gyration"]
            if observable == "inertia":
                low += float(physics.inertia(m, rho, x))
            else:
                low += float(physics.gravity_moment(m, x, self.gravity))
        hi = self.noise * low
        return hi / self.noise_ratio, hi


def attachment_design(k: int, evidence: str, *, seed: int = 0, **kwargs) -> Design:
    """An attachment alone (``k = 0``) or measured alone and with each of ``k`` segments.

    The attachment's box is ±50 % around the paper's ideal tube (2.91 kg, ``x`` 0.225 m,
    ``rho`` 0.13 m); each segment's around a nominal drawn once (``seed``) from
    ``m`` in [1, 4] kg, ``x`` in [0.1, 0.3] m, ``rho`` in [0.04, 0.1] m. ``kwargs`` go to
    :class:`Design`.
    """
    rng = np.random.default_rng([seed, k])
    priors = {
        "attachment": Prior.box(
            "attachment", mass=2.91, com_distance=0.225, radius_of_gyration=0.13
        )
    }
    for j in range(1, k + 1):
        name = f"seg{j:02d}"
        priors[name] = Prior.box(
            name,
            mass=rng.uniform(1.0, 4.0),
            com_distance=rng.uniform(0.1, 0.3),
            radius_of_gyration=rng.uniform(0.04, 0.1),
        )
    conditions = (("attachment",), *(("attachment", b) for b in list(priors)[1:]))
    return Design(priors, conditions, evidence, **kwargs)


#: Kinds of extra information :func:`extra_design` simulates.
EXTRA_KINDS = (
    "second mounting",
    "weighed mass",
    "balance point",
    "added mass",
    "all",
    "de Leva prior",
)


def extra_design(kind: str, *, seed: int = 0, **kwargs) -> Design:
    """An attachment alone and with one segment, with one kind of extra information.

    ``"second mounting"``: the attachment measured again 0.1 m further out; ``"weighed
    mass"``: both bodies weighed (SD 0.05 kg and 0.03 kg); ``"balance point"``: the
    attachment's centre of mass to 4 mm; ``"added mass"``: a known 0.5 kg point 0.3 m out
    mounted with the segment (with a 2 % torque gain, which a known mass can calibrate);
    ``"all"``: the second mounting, the segment weighed, the attachment's balance point and
    the added mass; ``"de Leva prior"``: no extra measurement, the segment's prior the de Leva
    (1996) male forearm + hand of a 72.5 kg man with a 0.27 m forearm (truths drawn from it).
    ``kwargs`` go to :class:`Design` (default evidence ``mean_se``).
    """
    if kind not in EXTRA_KINDS:
        raise InputError(f"kind: expected one of {', '.join(EXTRA_KINDS)}, got {kind!r}")
    kwargs.setdefault("evidence", "mean_se")
    evidence = kwargs.pop("evidence")
    base = attachment_design(1, evidence, seed=seed, **kwargs)
    plain: tuple[tuple[str, ...] | Mounting, ...] = (("attachment",), ("attachment", "seg01"))
    moved = Mounting(("attachment",), "attachment", 0.1)
    added = Mounting(("attachment", "seg01"), added=((0.5, 0.3, 0.0),))
    if kind == "second mounting":
        return dataclasses.replace(base, conditions=(*plain, moved))
    if kind == "weighed mass":
        return dataclasses.replace(
            base, measured={"attachment": {"mass": 0.05}, "seg01": {"mass": 0.03}}
        )
    if kind == "balance point":
        return dataclasses.replace(base, measured={"attachment": {"com_distance": 0.004}})
    if kind == "de Leva prior":
        forearm = anthropometric_prior("de-leva-male", "forearm+hand", 72.5, 0.27, name="seg01")
        return dataclasses.replace(base, priors={**base.priors, "seg01": forearm})
    if kind == "added mass":
        return dataclasses.replace(
            base,
            conditions=(("attachment",), added),
            torque_gain_sd=kwargs.get("torque_gain_sd", 0.02),
        )
    return dataclasses.replace(
        base,
        conditions=(("attachment",), added, moved),
        measured={"seg01": {"mass": 0.03}, "attachment": {"com_distance": 0.004}},
    )


@dataclass(frozen=True)
class Simulation:
    """One simulated study: the truth and the evidence the model reads.

    Attributes
    ----------
    truth : dict
        ``truth[body][quantity]`` for every quantity of :data:`~inertiafit.physics.REPORTED`,
        and ``truth["calibration"]["torque_gain"]`` with a torque gain.
    conditions : tuple of Condition
        The simulated evidence, one condition per entry of ``design.conditions``.
    noise_ranges : dict
        ``(condition label, observable) -> (sigma_lo, sigma_hi)`` of every Student-t
        observation (empty for ``mean_se``): what :func:`truncation_log_weights` needs.
    design : Design
    """

    truth: dict[str, dict[str, float]]
    conditions: tuple[Condition, ...]
    noise_ranges: dict[tuple[str, str], tuple[float, float]]
    design: Design
    measured: dict[str, dict[str, Observation]] = field(default_factory=dict)

    def model(self, scale: float = 1.0, *, systematics: bool = True) -> Model:
        """The model fitted to this study.

        ``scale`` multiplies every observation's scale: 1 is the right likelihood, 0.5 or 2
        a wrong one (the negative control). ``systematics=False`` leaves out the torque gain,
        the coupling and the shared error (another negative control).
        """
        check_positive(scale, "scale")

        def scaled(o: Observation | None) -> Observation | None:
            if o is None:
                return None
            return o.scaled(scale) if systematics else o.with_shared_error(0.0).scaled(scale)

        conditions = [
            Condition(
                c.mounting,
                scaled(c.inertia),
                scaled(c.gravity_moment),
                c.label,
                c.coupling if systematics else 0.0,
            )
            for c in self.conditions
        ]
        measured = {
            body: {key: obs.scaled(scale) for key, obs in table.items()}
            for body, table in self.measured.items()
        }
        return Model(
            self.design.priors,
            conditions,
            gravity=self.design.gravity,
            torque_gain_sd=self.design.torque_gain_sd if systematics else 0.0,
            measured=measured,
        )


def draw_truth_and_data(design: Design, rng: np.random.Generator) -> Simulation:
    """A truth from the prior boxes and evidence from the model's likelihood (module docstring)."""
    g = design.gravity
    truth: dict[str, dict[str, float]] = {}
    for body, prior in design.priors.items():
        d = {p: float(v[0]) for p, v in prior.sample(1, rng).items()}
        m, x, rho = d["mass"], d["com_distance"], d["radius_of_gyration"]
        d["inertia"] = float(physics.inertia(m, rho, x))
        d["gravity_moment"] = float(physics.gravity_moment(m, x, g))
        truth[body] = {q: d[q] for q in REPORTED}
    gain = 1.0
    if design.torque_gain_sd:
        gain = math.exp(design.torque_gain_sd * rng.standard_normal())
        truth["calibration"] = {"torque_gain": gain}
    n = int(design.n_trials)
    conditions, ranges = [], {}
    for mounting in design.mountings():
        bodies = mounting.bodies
        label = mounting.label
        totals = dict(zip(OBSERVABLES, mounting.totals(truth, g), strict=True))
        obs = {}
        error_g = 0.0
        # coupled: the gravity moment first, the inertia's error follows it
        for name in OBSERVABLES[::-1] if design.coupling else OBSERVABLES:
            mu = gain * float(totals[name])  # type: ignore[arg-type]
            lo, hi = design.noise_range(bodies, name)
            sigma = math.exp(rng.uniform(math.log(lo), math.log(hi)))
            where = f"{label} {name}"
            if design.evidence == "values":
                trials = mu + sigma * rng.standard_normal(n)
                obs[name] = Observation.from_values(trials.tolist(), where=where)
            elif design.evidence == "mean_sd":
                mean = mu + sigma / math.sqrt(n) * rng.standard_normal()
                sd = sigma * math.sqrt(rng.chisquare(n - 1) / (n - 1))
                obs[name] = Observation.from_mean_sd(mean, sd, n, where=where)
            else:
                se = sigma / math.sqrt(n)
                error = se * rng.standard_normal()
                shared = design.shared * se if name == "inertia" else 0.0
                if name == "gravity_moment":
                    error_g = error
                else:
                    error += design.coupling * error_g + shared * rng.standard_normal()
                obs[name] = Observation.from_mean_se(mu + error, se, where=where)
                if shared:
                    obs[name] = obs[name].with_shared_error(shared)
            if design.evidence != "mean_se":
                ranges[(label, name)] = (lo, hi)
        conditions.append(
            Condition(mounting, obs["inertia"], obs["gravity_moment"], label, design.coupling)
        )
    measured: dict[str, dict[str, Observation]] = {}
    for body, table in design.measured.items():
        for key, sd in table.items():
            quantity = measured_quantity(key, where=f"measured: {body}")
            true = quantity.value(truth[body]["mass"], truth[body]["com_distance"])
            reading = true + sd * rng.standard_normal()
            measured.setdefault(body, {})[key] = Observation.from_mean_se(
                reading, sd, where=f"measured {body} {key}"
            )
    return Simulation(truth, tuple(conditions), ranges, design, measured)


def truncation_log_weights(
    sim: Simulation, draws: Mapping[str, Mapping[str, np.ndarray]]
) -> np.ndarray:
    """Log of ``prod w(mu)`` per draw: the model's posterior → the exact one of the simulation.

    ``draws[body][quantity]`` are 1-D arrays of one length; a condition's ``mu`` is the sum over
    its bodies. Zero for ``mean_se`` (a Gaussian needs no correction).
    """
    from scipy import special

    length = len(next(iter(next(iter(draws.values())).values())))
    out = np.zeros(length)
    for cond in sim.conditions:
        for name in OBSERVABLES:
            if (cond.label, name) not in sim.noise_ranges:
                continue
            lo, hi = sim.noise_ranges[(cond.label, name)]
            obs: Observation = getattr(cond, name)
            n = obs.n
            totals = cond.mounting.totals(draws, sim.design.gravity)
            mu = np.asarray(totals[OBSERVABLES.index(name)])
            if "calibration" in draws:  # the observations are of the gain times the truth
                mu = mu * np.asarray(draws["calibration"]["torque_gain"])
            sd2 = n * obs.scale**2  # s^2
            q = (n - 1) * sd2 + n * (obs.center - mu) ** 2
            small, large = q / (2 * hi * hi), q / (2 * lo * lo)
            a = n / 2
            # P(a, large) - P(a, small), from the side where it does not cancel
            w = np.where(
                small > a,
                special.gammaincc(a, small) - special.gammaincc(a, large),
                special.gammainc(a, large) - special.gammainc(a, small),
            )
            with np.errstate(divide="ignore"):
                out += np.log(np.maximum(w, 0.0))
    return out


def hdi_contains(
    values: np.ndarray, weights: np.ndarray, truth: float, prob: float = 0.95
) -> bool:
    """Whether the shortest interval holding ``prob`` of the weighted draws contains ``truth``."""
    order = np.argsort(values)
    v = values[order]
    c = np.cumsum(weights[order])
    c /= c[-1]
    start = np.concatenate([[0.0], c[:-1]])  # mass before each draw
    end = np.searchsorted(c, start + prob - 1e-12)  # first draw closing prob of mass
    ok = end < len(v)
    i = np.flatnonzero(ok)
    widths = v[end[ok]] - v[i]
    best = int(np.argmin(widths))
    return bool(v[i[best]] <= truth <= v[end[ok][best]])


def sbc_ranks(
    draws: Mapping[str, Mapping[str, np.ndarray]],
    truth: Mapping[str, Mapping[str, float]],
    rng: np.random.Generator,
    *,
    log_weights: np.ndarray | None = None,
    n_draws: int = 199,
    hdi_prob: float = 0.95,
) -> tuple[np.ndarray, np.ndarray]:
    """Rank of the truth among ``n_draws`` posterior draws, and whether the HDI holds it.

    ``draws[body][quantity]`` are the kept draws (any shape, one per body and quantity, same
    size); ``n_draws`` of them are taken with replacement, with probabilities
    ``exp(log_weights)`` (uniform when ``None``). Returns two arrays in the order
    ``[(body, q) for body in truth for q in truth[body]]``: ranks in ``0..n_draws`` and
    booleans.
    """
    check_probability(hdi_prob, "hdi_prob")
    flat = {b: {q: np.ravel(draws[b][q]) for q in truth[b]} for b in truth}
    first = next(iter(truth))
    size = len(flat[first][next(iter(truth[first]))])
    if log_weights is None:
        weights = np.full(size, 1.0 / size)
    else:
        weights = np.exp(log_weights - np.max(log_weights))
        weights /= weights.sum()
    pick = rng.choice(size, size=n_draws, replace=True, p=weights)
    ranks, inside = [], []
    for b in truth:
        for q in truth[b]:
            x = flat[b][q]
            ranks.append(int(np.sum(x[pick] < truth[b][q])))
            inside.append(hdi_contains(x, weights, truth[b][q], hdi_prob))
    return np.array(ranks), np.array(inside)


@dataclass
class SBCResult:
    """Ranks and HDI hits of every simulated study of one design.

    Attributes
    ----------
    design : Design
    scale : float
        The factor on every observation's scale when fitting (1: the right likelihood).
    quantities : list of (body, quantity)
    ranks, ranks_unweighted : ndarray, shape (n_studies, n_quantities)
        Ranks in ``0..n_draws`` with the exact truncation weights, and without them (the
        model's posterior as sampled); identical for ``mean_se``.
    hdi_inside : ndarray of bool, same shape
    n_draws : int
    failures : Counter
        Studies that gave no posterior, by ``"ExceptionType: message"``.
    unconverged : int
        Fits that stopped at the step bound (their draws are kept: dropping them would select
        studies by their data).
    seconds : float
        Wall time of the whole run.
    """

    design: Design
    scale: float
    quantities: list[tuple[str, str]]
    ranks: np.ndarray
    ranks_unweighted: np.ndarray
    hdi_inside: np.ndarray
    n_draws: int
    failures: Counter = field(default_factory=Counter)
    unconverged: int = 0
    seconds: float = 0.0

    @property
    def n_studies(self) -> int:
        """Studies that gave a posterior."""
        return int(self.ranks.shape[0])


def run_sbc(
    design: Design,
    n_studies: int,
    *,
    seed: int = 0,
    settings: SamplerSettings | None = None,
    scale: float = 1.0,
    n_draws: int = 199,
    systematics: bool = True,
) -> SBCResult:
    """Simulate ``n_studies`` studies of ``design``, fit each and rank the truths.

    Each study is fitted with :func:`~inertiafit.inference.fit.fit` (``settings``, default
    :data:`SBC_SETTINGS`).
    Study ``i`` draws its truth and data from ``numpy.random.default_rng([seed, i])``.
    ``scale`` multiplies every observation's scale when fitting (a negative control);
    ``systematics=False`` fits without the design's torque gain, coupling and shared error
    (another; the gain's truth is then ranked against draws fixed at 1).
    A study whose fit raises :class:`~inertiafit.errors.InputError` (a box that cannot
    explain the simulated evidence) or ``ValueError`` (a sampler crash) is counted in
    ``failures`` and left out.
    """
    import time

    t0 = time.perf_counter()
    settings = settings or SBC_SETTINGS
    quantities = [(b, q) for b in design.priors for q in REPORTED]
    if design.torque_gain_sd:
        quantities.append(("calibration", "torque_gain"))
    ranks, plain, inside = [], [], []
    failures: Counter = Counter()
    unconverged = 0
    for i in range(int(n_studies)):
        rng = np.random.default_rng([seed, i])
        sim = draw_truth_and_data(design, rng)
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", ConvergenceWarning)
                post = fit(
                    sim.model(scale, systematics=systematics),
                    seed=int(rng.integers(2**31)),
                    settings=settings,
                )
        except (InputError, ValueError) as exc:
            failures[f"{type(exc).__name__}: {exc}"] += 1
            continue
        unconverged += any(issubclass(w.category, ConvergenceWarning) for w in caught)
        draws = {b: {q: post.draws(b, q).ravel() for q in REPORTED} for b in design.priors}
        if design.torque_gain_sd:
            size = draws[next(iter(design.priors))]["mass"].size
            gain = (
                np.ravel(post.tree["posterior"]["torque_gain"].to_numpy())
                if systematics
                else np.ones(size)
            )
            draws["calibration"] = {"torque_gain": gain}
        logw = truncation_log_weights(sim, draws)
        r, h = sbc_ranks(
            draws,
            sim.truth,
            np.random.default_rng([seed, i, 1]),
            log_weights=logw,
            n_draws=n_draws,
        )
        if sim.noise_ranges:
            r0, _ = sbc_ranks(
                draws, sim.truth, np.random.default_rng([seed, i, 1]), n_draws=n_draws
            )
        else:
            r0 = r
        ranks.append(r)
        plain.append(r0)
        inside.append(h)
    width = len(quantities)
    return SBCResult(
        design=design,
        scale=scale,
        quantities=quantities,
        ranks=np.array(ranks, int).reshape(-1, width),
        ranks_unweighted=np.array(plain, int).reshape(-1, width),
        hdi_inside=np.array(inside, bool).reshape(-1, width),
        n_draws=n_draws,
        failures=failures,
        unconverged=int(unconverged),
        seconds=time.perf_counter() - t0,
    )


def _central_ranks(n_draws: int, prob: float) -> tuple[int, int]:
    """Ranks ``lo..hi`` of the central ``prob`` interval of ``n_draws`` draws."""
    tail = round((1 - prob) / 2 * (n_draws + 1))
    return tail, n_draws - tail


def calibration_table(
    result: SBCResult, *, bins: int | None = None, unweighted: bool = False, prob: float = 0.95
) -> list[dict]:
    """One row per quantity: rank histogram, chi-square p-value, coverages and their p-values.

    ``bins`` must divide ``n_draws + 1`` (default: 20, 10 or 5, the most that leave at least
    8 studies per bin, else 4). Keys: ``body``, ``quantity``, ``n``, ``histogram``, ``chi2_p``,
    ``central`` (coverage of the central ``prob`` interval of the ranks), ``central_expected``
    (exact under calibration), ``central_p``, ``hdi``, ``hdi_p`` (two-sided binomial tests).
    """
    from scipy import stats

    check_probability(prob, "prob")
    ranks = result.ranks_unweighted if unweighted else result.ranks
    n, total = ranks.shape[0], result.n_draws + 1
    if bins is None:
        bins = next((b for b in (20, 10, 5) if total % b == 0 and n >= 8 * b), 4)
    if total % bins:
        raise InputError(f"bins: {bins} does not divide n_draws + 1 = {total}")
    lo, hi = _central_ranks(result.n_draws, prob)
    expected = (hi - lo + 1) / total
    rows = []
    for j, (body, q) in enumerate(result.quantities):
        r = ranks[:, j]
        hist = np.bincount(r * bins // total, minlength=bins)
        chi2_p = float(stats.chisquare(hist).pvalue) if n else math.nan
        covered = int(np.sum((r >= lo) & (r <= hi)))
        hdi_in = int(np.sum(result.hdi_inside[:, j]))
        rows.append(
            {
                "body": body,
                "quantity": q,
                "n": n,
                "histogram": hist.tolist(),
                "chi2_p": chi2_p,
                "central": covered / n if n else math.nan,
                "central_expected": expected,
                "central_p": float(stats.binomtest(covered, n, expected).pvalue)
                if n
                else math.nan,
                "hdi": hdi_in / n if n else math.nan,
                "hdi_p": float(stats.binomtest(hdi_in, n, prob).pvalue) if n else math.nan,
            }
        )
    return rows


def calibrated(rows: Sequence[Mapping], alpha: float = 0.001) -> bool:
    """Whether every p-value of every row stays above ``alpha / (3 * len(rows))``.

    Bonferroni over the rows' three tests: a calibrated posterior fails with probability at
    most ``alpha``.
    """
    check_probability(alpha, "alpha")
    limit = alpha / (3 * len(rows))
    return all(min(r["chi2_p"], r["central_p"], r["hdi_p"]) > limit for r in rows)
