"""Command line: ``inertiafit fit | run | run-many | demo | report | plan | priors``.

The command line only parses arguments and calls the library. Bad input ends with one line on
stderr (``inertiafit: error: ...``) and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

from inertiafit._checks import check_probability
from inertiafit.errors import InputError

__all__ = ["build_parser", "main"]


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (the usage stays behind ``--help``)."""

    def error(self, message: str):  # type: ignore[override]
        message = (
            message.replace("argument ", "", 1) if message.startswith("argument ") else message
        )
        self.exit(2, f"inertiafit: error: {' '.join(message.split())}\n")


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def _count(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None


def _add_common(p: argparse.ArgumentParser, default_out: str) -> None:
    p.add_argument(
        "--out",
        type=Path,
        default=Path(default_out),
        help=f"output folder, replaced whole (default: {default_out})",
    )
    p.add_argument("--seed", type=_count, default=0, help="seed of every random draw (default 0)")
    p.add_argument(
        "--hdi-prob",
        type=_number,
        default=0.95,
        help="probability of the highest-density intervals (default 0.95)",
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (also used to document the command line)."""
    from inertiafit import __version__

    parser = _Parser(
        prog="inertiafit",
        description="Inertial parameters (mass, centre-of-mass distance, radius of gyration) of a "
        "body on a dynamometer shaft, with Bayesian uncertainty.",
    )
    parser.add_argument("--version", action="version", version=f"inertiafit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    fit = sub.add_parser(
        "fit",
        help="one body from numbers: inertia and gravity moment",
        description="Posterior of one body's (m, x, rho) from its moment of inertia about the "
        "joint and its gravitational moment. Writes summary.csv, identification.csv, "
        "comparison.csv, posterior.nc, corner.pdf and corner.png into --out.",
    )
    fit.add_argument(
        "--prior",
        required=True,
        help="a shipped prior by name (see 'inertiafit priors') or a TOML file",
    )
    fit.add_argument(
        "--inertia",
        nargs="+",
        required=True,
        type=_number,
        metavar="V",
        help="moment of inertia about the joint, kg m^2 (trial values, "
        "or one value with --inertia-se or --inertia-sd/--inertia-n)",
    )
    fit.add_argument(
        "--inertia-se",
        type=_number,
        metavar="S",
        help="standard error of a single inertia value, kg m^2",
    )
    fit.add_argument(
        "--inertia-sd",
        type=_number,
        metavar="S",
        help="SD of the trials behind a mean inertia value, kg m^2",
    )
    fit.add_argument(
        "--inertia-n",
        type=_count,
        metavar="N",
        help="number of trials behind a mean inertia value",
    )
    fit.add_argument(
        "--gravity-moment",
        nargs="+",
        required=True,
        type=_number,
        metavar="V",
        help="gravitational moment m g x, N m (trial values or one value with an SE)",
    )
    fit.add_argument(
        "--gravity-moment-se",
        type=_number,
        metavar="S",
        help="standard error of a single gravity-moment value, N m",
    )
    fit.add_argument(
        "--gravity-moment-sd",
        type=_number,
        metavar="S",
        help="SD of the trials behind a mean gravity moment, N m",
    )
    fit.add_argument(
        "--gravity-moment-n",
        type=_count,
        metavar="N",
        help="number of trials behind a mean gravity moment",
    )
    fit.add_argument(
        "--gravity",
        type=_number,
        default=9.81,
        help="gravitational acceleration, m/s^2 (default 9.81, as the paper)",
    )
    fit.add_argument(
        "--torque-gain-sd",
        type=_number,
        default=0.0,
        metavar="S",
        help="relative SD of the torque channel's gain (0.01 = 1 %%), carried in the posterior "
        "(default 0: calibration uncertainty not included)",
    )
    fit.add_argument(
        "--mass",
        type=_number,
        metavar="KG",
        help="the body weighed on a scale, kg (with --mass-sd): extra evidence on m",
    )
    fit.add_argument(
        "--mass-sd",
        type=_number,
        metavar="KG",
        help="SD of that weighing, kg (a reading rounded to a step q: at least q/sqrt(12))",
    )
    fit.add_argument(
        "--com-distance",
        type=_number,
        metavar="M",
        help="a balance point: distance of the centre of mass from the joint axis, m "
        "(with --com-distance-sd)",
    )
    fit.add_argument(
        "--com-distance-sd",
        type=_number,
        metavar="M",
        help="SD of that balance point, m",
    )
    _add_common(fit, "inertiafit-output")

    run = sub.add_parser(
        "run",
        help="the whole pipeline on a study manifest and its trial files",
        description="Read every trial of STUDY (a TOML manifest), fit the gravity model of each "
        "condition, estimate the inertia of every fast trial, test the speed effect, sample the "
        "joint posterior over every body and write trials.csv, speed_effect.csv, summary.csv, "
        "identification.csv, comparison.csv, posterior.nc, corner-<body>.png, "
        "fast-trials-<condition>.png, inertia-by-speed.png (and .pdf with --formats png,pdf) "
        "and report.html into --out.",
    )
    run.add_argument("study", type=Path, metavar="STUDY", help="the study manifest (TOML)")
    _add_common(run, "inertiafit-output")
    run.add_argument(
        "--formats",
        default="png",
        help="figure formats, comma-separated from pdf,png,svg (default png; png,pdf adds "
        "vector PDFs)",
    )

    many = sub.add_parser(
        "run-many",
        help="run a batch of studies, on a Dask cluster or on this machine",
        description="Run the whole pipeline of 'run' on every STUDY, each into its own folder "
        "of --out named after its manifest, and write batch.csv (a row per study: manifest, "
        "folder, ok or failed with the error, seconds, convergence) and batch-summary.csv "
        "(every summary.csv stacked). With --scheduler the studies are tasks on that Dask "
        "cluster (its workers must see the same files); otherwise they run on a local Dask "
        "cluster of --workers processes, or one after another with --workers 1. A study that "
        "fails is recorded and the others go on; the exit status is then 1.",
    )
    many.add_argument(
        "studies", type=Path, nargs="+", metavar="STUDY", help="study manifests (TOML)"
    )
    many.add_argument(
        "--out",
        type=Path,
        required=True,
        help="batch folder, replaced whole; a subfolder per study",
    )
    many.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="address of a running Dask scheduler, e.g. tcp://host:8786 (default: this machine)",
    )
    many.add_argument(
        "--workers",
        type=_count,
        metavar="N",
        help="local worker processes (default: one per CPU, at most one per study; "
        "1 runs the studies one after another in this process)",
    )
    many.add_argument(
        "--connect-timeout",
        type=_number,
        default=10.0,
        metavar="S",
        help="seconds to wait for --scheduler (default 10)",
    )
    many.add_argument(
        "--seed", type=_count, default=0, help="seed of every study's sampler (default 0)"
    )
    many.add_argument(
        "--hdi-prob",
        type=_number,
        default=0.95,
        help="probability of the highest-density intervals (default 0.95)",
    )
    many.add_argument(
        "--formats",
        default="png",
        help="figure formats, comma-separated from pdf,png,svg (default png; png,pdf adds "
        "vector PDFs)",
    )

    demo = sub.add_parser(
        "demo",
        help="simulate the paper's experiment and run it end to end",
        description="Simulate the experiment of Son et al. (elbow attachment alone and with a 3 kg "
        "disk; 1 deg/s quasi-static; 240/270/300 deg/s x 10 fast trials; 1 kHz), write the trial "
        "files and manifest into --out/study, run the whole pipeline on them, and fit the "
        "paper's own published numbers beside it (--out/paper-numbers).",
    )
    _add_common(demo, "demo-output")

    report = sub.add_parser(
        "report",
        help="redraw the tables, figures and report.html of an output folder",
        description="Redraw every table (CSV, Markdown, LaTeX), figure and report.html of a folder "
        "written by 'run', 'demo' or 'fit' from its posterior.nc and trials.csv, without sampling "
        "again.",
    )
    report.add_argument("folder", type=Path, metavar="DIR", help="an output folder")
    report.add_argument(
        "--formats",
        default="png",
        help="figure formats, comma-separated from pdf,png,svg (default png; png,pdf adds "
        "vector PDFs)",
    )
    report.add_argument(
        "--hdi-prob",
        type=_number,
        default=0.95,
        help="probability of the highest-density intervals (default 0.95)",
    )

    plan = sub.add_parser(
        "plan",
        help="predicted posterior widths of candidate designs, before a session",
        description="Predict the posterior SD and HDI width of every body's m, x, rho, I and "
        "M_g for candidate designs (trials per speed, speeds, weighing, a second mounting, "
        "priors), from a design file (TOML; see the tutorial 'Planning a measurement "
        "session') or from a pilot study's --out folder (posterior.nc and trials.csv). "
        "With targets, finds the design reaching them with the fewest trials. Writes "
        "plan.csv, plan-search.csv and plan.pdf/.png into --out.",
    )
    plan.add_argument(
        "design", type=Path, nargs="?", metavar="DESIGN", help="a design file (TOML)"
    )
    plan.add_argument(
        "--pilot", type=Path, metavar="DIR", help="a pilot study's output folder instead"
    )
    plan.add_argument(
        "--trials-per-speed",
        type=_count,
        nargs="+",
        default=[],
        metavar="N",
        help="add variants of every design with these fast trials per speed",
    )
    plan.add_argument(
        "--weigh",
        nargs="+",
        default=[],
        metavar="BODY=SD",
        help="add variants with BODY weighed on a scale of this SD (kg)",
    )
    plan.add_argument(
        "--offset",
        nargs="+",
        default=[],
        metavar="BODY=D",
        help="add variants with BODY also measured D m further out (a second mounting)",
    )
    plan.add_argument(
        "--target",
        nargs="+",
        default=[],
        metavar="BODY.PARAMETER=WIDTH",
        help="requested HDI width (SI units), e.g. forearm.mass=0.2",
    )
    plan.add_argument(
        "--out",
        type=Path,
        default=Path("inertiafit-plan"),
        help="output folder, replaced whole (default: inertiafit-plan)",
    )
    plan.add_argument("--seed", type=_count, default=0, help="seed (default 0)")
    plan.add_argument(
        "--hdi-prob",
        type=_number,
        default=None,
        help="probability of the HDIs (default: the design file's, else 0.95)",
    )
    plan.add_argument(
        "--formats",
        default="pdf,png",
        help="figure formats, comma-separated from pdf,png,svg (default pdf,png)",
    )

    sub.add_parser("priors", help="list the shipped priors")
    return parser


def _fit(args) -> int:
    from inertiafit.pipeline.fit import run_fit

    if args.gravity <= 0:
        raise InputError(f"--gravity: expected a positive number, got {args.gravity}")
    run_fit(
        prior=args.prior,
        inertia=args.inertia,
        inertia_se=args.inertia_se,
        inertia_sd=args.inertia_sd,
        inertia_n=args.inertia_n,
        gravity_moment=args.gravity_moment,
        gravity_moment_se=args.gravity_moment_se,
        gravity_moment_sd=args.gravity_moment_sd,
        gravity_moment_n=args.gravity_moment_n,
        gravity=args.gravity,
        torque_gain_sd=args.torque_gain_sd,
        mass=args.mass,
        mass_sd=args.mass_sd,
        com_distance=args.com_distance,
        com_distance_sd=args.com_distance_sd,
        out=args.out,
        seed=args.seed,
        hdi_prob=args.hdi_prob,
    )
    return 0


def _run(args) -> int:
    from inertiafit.pipeline.study import run_study
    from inertiafit.plotting.style import check_formats

    formats = check_formats(args.formats.split(","))
    run_study(args.study, out=args.out, seed=args.seed, hdi_prob=args.hdi_prob, formats=formats)
    return 0


def _run_many(args) -> int:
    from inertiafit.pipeline.batch import run_many
    from inertiafit.plotting.style import check_formats

    if not args.connect_timeout > 0:
        raise InputError(
            f"--connect-timeout: expected a positive number of seconds, got {args.connect_timeout}"
        )
    batch = run_many(
        args.studies,
        args.out,
        scheduler=args.scheduler,
        workers=args.workers,
        seed=args.seed,
        hdi_prob=args.hdi_prob,
        formats=check_formats(args.formats.split(",")),
        connect_timeout=args.connect_timeout,
    )
    n, failed = len(batch.table), batch.failed
    print(
        f"{n - len(failed)} of {n} studies done in {batch.seconds:.1f} s {batch.where}; "
        f"{batch.out / 'batch.csv'}"
    )
    if failed:
        print(
            f"inertiafit: error: {len(failed)} of {n} studies failed: {', '.join(failed)} "
            f"(errors in {batch.out / 'batch.csv'})",
            file=sys.stderr,
        )
        return 1
    return 0


def _report(args) -> int:
    from inertiafit.pipeline.redraw import redraw

    redraw(args.folder, formats=args.formats.split(","), hdi_prob=args.hdi_prob)
    return 0


def _demo(args) -> int:
    from inertiafit.pipeline.demo import run_demo

    run_demo(out=args.out, seed=args.seed, hdi_prob=args.hdi_prob)
    return 0


def _pairs(items: list[str], option: str, what: str) -> dict[str, float]:
    """``KEY=NUMBER`` items as a dict (the option's message names it)."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not sep or not key or not math.isfinite(number):
            raise InputError(f"{option}: expected {what}, got {item!r}")
        out[key] = number
    return out


def _plan(args) -> int:
    from inertiafit.pipeline.plan import run_plan
    from inertiafit.plotting.style import check_formats

    if (args.design is None) == (args.pilot is None):
        raise InputError("plan: give a design file or --pilot DIR (one of them)")
    offsets: dict[str, list[float]] = {}
    for item in args.offset:
        for body, d in _pairs([item], "--offset", "BODY=D (m)").items():
            offsets.setdefault(body, []).append(d)
    run_plan(
        args.design,
        pilot=args.pilot,
        out=args.out,
        trials_per_speed=args.trials_per_speed,
        weigh=_pairs(args.weigh, "--weigh", "BODY=SD (kg)"),
        offsets=offsets,
        targets=_pairs(args.target, "--target", "BODY.PARAMETER=WIDTH"),
        hdi_prob=args.hdi_prob,
        seed=args.seed,
        formats=check_formats(args.formats.split(",")),
    )
    return 0


def _priors(_args) -> int:
    from inertiafit.inference.priors import available_priors, load_prior

    for name in available_priors():
        print(load_prior(name).describe())
    return 0


def _as_options(message: str, parser: argparse.ArgumentParser) -> str:
    """A library message in the command line's words: argument names become option names.

    Library functions name their arguments (``hdi_prob: expected ...``, ``inertia_sd and
    inertia_n go together``); here they read ``--hdi-prob``, ``--inertia-sd``. A name with an
    underscore is replaced anywhere; a plain word (``out``, ``inertia``) only where it leads
    the message as its subject (``out: ...``, ``inertia[0]: ...``), so prose is left alone.
    """
    dests: set[str] = set()
    for action in parser._actions:  # argparse keeps its subparsers only here
        choices = getattr(action, "choices", None)
        if isinstance(choices, dict):
            for sub in choices.values():
                dests.update(a.dest for a in sub._actions if a.option_strings and a.dest != "help")
    names = sorted(dests, key=len, reverse=True)
    compound = [n for n in names if "_" in n]
    if compound:
        message = re.sub(
            r"(?<![\w-])(" + "|".join(map(re.escape, compound)) + r")(?![\w-])",
            lambda m: "--" + m.group(1).replace("_", "-"),
            message,
        )
    lead = re.match(r"(\w+)(?=[:\[])", message)
    if lead and lead.group(1) in dests:
        message = "--" + lead.group(1).replace("_", "-") + message[lead.end() :]
    return message


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``inertiafit`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    handlers = {
        "fit": _fit,
        "run": _run,
        "run-many": _run_many,
        "demo": _demo,
        "report": _report,
        "plan": _plan,
        "priors": _priors,
    }
    try:
        if getattr(args, "hdi_prob", None) is not None:
            check_probability(args.hdi_prob, "hdi_prob")
        return handlers[args.command](args)
    except InputError as exc:
        print(f"inertiafit: error: {_as_options(str(exc), parser)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("inertiafit: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
