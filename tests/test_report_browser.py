"""report.html the way a reader meets it: rendered by headless Chromium."""

import html
import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from matplotlib.image import imread

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
]

pytestmark = pytest.mark.skipif(
    CHROMIUM is None and not os.environ.get("CI"),
    reason="Debian's chromium is not installed (.ci/run installs it; CI fails without it)",
)


def chromium(*args, tmp_path):
    assert CHROMIUM is not None, "chromium missing: .ci/run must install Debian's chromium"
    cmd = [CHROMIUM, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}", *args]
    return subprocess.run(
        cmd, capture_output=True, text=True, encoding="utf-8", timeout=120, check=True
    )


@pytest.fixture(scope="module")
def report(disk_fit):
    """report.html of conftest's fit of the paper's disk (the page a redraw writes comes from
    the same code: test_report_command.py checks the redraw of a fit folder)."""
    return disk_fit / "report.html"


@pytest.mark.slow
def test_every_figure_is_decoded_by_the_browser(report, tmp_path):
    html = report.read_text(encoding="utf-8")
    n_images = html.count("<img ")
    assert n_images >= 4
    dom = chromium(
        "--virtual-time-budget=5000", "--dump-dom", report.as_uri(), tmp_path=tmp_path
    ).stdout
    drawn = re.search(r'data-figures-drawn="(\d+)"', dom)
    assert drawn, "the page's load handler did not run"
    assert int(drawn.group(1)) == n_images


@pytest.mark.slow
def test_screenshot_shows_tables_and_figures(report, tmp_path):
    shot = tmp_path / "page.png"
    chromium("--window-size=1200,2600", f"--screenshot={shot}", report.as_uri(), tmp_path=tmp_path)
    img = imread(shot)[..., :3]
    assert img.shape[:2] == (2600, 1200)
    dark = (img.max(-1) < 0.3).mean()  # text and lines
    assert dark > 0.005
    # Figures are drawn in the palette's blue (#0072B2): thousands of such pixels.
    blue = np.abs(img - np.array([0x00, 0x72, 0xB2]) / 255).max(-1) < 0.12
    assert blue.sum() > 2000
    # A page that failed to draw is uniformly white.
    assert img.std() > 0.05


#: Measures the page as laid out at the window's width, every ``<details>`` opened: the
#: document's scroll width, every element that reaches past the window or spills out of its
#: box, and every table box that would need a sideways scroll. Added to a copy of the page
#: only; the report itself runs no such script.
MEASURE = """<script>window.addEventListener('load', function () {
  var folds = document.querySelectorAll('details');
  for (var k = 0; k < folds.length; k++) { folds[k].open = true; }
  var width = document.documentElement.clientWidth, bad = [];
  var all = document.body.querySelectorAll('*');
  for (var i = 0; i < all.length; i++) {
    var e = all[i], r = e.getBoundingClientRect(), style = getComputedStyle(e);
    if (r.right > width + 0.5) { bad.push('past window: ' + e.tagName); continue; }
    if (style.overflowX === 'visible' && e.clientWidth > 0 && e.scrollWidth > e.clientWidth + 1)
      { bad.push('spills: ' + e.tagName + ' ' + e.scrollWidth + ' > ' + e.clientWidth); }
  }
  var boxes = document.querySelectorAll('div.table');
  for (var j = 0; j < boxes.length; j++) {
    if (boxes[j].scrollWidth > boxes[j].clientWidth + 1)
      { bad.push('scrolls: ' + boxes[j].textContent.slice(0, 60)); }
  }
  document.body.setAttribute('data-scroll-width', String(document.documentElement.scrollWidth));
  document.body.setAttribute('data-tables', String(boxes.length));
  document.body.setAttribute('data-overflow', bad.join(' | '));
});</script>"""


@pytest.fixture(scope="module")
def study_report(study_out):
    """report.html of conftest's `inertiafit run` on a simulated two-body study."""
    return study_out / "report.html"


def layout(report, tmp_path, width=1280):
    """What :data:`MEASURE` finds in ``report`` at ``width`` px: scroll width, tables, faults."""
    page = tmp_path / "measured.html"
    page.write_text(
        report.read_text(encoding="utf-8").replace("</body>", MEASURE + "</body>"),
        encoding="utf-8",
    )
    dom = chromium(
        f"--window-size={width},900",
        "--virtual-time-budget=5000",
        "--dump-dom",
        page.as_uri(),
        tmp_path=tmp_path,
    ).stdout
    found = dict(re.findall(r'data-(scroll-width|tables|overflow)="([^"]*)"', dom))
    assert found, "the measuring script did not run"
    return int(found["scroll-width"]), int(found["tables"]), found["overflow"]


@pytest.mark.slow
@pytest.mark.parametrize("which", ["study", "fit"])
def test_nothing_overflows_a_1280_px_window(which, study_report, report, tmp_path):
    page = study_report if which == "study" else report
    width, tables, faults = layout(page, tmp_path)
    assert tables >= (12 if which == "study" else 6)  # the study: a table per condition and kind
    assert width <= 1280
    assert faults == ""
    # the negative control: the same page in a window too narrow for its widest table
    width, _, faults = layout(page, tmp_path, width=500)
    assert "scrolls: " in faults
    assert width <= 500  # a wide table scrolls in its own box; the page never does


@pytest.mark.slow
def test_study_report_screenshot_at_1280_px(study_report, tmp_path):
    shot = tmp_path / "page.png"
    chromium("--window-size=1280,3000", f"--screenshot={shot}", study_report.as_uri(),
             tmp_path=tmp_path)  # fmt: skip
    img = imread(shot)[..., :3]
    assert img.shape[:2] == (3000, 1280)
    # the page's content column (1200 px) is centred: a white margin on both sides
    columns = (img.max(-1) < 0.3).any(0)  # columns with text or lines
    assert not columns[:30].any()
    assert not columns[-30:].any()


#: Measures where the table of contents and the intervals figure (the first ``<img>``, its alt
#: text the intervals caption) sit as the page first opens: their boxes' top and bottom, in
#: px from the window's top. Added to a copy of the page only.
FIRST_SCREEN = """<script>window.addEventListener('load', function () {
  var toc = document.querySelector('nav.toc'), img = document.images[0];
  var t = toc.getBoundingClientRect(), f = img.getBoundingClientRect();
  var out = [t.top, t.bottom, f.top, f.bottom, img.alt].join('|');
  document.body.setAttribute('data-first-screen', out);
});</script>"""


def first_screen(report, tmp_path):
    """TOC top and bottom, figure top and bottom (px), the figure's alt text: at 1280x900."""
    page = tmp_path / "first-screen.html"
    page.write_text(
        report.read_text(encoding="utf-8").replace("</body>", FIRST_SCREEN + "</body>"),
        encoding="utf-8",
    )
    dom = chromium(
        "--window-size=1280,900",
        "--virtual-time-budget=5000",
        "--dump-dom",
        page.as_uri(),
        tmp_path=tmp_path,
    ).stdout
    found = re.search(r'data-first-screen="([^"]*)"', dom)
    assert found, "the measuring script did not run"
    *numbers, alt = found.group(1).split("|", 4)
    return [float(v) for v in numbers], html.unescape(alt)


@pytest.mark.slow
@pytest.mark.parametrize("which", ["study", "fit"])
def test_first_screen_shows_contents_and_intervals_figure(which, study_report, report, tmp_path):
    page = study_report if which == "study" else report
    (toc_top, toc_bottom, fig_top, fig_bottom), alt = first_screen(page, tmp_path)
    assert alt.startswith("Every body's m, x, rho, I and M_g: the posterior's 95% HDI")
    # the table of contents, then the figure, both begun on the first screen (900 px) ...
    assert 0 <= toc_top < toc_bottom < fig_top < 900
    # ... and most of the figure on it: the reader sees the answer without scrolling
    assert min(fig_bottom, 900) - fig_top > 0.5 * (fig_bottom - fig_top)
