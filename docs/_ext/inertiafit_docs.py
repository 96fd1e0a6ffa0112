"""Sphinx helpers for the inertiafit docs: pages built from the code at build time.

- ``.. inertiafit-cli::`` writes the command-line reference from
  :func:`inertiafit.cli.build_parser`, so the reference cannot drift from ``--help``.
- ``.. inertiafit-priors::`` writes the table of shipped priors from
  :func:`inertiafit.inference.priors.available_priors`.
- ``.. inertiafit-anthropometric::`` writes the anthropometric tables (fractions, lengths to
  measure, spreads and sources) from the files in ``priors/anthropometric/``.
- :func:`figure_scraper` lets sphinx-gallery show the matplotlib ``Figure`` objects an example
  holds (the examples never use pyplot, so the default scraper would find nothing).
"""

from __future__ import annotations

import argparse
import os
import re
from contextlib import contextmanager
from typing import Any

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

#: Width of generated usage lines (argparse reads COLUMNS).
USAGE_WIDTH = 88


def rst_escape(text: str) -> str:
    """Escape the characters that reStructuredText would read as markup."""
    return re.sub(r"([\\`*|_])", r"\\\1", text)


@contextmanager
def _columns(width: int):
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old


def _subcommands(parser: argparse.ArgumentParser):
    """``(name, help, subparser)`` of every subcommand, in the order they were added."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name, ""), sub


def _option_rows(parser: argparse.ArgumentParser) -> list[tuple[str, str]]:
    rows = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction | argparse._HelpAction):
            continue
        if action.option_strings:
            if action.nargs == 0:
                name = ", ".join(action.option_strings)
            else:
                metavar = action.metavar or action.dest.upper()
                suffix = f" {metavar} [{metavar} ...]" if action.nargs == "+" else f" {metavar}"
                name = ", ".join(s + suffix for s in action.option_strings)
            if action.required:
                name += " (required)"
        else:
            name = action.metavar or action.dest
        rows.append((name, action.help or ""))
    return rows


def _table(rows: list[tuple[str, str]], header: tuple[str, str]) -> list[str]:
    lines = [".. list-table::", "   :header-rows: 1", "   :widths: 35 65", ""]
    for left, right in [header, *rows]:
        lines += [f"   * - ``{left}``" if left != header[0] else f"   * - {left}"]
        lines += [f"     - {rst_escape(right) or ' '}"]
    return [*lines, ""]


def cli_reference_rst(parser: argparse.ArgumentParser | None = None) -> list[str]:
    """The command-line reference as reStructuredText lines (one section per command)."""
    if parser is None:
        from inertiafit.cli import build_parser

        parser = build_parser()
    with _columns(USAGE_WIDTH):
        lines = [
            rst_escape(parser.description or ""),
            "",
            ".. code-block:: text",
            "",
            *("   " + ln for ln in parser.format_usage().rstrip().splitlines()),
            "",
            *_table(_option_rows(parser), ("option", "meaning")),
        ]
        for name, help_text, sub in _subcommands(parser):
            title = f"``{parser.prog} {name}``"
            lines += [f".. _cli-{name}:", "", title, "-" * len(title), ""]
            if help_text:
                lines += [rst_escape(help_text[0].upper() + help_text[1:]) + ".", ""]
            lines += [".. code-block:: text", ""]
            lines += ["   " + ln for ln in sub.format_usage().rstrip().splitlines()]
            lines += [""]
            if sub.description:
                lines += [rst_escape(sub.description), ""]
            rows = _option_rows(sub)
            if rows:
                lines += _table(rows, ("argument", "meaning"))
    return lines


class CliReference(SphinxDirective):
    """``.. inertiafit-cli::`` — the reference of every command, from the parser itself."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        """Parse the generated reStructuredText, titles allowed, into the page."""
        container = nodes.section()
        container.document = self.state.document
        nested_parse_with_titles(
            self.state, StringList(cli_reference_rst(), source="inertiafit.cli"), container
        )
        return container.children


def _fmt(value: float) -> str:
    return f"{value:.4g}"


def priors_table_rst() -> list[str]:
    """A list-table of the shipped priors: name, body, box per parameter, source, reference."""
    from inertiafit.inference.priors import available_priors, load_prior
    from inertiafit.physics import PARAMETERS, UNITS

    lines = [
        ".. list-table::",
        "   :header-rows: 1",
        "   :widths: 18 27 30 25",
        "",
        "   * - name",
        "     - body",
        "     - nominal [lower, upper]",
        "     - source",
    ]
    for name in available_priors():
        prior = load_prior(name)
        box = "; ".join(
            f"{p} {_fmt(prior.nominal[p])} [{_fmt(prior.lower[p])}, {_fmt(prior.upper[p])}] "
            f"{UNITS[p]}"
            for p in PARAMETERS
        )
        source = prior.source or " "
        ref = prior.reference
        if ref:
            values = ", ".join(f"{k} {_fmt(v)}" for k, v in ref.items() if k != "label")
            source += f" (reference: {ref.get('label', '')}: {values})"
        lines += [
            f"   * - ``{name}``",
            f"     - {rst_escape(prior.description) or ' '}",
            f"     - {rst_escape(box)}",
            f"     - {rst_escape(source)}",
        ]
    return [*lines, ""]


class PriorsTable(SphinxDirective):
    """``.. inertiafit-priors::`` — the table of shipped priors, read from the prior files."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        """Parse the generated table into the page."""
        container = nodes.container()
        self.state.nested_parse(
            StringList(priors_table_rst(), source="inertiafit.inference.priors"), 0, container
        )
        return container.children


def anthropometric_table_rst() -> list[str]:
    """One list-table per anthropometric table file: segment, length, fractions, spread."""
    from inertiafit.inference.anthropometric import available_tables, load_table

    lines: list[str] = []
    for path in available_tables().values():
        table = load_table(path)
        names = ", ".join(f"``{n}``" for n in table.names())
        spread = ", ".join(f"{p} {v:g}" for p, v in table.spread.items())
        lines += [
            f"**{rst_escape(table.title)}** — names: {names}",
            "",
            (
                f"Source: {rst_escape(table.citation)}. Radius of gyration: the {table.radius} one,"
                f" about the CoM. Spread (SD of log): {spread} — {rst_escape(table.spread_source)}."
            ),
            "",
            ".. list-table::",
            "   :header-rows: 1",
            "   :widths: 14 34 13 13 13 13",
            "",
            "   * - segment",
            "     - segment_length (proximal → distal)",
            "     - mass / body mass",
            "     - CoM / length, from proximal",
            "     - radius / length, about CoM",
            "     - own spread",
        ]
        for seg in table.segments.values():
            cells = ["", "", ""]
            if seg.unsupported:
                cells = ["not given: " + seg.unsupported, "", ""]
            elif seg.parts:
                cells = ["composed of " + " + ".join(seg.parts), "", ""]
            else:
                for i, key in enumerate(("mass", "com", "radius")):
                    cells[i] = " / ".join(
                        f"{v[key]:.4g}" + (f" ({sex[0].upper()})" if sex else "")
                        for sex, v in seg.fractions.items()
                    )
            own = ", ".join(f"{p} {v:g}" for p, v in seg.spread.items()) or " "
            lines += [
                f"   * - {rst_escape(seg.name)}",
                f"     - {rst_escape(seg.length) or ' '}",
                *(f"     - {rst_escape(c) or ' '}" for c in cells),
                f"     - {rst_escape(own)}",
            ]
        lines += [""]
    return lines


class AnthropometricTable(SphinxDirective):
    """``.. inertiafit-anthropometric::`` — the anthropometric tables, read from their files.

    Used from a Markdown page, where the directive's own state parses Markdown; the generated
    reStructuredText is therefore parsed by docutils' reStructuredText parser into a scratch
    document whose nodes are returned.
    """

    has_content = False

    def run(self) -> list[nodes.Node]:
        """Parse the generated tables (reStructuredText) and return their nodes."""
        from docutils.parsers.rst import Parser
        from docutils.utils import new_document

        document = new_document("inertiafit-anthropometric", self.state.document.settings)
        Parser().parse("\n".join(anthropometric_table_rst()), document)
        return list(document.children)


def figure_scraper(_block: Any, block_vars: dict[str, Any], gallery_conf: dict, **kwargs) -> str:
    """Sphinx-gallery scraper: save every new matplotlib ``Figure`` an example's globals hold.

    Figures found in the example's namespace (directly, or as values of a dict or list) after
    each code block, and not saved before, are written to the gallery's image paths.
    """
    from matplotlib.figure import Figure
    from sphinx_gallery.scrapers import figure_rst

    seen: list = block_vars.setdefault("_inertiafit_seen_figures", [])
    found = []
    for value in list(block_vars["example_globals"].values()):
        candidates = value.values() if isinstance(value, dict) else value
        if isinstance(value, Figure):
            candidates = [value]
        elif not isinstance(value, dict | list | tuple):
            continue
        for fig in candidates:
            if isinstance(fig, Figure) and not any(fig is s for s in seen + found):
                found.append(fig)
    paths = []
    for fig, path in zip(found, block_vars["image_path_iterator"], strict=False):
        fig.savefig(path, dpi=90, **kwargs)
        seen.append(fig)
        paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"]) if paths else ""


#: Placeholder in the root toctree for top-level pages it does not name yet.
MORE_PAGES = "inertiafit-more-pages"


def _more_pages(app, docname: str, source: list[str]) -> None:
    """Replace :data:`MORE_PAGES` in the root toctree by every top-level page it does not list.

    Engineers add pages to ``docs/`` (``figures.md``, ``benchmarks.md``, ...) independently;
    this keeps each of them in the navigation without an edit to ``index.md`` (a page in no
    toctree is a warning, and the docs build treats warnings as errors).
    """
    if docname != app.config.root_doc or MORE_PAGES not in source[0]:
        return
    text = source[0]
    listed = set(re.findall(r"^([\w./-]+)\s*$", text, flags=re.MULTILINE))
    extra = sorted(
        d
        for d in app.env.found_docs
        if "/" not in d and d != docname and d not in listed and d != MORE_PAGES
    )
    source[0] = text.replace(MORE_PAGES, "\n".join(extra))


def _reread_root(app, _env, added, _changed, removed) -> list[str]:
    """Re-read the root page whenever pages come or go, so its toctree follows them."""
    return [app.config.root_doc] if added or removed else []


def setup(app) -> dict[str, Any]:
    """Register the directives, the root-toctree hook and nothing else."""
    app.add_directive("inertiafit-cli", CliReference)
    app.add_directive("inertiafit-priors", PriorsTable)
    app.add_directive("inertiafit-anthropometric", AnthropometricTable)
    app.connect("source-read", _more_pages)
    app.connect("env-get-outdated", _reread_root)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
