"""The demo's index page (issue 34 item 3): one page linking the rigid report, the living
report, the information result and the paper-numbers results, each with its line."""

from __future__ import annotations

import html
import re
from pathlib import Path

import pandas as pd

from inertiafit.pipeline.demo import DEMO_INDEX, write_demo_index

LIVING = pd.DataFrame(
    {
        "model": ["rigid", "living"],
        "quantity": ["inertia", "inertia"],
        "truth": [0.0871, 0.0871],
        "median": [0.1289, 0.0867],
        "hdi_lower": [0.1250, 0.0850],
        "hdi_upper": [0.1330, 0.0884],
        "error": [0.48, -0.005],
        "covers": [False, True],
    }
)


def _demo_folder(root: Path) -> Path:
    """A folder shaped as `inertiafit demo` leaves it (the files the index links)."""
    for path, _, _ in DEMO_INDEX:
        target = root / path
        target.parent.mkdir(parents=True, exist_ok=True)
        if path.endswith(".html"):
            target.write_text("<html></html>", encoding="utf-8")
    (root / "living" / "living.csv").write_text(LIVING.to_csv(index=False), encoding="utf-8")
    info = pd.DataFrame({"body": ["weight"], "information": ["prior box"], "mass": [1.2]})
    (root / "information" / "information.csv").write_text(
        info.to_csv(index=False), encoding="utf-8"
    )
    return root


def _links(page: str) -> list[str]:
    return [html.unescape(h) for h in re.findall(r"<a href='([^']*)'>", page)]


def test_index_links_every_result_once_and_each_link_opens_a_file(tmp_path):
    folder = _demo_folder(tmp_path / "demo-output")
    index = write_demo_index(folder)
    assert index == folder / "index.html"
    page = index.read_text(encoding="utf-8")
    links = _links(page)
    assert links == [path for path, _, _ in DEMO_INDEX]
    for link in links:
        assert (index.parent / link).is_file(), link
    # rigid, living, information and paper numbers, each with its one line
    for needed in ("report.html", "living/report.html", "information/information.csv"):
        assert needed in links
    assert sum(link.startswith("paper-numbers/") for link in links) == 2
    for _, title, line in DEMO_INDEX:
        assert html.escape(title) in page
        assert html.escape(line) in page
    # the rigid-vs-living result is on the page itself, not only in the CSV
    assert "0.48" in page
    assert "-0.005" in page


def test_index_leaves_out_what_the_demo_did_not_write(tmp_path):
    folder = _demo_folder(tmp_path / "demo-output")
    (folder / "living" / "report.html").unlink()
    page = write_demo_index(folder).read_text(encoding="utf-8")
    assert "living/report.html" not in _links(page)
    assert all((folder / link).is_file() for link in _links(page))
