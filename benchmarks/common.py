"""Helpers shared by the benchmarks: the machine, timing, tables, accuracy.

Every benchmark module has ``run(*, quick, seed) -> dict`` (its rows, its printed table and
its targets) and a ``main()`` so it runs alone; ``benchmarks/run.py`` runs them all.
"""

from __future__ import annotations

import math
import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
QUANTITIES = ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment")


def machine() -> dict:
    """What the numbers were measured on: cores, CPU, memory, versions, BLAS settings."""
    import numpy
    import scipy

    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem_gib = float("nan")
    try:
        for line in Path("/proc/meminfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("MemTotal"):
                mem_gib = int(line.split()[1]) / 2**20
                break
    except OSError:
        pass
    versions = {"python": platform.python_version(), "numpy": numpy.__version__}
    versions["scipy"] = scipy.__version__
    for mod in ("emcee", "arviz", "xarray", "pandas", "matplotlib", "inertiafit"):
        try:
            versions[mod] = __import__(mod).__version__
        except (ImportError, AttributeError):
            versions[mod] = "n/a"
    blas = "unknown"
    try:
        cfg = numpy.show_config(mode="dicts")
        info = cfg["Build Dependencies"]["blas"]
        blas = f"{info.get('name')} {info.get('version')}"
    except (TypeError, KeyError):
        pass
    return {
        "nproc": os.cpu_count(),
        "cpu": cpu,
        "memory_gib": round(mem_gib, 1),
        "platform": platform.platform(),
        "versions": versions,
        "blas": blas,
        # Set on some processors for old OpenBLAS builds; it slows a current numpy.
        "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
        "OPENBLAS_L2_SIZE": os.environ.get("OPENBLAS_L2_SIZE"),
        "inertiafit_path": str(Path(__import__("inertiafit").__file__).parent),
    }


def warn_blas_env() -> None:
    if os.environ.get("OPENBLAS_CORETYPE") or os.environ.get("OPENBLAS_L2_SIZE"):
        print(
            "note: OPENBLAS_CORETYPE/OPENBLAS_L2_SIZE are set; they slow a current numpy. "
            "For timing, run: env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE "
            ".venv/bin/python benchmarks/run.py",
            file=sys.stderr,
        )


def best_of(func: Callable[[], object], repeats: int) -> tuple[float, list[float], object]:
    """Wall time of ``func``: the minimum over ``repeats`` calls, all times, the last result.

    The minimum is the least disturbed measurement on a shared machine.
    """
    times = []
    result = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - t0)
    return min(times), times, result


#: Exit status of ``benchmarks/run.py`` (and of a benchmark run alone) when a guard fails: 0
#: when every guard passes, 1 for a crash (Python's own), 2 for a bad command line (argparse).
GUARD_FAILED = 3


def load_average() -> tuple[float, float, float] | None:
    """The 1, 5 and 15 minute load averages (``uptime``), or None where the OS has none."""
    try:
        return os.getloadavg()
    except OSError:
        return None


def load_text() -> str:
    load = load_average()
    return "n/a" if load is None else ", ".join(f"{v:.2f}" for v in load)


def interleaved(
    sides: dict[str, Callable[[int], object]], rounds: int
) -> dict[str, list[tuple[float, object]]]:
    """Wall time and result of each side, called in turn (A B A B ...) for ``rounds`` rounds.

    Each function gets the round's index (a seed, say). Alternating puts a busy moment of a
    shared machine on both sides alike; a side's figure is then the median over the rounds
    (:func:`spread`), and a ratio the median of the rounds' ratios (:func:`paired_ratios`).
    """
    out: dict[str, list[tuple[float, object]]] = {name: [] for name in sides}
    for k in range(rounds):
        for name, func in sides.items():
            t0 = time.perf_counter()
            result = func(k)
            out[name].append((time.perf_counter() - t0, result))
    return out


def median(values: Sequence[float]) -> float:
    import statistics

    return float(statistics.median(values))


def spread(values: Sequence[float]) -> dict[str, float]:
    """Median, smallest and largest of ``values`` (the spread printed beside a median)."""
    return {"median": median(values), "low": float(min(values)), "high": float(max(values))}


def paired_ratios(top: Sequence[float], bottom: Sequence[float]) -> list[float]:
    """``top[k] / bottom[k]`` per round: each ratio from two measurements made side by side."""
    return [a / b for a, b in zip(top, bottom, strict=True)]


def spread_text(s: dict[str, float], fmt: str = ".2f", unit: str = "") -> str:
    """``median (low-high)``, e.g. ``3.41x (3.10-3.92)``."""
    return f"{s['median']:{fmt}}{unit} ({s['low']:{fmt}}-{s['high']:{fmt}})"


def guard(target: str, value: float, limit: float, *, below: bool, shown: str) -> dict:
    """A guarded figure: PASS when ``value <= limit`` (``below``) or ``>= limit``, else FAIL.

    ``benchmarks/run.py`` (and a benchmark run alone) exits with :data:`GUARD_FAILED` when any
    guard fails; other targets (``status`` "met" / "NOT met") are reported only.
    """
    ok = value <= limit if below else value >= limit
    return {"target": target, "value": shown, "status": "PASS" if ok else "FAIL", "guard": True}


def failed_guards(targets: Sequence[dict]) -> list[dict]:
    return [t for t in targets if t.get("guard") and t["status"] != "PASS"]


def accuracy(draws: dict, ref) -> tuple[float, float]:
    """Largest |mean error| in posterior SDs and largest |SD ratio - 1| over the quantities."""
    return ref.agreement({q: draws[q] for q in QUANTITIES})


def table(columns: Sequence[tuple[str, str, str]], rows: Sequence[dict]) -> str:
    """Plain-text table; ``columns`` are ``(key, heading, format)``."""
    cells = [[h for _, h, _ in columns]]
    for r in rows:
        line = []
        for key, _, fmt in columns:
            v = r.get(key)
            if v is None:
                line.append("-")
            elif isinstance(v, str):
                line.append(v)
            else:
                line.append(format(v, fmt))
        cells.append(line)
    widths = [max(len(c[i]) for c in cells) for i in range(len(columns))]
    out = []
    for n, c in enumerate(cells):
        first = c[0].ljust(widths[0])
        out.append(
            "  ".join([first, *(x.rjust(w) for x, w in zip(c[1:], widths[1:], strict=True))])
        )
        if n == 0:
            out.append("-" * len(out[0]))
    return "\n".join(out)


def verdict(value: float, limit: float, *, below: bool = True) -> str:
    ok = value <= limit if below else value >= limit
    return "met" if ok else "NOT met"


def standalone(
    run: Callable[..., dict],
    doc: str,
    *,
    seed: int,
    quick_help: str,
    options: dict[str, dict] | None = None,
) -> None:
    """Command line of one benchmark run alone: ``--json``, ``--seed``, ``--quick``.

    ``options`` maps further flags to their ``add_argument`` keywords; their values are passed
    to ``run`` by name (``--max-steps`` as ``max_steps``).
    """
    import argparse
    import json

    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--json", help="also write the results as JSON to this file")
    parser.add_argument("--seed", type=int, default=seed)
    parser.add_argument("--quick", action="store_true", help=quick_help)
    for flag, kwargs in (options or {}).items():
        parser.add_argument(flag, **kwargs)
    args = parser.parse_args()
    extra = {
        name: getattr(args, name)
        for name in (flag.lstrip("-").replace("-", "_") for flag in options or {})
    }
    result = run(quick=args.quick, seed=args.seed, **extra)
    print(result["table"])
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(result, fh, indent=2)
    failed = failed_guards(result.get("targets", []))
    for t in result.get("targets", []):
        if t.get("guard"):
            print(f"{t['status']}: {t['target']}: {t['value']}")
    if failed:
        sys.exit(GUARD_FAILED)


def hdi(draws, prob: float = 0.95) -> tuple[float, float]:
    """The shortest interval holding ``prob`` of the draws (their highest-density interval)."""
    import numpy as np

    x = np.sort(np.ravel(draws))
    k = math.floor(prob * x.size)
    i = int(np.argmin(x[k:] - x[: x.size - k]))
    return float(x[i]), float(x[i + k])


def binomial_interval(k: int, n: int) -> tuple[float, float]:
    """Clopper-Pearson 95 % interval of a share ``k / n`` (exact, never outside [0, 1])."""
    from scipy import stats

    lo = stats.beta.ppf(0.025, k, n - k + 1) if k else 0.0
    hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return float(lo), float(hi)


def _truth_and_priors(rng, nominal: dict) -> tuple[dict, dict]:
    """Each body's truth drawn uniformly from the +-50 % box around its nominal values, and
    the priors' nominal values (``simulate_living_study``'s ``bodies`` and ``priors``)."""
    truth = {b: tuple(v * rng.uniform(0.5, 1.5) for v in nom) for b, nom in nominal.items()}
    priors = {
        b: {"mass": v[0], "radius_of_gyration": v[1], "com_distance": v[2]}
        for b, v in nominal.items()
    }
    return truth, priors


def living_shank_bodies(rng) -> tuple[dict, dict]:
    """A seated knee study's bodies: ``(truth, priors)`` drawn from ``rng``.

    A knee attachment (a shin pad on a lever: 1.8 kg +-20 %, radius of gyration 0.10 m +-20 %,
    centre of mass 0.20 m from the axis) and an adult's shank and foot (4.2 kg +-30 %, about
    5.6 % of a 75 kg body, de Leva 1996; radius of gyration about its centre of mass 0.17 m
    +-20 %, centre of mass 0.26 m below the knee), the truth drawn uniformly from the +-50 %
    box around them, as :func:`living_forearm_bodies`.
    """
    nominal = {
        "attachment": (1.8 * rng.uniform(0.8, 1.2), 0.10 * rng.uniform(0.8, 1.2), 0.20),
        "shank": (4.2 * rng.uniform(0.7, 1.3), 0.17 * rng.uniform(0.8, 1.2), 0.26),
    }
    return _truth_and_priors(rng, nominal)


def living_forearm_bodies(rng) -> tuple[dict, dict]:
    """A living-forearm study's bodies: ``(truth, priors)`` drawn from ``rng``.

    Nominal values that vary between studies (the attachment's mass and radius +-20 %, the
    forearm's mass +-30 % and radius +-20 %), the truth drawn uniformly from the +-50 % box
    around them, and the priors' nominal values (``simulate_living_study``'s ``bodies`` and
    ``priors``).
    """
    nominal = {
        "attachment": (2.91 * rng.uniform(0.8, 1.2), 0.13 * rng.uniform(0.8, 1.2), 0.225),
        "forearm": (1.5 * rng.uniform(0.7, 1.3), 0.08 * rng.uniform(0.8, 1.2), 0.15),
    }
    return _truth_and_priors(rng, nominal)
