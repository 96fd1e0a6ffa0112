"""A living study's analysis against the rigid analysis of the same trials (issue 32, item 8).

The living tutorial's design (``simulate_living_study``: an elbow attachment alone and with
a forearm, two postures 45 deg apart, sweeps both ways, three rest trials per posture, five
fast trials at 180 deg/s per posture): analysed as the manifest says (the forearm living:
the joint fit of gravity and the passive curve, the living fast trials' windows, the
posterior) and as a rigid study of the same files (``living``, ``[passive]``, ``[postures]``
and every ``posture`` taken out: the rigid model's gravity fit and inertia per trial, the
posterior; its rest trials left out, which a rigid study cannot have, so the living analysis
has six trials more to read). Each is ``process_study`` then ``fit`` (the sampler, the same settings and
seed), timed in alternation, best of the repeats; the ratio is living / rigid. Target: at
most 2x (issue 32).

Run:  .venv/bin/python benchmarks/living_speed.py [--quick] [--json FILE]
"""

from __future__ import annotations

import re
import sys
import tempfile
import time
from pathlib import Path

from common import standalone, table

TARGET = 2.0


def rigid_view(manifest: Path) -> Path:
    """The same study analysed as rigid: ``rigid.toml`` beside it."""
    text = manifest.read_text(encoding="utf-8")
    text = re.sub(r"(?m)^living = true\n", "", text)
    text = re.sub(r"(?m)^posture = \"[^\"]*\"\n", "", text)
    # the [passive] and [postures.*] tables, up to the next table that is neither
    text = re.sub(r"(?ms)^\[(passive|postures\.[^\]]+)\]\n.*?(?=^\[(?!postures\.))", "", text)
    # a rest trial is a living joint's (a rigid study has none): its entries go
    blocks = text.split("[[trials]]")
    text = "[[trials]]".join(b for b in blocks if 'kind = "rest"' not in b)
    out = manifest.with_name("rigid.toml")
    out.write_text(text, encoding="utf-8")
    return out


def run(*, quick: bool = False, seed: int = 32) -> dict:
    from inertiafit.inference.evidence import study_model
    from inertiafit.inference.fit import fit
    from inertiafit.inference.sampler import SamplerSettings
    from inertiafit.processing.study import process_study
    from inertiafit.simulate import simulate_living_study

    repeats = 2 if quick else 4
    settings = SamplerSettings(progress=False)
    with tempfile.TemporaryDirectory() as tmp:
        manifest = simulate_living_study(Path(tmp) / "study", seed=seed, postures="two")
        views = {"living": manifest, "rigid": rigid_view(manifest)}

        def analyse(path: Path) -> dict[str, float]:
            t0 = time.perf_counter()
            processed = process_study(path)
            t1 = time.perf_counter()
            fit(study_model(processed), seed=seed, settings=settings)
            return {"processing": t1 - t0, "sampling": time.perf_counter() - t1}

        analyse(views["living"])  # warm: imports, caches
        best: dict[str, dict[str, float]] = {}
        for _ in range(repeats):
            for name, path in views.items():
                times = analyse(path)
                total = sum(times.values())
                if name not in best or total < best[name]["total"]:
                    best[name] = {**times, "total": total}
        trials = len(process_study(views["living"]).trials)
    ratio = best["living"]["total"] / best["rigid"]["total"]
    rows = [
        {"analysis": name, **best[name], "ratio": best[name]["total"] / best["rigid"]["total"]}
        for name in ("rigid", "living")
    ]
    cols = [
        ("analysis", "analysis", ""),
        ("processing", "processing (s)", ".2f"),
        ("sampling", "posterior (s)", ".2f"),
        ("total", "total (s)", ".2f"),
        ("ratio", "x rigid", ".2f"),
    ]
    text = "\n".join(
        [
            (
                f"== A living study against the rigid analysis of its {trials} trials "
                "(benchmarks/living_speed.py)"
            ),
            table(cols, rows),
            (
                f"living / rigid = {ratio:.2f}x (target <= {TARGET:g}x: "
                f"{'met' if ratio <= TARGET else 'NOT met'}); best of {repeats}"
            ),
        ]
    )
    return {"rows": rows, "ratio": ratio, "target": TARGET, "table": text}


def main() -> None:
    standalone(run, __doc__ or "", seed=32, quick_help="2 repeats instead of 4")


if __name__ == "__main__":
    sys.exit(main())
