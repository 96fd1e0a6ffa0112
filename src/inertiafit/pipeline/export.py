"""``inertiafit export``: a results folder's posterior as musculoskeletal model files.

Reads ``posterior.nc`` of a folder written by ``run``, ``fit`` or ``demo`` (through
:func:`~inertiafit.posterior.open_posterior` and
:func:`~inertiafit.inference.priors.priors_from_posterior`, as ``inertiafit report`` does),
builds each body's segment (:mod:`inertiafit.report.export`) and writes into ``out``
(replaced whole, :func:`~inertiafit.io.outputs.output_folder`):

* ``model.<ext>``: the posterior-median model (``.bioMod``, ``.osim`` or ``.json``);
* with ``draws = N``: ``draws/model-0001.<ext>`` ... one model per posterior draw, for Monte
  Carlo studies;
* ``export.csv``: every number of every model written, a row per model and body.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from inertiafit._checks import check_seed, check_whole
from inertiafit.errors import InputError
from inertiafit.inference.priors import priors_from_posterior
from inertiafit.io.outputs import check_out, guard_outputs, output_folder, write_csv
from inertiafit.posterior import open_posterior
from inertiafit.report.export import (
    EXPORT_COLUMNS,
    FORMATS,
    SUFFIXES,
    BodyInertia,
    Frame,
    OtherRadii,
    exported_bodies,
    load_declarations,
    other_radii,
    write_model,
)

__all__ = ["MAX_DRAWS", "run_export"]

#: Most model files one export writes.
MAX_DRAWS = 10_000


def _rows(label: str, bodies: list[BodyInertia]) -> list[dict]:
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
        }
        for b in bodies
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
    echo: Callable[[str], None] = print,
) -> tuple[list[BodyInertia], list[list[BodyInertia]]]:
    """``inertiafit export``: write the median model (and ``draws`` sampled ones) in ``fmt``.

    Parameters
    ----------
    results : path
        An output folder of ``run``, ``fit`` or ``demo`` (holding ``posterior.nc``).
    fmt : str
        ``biomod``, ``osim`` or ``json``.
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

    Returns
    -------
    median, sampled
        The median model's bodies and each sampled model's.
    """
    if fmt not in FORMATS:
        raise InputError(f"format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    if draws is not None:
        draws = check_whole(draws, "draws")
        if draws > MAX_DRAWS:
            raise InputError(f"draws: expected at most {MAX_DRAWS} models, got {draws}")
    check_seed(seed)
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
    median, sampled = exported_bodies(post, radii, frame=frame, draws=draws or 0, seed=seed)
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    name = str(inputs.get("name") or results.resolve().name)
    gravity = float(post.tree["constant_data"]["gravity"])
    suffix = SUFFIXES[fmt]
    width = max(4, len(str(draws or 0)))
    rows = _rows("median", median)
    with output_folder(out) as folder:
        title = f"{name}: posterior medians of {results / 'posterior.nc'}"
        write_model(folder / f"model{suffix}", median, fmt, frame=frame, title=title,
                    gravity=gravity)  # fmt: skip
        if sampled:
            (folder / "draws").mkdir()
        for k, bodies in enumerate(sampled, start=1):
            label = f"{k:0{width}d}"
            title = f"{name}: posterior draw {k} of {draws} (seed {seed}) of {results}"
            write_model(folder / "draws" / f"model-{label}{suffix}", bodies, fmt, frame=frame,
                        title=title, gravity=gravity)  # fmt: skip
            rows += _rows(label, bodies)
        write_csv(pd.DataFrame(rows, columns=EXPORT_COLUMNS), folder / "export.csv")
    echo(
        f"wrote {out}: model{suffix} (posterior medians)"
        + (f", draws/ ({draws} models sampled from the posterior, seed {seed})" if draws else "")
        + ", export.csv"
    )
    for b in median:
        echo(f"  {b.name}: other radii {b.source}")
    return median, sampled
