"""``inertiafit plan``: read the inputs, call the planner, write ``plan.csv`` and its figure.

The planner itself is :mod:`inertiafit.planning` (designs, :func:`~inertiafit.planning.plan`,
the design-file and pilot readers); this module is the command. docs/tutorials/planning.md is
the tutorial; the predictions are validated against full simulated studies in
docs/validation.md (:func:`inertiafit.validation.widths.simulated_widths`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from inertiafit._checks import check_probability, check_seed
from inertiafit.errors import InputError
from inertiafit.io.outputs import check_out, guard_outputs
from inertiafit.planning.design import design_variants
from inertiafit.planning.files import load_plan_file, pilot_inputs
from inertiafit.planning.planner import PlanResult, plan

__all__ = ["run_plan"]


@guard_outputs
def run_plan(
    design_file: str | Path | None = None,
    *,
    pilot: str | Path | None = None,
    out: str | Path,
    trials_per_speed: Sequence[int] = (),
    weigh: Mapping[str, float] | None = None,
    offsets: Mapping[str, Sequence[float]] | None = None,
    targets: Mapping[str, float] | None = None,
    hdi_prob: float | None = None,
    seed: int = 0,
    formats: tuple[str, ...] = ("pdf", "png"),
    echo: Callable[[str], None] = print,
) -> PlanResult:
    """``inertiafit plan``: predictions of a design file or of a pilot's variants, written.

    With ``design_file`` its designs; with ``pilot`` (a folder written by ``inertiafit run``)
    the pilot's own design and its variants: every count of ``trials_per_speed``, each body of
    ``weigh`` weighed with that SD (kg), each body of ``offsets`` moved in a second mounting at
    each offset (m). ``targets`` and ``hdi_prob`` override the file's. Writes ``plan.csv``,
    ``plan-search.csv`` (with targets) and ``plan.pdf``/``.png`` into ``out`` (replaced whole)
    and echoes the table.
    """
    from inertiafit.io.outputs import output_folder, write_csv
    from inertiafit.plotting.style import save_figure

    check_seed(seed)
    if (design_file is None) == (pilot is None):
        raise InputError("plan: give a design file or a pilot folder (one of them)")
    check_out(out, inputs=[design_file, pilot])
    if design_file is not None:
        kwargs = load_plan_file(design_file)
        if trials_per_speed or weigh or offsets:
            extra = []
            for d in kwargs["designs"]:
                extra += design_variants(d, trials_per_speed, weigh or {}, offsets or {})
            kwargs["designs"] = kwargs["designs"] + extra
    else:
        info = pilot_inputs(pilot)  # type: ignore[arg-type]
        base = info.pop("design")
        kwargs = {
            **info,
            "designs": [
                base,
                *design_variants(base, trials_per_speed, weigh or {}, offsets or {}),
            ],
        }
    if targets:
        kwargs["targets"] = {**kwargs.get("targets", {}), **targets}
    if hdi_prob is not None:
        kwargs["hdi_prob"] = check_probability(hdi_prob, "hdi_prob")
    result = plan(**kwargs, seed=seed)
    with output_folder(out) as folder:
        write_csv(result.table, folder / "plan.csv")
        if len(result.search):
            write_csv(result.search, folder / "plan-search.csv")
        save_figure(result.figure(), folder / "plan", formats)
    echo(result.text())
    echo(f"({len(result.table['design'].unique())} designs predicted in {result.seconds:.1f} s)")
    return result
