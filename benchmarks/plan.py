"""`inertiafit plan` against full simulated studies: predicted vs simulated posterior widths.

For each design, `inertiafit.pipeline.plan.plan` predicts every body's posterior SD and 95 %
HDI width from the expected data (importance sampling around a linearised fit, no sampler),
and `simulated_widths` runs R full simulated studies of the same design (trial files at 1 kHz
with `Noise.paper()`, truth = the nominal values, each through `analyse_study`) and averages
their posterior SDs and HDI widths. The table prints, per design, the worst ratio predicted /
simulated over bodies and parameters (target: every ratio within 0.8-1.25, i.e. within 20 %),
and the time of the predictions (target: ten designs in a few seconds).

Designs: the paper's two bodies (attachment alone, attachment + 3 kg disk; truth = the
simulator's paper truth, +-50 % boxes around it): 10 fast trials per speed at 240/270/300 deg/s;
3 per speed; 5 at 240 deg/s only; a normal prior (SD 5 %) on the attachment's mass.

Run:  .venv/bin/python benchmarks/plan.py [--quick] [--replicates R] [--json FILE]
      (full: R = 6, about 2 minutes on 2 cores; --quick: R = 2)
"""

from __future__ import annotations

import tempfile
import time

import numpy as np
from common import standalone, table

from inertiafit.pipeline.plan import Design, Mounting, plan, simulated_widths
from inertiafit.simulate import PAPER_TRUTH

BODIES = {
    b: {"mass": v.mass, "radius_of_gyration": v.radius_of_gyration, "com_distance": v.com_distance}
    for b, v in PAPER_TRUTH.items()
}
PAPER = (Mounting(("attachment",)), Mounting(("attachment", "weight")))
NORMAL_MASS = {
    "mass": {"distribution": "normal", "mean": 2.85, "sd": 0.1425, "unit": "kg"},
    "com_distance": {"nominal": 0.24, "unit": "m"},
    "radius_of_gyration": {"nominal": 0.12, "unit": "m"},
}
DESIGNS = (
    Design("paper: 10 per speed", PAPER),
    Design("3 per speed", PAPER, trials_per_speed=3),
    Design("5 at 240 deg/s", PAPER, trials_per_speed=5, speeds=(240.0,)),
    Design("normal prior on mass", PAPER, priors={"attachment": NORMAL_MASS}),
)
#: Every ratio predicted / simulated must lie in this band.
BAND = (0.8, 1.25)


def compare(designs, replicates: int, seed: int, folder) -> list[dict]:
    """A row per design, body and parameter: predicted and simulated SD and HDI width."""
    predicted = plan(BODIES, designs, seed=seed).table
    rows = []
    for d in designs:
        sim = simulated_widths(
            BODIES, d, replicates=replicates, seed=seed, folder=folder
        ).set_index(["body", "parameter"])
        pred = predicted[predicted["design"] == d.name].set_index(["body", "parameter"])
        for key, r in sim.iterrows():
            p = pred.loc[key]
            rows.append(
                {
                    "design": d.name,
                    "body": key[0],
                    "parameter": key[1],
                    "sd_pred": float(p["sd"]),
                    "sd_sim": float(r["sd"]),
                    "width_pred": float(p["hdi_width"]),
                    "width_sim": float(r["hdi_width"]),
                    "width_sim_se": float(r["hdi_width_sd"]) / np.sqrt(replicates),
                    "sd_ratio": float(p["sd"]) / float(r["sd"]),
                    "width_ratio": float(p["hdi_width"]) / float(r["hdi_width"]),
                }
            )
    return rows


def run(*, quick: bool = False, seed: int = 0, replicates: int | None = None) -> dict:
    reps = replicates or (2 if quick else 6)
    t0 = time.perf_counter()
    ten = [d for d in DESIGNS for _ in range(3)][:10]
    ten = [Design(f"{d.name} #{i}", d.mountings, d.trials_per_speed, d.speeds, priors=d.priors)
           for i, d in enumerate(ten)]  # fmt: skip
    plan(BODIES, ten[:1], seed=seed)  # imports warm
    t1 = time.perf_counter()
    plan(BODIES, ten, seed=seed)
    ten_seconds = time.perf_counter() - t1
    with tempfile.TemporaryDirectory() as tmp:
        rows = compare(DESIGNS, reps, seed, tmp)
    text = table(
        [
            ("design", "design", ""),
            ("body", "body", ""),
            ("parameter", "parameter", ""),
            ("sd_pred", "SD pred", ".3g"),
            ("sd_sim", "SD sim", ".3g"),
            ("width_pred", "HDI pred", ".3g"),
            ("width_sim", "HDI sim", ".3g"),
            ("width_ratio", "pred/sim", ".2f"),
        ],
        rows,
    )
    ratios = [r[k] for r in rows for k in ("sd_ratio", "width_ratio")]
    worst = max(ratios, key=lambda v: abs(np.log(v)))
    inside = all(BAND[0] <= v <= BAND[1] for v in ratios)
    text += (
        f"\n\n{reps} simulated studies per design; worst ratio predicted/simulated {worst:.2f} "
        f"(SD and HDI width, every body and parameter); ten designs predicted in "
        f"{ten_seconds:.1f} s"
    )
    return {
        "title": "plan: predicted vs simulated posterior widths",
        "rows": rows,
        "table": text,
        "replicates": reps,
        "ten_designs_seconds": ten_seconds,
        "seconds_total": time.perf_counter() - t0,
        "targets": [
            {
                "target": "every ratio pred/sim in 0.8-1.25",
                "value": f"{worst:.2f}",
                "status": "met" if inside else "NOT met",
            },
            {
                "target": "ten designs < 5 s",
                "value": f"{ten_seconds:.1f} s",
                "status": "met" if ten_seconds < 5 else "NOT met",
            },
        ],
    }


def main() -> None:
    standalone(
        run,
        __doc__,
        seed=0,
        quick_help="2 simulated studies per design",
        options={"--replicates": {"type": int, "default": None, "help": "studies per design"}},
    )


if __name__ == "__main__":
    main()
