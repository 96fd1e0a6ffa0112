"""Command line: ``inertiafit fit | run | run-many | demo | report | plan | priors``.

The command line only parses arguments and calls the library: one pipeline function per
command. Each command is one block below, a :class:`Command` holding its help, its options
(``arguments``) and its handler (``run``), registered with :func:`register_command` in the
order ``--help`` lists them (:data:`COMMANDS`). Options several commands share are defined once
(:func:`add_out`, :func:`add_seed`, :func:`add_hdi_prob`, :func:`add_formats`). The library checks the values; bad input ends with one line on stderr
(``inertiafit: error: ...``) and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import re
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import ClassVar

from inertiafit._checks import check_seed
from inertiafit.errors import InputError
from inertiafit.plotting.style import figure_dpi

__all__ = [
    "COMMANDS",
    "Command",
    "add_ess_min",
    "add_formats",
    "add_hdi_prob",
    "add_out",
    "add_seed",
    "build_parser",
    "main",
    "register_command",
]


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (the usage stays behind ``--help``)."""

    def error(self, message: str):  # type: ignore[override]
        message = (
            message.replace("argument ", "", 1) if message.startswith("argument ") else message
        )
        self.exit(2, f"inertiafit: error: {' '.join(message.split())}\n")


# --- argument types: text to a value, or one line naming the option --------------------------


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


def _seed(text: str) -> int:
    """A seed, checked while parsing: before any work."""
    try:
        value: object = int(text)
    except ValueError:
        value = text
    try:
        return check_seed(value, "seed")
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("seed: ")) from None


def _formats(text: str) -> list[str]:
    return text.split(",")


# --- options shared by several commands, each defined once ------------------------------------


def add_out(p: argparse.ArgumentParser, default: str | None, help: str | None = None) -> None:
    """``--out``: the output folder, required when ``default`` is ``None``."""
    if default is None:
        p.add_argument("--out", type=Path, required=True, help=help)
    else:
        p.add_argument(
            "--out",
            type=Path,
            default=Path(default),
            help=help or f"output folder, replaced whole (default: {default})",
        )


def add_seed(p: argparse.ArgumentParser, help: str = "seed of every random draw (default 0)"):
    """``--seed``: checked while parsing, before any work (default 0)."""
    p.add_argument("--seed", type=_seed, default=0, help=help)


def add_hdi_prob(
    p: argparse.ArgumentParser,
    default: float | None = 0.95,
    help: str = "probability of the highest-density intervals (default 0.95)",
) -> None:
    """``--hdi-prob``: a number, checked by the library (default 0.95)."""
    p.add_argument("--hdi-prob", type=_number, default=default, help=help)


def add_ess_min(p: argparse.ArgumentParser) -> None:
    """``--ess-min``: the bulk ESS a study's sampler must reach (checked by the library)."""
    p.add_argument(
        "--ess-min",
        type=_number,
        default=None,
        metavar="N",
        help="bulk ESS every reported quantity must reach before sampling stops (default "
        "1000; 100-100000): more stores more draws, for a population of studies",
    )


def add_formats(p: argparse.ArgumentParser) -> None:
    """``--formats``: the figure formats, comma-separated (default png)."""
    p.add_argument(
        "--formats",
        type=_formats,
        default="png",
        help="figure formats, comma-separated from pdf,png,svg (default png; png,pdf adds "
        "vector PDFs)",
    )


def _add_common(p: argparse.ArgumentParser, default_out: str) -> None:
    """``--out``, ``--seed`` and ``--hdi-prob`` of a command that samples."""
    add_out(p, default_out)
    add_seed(p)
    add_hdi_prob(p)


# --- the commands ------------------------------------------------------------------------------


class Command:
    """One command: its name and help, its options and its handler (:func:`register_command`).

    ``arguments`` adds its options to its subparser; ``run`` calls the library with them and
    returns the exit status. A library :class:`~inertiafit.errors.InputError` raised in
    ``run`` is shown as one line in the options' words (exit status 2).
    """

    name: ClassVar[str]
    help: ClassVar[str]
    description: ClassVar[str | None] = None

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        """Add the command's options to its subparser."""

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        """Call the pipeline; the exit status."""
        raise NotImplementedError


#: The commands by name, in the order ``--help`` lists them (:func:`register_command`).
COMMANDS: dict[str, type[Command]] = {}


def register_command[C: type[Command]](cls: C) -> C:
    """Register a command (a class decorator): ``inertiafit <cls.name>`` runs ``cls.run``.

    ``cls`` subclasses :class:`Command`: its ``name`` and ``help``, its options
    (``arguments``, the shared ones through :func:`add_out`, :func:`add_seed`,
    :func:`add_hdi_prob` and :func:`add_formats`) and its handler (``run``), which only calls
    the library. ``--help`` lists the commands in the order they were registered.

    Raises
    ------
    ValueError
        When a command of that name is registered already.
    """
    if cls.name in COMMANDS:
        msg = f"command {cls.name!r} is registered already"
        raise ValueError(msg)
    COMMANDS[cls.name] = cls
    return cls


@register_command
class _Fit(Command):
    name = "fit"
    help = "one body from numbers: inertia and gravity moment"
    description = (
        "Posterior of one body's (m, x, rho) from its moment of inertia about the joint and its "
        "gravitational moment. Writes what `inertiafit run` writes, less the trial tables: "
        "summary, identification and comparison tables (.csv/.md/.tex), posterior.nc, "
        "corner.png, identification-<body>.png, trace and rank plots, methods.md, "
        "references.bib and report.html into --out."
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "--prior",
            required=True,
            help="a shipped prior by name (see 'inertiafit priors') or a TOML file",
        )
        p.add_argument(
            "--inertia",
            nargs="+",
            required=True,
            type=_number,
            metavar="V",
            help="moment of inertia about the joint, kg m^2 (trial values, "
            "or one value with --inertia-se or --inertia-sd/--inertia-n)",
        )
        p.add_argument(
            "--inertia-se",
            type=_number,
            metavar="S",
            help="standard error of a single inertia value, kg m^2",
        )
        p.add_argument(
            "--inertia-sd",
            type=_number,
            metavar="S",
            help="SD of the trials behind a mean inertia value, kg m^2",
        )
        p.add_argument(
            "--inertia-n",
            type=_count,
            metavar="N",
            help="number of trials behind a mean inertia value",
        )
        p.add_argument(
            "--gravity-moment",
            nargs="+",
            required=True,
            type=_number,
            metavar="V",
            help="gravitational moment m g x, N m (trial values or one value with an SE)",
        )
        p.add_argument(
            "--gravity-moment-se",
            type=_number,
            metavar="S",
            help="standard error of a single gravity-moment value, N m",
        )
        p.add_argument(
            "--gravity-moment-sd",
            type=_number,
            metavar="S",
            help="SD of the trials behind a mean gravity moment, N m",
        )
        p.add_argument(
            "--gravity-moment-n",
            type=_count,
            metavar="N",
            help="number of trials behind a mean gravity moment",
        )
        p.add_argument(
            "--gravity",
            type=_number,
            default=9.81,
            help="gravitational acceleration, m/s^2 (default 9.81, as the paper)",
        )
        p.add_argument(
            "--torque-gain-sd",
            type=_number,
            default=0.0,
            metavar="S",
            help="relative SD of the torque channel's gain (0.01 = 1 %%), carried in the "
            "posterior (default 0: calibration uncertainty not included)",
        )
        p.add_argument(
            "--mass",
            type=_number,
            metavar="KG",
            help="the body weighed on a scale, kg (with --mass-sd): extra evidence on m",
        )
        p.add_argument(
            "--mass-sd",
            type=_number,
            metavar="KG",
            help="SD of that weighing, kg (a reading rounded to a step q: at least q/sqrt(12))",
        )
        p.add_argument(
            "--com-distance",
            type=_number,
            metavar="M",
            help="a balance point: distance of the centre of mass from the joint axis, m "
            "(with --com-distance-sd)",
        )
        p.add_argument(
            "--com-distance-sd",
            type=_number,
            metavar="M",
            help="SD of that balance point, m",
        )
        _add_common(p, "inertiafit-output")
        add_formats(p)

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        from inertiafit.measured import MEASURED_QUANTITIES, measurements
        from inertiafit.pipeline.fit import run_fit

        # each direct measurement's option and its SD's (--mass, --mass-sd), read once here
        measured = measurements(
            **{q: (getattr(args, q), getattr(args, f"{q}_sd")) for q in MEASURED_QUANTITIES}
        )
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
            measured=measured,
            formats=args.formats,
            out=args.out,
            seed=args.seed,
            hdi_prob=args.hdi_prob,
        )
        return 0


@register_command
class _Run(Command):
    name = "run"
    help = "the whole pipeline on a study manifest and its trial files"
    description = (
        "Read every trial of STUDY (a TOML manifest), fit the gravity model of each condition, "
        "estimate the inertia of every fast trial, test the speed effect, sample the joint "
        "posterior over every body and write trials.csv, speed_effect.csv, summary.csv, "
        "identification.csv, comparison.csv, posterior.nc, corner-<body>.png, "
        "fast-trials-<condition>.png, inertia-by-speed.png (and .pdf with --formats png,pdf) "
        "and report.html into --out."
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument("study", type=Path, metavar="STUDY", help="the study manifest (TOML)")
        _add_common(p, "inertiafit-output")
        add_formats(p)
        add_ess_min(p)

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        from inertiafit.pipeline.study import run_study
        from inertiafit.plotting.style import check_formats

        run_study(
            args.study,
            out=args.out,
            seed=args.seed,
            hdi_prob=args.hdi_prob,
            formats=check_formats(args.formats),
            ess_min=args.ess_min,
        )
        return 0


@register_command
class _RunMany(Command):
    name = "run-many"
    help = "run a batch of studies, on a Dask cluster or on this machine"
    description = (
        "Run the whole pipeline of 'run' on every STUDY, each into its own folder of --out "
        "named after its manifest, and write batch.csv (a row per study: manifest, folder, ok "
        "or failed with the error, seconds, convergence) and batch-summary.csv (every "
        "summary.csv stacked). With --scheduler the studies are tasks on that Dask cluster "
        "(its workers must see the same files); otherwise they run on a local Dask cluster of "
        "--workers processes, or one after another with --workers 1. A cluster needs Dask, the "
        "optional cluster extra (pip install 'inertiafit[cluster]'); without it the studies "
        "run one after another. A study that fails is recorded and the others go on; the exit "
        "status is then 1."
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "studies", type=Path, nargs="+", metavar="STUDY", help="study manifests (TOML)"
        )
        add_out(p, None, help="batch folder, replaced whole; a subfolder per study")
        p.add_argument(
            "--scheduler",
            metavar="ADDR",
            help="address of a running Dask scheduler, e.g. tcp://host:8786 "
            "(default: this machine)",
        )
        p.add_argument(
            "--workers",
            type=_count,
            metavar="N",
            help="local worker processes (default: one per CPU, at most one per study; "
            "1 runs the studies one after another in this process)",
        )
        p.add_argument(
            "--connect-timeout",
            type=_number,
            default=10.0,
            metavar="S",
            help="seconds to wait for --scheduler (default 10)",
        )
        add_seed(p, help="seed of every study's sampler (default 0)")
        add_hdi_prob(p)
        add_formats(p)
        add_ess_min(p)

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        from inertiafit.pipeline.batch import run_many

        batch = run_many(
            args.studies,
            args.out,
            scheduler=args.scheduler,
            workers=args.workers,
            seed=args.seed,
            hdi_prob=args.hdi_prob,
            formats=args.formats,
            connect_timeout=args.connect_timeout,
            ess_min=args.ess_min,
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


@register_command
class _Demo(Command):
    name = "demo"
    help = "simulate the paper's experiment and run it end to end"
    description = (
        "Simulate the experiment of Son et al. (elbow attachment alone and with a 3 kg disk; "
        "1 deg/s quasi-static; 240/270/300 deg/s x 10 fast trials; 1 kHz), write the trial "
        "files and manifest into --out/study, run the whole pipeline on them, and fit the "
        "paper's own published numbers beside it (--out/paper-numbers)."
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        _add_common(p, "demo-output")

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        from inertiafit.pipeline.demo import run_demo

        run_demo(out=args.out, seed=args.seed, hdi_prob=args.hdi_prob)
        return 0


@register_command
class _Population(Command):
    name = "population"
    help = "pool many subjects' studies into a population: regressions with scatter"
    description = (
        "Pool the studies of many subjects (each DIR a 'run' or 'fit' output folder, or a "
        "'run-many' output folder: all its studies) into a population per body: log-linear "
        "regressions of m, x and rho on body mass and segment length (the manifests' [subject] "
        "body_mass and each body's segment_length) with a correlated scatter between subjects, "
        "inferred by reweighting each subject's stored draws from its own prior (Hogg, Myers & "
        "Bovy 2010). Writes population.csv, subjects.csv (each subject's own and pooled "
        "estimates), population.nc (a new study's prior: prior = { population = "
        '"OUT/population.nc" }) and report.html into --out.'
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "sources", type=Path, nargs="+", metavar="DIR", help="run, fit or run-many outputs"
        )
        add_out(p, "population-output")
        p.add_argument(
            "--bodies",
            metavar="NAMES",
            help="comma-separated bodies to pool (default: every body in 3 or more studies "
            "with its covariates recorded)",
        )
        add_seed(p)
        add_hdi_prob(p)
        add_formats(p)

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        from inertiafit.pipeline.population import run_population

        bodies = None
        if args.bodies is not None:
            bodies = [b.strip() for b in args.bodies.split(",") if b.strip()]
        # The library warns; the command says each warning once, in a line of its own after
        # the results, as `run` does (not Python's file:line form with a line of source).
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            run_population(
                args.sources,
                out=args.out,
                seed=args.seed,
                hdi_prob=args.hdi_prob,
                bodies=bodies,
                formats=args.formats,
            )
        for w in caught:
            print(f"warning: {w.message}")
        return 0


@register_command
class _Report(Command):
    name = "report"
    help = "redraw the tables, figures and report.html of an output folder"
    description = (
        "Redraw every table (CSV, Markdown, LaTeX), figure and report.html of a folder written "
        "by 'run', 'demo' or 'fit' from its posterior.nc and trials.csv, without sampling again."
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument("folder", type=Path, metavar="DIR", help="an output folder")
        add_formats(p)
        add_hdi_prob(p)

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        from inertiafit.pipeline.redraw import redraw

        redraw(args.folder, formats=args.formats, hdi_prob=args.hdi_prob)
        return 0


@register_command
class _Export(Command):
    name = "export"
    help = "a results folder's posterior as model files (biorbd .bioMod, OpenSim .osim, JSON)"
    description = (
        "Write every body of a folder written by 'run', 'fit' or 'demo' as a segment with its "
        "mass, centre of mass and inertia tensor about the centre of mass: the posterior "
        "medians as model.<ext>, with --draws N also N models sampled from the posterior "
        "(draws/), and export.csv. The dynamometer measures the radius of gyration about one "
        "axis; the other two come from the body's de Leva prior, or are declared (--radii, "
        "--ratios, --segment or --declare). Each model feels gravity as the body did on the "
        "dynamometer (its angle is the dynamometer's, at the study's phase), and a living "
        "body's joint carries its passive moment and damping. See the docs page 'Export and "
        "joint moments'."
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument("folder", type=Path, metavar="RESULTS_DIR", help="a results folder")
        p.add_argument(
            "--format",
            required=True,
            metavar="FORMAT",
            help="biomod (biorbd), osim (OpenSim 4), json, or a format registered with "
            "inertiafit.report.export.register_format",
        )
        add_out(p, None, "output folder, replaced whole")
        p.add_argument(
            "--draws",
            type=_count,
            metavar="N",
            help="also write N models sampled from the posterior (draws/)",
        )
        add_seed(p, "seed of the draws (default 0)")
        p.add_argument(
            "--declare", type=Path, metavar="FILE", help="a TOML file of [bodies.<name>] tables"
        )
        p.add_argument(
            "--radii",
            nargs="+",
            default=[],
            metavar="BODY=LONG,CROSS",
            help="BODY's radii of gyration about its long and cross axis (m)",
        )
        p.add_argument(
            "--ratios",
            nargs="+",
            default=[],
            metavar="BODY=LONG,CROSS",
            help="the same as multiples of the measured radius",
        )
        p.add_argument(
            "--segment",
            nargs="+",
            default=[],
            metavar="BODY=TABLE:SEGMENT",
            help="BODY's other radii from an anthropometric table (de-leva-male:forearm)",
        )
        p.add_argument(
            "--long-axis",
            default="+x",
            metavar="AXIS",
            help="the body axis from the joint to the centre of mass: +x (default), y, -z, ... "
            "(a negative one as --long-axis=-y)",
        )
        p.add_argument(
            "--joint-axis",
            default="z",
            metavar="AXIS",
            help="the body axis that is the dynamometer axis (default z)",
        )
        p.add_argument(
            "--phase",
            type=float,
            metavar="DEG",
            help="the dynamometer's phase phi in degrees: the models feel M_g sin(q + phi) "
            "(default: the phase the study measured; 0 for a folder of 'fit')",
        )

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        from inertiafit.pipeline.export import run_export
        from inertiafit.report.export import declared_radii

        declared = {}
        for option, items in (
            ("--radii", args.radii),
            ("--ratios", args.ratios),
            ("--segment", args.segment),
        ):
            for item in items:
                body, sep, value = item.partition("=")
                if option == "--segment":
                    table, colon, segment = value.partition(":")
                    if not sep or not body or not colon:
                        raise InputError(f"{option}: expected BODY=TABLE:SEGMENT, got {item!r}")
                    entry: dict = {"table": table, "segment": segment}
                else:
                    try:
                        numbers = [float(v) for v in value.split(",")]
                    except ValueError:
                        numbers = []
                    if not sep or not body or len(numbers) != 2:
                        raise InputError(f"{option}: expected BODY=LONG,CROSS, got {item!r}")
                    kind = "radius" if option == "--radii" else "ratio"
                    entry = {f"{kind}_long": numbers[0], f"{kind}_cross": numbers[1]}
                declared[body] = declared_radii(body, entry, where=option)
        run_export(
            args.folder,
            fmt=args.format,
            out=args.out,
            draws=args.draws,
            seed=args.seed,
            declarations=args.declare,
            declared=declared,
            long_axis=args.long_axis,
            joint_axis=args.joint_axis,
            phase=None if args.phase is None else math.radians(_phase_degrees(args.phase)),
        )
        return 0


def _phase_degrees(value: float) -> float:
    """``--phase``: a finite angle in degrees."""
    if not math.isfinite(value):
        raise InputError(f"--phase: expected a finite angle in degrees, got {value!r}")
    return value


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


@register_command
class _Plan(Command):
    name = "plan"
    help = "predicted posterior widths of candidate designs, before a session"
    description = (
        "Predict the posterior SD and HDI width of every body's m, x, rho, I and M_g for "
        "candidate designs (trials per speed, speeds, weighing, a second mounting, priors), "
        "from a design file (TOML; see the tutorial 'Planning a measurement session') or from "
        "a pilot study's --out folder (posterior.nc and trials.csv). With targets, finds the "
        "design reaching them with the fewest trials. Writes plan.csv, plan-search.csv and "
        "plan.pdf/.png into --out."
    )

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "design", type=Path, nargs="?", metavar="DESIGN", help="a design file (TOML)"
        )
        p.add_argument(
            "--pilot", type=Path, metavar="DIR", help="a pilot study's output folder instead"
        )
        p.add_argument(
            "--trials-per-speed",
            type=_count,
            nargs="+",
            default=[],
            metavar="N",
            help="add variants of every design with these fast trials per speed",
        )
        p.add_argument(
            "--weigh",
            nargs="+",
            default=[],
            metavar="BODY=SD",
            help="add variants with BODY weighed on a scale of this SD (kg)",
        )
        p.add_argument(
            "--offset",
            nargs="+",
            default=[],
            metavar="BODY=D",
            help="add variants with BODY also measured D m further out (a second mounting)",
        )
        p.add_argument(
            "--target",
            nargs="+",
            default=[],
            metavar="BODY.PARAMETER=WIDTH",
            help="requested HDI width (SI units), e.g. forearm.mass=0.2",
        )
        add_out(p, "inertiafit-plan")
        add_seed(p, help="seed (default 0)")
        add_hdi_prob(
            p, default=None, help="probability of the HDIs (default: the design file's, else 0.95)"
        )
        add_formats(p)

    @staticmethod
    def run(args: argparse.Namespace) -> int:
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
            formats=check_formats(args.formats),
        )
        return 0


@register_command
class _Priors(Command):
    name = "priors"
    help = "list the shipped priors"

    @staticmethod
    def run(_args: argparse.Namespace) -> int:
        from inertiafit.inference.priors import available_priors, load_prior

        for name in available_priors():
            print(load_prior(name).describe())
        return 0


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
    for command in COMMANDS.values():
        p = sub.add_parser(command.name, help=command.help, description=command.description)
        command.arguments(p)
        p.set_defaults(handler=command.run)
    return parser


# --- library messages in the command line's words ----------------------------------------------

#: A whole word of a message that may be an argument's name: maybe in a parenthesis, maybe
#: indexed (``inertia[1]``), maybe followed by punctuation.
_WORD = re.compile(r"(\(?)(\w+)((?:\[\d+\])?[,;:.)]?)")


def _option_names(parser: argparse.ArgumentParser, command: str | None = None) -> set[str]:
    """Every option's ``dest`` of ``command`` (all subcommands' when ``None``).

    Only the command's own options: ``run`` has no ``--prior``, so a message of ``run`` that
    starts with ``prior`` is about a prior, not an option.
    """
    dests: set[str] = set()
    for action in parser._actions:  # argparse keeps its subparsers only here
        choices = getattr(action, "choices", None)
        if isinstance(choices, dict):
            for name, sub in choices.items():
                if command is None or name == command:
                    dests.update(
                        a.dest for a in sub._actions if a.option_strings and a.dest != "help"
                    )
    return dests


def _as_options(message: str, parser: argparse.ArgumentParser, command: str | None = None) -> str:
    """A library message in the command line's words: argument names become option names.

    Library functions start a message about an argument with its name (``hdi_prob: expected
    ...``, ``inertia[1]: ...``, ``inertia_sd and inertia_n go together``, ``mass: needs its SD
    mass_sd too``); here they read ``--hdi-prob``, ``--inertia-sd``. Only a message that
    *starts* with an argument name is rewritten, and only whole words: the leading name, and
    further names with an underscore (a plain word further on is prose). A message that starts
    with a file or a manifest key (``study.toml: ...``, ``file not found: ...``) is left as it
    is, and a word inside a path or a dotted key is never a whole word, so paths and keys that
    hold an argument's name never change.
    """
    names = _option_names(parser, command)
    words = message.split(" ")
    lead = _WORD.fullmatch(words[0])
    if lead is None or lead.group(1) or lead.group(2) not in names:
        return message
    shown = []
    for i, word in enumerate(words):
        token = _WORD.fullmatch(word)
        if token and token.group(2) in names and (i == 0 or "_" in token.group(2)):
            opening, name, closing = token.groups()
            shown.append(f"{opening}--{name.replace('_', '-')}{closing}")
        else:
            shown.append(word)
    return " ".join(shown)


def _speak_any_terminal() -> None:
    r"""Let stdout and stderr write every character, whatever the terminal's encoding.

    The reports print ``ρ``, ``±`` and ``·``; in an ASCII locale with Python's UTF-8 mode off
    (``PYTHONUTF8=0 LC_ALL=C``, as some CI machines run) each such line raised
    UnicodeEncodeError after the results were written. A character the terminal cannot
    encode is printed as its escape (``\xb7``) instead.
    """
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None and stream.errors in {"strict", "surrogateescape"}:
            reconfigure(errors="backslashreplace")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``inertiafit`` command."""
    _speak_any_terminal()
    parser = build_parser()
    args = parser.parse_args(argv)
    handler: Callable[[argparse.Namespace], int] = args.handler
    try:
        figure_dpi()  # a bad INERTIAFIT_DPI is said before any work, not after the sampling
        return handler(args)
    except InputError as exc:
        shown = _as_options(str(exc), parser, getattr(args, "command", None))
        print(f"inertiafit: error: {shown}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("inertiafit: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of stdout went away (``| head``): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:  # the machine's, not the input's: a full disk, a lost mount
        where = f"{exc.filename}: " if exc.filename else ""
        print(
            f"inertiafit: error: {where}{exc.strerror or exc}; nothing was replaced (an output "
            "folder is swapped in only once complete)"
            + ("; free some space and run again" if exc.errno == errno.ENOSPC else ""),
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
