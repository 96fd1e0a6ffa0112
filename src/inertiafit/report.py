"""A self-contained ``report.html``: tables and figures embedded, readable without a network."""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Mapping
from pathlib import Path

import pandas as pd

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: right; }
th { background: #f4f4f4; } td:first-child, th:first-child { text-align: left; }
figure { margin: 1em 0; } img { max-width: 100%; border: 1px solid #eee; }
.note { color: #555; font-size: 0.9em; } pre { background: #f8f8f8; padding: 0.6em; }
.warn { color: #a33; }
"""


def figure_png(fig, dpi: int = 110) -> bytes:
    """PNG of a Matplotlib figure, for embedding."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def figure_png_base64(fig, dpi: int = 110) -> str:
    """PNG of a Matplotlib figure as base64 text, for embedding."""
    return base64.b64encode(figure_png(fig, dpi)).decode("ascii")


def table_html(frame: pd.DataFrame, digits: int = 4) -> str:
    """An HTML table with numbers rounded to ``digits`` significant figures."""

    def fmt(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.{digits}g}"
        return html.escape(str(v))

    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in frame.columns)
    rows = "".join(
        "<tr>" + "".join(f"<td>{fmt(v)}</td>" for v in row) + "</tr>"
        for row in frame.itertuples(index=False)
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"


def write_report(
    path: str | Path,
    *,
    title: str,
    sections: list[tuple[str, list]],
    notes: Mapping[str, str] | None = None,
) -> Path:
    """Write a self-contained HTML report.

    Parameters
    ----------
    path : str or pathlib.Path
        Where to write ``report.html``.
    title : str
        Page title.
    sections : list of (heading, items)
        Items are :class:`pandas.DataFrame` (a table), Matplotlib figures or PNG bytes (embedded),
        ``("caption", figure)`` pairs, or strings (a paragraph; ``pre:`` prefix for
        preformatted text, ``warn:`` for a warning).
    notes : mapping, optional
        Key-value pairs listed at the end (inputs, versions, seed).
    """
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    for heading, items in sections:
        parts.append(f"<h2>{html.escape(heading)}</h2>")
        for entry in items:
            caption, item = entry if isinstance(entry, tuple) else ("", entry)
            if isinstance(item, pd.DataFrame):
                parts.append(table_html(item))
            elif isinstance(item, str):
                if item.startswith("pre:"):
                    parts.append(f"<pre>{html.escape(item[4:])}</pre>")
                elif item.startswith("warn:"):
                    parts.append(f"<p class='warn'>{html.escape(item[5:])}</p>")
                else:
                    parts.append(f"<p class='note'>{html.escape(item)}</p>")
            else:
                data = (
                    base64.b64encode(item).decode("ascii")
                    if isinstance(item, bytes)
                    else figure_png_base64(item)
                )
                parts.append(
                    f"<figure><img alt='{html.escape(caption or heading)}' "
                    f"src='data:image/png;base64,{data}'>"
                    + (
                        f"<figcaption class='note'>{html.escape(caption)}</figcaption>"
                        if caption
                        else ""
                    )
                    + "</figure>"
                )
    if notes:
        parts.append("<h2>Inputs and provenance</h2><table><tbody>")
        for k, v in notes.items():
            parts.append(
                f"<tr><td>{html.escape(k)}</td><td style='text-align:left'>"
                f"{html.escape(str(v))}</td></tr>"
            )
        parts.append("</tbody></table>")
    # Records, once the page has loaded, how many embedded figures the browser decoded; a
    # headless-browser test reads it back (nothing is fetched: the page stays offline).
    parts.append(
        "<script>window.addEventListener('load', function () { var n = 0;"
        " for (var i = 0; i < document.images.length; i++) {"
        " if (document.images[i].complete && document.images[i].naturalWidth > 0) { n++; } }"
        " document.body.setAttribute('data-figures-drawn', String(n)); });</script>"
    )
    parts.append("</body></html>")
    path = Path(path)
    path.write_text("\n".join(parts), encoding="utf-8")
    return path
