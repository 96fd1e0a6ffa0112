"""``inertiafit export``: a results folder's posterior as musculoskeletal model files.

Reads ``posterior.nc`` of a folder written by ``run``, ``fit`` or ``demo`` (through
:func:`~inertiafit.posterior.open_posterior` and
:func:`~inertiafit.inference.priors.priors_from_posterior`, as ``inertiafit report`` does),
builds each body's segment (:mod:`inertiafit.report.export`), places it so that it feels
gravity as it did on the dynamometer (the study's phase, or ``phase``), adds a living body's
joint (:mod:`inertiafit.report.living_joint`) and writes into ``out`` (replaced whole,
:func:`~inertiafit.io.outputs.output_folder`), in any registered format
(:func:`~inertiafit.report.export.register_format`):

* ``model.<ext>``: the posterior-median model;
* with ``draws = N``: ``draws/model-0001.<ext>`` ... one model per posterior draw, for Monte
  Carlo studies;
* ``export.csv``: every number of every model written, a row per model and body;
* with a living body, ``passive.csv``: its joint's tabulated curve in every model.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from inertiafit._checks import check_finite, check_seed, check_whole
from inertiafit.errors import InputError
from inertiafit.inference.priors import priors_from_posterior
from inertiafit.io.outputs import check_out, guard_outputs, output_folder, write_csv
from inertiafit.posterior import open_posterior
from inertiafit.report.export import (
    EXPORT_COLUMNS,
    BodyInertia,
    ExportModel,
    Frame,
    OtherRadii,
    data_phase,
    export_format,
    exported_bodies,
    load_declarations,
    other_radii,
    write_model,
)
from inertiafit.report.living_joint import living_joint

__all__ = ["MAX_DRAWS", "PASSIVE_COLUMNS", "run_export"]

#: Most model files one export writes.
MAX_DRAWS = 10_000
#: Columns of ``passive.csv``: a row per model, living body and tabulated angle.
PASSIVE_COLUMNS = [
    "model",
    "body",
    "device_angle",
    "joint_angle",
    "passive_moment",
    "hysteresis",
    "damping",
]


def _rows(label: str, bodies: list[BodyInertia], phase: float) -> list[dict]:
    return [
        {
            "model": label,
            "body": b.name,
            "mass": b.mass,
            "com_x": b.com[0],
            "com_y": b.com[1],
            "com_z": b.com[2],
            "inertia_xx": b.inertia[0][0],
            "inertia_yy": b.inertia[1][1],
            "inertia_zz": b.inertia[2][2],
            "radius_joint": b.radii["joint"],
            "radius_long": b.radii["long"],
            "radius_cross": b.radii["cross"],
            "posterior_draw": b.draw,
            "phase": phase,
            "damping": b.joint.damping if b.joint is not None else math.nan,
            "passive_line_error": b.joint.line_error if b.joint is not None else math.nan,
        }
        for b in bodies
    ]


def _passive_rows(label: str, bodies: list[BodyInertia]) -> list[dict]:
    return [
        {
            "model": label,
            "body": b.name,
            "device_angle": math.degrees(q),
            "joint_angle": math.degrees(q + b.joint.zero),
            "passive_moment": p,
            "hysteresis": h,
            "damping": b.joint.damping,
        }
        for b in bodies
        if b.joint is not None
        for q, p, h in zip(b.joint.angle, b.joint.moment, b.joint.hysteresis, strict=True)
    ]


@guard_outputs
def run_export(
    results: str | Path,
    *,
    fmt: str,
    out: str | Path,
    draws: int | None = None,
    seed: int = 0,
    declarations: str | Path | None = None,
    declared: Mapping[str, OtherRadii] | None = None,
    long_axis: str = "+x",
    joint_axis: str = "z",
    phase: float | None = None,
    echo: Callable[[str], None] = print,
) -> tuple[list[BodyInertia], list[list[BodyInertia]]]:
    """``inertiafit export``: write the median model (and ``draws`` sampled ones) in ``fmt``.

    Parameters
    ----------
    results : path
        An output folder of ``run``, ``fit`` or ``demo`` (holding ``posterior.nc``).
    fmt : str
        A registered format: ``biomod``, ``osim``, ``json``, or one added with
        :func:`~inertiafit.report.export.register_format`.
    out : path
        Output folder, replaced whole.
    draws : int, optional
        Models sampled from the posterior besides the median one (at least 1; none when
        not given).
    seed : int
        Seeds the draws.
    declarations : path, optional
        A TOML file of ``[bodies.<name>]`` tables: each body's other two radii
        (:func:`~inertiafit.report.export.load_declarations`).
    declared : mapping, optional
        More declarations (the command line's ``--radii`` and ``--segment``); they win.
    long_axis, joint_axis : str
        The body frame (:class:`~inertiafit.report.export.Frame`).
    phase : float, optional
        ``phi`` (rad): the models' angle ``q`` is the dynamometer's ``theta`` and they feel
        ``M_g sin(q + phi)``. Default: the phase the study measured
        (:func:`~inertiafit.report.export.data_phase`; 0 for a folder of ``fit``).

    Returns
    -------
    median, sampled
        The median model's bodies and each sampled model's.
    """
    writer = export_format(fmt)
    if draws is not None:
        draws = check_whole(draws, "draws")
        if draws > MAX_DRAWS:
            raise InputError(f"draws: expected at most {MAX_DRAWS} models, got {draws}")
    check_seed(seed)
    if phase is not None:
        phase = check_finite(phase, "phase", "rad")
    frame = Frame(long_axis=long_axis, joint_axis=joint_axis)
    results = Path(results)
    if not results.is_dir():
        raise InputError(f"{results}: no such results folder")
    if not (results / "posterior.nc").is_file():
        raise InputError(
            f"{results}: no posterior.nc; expected an output folder of 'inertiafit run', "
            "'fit' or 'demo'"
        )
    check_out(out, inputs=[results, declarations])
    post = open_posterior(results / "posterior.nc")
    priors = priors_from_posterior(post)
    wanted = load_declarations(declarations) if declarations is not None else {}
    wanted.update(declared or {})
    radii = other_radii(post, priors, wanted)
    try:
        joint = living_joint(post)
        joint_note = ""
    except InputError as exc:  # an older file: the bodies still export, and it is said
        joint, joint_note = None, f"  no joint exported: {exc}"
    median, sampled = exported_bodies(
        post, radii, frame=frame, draws=draws or 0, seed=seed, joint=joint
    )
    if phase is None:
        phase, phase_source = data_phase(post)
    else:
        phase_source = "given"
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    name = str(inputs.get("name") or results.resolve().name)
    gravity = float(post.tree["constant_data"]["gravity"])
    suffix = writer.suffix
    width = max(4, len(str(draws or 0)))

    def model(bodies: list[BodyInertia], title: str) -> ExportModel:
        return ExportModel(tuple(bodies), frame, title, gravity, phase, phase_source)

    rows = _rows("median", median, phase)
    passive = _passive_rows("median", median)
    with output_folder(out) as folder:
        title = f"{name}: posterior medians of {results / 'posterior.nc'}"
        write_model(folder / f"model{suffix}", model(median, title), fmt)
        if sampled:
            (folder / "draws").mkdir()
        for k, bodies in enumerate(sampled, start=1):
            label = f"{k:0{width}d}"
            title = f"{name}: posterior draw {k} of {draws} (seed {seed}) of {results}"
            write_model(folder / "draws" / f"model-{label}{suffix}", model(bodies, title), fmt)
            rows += _rows(label, bodies, phase)
            passive += _passive_rows(label, bodies)
        write_csv(pd.DataFrame(rows, columns=EXPORT_COLUMNS), folder / "export.csv")
        if passive:
            write_csv(pd.DataFrame(passive, columns=PASSIVE_COLUMNS), folder / "passive.csv")
    echo(
        f"wrote {out}: model{suffix} (posterior medians)"
        + (f", draws/ ({draws} models sampled from the posterior, seed {seed})" if draws else "")
        + ", export.csv"
        + (", passive.csv" if passive else "")
    )
    echo(
        f"  placed to feel gravity as on the dynamometer: M_g sin(q + phi), phi = {phase:.4g} "
        f"rad ({math.degrees(phase):.3g} deg; {phase_source})"
    )
    if joint_note:
        echo(joint_note)
    for b in median:
        echo(f"  {b.name}: other radii {b.source}")
        if b.joint is not None:
            lo, hi = (math.degrees(v) for v in (b.joint.angle[0], b.joint.angle[-1]))
            echo(
                f"  {b.name}: its joint's passive moment over {lo:.3g} to {hi:.3g} deg "
                f"(0 at {math.degrees(b.joint.reference):.3g} deg) and damping "
                f"{b.joint.damping:.3g} N m s/rad; a straight line is within "
                f"{b.joint.line_error:.2g} N m of the curve (what a .bioMod holds)"
            )
    return median, sampled
