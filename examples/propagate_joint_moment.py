"""
Carrying the uncertainty into a joint moment
============================================

Andrews & Mish found that a ±5 % error in the body-segment parameters became up to 12 % in the
joint moments of inverse dynamics. This script asks the same question of three states of
knowledge about one forearm + hand (a simulated 75 kg man, forearm 0.27 m): the paper's ±50 %
box around de Leva's values, de Leva's anthropometric prior, and the posterior after a
dynamometer session. :func:`inertiafit.propagate` carries each one's draws of ``(m, x, rho)``
into the elbow moment of the same fast flexion, ``M(t) = I alpha + M_g sin(theta)``, and says
which parameter the spread is due to. The posterior is then exported as a biorbd model.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import inertiafit as ift
from inertiafit.inference.priors import anthropometric_prior

OUT = Path("examples-output") / "propagate"
OUT.mkdir(parents=True, exist_ok=True)

# %%
# Three states of knowledge
# -------------------------
# de Leva's table gives the prior; the box is the paper's ±50 % around the same values. The
# subject's true parameters are one draw of the prior, and the session "measures" their
# ``I`` and ``M_g`` with 1 % standard errors.

de_leva = anthropometric_prior("de-leva-male", "forearm+hand", 75.0, 0.27, name="forearm")
box = ift.load_prior({**de_leva.nominal, "spread": 0.5}, name="box")
rng = np.random.default_rng(7)
truth = {p: float(v[0]) for p, v in de_leva.sample(1, rng).items()}
m, x, rho = truth["mass"], truth["com_distance"], truth["radius_of_gyration"]
inertia, gravity_moment = m * (rho**2 + x**2), m * 9.81 * x
print(f"truth: m = {m:.3f} kg, x = {x:.4f} m, rho = {rho:.4f} m")
posterior = ift.fit_body(
    de_leva,
    inertia=inertia,
    inertia_se=0.01 * inertia,
    gravity_moment=gravity_moment,
    gravity_moment_se=0.01 * gravity_moment,
    seed=1,
    settings=ift.SamplerSettings(ess_min=400),
)

# %%
# One motion
# ----------
# A fast elbow flexion from 10° to 130° (angle from the hanging forearm) in 0.4 s, minimum
# jerk; its acceleration is given exactly rather than differentiated.

t = np.linspace(0.0, 0.4, 401)
tau = t / 0.4
start, sweep = np.radians(10.0), np.radians(120.0)
angle = start + sweep * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
acceleration = sweep / 0.4**2 * (60 * tau - 180 * tau**2 + 120 * tau**3)
motion = {"time": t, "angle": angle, "acceleration": acceleration}
true_moment = inertia * acceleration + gravity_moment * np.sin(angle)

# %%
# The moment's band under each
# ----------------------------
# At the instant of the largest moment: the median, the 95 % band and its half-width relative
# to the median, and the share of the moment's variance each parameter accounts for (by
# conditioning on it; correlated parameters' shares overlap).

results = {
    "±50 % box": ift.propagate(box, motion, seed=2),
    "de Leva prior": ift.propagate(de_leva, motion, seed=2),
    "measured posterior": ift.propagate(posterior, motion, seed=2),
}
peak = int(np.argmax(np.abs(true_moment)))
print(f"\nelbow moment at t = {t[peak]:.3f} s (truth {true_moment[peak]:.3f} N m)")
print(f"{'knowledge':20s} {'median':>8s} {'95 % HDI':>20s} {'± %':>6s}  share m / x / rho")
for name, result in results.items():
    lo, hi = result.hdi[peak]
    shares = result.shares().iloc[peak]
    print(
        f"{name:20s} {result.median[peak]:8.3f} [{lo:8.3f}, {hi:8.3f}] "
        f"{50 * (hi - lo) / abs(result.median[peak]):5.1f}  "
        f"{shares['share_mass']:.2f} / {shares['share_com_distance']:.2f} / "
        f"{shares['share_radius_of_gyration']:.2f}"
    )

fig, ax = plt.subplots(figsize=(6.5, 3.8), layout="constrained")
for (name, result), color in zip(results.items(), ("0.75", "tab:orange", "tab:blue"), strict=True):
    ax.fill_between(t, result.hdi[:, 0], result.hdi[:, 1], color=color, alpha=0.6, label=name)
ax.plot(t, true_moment, color="k", lw=1, label="truth")
ax.set(xlabel="time [s]", ylabel="elbow moment [N m]", title="95 % bands of the same flexion")
ax.legend(frameon=False, fontsize=8)
fig.savefig(OUT / "moment-bands.png", dpi=120)
results["measured posterior"].table().to_csv(OUT / "posterior-moment.csv", index=False)

# %%
# The posterior in a musculoskeletal model
# ----------------------------------------
# ``inertiafit export`` (here :func:`inertiafit.run_export`) writes the forearm as a biorbd
# segment; de Leva's sagittal and longitudinal radii come from the prior's table. Ten models
# sampled from the posterior carry the uncertainty into a Monte Carlo study.

(OUT / "results").mkdir(exist_ok=True)
posterior.save(OUT / "results" / "posterior.nc")
ift.run_export(OUT / "results", fmt="biomod", out=OUT / "model", draws=10, seed=3)
print((OUT / "model" / "model.bioMod").read_text().split("segment forearm")[1])
