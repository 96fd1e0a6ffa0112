"""``inertiafit population``: many subjects' studies pooled into a population, written to a folder.

Reads each DIR (:func:`inertiafit.inference.pooling.gather`), fits the population
(:func:`inertiafit.inference.pooling.population`) and writes into ``out``:

- ``population.csv``: every body's hyperparameters (the typical subject's ``m, x, rho, I,
  M_g``, slopes, scatters, correlations) with their HDIs;
- ``subjects.csv``: each subject's own and pooled estimates side by side;
- ``population.nc``: the hyperparameters' draws and the design (``xarray.open_datatree``);
  ``prior = { population = "OUT/population.nc" }`` starts a new subject's study from it;
- ``report.html`` and its figures (:mod:`inertiafit.report.population`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from inertiafit._checks import check_probability, check_seed
from inertiafit.inference.pooling import PopulationPosterior, population
from inertiafit.inference.population import Hyperprior
from inertiafit.io.outputs import check_out, guard_outputs, output_folder, write_csv
from inertiafit.plotting.style import DEFAULT_FORMATS, check_formats
from inertiafit.report.population import write_population_report

__all__ = ["run_population"]


@guard_outputs
def run_population(
    sources: Sequence[str | Path],
    *,
    out: str | Path = "population-output",
    seed: int = 0,
    hdi_prob: float = 0.95,
    bodies: Sequence[str] | None = None,
    covariates: Mapping[str, Sequence[str]] | None = None,
    hyperprior: Hyperprior | None = None,
    formats: tuple[str, ...] | list[str] = DEFAULT_FORMATS,
    echo: Callable[[str], None] = print,
) -> PopulationPosterior:
    """``inertiafit population DIR... --out OUT``: pool the studies, write the outputs, print."""
    seed = check_seed(seed)
    check_probability(hdi_prob, "hdi_prob")
    fmts = check_formats(formats)
    check_out(out, inputs=list(sources))
    pop = population(
        sources, seed=seed, bodies=bodies, covariates=covariates, hyperprior=hyperprior, echo=echo
    )
    summary = pop.summary(hdi_prob)
    subjects = pop.subjects(hdi_prob)
    with output_folder(out) as folder:
        write_csv(summary, folder / "population.csv")
        write_csv(subjects, folder / "subjects.csv")
        pop.save(folder / "population.nc", hdi_prob)
        written = write_population_report(folder, pop, hdi_prob=hdi_prob, formats=fmts)
    echo("")
    echo(pop.text(hdi_prob))
    figures = sorted({n.rsplit(".", 1)[0] for n in written if n.rsplit(".", 1)[-1] in fmts})
    echo(
        f"\nwrote {out}/: population.csv, subjects.csv, population-tables.csv, population.nc, "
        f"report.html; figures {', '.join(figures)} ({', '.join(fmts)})"
    )
    return pop
