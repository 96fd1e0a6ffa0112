"""`inertiafit plan` against full simulated studies: predicted vs simulated posterior widths.

For each design, `inertiafit.planning.planner.plan` predicts every body's posterior SD and 95 %
HDI width from the expected data (importance sampling around a linearised fit, no sampler),
and `simulated_widths` runs R full simulated studies of the same design (trial files at 1 kHz
with `Noise.paper()`, truth = the nominal values, each through `analyse_study`) and averages
their posterior SDs and HDI widths. The table prints, per design, the worst ratio predicted /
simulated over bodies and parameters (target: every ratio within 0.8-1.2, i.e. within 20 %),
and the time of the predictions (target: ten designs in a few seconds).

Designs ("paper"): the paper's two bodies (attachment alone, attachment + 3 kg disk; truth =
the simulator's paper truth, +-50 % boxes around it): 10 fast trials per speed at
240/270/300 deg/s; 3 per speed; 5 at 240 deg/s only; a normal prior (SD 5 %) on the
attachment's mass.

Designs with extra information ("extra", 10 per speed, +-50 % boxes): the paper attachment
measured alone — box only, weighed (scale SD 0.02 kg), a second mounting with it moved +5 cm
and +1 cm; a forearm-like segment (1.6 kg, rho 0.075 m, x 0.16 m) on the attachment — box only,
the forearm weighed, the forearm's second mounting at +5 cm (where `offset_scan` says m and x
first narrow 3x) and +1 cm. A second table prints, for m, x and rho of the body given the
extra information, the factor box-alone width / width with it, predicted and simulated (with
the simulated factor's Monte Carlo SE).

Run:  .venv/bin/python benchmarks/plan.py [--quick] [--replicates R] [--part paper|extra]
      [--json FILE]   (full: R = 6, about 7 minutes on 2 cores; --quick: R = 2)
"""

from __future__ import annotations

import tempfile
import time

import numpy as np
from common import standalone, table

from inertiafit.mounting import Mounting
from inertiafit.planning.design import Design
from inertiafit.planning.planner import plan
from inertiafit.simulate import PAPER_TRUTH
from inertiafit.validation.widths import simulated_widths

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
#: The extra-information designs: the paper attachment and a forearm-like segment.
EXTRA_BODIES = {
    "attachment": BODIES["attachment"],
    "forearm": {"mass": 1.6, "radius_of_gyration": 0.075, "com_distance": 0.16},
}
SCALE_SD = 0.02
ALONE = (Mounting(("attachment",)),)
WITH_FOREARM = (Mounting(("attachment",)), Mounting(("attachment", "forearm")))


def _extra(prefix: str, base: tuple[Mounting, ...], body: str) -> list[Design]:
    """Box only, ``body`` weighed, ``body``'s second mounting at +5 cm and +1 cm."""
    moved = [Mounting(base[-1].bodies, body, d) for d in (0.05, 0.01)]
    return [
        Design(f"{prefix}: box", base),
        Design(f"{prefix}: weighed", base, weighed={body: SCALE_SD}),
        Design(f"{prefix}: +5 cm", (*base, moved[0])),
        Design(f"{prefix}: +1 cm", (*base, moved[1])),
    ]


#: (designs, the body whose extra information they vary), by group.
EXTRA = {
    "attachment alone": (_extra("attachment", ALONE, "attachment"), "attachment"),
    "forearm on the attachment": (_extra("forearm", WITH_FOREARM, "forearm"), "forearm"),
}
#: Every ratio predicted / simulated must lie in this band.
BAND = (0.8, 1.2)


def compare(designs, replicates: int, seed: int, folder, bodies=BODIES) -> list[dict]:
    """A row per design, body and parameter: predicted and simulated SD and HDI width."""
    predicted = plan(bodies, designs, seed=seed).table
    rows = []
    for d in designs:
        sim = simulated_widths(
            bodies, d, replicates=replicates, seed=seed, folder=folder
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
                    "sd_sim_se": float(r["sd_sd"]) / np.sqrt(replicates),
                    "width_sim_se": float(r["hdi_width_sd"]) / np.sqrt(replicates),
                    "sd_ratio": float(p["sd"]) / float(r["sd"]),
                    "width_ratio": float(p["hdi_width"]) / float(r["hdi_width"]),
                }
            )
    return rows


def factors(rows: list[dict]) -> list[dict]:
    """Box-alone width over the width with the extra information: predicted and simulated."""
    by = {(r["design"], r["body"], r["parameter"]): r for r in rows}
    out = []
    for group, (designs, body) in EXTRA.items():
        box = designs[0].name
        for d in designs[1:]:
            for p in ("mass", "com_distance", "radius_of_gyration"):
                b, r = by.get((box, body, p)), by.get((d.name, body, p))
                if b is None or r is None:
                    continue
                sim = b["width_sim"] / r["width_sim"]
                rel = np.hypot(
                    b["width_sim_se"] / b["width_sim"], r["width_sim_se"] / r["width_sim"]
                )
                out.append(
                    {
                        "group": group,
                        "design": d.name,
                        "parameter": p,
                        "pred": b["width_pred"] / r["width_pred"],
                        "sim": sim,
                        "sim_se": sim * rel,
                    }
                )
    return out


def run(
    *,
    quick: bool = False,
    seed: int = 0,
    replicates: int | None = None,
    part: str = "all",
) -> dict:
    reps = replicates or (2 if quick else 6)
    t0 = time.perf_counter()
    ten = [d for d in DESIGNS for _ in range(3)][:10]
    ten = [Design(f"{d.name} #{i}", d.mountings, d.trials_per_speed, d.speeds, priors=d.priors)
           for i, d in enumerate(ten)]  # fmt: skip
    plan(BODIES, ten[:1], seed=seed)  # imports warm
    t1 = time.perf_counter()
    plan(BODIES, ten, seed=seed)
    ten_seconds = time.perf_counter() - t1
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        if part in ("all", "paper"):
            rows += compare(DESIGNS, reps, seed, tmp)
        if part in ("all", "extra"):
            for designs, _body in EXTRA.values():
                rows += compare(designs, reps, seed, tmp, bodies=EXTRA_BODIES)
    text = table(
        [
            ("design", "design", ""),
            ("body", "body", ""),
            ("parameter", "parameter", ""),
            ("sd_pred", "SD pred", ".3g"),
            ("sd_sim", "SD sim", ".3g"),
            ("width_pred", "HDI pred", ".3g"),
            ("width_sim", "HDI sim", ".3g"),
            ("width_sim_se", "MC SE", ".2g"),
            ("sd_ratio", "SD p/s", ".2f"),
            ("width_ratio", "HDI p/s", ".2f"),
        ],
        rows,
    )
    ratios = [r[k] for r in rows for k in ("sd_ratio", "width_ratio")]
    worst = max(ratios, key=lambda v: abs(np.log(v)))
    inside = all(BAND[0] <= v <= BAND[1] for v in ratios)
    text += (
        f"\n\n{reps} simulated studies per design; worst ratio predicted/simulated {worst:.2f} "
        f"(SD and HDI width, every body and parameter); MC SE: Monte Carlo SE of the simulated "
        f"mean HDI width; ten designs predicted in {ten_seconds:.1f} s"
    )
    fac = factors(rows)
    if fac:
        text += "\n\nBox-alone HDI width / HDI width with the extra information:\n\n"
        text += table(
            [
                ("design", "design", ""),
                ("parameter", "parameter", ""),
                ("pred", "predicted", ".2f"),
                ("sim", "simulated", ".2f"),
                ("sim_se", "MC SE", ".2f"),
            ],
            fac,
        )
    return {
        "title": "plan: predicted vs simulated posterior widths",
        "rows": rows,
        "factors": fac,
        "table": text,
        "replicates": reps,
        "ten_designs_seconds": ten_seconds,
        "seconds_total": time.perf_counter() - t0,
        "targets": [
            {
                "target": "every ratio pred/sim in 0.8-1.2",
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
        options={
            "--replicates": {"type": int, "default": None, "help": "studies per design"},
            "--part": {
                "choices": ("all", "paper", "extra"),
                "default": "all",
                "help": "the paper designs, those with extra information, or both",
            },
        },
    )


if __name__ == "__main__":
    main()
