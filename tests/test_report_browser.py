"""report.html the way a reader meets it: rendered by headless Chromium."""

import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from matplotlib.image import imread

from inertiafit.pipeline.fit import run_fit

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
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=True)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    from inertiafit.pipeline.redraw import redraw

    out = tmp_path_factory.mktemp("fit") / "out"
    run_fit(
        prior="disk-3kg",
        inertia=[0.594],
        inertia_se=0.0105,
        gravity_moment=[12.8],
        gravity_moment_se=0.05,
        out=out,
        seed=1,
        echo=lambda *a: None,
    )
    redraw(out, echo=lambda *a: None)
    return out / "report.html"


@pytest.mark.slow
def test_every_figure_is_decoded_by_the_browser(report, tmp_path):
    html = report.read_text()
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
