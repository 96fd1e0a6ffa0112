"""
Reading ``posterior.nc`` with ArviZ and xarray
==============================================

Every fit is saved as an ArviZ DataTree in netCDF (``posterior.nc``): the draws, the prior
draws, the evidence, the prior box, the sampler's diagnostics and the provenance. It opens
without inertiafit — with ``xarray.open_datatree`` — and every ArviZ function works on it. This
script writes one, reopens it both ways, and computes a few things the built-in tables do not.
"""

from pathlib import Path

import arviz_stats
import numpy as np
import xarray as xr

import inertiafit as ift

OUT = Path("examples-output") / "arviz"
OUT.mkdir(parents=True, exist_ok=True)

# %%
# Write a posterior
# -----------------
# The paper's attachment from its reported numbers (``inertiafit fit`` writes the same file).

post = ift.fit_body(
    "biodex-elbow-attachment",
    inertia=0.216,
    inertia_sd=0.017,
    inertia_n=30,
    gravity_moment=7.415,
    gravity_moment_se=0.05,
    seed=5,
)
path = post.save(OUT / "posterior.nc")

# %%
# Open it with xarray
# -------------------
# Groups: ``posterior``, ``sample_stats``, ``log_likelihood``, ``observed_data``, ``prior``,
# ``constant_data``; each posterior variable is ``(chain, draw, body)`` — walkers as chains.

tree = xr.open_datatree(path, engine="h5netcdf")
print(tree.groups)
print(tree["posterior"])

# %%
# The provenance travels with the draws: versions, seed, sampler settings and diagnostics.

for key in ("seed", "converged", "n_walkers", "n_steps", "tau_max"):
    print(f"{key}: {tree.attrs.get(key)}")

# %%
# ArviZ summaries
# ---------------
# ``arviz_stats.summary`` gives means, SDs, credible intervals, ESS and R-hat;
# ``arviz_stats.hdi`` the highest-density intervals. (inertiafit's own ``summary()`` is the
# same numbers in the layout of ``summary.csv``.)

print(arviz_stats.summary(tree, ci_prob=0.95, round_to=4).to_string())

# %%

hdi = arviz_stats.hdi(tree, prob=0.9)
print(hdi["mass"].values, "kg (90 % HDI)")

# %%
# Questions of your own, with xarray
# ----------------------------------
# Draws are plain arrays: any function of them has a posterior. The probability that the mass
# exceeds the nominal 2.91 kg; the posterior of the inertia about the centre of mass
# ``m ρ²``; and how the prior box compares with the posterior.

draws = tree["posterior"].to_dataset().sel(body="biodex-elbow-attachment")
print(f"P(m > 2.91 kg) = {float((draws['mass'] > 2.91).mean()):.2f}")

inertia_cm = draws["mass"] * draws["radius_of_gyration"] ** 2
lo, hi = np.quantile(inertia_cm, [0.025, 0.975])
print(f"I_cm = m rho^2: median {float(inertia_cm.median()):.4f}, 95 % [{lo:.4f}, {hi:.4f}] kg m^2")

box = tree["constant_data"].to_dataset()
print(box[["nominal", "lower", "upper"]].to_dataframe())

# %%
# Back into inertiafit
# --------------------
# ``open_posterior`` gives the :class:`~inertiafit.Posterior` with its tables and plots again,
# e.g. to redraw a corner plot with other quantiles or to change the HDI probability.

again = ift.open_posterior(path)
print(again.summary(hdi_prob=0.9)[["parameter", "median", "hdi_lower", "hdi_upper"]])
fig = again.corner(quantiles=(0.05, 0.5, 0.95))
fig.savefig(OUT / "corner-90.png", dpi=100)
