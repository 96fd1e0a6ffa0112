"""Outputs of a result: tables, figures, ``report.html`` and terminal text.

- :mod:`~inertiafit.report.result`: :class:`Result`, the plain data every output is drawn from;
- :mod:`~inertiafit.report.comparison`: the one comparison table (prior, ideal, posterior,
  the paper's estimator);
- :mod:`~inertiafit.report.tables`: CSV, Markdown and LaTeX tables;
- :mod:`~inertiafit.report.plots`: the study's and posterior's figures;
- :mod:`~inertiafit.report.figures`: every figure of a result as a record (file stem, drawing
  function, section and caption in ``report.html``), read by the file writer and the page;
- :mod:`~inertiafit.report.html`: the self-contained ``report.html``;
- :mod:`~inertiafit.report.text`: comparison tables for the terminal;
- :mod:`~inertiafit.report.methods`: the Methods text (``methods.md``) of a result, and
  :mod:`~inertiafit.report.references` its reference list (``references.bib``);
- :mod:`~inertiafit.report.outputs`: every output file of a result into a folder.

Nothing here samples or reads trial files: the pipeline builds a :class:`Result`, the report
draws it.
"""

from __future__ import annotations

__all__: list[str] = []
