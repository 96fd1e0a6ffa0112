"""A single fast trial's standard errors against its errors: is error / SE a unit Normal?

Each simulated fast trial (``simulate_trial``, the simulator's default noise: white torque
noise 0.4 N m, a drift of 0.03 N m with a 0.2 s correlation time, velocity noise 0.5 deg/s,
servo ripple, a quantised angle; the lag estimated) is processed by ``estimate_inertia``
against a gravity model known exactly, so that the only errors are the trial's own:

- **rigid**: ``I`` drawn uniformly from 0.05-0.6 kg m^2; the condition's gravity model exact,
  its noise model (``GravityFit.noise``) fitted on a simulated 90 s quasi-static sweep (one
  sweep per ten trials);
- **living**: the same, plus an elbow's passive moment, hysteresis and viscous damping
  whose coefficients are drawn from the shipped elbow prior (``b ~ N(0.1, 0.1)`` N m s/rad,
  the passive curve's and the hysteresis' coefficients from theirs): ``I`` and ``b`` fitted
  over the acceleration and deceleration windows with the static curve known exactly.

Printed per speed: the SD of ``(estimate - truth) / SE`` for the rigid ``I``, the living
``I`` and ``b`` (1 when the SEs are calibrated; over 60 trials an SD has a Monte Carlo SE of
about 9 %, and the table gives the chi-square 99.9 % band of the SD), their mean, and the
Kolmogorov-Smirnov p-value of the ranks ``Phi(z)`` (the simulation-based calibration of the
living estimates: truths from the prior, data from the simulator). Two negative controls on
the same trials: the SEs computed with white noise only (the drift left out), and the rigid
estimate of the living trials (damping read as inertia).

Run:  .venv/bin/python benchmarks/trial_se.py [--quick] [--trials N] [--seed S] [--json FILE]
      (60 trials per speed and kind, about 20 s; --quick 20)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from common import standalone, table
from scipy import stats

SPEEDS = (180.0, 240.0)
MOMENT, PHASE, OFFSET = 2.2, 0.3, 0.1
#: The elbow's angle at the device's 0 (rad).
ZERO = math.radians(60.0)
#: Trials per simulated quasi-static sweep (the noise model they share).
PER_SWEEP = 10
#: Two-sided level of the chi-square band printed for the SD of the z-scores.
LEVEL = 1e-3


def sd_band(n: int, level: float = LEVEL) -> tuple[float, float]:
    """Band of the sample SD of ``n`` unit Normal draws holding it with ``1 - level``."""
    dof = n - 1
    lo, hi = stats.chi2.ppf([level / 2, 1 - level / 2], dof)
    return math.sqrt(lo / dof), math.sqrt(hi / dof)


def elbow_basis():
    """The shipped elbow prior as the static fit's basis (60 deg at the device's 0)."""
    from inertiafit.io.manifest import PassivePrior
    from inertiafit.io.shipped import PASSIVE_ENTRIES, load_passive_prior
    from inertiafit.processing.living import passive_basis

    shipped = load_passive_prior("elbow")
    values = {k: shipped[k]["value"] if k in shipped else None for k in PASSIVE_ENTRIES}
    prior = PassivePrior(
        joint="elbow", joint_angle_at_zero=math.degrees(ZERO), sources={}, **values
    )
    return passive_basis(prior)


def _noise_model(rng: np.random.Generator, noise=None):
    """The noise model of a simulated quasi-static sweep's gravity fit (``None`` before it)."""
    from inertiafit.processing.gravity import fit_gravity
    from inertiafit.simulate.signals import simulate_trial

    sweep = simulate_trial(
        inertia=0.25,
        gravity_moment=MOMENT,
        kind="quasi-static",
        speed_deg_s=1.0,
        phi=PHASE,
        offset=OFFSET,
        rng=rng,
        noise=noise,
    )
    return getattr(fit_gravity(sweep), "noise", None)


def _exact_gravity(noise):
    from inertiafit.processing.gravity import GravityFit

    fit = GravityFit(MOMENT, 0.0, PHASE, 0.0, OFFSET, 0.0, 0.0, 1000, 1000.0, 1.5, 0.02)
    return dataclasses.replace(fit, noise=noise) if noise is not None else fit


def _static_layout(basis):
    """The joint static fit of two exact sweeps: the layout every trial's curve shares.

    Only its layout is used (coefficient names, posture, basis, conditions): each trial puts
    its own truth in (:func:`_exact_curve`), and a fast trial's estimate reads nothing else
    of the fit. That layout does not depend on the coefficients, so one fit serves every
    trial (at the prior means; it cost as much as the trials' own estimates).
    """
    from inertiafit.processing.living import PostureGeometry, StaticRecord, fit_statics

    coef = {n: m for n, (m, _) in zip(basis.names, basis.priors, strict=True)}
    h = basis.hysteresis[0]
    records = []
    for direction in (1, -1):  # two exact sweeps, up and down
        theta = np.linspace(0.0, math.radians(90.0), 600)[::direction]
        passive = sum(c * coef[n] for n, c in zip(basis.names, basis.columns(theta), strict=True))
        torque = MOMENT * np.sin(theta + PHASE) + OFFSET + passive + h * direction
        records.append(StaticRecord(theta, torque, "F", "seated", "quasi-static", "sweep"))
    return fit_statics(records, {"seated": PostureGeometry("seated")}, basis)


def _exact_curve(rng: np.random.Generator, basis, noise, layout):
    """A living condition's static curve with coefficients drawn from the prior, exact.

    ``layout`` is :func:`_static_layout`'s fit. Returns ``(curve, extra)``: the
    :class:`StaticCurve` a fast trial subtracts and the joint's torque
    ``extra(angle, velocity)`` without the damping.
    """
    from inertiafit.processing.living import REST_SPEED

    names = basis.names
    coef = {n: rng.normal(m, s) for n, (m, s) in zip(names, basis.priors, strict=True)}
    h = rng.normal(*basis.hysteresis)
    smooth = getattr(layout, "smooth", None)  # the passive curve's smooth part, if any
    eta, beta = np.zeros(0), np.zeros(0)
    if smooth is not None:  # from its prior too: a grid point, then the coefficients
        # (amplitudes up to 1 N m: a passive curve that swings by tens of N m within ten
        # degrees is no relaxed elbow, and a fast trial's window checks are not made for it)
        eta = rng.normal(0.0, np.sqrt(smooth.hysteresis_variances(basis.hysteresis[1])))
        grid = [(a, ell) for a, ell in smooth.grid if a <= 1.0]
        amplitude, length = grid[rng.integers(len(grid))]
        beta = rng.normal(0.0, np.sqrt(smooth.variances(amplitude, length)))
        coef |= dict(zip(smooth.names, beta, strict=True))
        coef |= dict(zip(smooth.hysteresis_names, eta, strict=True))
    truth = np.empty(len(layout.names))
    for i, name in enumerate(layout.names):
        kind = name.partition(":")[0]
        truth[i] = {
            "A": MOMENT * math.cos(PHASE),
            "B": MOMENT * math.sin(PHASE),
            "C": OFFSET,
            "hysteresis": h,
        }.get(kind, coef.get(name, math.nan))
    if np.isnan(truth).any():  # every coefficient is known: the truth, not a fitted value
        raise AssertionError(f"no truth for {layout.names}")
    changes = {"coefficients": truth}
    if noise is not None:
        changes["noise"] = {"F": noise}
    fit = dataclasses.replace(layout, **changes)

    def extra(angle, velocity):
        passive = sum(c * coef[n] for n, c in zip(names, basis.columns(angle), strict=True))
        moving = np.where(np.abs(velocity) > REST_SPEED, np.sign(velocity), 0.0)
        if smooth is None:
            return passive + h * moving
        functions = np.column_stack(smooth.columns(basis.zero + np.asarray(angle, dtype=float)))
        passive = passive + functions @ beta
        return passive + (h + functions[:, : eta.size] @ eta) * moving

    return fit.curve("F", "seated", 1), extra


def scores(
    speed: float, n: int, seed: int, noise=None, *, white_only: bool = True
) -> dict[str, np.ndarray]:
    """z-scores ``(estimate - truth) / SE`` of ``n`` rigid and ``n`` living fast trials.

    ``noise`` (a :class:`~inertiafit.simulate.signals.Noise`) for every trial and sweep;
    default the simulator's.

    Keys: ``rigid I``, ``living I``, ``living b``; with the drift-aware SEs also the
    controls ``rigid I, white only``, ``living b, white only`` (``white_only=False`` leaves
    these two out: they draw nothing, so the other scores are the same) and ``living I,
    rigid estimate``.
    """
    from inertiafit.processing.inertia import estimate_inertia
    from inertiafit.simulate.signals import simulate_trial

    try:
        from inertiafit.processing.gravity import TorqueNoise, white_level
    except ImportError:  # the code before the drift-aware SEs: no controls
        TorqueNoise = white_level = None

    rng = np.random.default_rng([seed, int(speed)])
    basis = elbow_basis()
    layout = _static_layout(basis)
    out: dict[str, list[float]] = {}

    def add(key: str, value: float) -> None:
        out.setdefault(key, []).append(value)

    model = None
    for k in range(n):
        if k % PER_SWEEP == 0:
            model = _noise_model(rng, noise)
        gravity = _exact_gravity(model)
        inertia = rng.uniform(0.05, 0.6)
        trial = simulate_trial(
            inertia=inertia,
            gravity_moment=MOMENT,
            speed_deg_s=speed,
            phi=PHASE,
            offset=OFFSET,
            rng=rng,
            noise=noise,
        )
        est = estimate_inertia(trial, gravity)
        add("rigid I", (est.inertia - inertia) / est.inertia_se)
        if TorqueNoise is not None and white_only:
            white = TorqueNoise(white_level(trial["torque"].values))
            control = estimate_inertia(trial, gravity, noise=white)
            add("rigid I, white only", (control.inertia - inertia) / control.inertia_se)

        curve, extra = _exact_curve(rng, basis, model, layout)
        inertia = rng.uniform(0.05, 0.6)
        damping = rng.normal(*basis.damping)
        trial = simulate_trial(
            inertia=inertia,
            gravity_moment=MOMENT,
            speed_deg_s=speed,
            phi=PHASE,
            offset=OFFSET,
            rng=rng,
            noise=noise,
            extra_torque=lambda a, v, e=extra, b=damping: e(a, v) + b * v,
        )
        est = estimate_inertia(trial, curve)
        add("living I", (est.inertia - inertia) / est.inertia_se)
        add("living b", (est.damping - damping) / est.damping_se)
        if TorqueNoise is not None:
            if white_only:
                white = TorqueNoise(white_level(trial["torque"].values))
                control = estimate_inertia(trial, curve, noise=white)
                add("living b, white only", (control.damping - damping) / control.damping_se)
            rigid = estimate_inertia(trial, gravity)
            add("living I, rigid estimate", (rigid.inertia - inertia) / rigid.inertia_se)
    return {key: np.array(values) for key, values in out.items()}


def summarise(z: np.ndarray) -> dict:
    """SD, mean and the KS p-value of the ranks ``Phi(z)`` of one set of z-scores."""
    lo, hi = sd_band(z.size)
    sd = float(np.std(z, ddof=1))
    return {
        "n": int(z.size),
        "sd": sd,
        "mean": float(np.mean(z)),
        "band": f"[{lo:.2f}, {hi:.2f}]",
        "inside": lo <= sd <= hi,
        "ks_p": float(stats.kstest(stats.norm.cdf(z), "uniform").pvalue),
    }


def run(*, quick: bool = False, seed: int = 20261126, trials: int | None = None) -> dict:
    n = trials or (20 if quick else 60)
    rows = []
    for speed in SPEEDS:
        for key, z in scores(speed, n, seed).items():
            rows.append({"speed": speed, "estimate": key, **summarise(z)})
    text = table(
        [
            ("speed", "speed (deg/s)", ".0f"),
            ("estimate", "estimate", ""),
            ("n", "trials", "d"),
            ("sd", "SD of error/SE", ".2f"),
            ("band", f"{1 - LEVEL:.1%} band", ""),
            ("mean", "mean", "+.2f"),
            ("ks_p", "KS p of Phi(z)", ".2g"),
        ],
        rows,
    )
    checked = [r for r in rows if "," not in r["estimate"]]
    controls = [r for r in rows if "," in r["estimate"]]
    return {
        "name": "trial_se",
        "title": "A fast trial's own standard errors (error / SE over simulated trials)",
        "rows": rows,
        "table": text,
        "targets": [
            {
                "target": "SD of error/SE inside its chi-square band, rigid and living, "
                "180 and 240 deg/s",
                "value": ", ".join(f"{r['sd']:.2f}" for r in checked),
                "status": "met" if all(r["inside"] for r in checked) else "NOT met",
            },
            {
                "target": "the controls (drift left out; rigid estimate of a living trial) fail",
                "value": ", ".join(f"{r['sd']:.2f}" for r in controls),
                "status": "met" if controls and not all(r["inside"] for r in controls) else "-",
            },
        ],
    }


def main() -> None:
    standalone(
        run,
        __doc__,
        seed=20261126,
        quick_help="20 trials per speed and kind",
        options={"--trials": {"type": int, "help": "trials per speed and kind (default 60)"}},
    )


if __name__ == "__main__":
    main()
