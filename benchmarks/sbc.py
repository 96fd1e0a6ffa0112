"""Simulation-based calibration (Talts et al. 2018): the posterior is right on average.

Designs (``inertiafit.validation.sbc.attachment_design``): one body (the paper's attachment,
±50 % box), and an attachment measured alone and with each of K = 1, 3, 10 segments. Each
with three kinds of evidence on both observables: five trial values per condition
(Student-t), their mean and SD with n = 5 (the same Student-t), or one value with its SE
(Gaussian). Per simulated study: a truth drawn from the boxes, data from the model's own
likelihood, a fit with ``inference.fit.fit`` (``sbc.SBC_SETTINGS``: the default sampler,
R-hat <= 1.02, ESS >= 400), the rank of the truth among 199 draws, and whether the 95 % HDI
holds it. Printed per quantity: the rank histogram (10 bins), the chi-square p-value against
uniform ranks, the coverage of the central 95 % interval and of the 95 % HDI (each with its
two-sided binomial p-value). A design passes when no p-value is below 0.001 / (number of
tests) (Bonferroni). Segment rows summarise all K segments: the smallest p-value and the
range of coverages.

Extra information (``inertiafit.validation.sbc.extra_design``): an attachment alone and with one
segment (Gaussian evidence) with a second mounting, weighed masses, a balance point, a known
added mass with a torque gain, all of them at once, and the segment under a de Leva (1996) prior
(truths drawn from it); 100 studies each.

Negative controls: the same studies fitted with every observation's scale multiplied by 0.5
or 2 (the data were generated with the right one), and the all-extra-information design with
every scale (the measurements' too) times 0.3; they must fail the same test.
For Student-t evidence the summary also says what the test gives without the exact
truncation weights (``sbc`` module docstring).

Run:  .venv/bin/python benchmarks/sbc.py [--quick] [--fraction F] [--json FILE]
      (full: 400 / 300 / 200 / 100 studies for K = 0 / 1 / 3 / 10, about 30 minutes on 2
      cores; --quick: a fifth, no K = 10; --fraction scales every count)
"""

from __future__ import annotations

import sys

from common import standalone, table

from inertiafit.posterior.pins import SHORT
from inertiafit.validation.sbc import (
    EVIDENCE,
    EXTRA_KINDS,
    attachment_design,
    calibrated,
    calibration_table,
    extra_design,
    run_sbc,
)

ALPHA = 0.001
#: Studies per design with extra information (``sbc.extra_design``), full run.
EXTRA_STUDIES = 100
BINS = 10
#: (segments, studies) of the full run.
CALIBRATED = ((0, 400), (1, 300), (3, 200), (10, 100))
#: (segments, evidence, scale, studies) of the full run's negative controls.
NEGATIVE = (
    *((0, ev, s, 200) for ev in EVIDENCE for s in (0.5, 2.0)),
    (3, "values", 0.5, 100),
    (3, "values", 2.0, 100),
)


def _count(n: int, quick: bool, fraction: float) -> int:
    return max(20, round(n * fraction / (5 if quick else 1)))


def _shown(rows: list[dict], label: str) -> list[dict]:
    """The attachment's rows as they are; each quantity of the segments summarised."""
    out = []
    segments = [r for r in rows if r["body"] != "attachment"]
    for r in rows:
        if r["body"] == "attachment":
            out.append(
                {
                    "config": label,
                    "body": "attachment",
                    "q": SHORT[r["quantity"]],
                    "hist": " ".join(f"{c:d}" for c in r["histogram"]),
                    "chi2_p": r["chi2_p"],
                    "central": f"{r['central']:.3f}",
                    "central_p": r["central_p"],
                    "hdi": f"{r['hdi']:.3f}",
                    "hdi_p": r["hdi_p"],
                }
            )
            label = ""
    if segments:
        n_seg = len({r["body"] for r in segments})
        for q, short in SHORT.items():
            rs = [r for r in segments if r["quantity"] == q]
            cen = [r["central"] for r in rs]
            hdi = [r["hdi"] for r in rs]
            out.append(
                {
                    "config": "",
                    "body": f"{n_seg} segments",
                    "q": short,
                    "hist": "(min p; coverage range)",
                    "chi2_p": min(r["chi2_p"] for r in rs),
                    "central": f"{min(cen):.2f}-{max(cen):.2f}",
                    "central_p": min(r["central_p"] for r in rs),
                    "hdi": f"{min(hdi):.2f}-{max(hdi):.2f}",
                    "hdi_p": min(r["hdi_p"] for r in rs),
                }
            )
    return out


def _summary(result, rows, unweighted_rows) -> dict:
    n_tests = 3 * len(rows)
    min_p = min(min(r["chi2_p"], r["central_p"], r["hdi_p"]) for r in rows)
    out = {
        "studies": result.n_studies,
        "failures": dict(result.failures),
        "unconverged": result.unconverged,
        "seconds": result.seconds,
        "n_tests": n_tests,
        "min_p": min_p,
        "bonferroni_p": min(1.0, min_p * n_tests),
        "passes": calibrated(rows, ALPHA),
    }
    if unweighted_rows is not None:
        min_u = min(min(r["chi2_p"], r["central_p"], r["hdi_p"]) for r in unweighted_rows)
        out["unweighted_bonferroni_p"] = min(1.0, min_u * n_tests)
        out["unweighted_passes"] = calibrated(unweighted_rows, ALPHA)
    return out


def _one(k: int, evidence: str, scale: float, n: int, seed: int, extra: str | None = None) -> dict:
    design = attachment_design(k, evidence) if extra is None else extra_design(extra)
    result = run_sbc(design, n, seed=seed, scale=scale)
    rows = calibration_table(result, bins=BINS)
    unweighted = (
        calibration_table(result, bins=BINS, unweighted=True)
        if design.evidence != "mean_se"
        else None
    )
    summary = _summary(result, rows, unweighted)
    label = (f"K={k} {evidence}" if extra is None else f"K=1 mean_se, {extra}") + (
        f" scale x{scale:g}" if scale != 1 else ""
    )
    sys.stderr.write(
        f"sbc: {label}: {result.n_studies} studies, {result.seconds:.0f} s, "
        f"Bonferroni p {summary['bonferroni_p']:.3g}, failures {sum(result.failures.values())}, "
        f"unconverged {result.unconverged}\n"
    )
    sys.stderr.flush()
    return {
        "config": label,
        "segments": k,
        "evidence": evidence,
        "scale": scale,
        "rows": rows,
        "unweighted_rows": unweighted,
        "summary": summary,
    }


def _summary_line(run: dict) -> str:
    s = run["summary"]
    fails = sum(s["failures"].values())
    line = (
        f"{run['config']}: {s['studies']} studies ({fails} failed"
        + (f": {s['failures']}" if fails else "")
        + f", {s['unconverged']} at the step bound), {s['seconds']:.0f} s; "
        f"smallest p x {s['n_tests']} tests = {s['bonferroni_p']:.3g} -> "
        + ("calibrated" if s["passes"] else "NOT calibrated")
    )
    if "unweighted_passes" in s:
        line += f"; without the truncation weights {s['unweighted_bonferroni_p']:.3g} -> " + (
            "calibrated" if s["unweighted_passes"] else "NOT calibrated"
        )
    return line


def run(*, quick: bool = False, seed: int = 1, fraction: float = 1.0) -> dict:
    calibrated_runs, negative_runs = [], []
    for k, n in CALIBRATED:
        if quick and k == 10:
            continue
        for evidence in EVIDENCE:
            calibrated_runs.append(_one(k, evidence, 1.0, _count(n, quick, fraction), seed))
    for kind in EXTRA_KINDS:
        n = _count(EXTRA_STUDIES, quick, fraction)
        calibrated_runs.append(_one(1, "mean_se", 1.0, n, seed, extra=kind))
    for k, evidence, scale, n in NEGATIVE:
        negative_runs.append(_one(k, evidence, scale, _count(n, quick, fraction), seed))
    negative_runs.append(
        _one(1, "mean_se", 0.3, _count(EXTRA_STUDIES // 2, quick, fraction), seed, extra="all")
    )
    columns = [
        ("config", "config", ""),
        ("body", "body", ""),
        ("q", "q", ""),
        ("hist", "rank histogram (10 bins)", ""),
        ("chi2_p", "chi2 p", ".3g"),
        ("central", "central 95%", ""),
        ("central_p", "p", ".3g"),
        ("hdi", "HDI 95%", ""),
        ("hdi_p", "p", ".3g"),
    ]
    shown = [row for r in calibrated_runs for row in _shown(r["rows"], r["config"])]
    text = table(columns, shown)
    text += "\n\n" + "\n".join(_summary_line(r) for r in calibrated_runs)
    text += "\n\nNegative controls (fitted with every observation's scale times 0.5 or 2):\n"
    neg_shown = [row for r in negative_runs for row in _shown(r["rows"], r["config"])]
    text += table(columns, neg_shown)
    text += "\n\n" + "\n".join(_summary_line(r) for r in negative_runs)
    text += (
        f"\n\nA design passes when every p-value exceeds {ALPHA} / (number of tests) "
        "(Bonferroni). Central 95 %: ranks 5..194 of 0..199, exactly 0.95 when calibrated."
    )
    n_ok = sum(r["summary"]["passes"] for r in calibrated_runs)
    n_caught = sum(not r["summary"]["passes"] for r in negative_runs)
    failures = sum(sum(r["summary"]["failures"].values()) for r in calibrated_runs + negative_runs)
    return {
        "name": "sbc",
        "title": "7. Simulation-based calibration: ranks of the truth and coverage",
        "rows": calibrated_runs,
        "negative_controls": negative_runs,
        "table": text,
        "targets": [
            {
                "target": "every design calibrated (Bonferroni, alpha 0.001)",
                "value": f"{n_ok} of {len(calibrated_runs)}",
                "status": "met" if n_ok == len(calibrated_runs) else "NOT met",
            },
            {
                "target": "every negative control fails the same test",
                "value": f"{n_caught} of {len(negative_runs)}",
                "status": "met" if n_caught == len(negative_runs) else "NOT met",
            },
            {
                "target": "no study without a posterior (sampler crash, infeasible box)",
                "value": str(failures),
                "status": "met" if failures == 0 else "NOT met",
            },
        ],
    }


def main() -> None:
    standalone(
        run,
        __doc__,
        seed=1,
        quick_help="a fifth of the studies, no K = 10 (about 5 minutes)",
        options={"--fraction": {"type": float, "default": 1.0, "help": "scale every study count"}},
    )


if __name__ == "__main__":
    main()
