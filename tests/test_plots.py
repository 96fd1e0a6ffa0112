"""Figures: structure (axes, labels with units, prior-box limits, truths, sizes, no global state)
and pixels (PNG comparison against ``tests/baseline_images``).

The image tests draw seeded synthetic inputs (not a sampler run), so a change to the sampler
does not move a pixel; only a change to the drawing does. To regenerate the baselines after an
intended change, look at the new images, then::

    INERTIAFIT_UPDATE_BASELINES=1 .venv/bin/python -m pytest tests/test_plots.py -q
"""

from __future__ import annotations

import functools
import itertools
import os
import shutil
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
import xarray as xr
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.testing.compare import compare_images
from scipy.stats import norm

from inertiafit.baseline import curve_mass_intervals, paper_baseline
from inertiafit.errors import InputError
from inertiafit.physics import PARAMETERS, REPORTED
from inertiafit.plotting import raster, style
from inertiafit.plotting.corner import IDEAL_COLOUR, IDEAL_LABEL, TRUTH_LABEL, corner_figure
from inertiafit.posterior import Posterior
from inertiafit.report import plots
from inertiafit.report.plots.identification import curve_verdict

BASELINES = Path(__file__).parent / "baseline_images"
UPDATE = os.environ.get("INERTIAFIT_UPDATE_BASELINES") == "1"
DPI = 60
# RMS over 0-255 pixel values. Re-rendering here gives 0; a moved tick label gives ~3, a moved
# panel or a missing curve far more (checked by breaking the figures once).
TOL = 1.0

G = 9.81
NOMINAL = {"attachment": (2.91, 0.225, 0.13), "weight": (2.92, 0.45, 0.035)}
TRUTHS = {"mass": 2.91, "com_distance": 0.225, "radius_of_gyration": 0.13}


def walk(rng: np.random.Generator, shape: tuple[int, int], phi: float = 0.9) -> np.ndarray:
    """Standard-normal AR(1) series per walker, like a sampler's correlated draws."""
    z = rng.standard_normal(shape)
    out = np.empty(shape)
    out[:, 0] = z[:, 0]
    for t in range(1, shape[1]):
        out[:, t] = phi * out[:, t - 1] + np.sqrt(1 - phi**2) * z[:, t]
    return out


def synthetic_posterior(seed: int = 0, n_chain: int = 16, n_draw: int = 150) -> Posterior:
    """Draws spread along each body's identification curve inside a ±50 % box, seeded."""
    rng = np.random.default_rng(seed)
    post: dict[str, list[np.ndarray]] = {p: [] for p in REPORTED}
    prior: dict[str, list[np.ndarray]] = {p: [] for p in REPORTED}
    nominal, lower, upper = [], [], []
    for m0, x0, r0 in NOMINAL.values():
        nom = np.array([m0, x0, r0])
        lo, hi = 0.5 * nom, 1.5 * nom
        a0, i0 = m0 * x0, m0 * (r0**2 + x0**2)
        m_lo, m_hi = curve_mass_intervals(
            inertia=i0, gravity_moment=a0 * G, lower=lo, upper=hi, gravity=G
        )[0]
        shape = (n_chain, n_draw)
        m = m_lo + (m_hi - m_lo) * norm.cdf(walk(rng, shape))
        a = a0 * (1 + 0.005 * walk(rng, shape))
        inertia = i0 * (1 + 0.01 * walk(rng, shape))
        x = a / m
        rho = np.sqrt(np.clip(inertia / m - x**2, 1e-8, None))
        for store, (mm, xx, rr) in (
            (post, (m, x, rho)),
            (prior, tuple(rng.uniform(lo, hi, (1, 2000, 3)).transpose(2, 0, 1))),
        ):
            store["mass"].append(mm)
            store["com_distance"].append(xx)
            store["radius_of_gyration"].append(rr)
            store["inertia"].append(mm * (rr**2 + xx**2))
            store["gravity_moment"].append(mm * G * xx)
        nominal.append(nom)
        lower.append(lo)
        upper.append(hi)
    bodies = list(NOMINAL)

    def group(values):
        return xr.Dataset(
            {p: (("chain", "draw", "body"), np.stack(v, axis=-1)) for p, v in values.items()},
            coords={"body": bodies},
        )

    box = ("body", "parameter")
    constant = xr.Dataset(
        {"nominal": (box, nominal), "lower": (box, lower), "upper": (box, upper), "gravity": G},
        coords={"body": bodies, "parameter": list(PARAMETERS)},
    )
    tree = xr.DataTree.from_dict(
        {"posterior": group(post), "prior": group(prior), "constant_data": constant}
    )
    return Posterior(tree)


def synthetic_traces(seed: int = 0) -> list[dict]:
    rng = np.random.default_rng(seed)
    traces = []
    for speed in (240.0, 270.0, 300.0):
        for _ in range(3):
            t = np.arange(0.0, 0.8, 0.002)
            alpha = np.radians(3000.0) * (1 + 0.03 * rng.standard_normal())
            t0 = 0.05 + 0.01 * rng.standard_normal()
            v_max = np.radians(speed)
            vel = np.clip(alpha * (t - t0), 0.0, v_max)
            vel += 0.01 * np.sin(2 * np.pi * 25 * t) + 0.003 * rng.standard_normal(t.size)
            traces.append(
                {
                    "time": t,
                    "velocity": vel,
                    "acceleration": np.gradient(vel, t),
                    "speed": speed,
                    "window": (t0 + 0.01, t0 + 0.8 * v_max / alpha),
                }
            )
    return traces


def synthetic_trials(seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = [
        {"condition": cond, "speed": speed, "inertia": mean * (1 + 0.04 * rng.standard_normal())}
        for cond, mean in (("A", 0.216), ("B", 0.81))
        for speed in (240, 270, 300)
        for _ in range(10)
    ]
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def posterior():
    return synthetic_posterior()


@pytest.fixture(scope="module")
def baseline():
    return paper_baseline(  # the same body and data as the synthetic posterior's attachment
        inertia=2.91 * (0.13**2 + 0.225**2),
        gravity_moment=2.91 * G * 0.225,
        nominal=NOMINAL["attachment"],
        method="SLSQP",
        ks=range(-50, 51, 5),
    )


def check_image(fig, name: str, tmp_path: Path) -> None:
    """Compare the figure at :data:`DPI` with ``baseline_images/<name>.png``."""
    (actual,) = style.save_figure(fig, tmp_path / name, formats=("png",), dpi=DPI)
    expected = BASELINES / f"{name}.png"
    if UPDATE:
        BASELINES.mkdir(exist_ok=True)
        shutil.copyfile(actual, expected)
        return
    if not expected.is_file():
        pytest.fail(f"{expected} missing: run with INERTIAFIT_UPDATE_BASELINES=1 to create it")
    assert expected.stat().st_size < 60_000, "keep baseline images small"
    err = compare_images(str(expected), str(actual), tol=TOL)
    assert err is None, err


def figures(post, base):
    """Every figure with its default arguments, by baseline name."""
    body = "attachment"
    return {
        "corner": lambda: post.corner(body, truths=TRUTHS, parameters=PARAMETERS),
        "identification-curve": lambda: plots.plot_identification_curve(post, body, baseline=base),
        "fast-trials": lambda: plots.plot_fast_trials(synthetic_traces(), title="A"),
        "inertia-by-speed": lambda: plots.plot_inertia_by_speed(synthetic_trials()),
        "trace": lambda: plots.plot_trace(post, body, max_walkers=4),
        "rank": lambda: plots.plot_rank(post, body),
        "intervals": lambda: plots.plot_intervals(post),
    }


# --- pixels -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name",
    [
        "corner",
        "identification-curve",
        "fast-trials",
        "inertia-by-speed",
        "trace",
        "rank",
        "intervals",
    ],
)
def test_figure_matches_its_baseline_image(name, posterior, baseline, tmp_path):
    check_image(figures(posterior, baseline)[name](), name, tmp_path)


def test_image_comparison_catches_a_moved_label(posterior, baseline, tmp_path):
    # The negative control: the same figure with one label changed must not pass.
    if UPDATE:
        pytest.skip("regenerating baselines")
    fig = figures(posterior, baseline)["trace"]()
    fig.axes[0].set_ylabel("$m$ [g]")
    (actual,) = style.save_figure(fig, tmp_path / "trace", formats=("png",), dpi=DPI)
    assert compare_images(str(BASELINES / "trace.png"), str(actual), tol=TOL) is not None


# --- structure ----------------------------------------------------------------------------------


def test_no_function_changes_rcparams_or_opens_pyplot_figures(posterior, baseline):
    import matplotlib.pyplot as plt

    before = dict(matplotlib.rcParams)
    open_before = plt.get_fignums()
    for make in figures(posterior, baseline).values():
        make()
        assert dict(matplotlib.rcParams) == before
    plots.plot_joint_corner(posterior)
    assert dict(matplotlib.rcParams) == before
    assert plt.get_fignums() == open_before


@pytest.mark.parametrize(("width", "inches"), [("single", 3.5), ("double", 7.0), (5.0, 5.0)])
def test_width_sets_the_figure_width(posterior, width, inches):
    body = "attachment"
    for fig in (
        post_fig
        for post_fig in (
            posterior.corner(body, width=width),
            plots.plot_joint_corner(posterior, width=width),
            plots.plot_identification_curve(posterior, body, width=width),
            plots.plot_trace(posterior, body, width=width),
            plots.plot_rank(posterior, body, width=width),
            plots.plot_fast_trials(synthetic_traces(), width=width),
            plots.plot_inertia_by_speed(synthetic_trials(), width=width),
            plots.plot_intervals(posterior, width=width),
        )
    ):
        assert fig.get_size_inches()[0] == pytest.approx(inches)


def test_defaults_are_journal_column_widths(posterior):
    assert posterior.corner("attachment").get_size_inches()[0] == style.DOUBLE_COLUMN
    assert plots.plot_trace(posterior, "weight").get_size_inches()[0] == style.DOUBLE_COLUMN
    with pytest.raises(ValueError, match="width"):
        plots.plot_trace(posterior, "weight", width="triple")
    with pytest.raises(ValueError, match="width"):
        style.figure_width(-1.0)


def test_corner_axes_span_the_prior_box_with_truth_lines(posterior):
    fig = posterior.corner("weight", truths={"mass": 2.92, "inertia": 0.6}, prior_box=True)
    axes = np.asarray(fig.axes).reshape(5, 5)
    lower = (1.46, 0.225, 0.0175)
    upper = (4.38, 0.675, 0.0525)
    for i in range(3):
        assert axes[-1, i].get_xlim() == pytest.approx((lower[i], upper[i]))
        assert "[" in axes[-1, i].get_xlabel()
    assert axes[2, 0].get_ylim() == pytest.approx((lower[2], upper[2]))
    assert axes[-1, 3].get_xlabel() == "$I$ [kg m$^2$]"
    truth = [
        ln
        for ln in axes[-1, 0].get_lines()
        if ln.get_color() == style.PALETTE[1] and ln.get_xdata()[0] == pytest.approx(2.92)
    ]
    assert truth, "truth line for mass missing"
    inertia_truth = [ln for ln in axes[3, 3].get_lines() if ln.get_color() == style.PALETTE[1]]
    assert inertia_truth
    # the box edges are drawn (dashed, prior colour) on every mass panel
    edges = [ln for ln in axes[0, 0].get_lines() if ln.get_color() == style.PRIOR_COLOUR]
    assert sorted(ln.get_xdata()[0] for ln in edges) == pytest.approx([1.46, 4.38])


def test_corner_density_is_one_image_per_panel_unless_its_cells_have_edges(posterior):
    from matplotlib.collections import PolyQuadMesh

    def count(fig):
        images = sum(len(ax.images) for ax in fig.axes)
        meshes = sum(isinstance(c, PolyQuadMesh) for ax in fig.axes for c in ax.collections)
        return images, meshes

    assert count(posterior.corner("attachment")) == (10, 0)  # 5 quantities, 10 2-D panels
    edged = posterior.corner("attachment", pcolor_kwargs={"edgecolors": "k"})
    assert count(edged) == (0, 10)


def test_dropping_the_hidden_draws_leaves_the_corner_picture_unchanged(
    posterior, tmp_path, monkeypatch
):
    def draws(fig):
        return sum(
            len(ln.get_xdata()) for ax in fig.axes for ln in ax.lines if ln.get_rasterized()
        )

    fig = posterior.corner("attachment", truths=TRUTHS)
    kept = draws(fig)
    (dropped,) = style.save_figure(fig, tmp_path / "dropped", formats=("png",), dpi=100)
    monkeypatch.setattr(raster, "drop_hidden_points", lambda ax: None)
    fig = posterior.corner("attachment", truths=TRUTHS)
    (every,) = style.save_figure(fig, tmp_path / "every", formats=("png",), dpi=100)
    assert kept < draws(fig) / 2
    assert compare_images(str(every), str(dropped), tol=0) is None  # the same pixels


def test_joint_corner_has_every_bodys_parameters_on_their_boxes(posterior):
    truths = {"weight": {"mass": 2.92}}
    fig = plots.plot_joint_corner(posterior, truths=truths, prior_box=True)
    axes = np.asarray(fig.axes).reshape(6, 6)
    # the body on a line of its own: "attachment: m [kg]attachment: x [m]" ran together
    assert [ax.get_xlabel() for ax in axes[-1]] == [
        "attachment\n$m$ [kg]",
        "attachment\n$x$ [m]",
        "attachment\n$\\rho$ [m]",
        "weight\n$m$ [kg]",
        "weight\n$x$ [m]",
        "weight\n$\\rho$ [m]",
    ]
    fig.draw_without_rendering()
    boxes = [ax.xaxis.label.get_window_extent() for ax in axes[-1]]
    assert all(a.x1 < b.x0 for a, b in itertools.pairwise(boxes))  # no two labels touch
    assert axes[-1, 0].get_xlim() == pytest.approx((1.455, 4.365))
    assert axes[-1, 4].get_xlim() == pytest.approx((0.225, 0.675))

    def truth_lines(ax):  # corner.py draws NaN lines for missing truths
        return [
            ln
            for ln in ax.get_lines()
            if ln.get_color() == style.PALETTE[1] and np.isfinite(ln.get_xdata()).all()
        ]

    assert truth_lines(axes[-1, 3])
    assert not truth_lines(axes[-1, 0])

    class Ideal:  # like inertiafit.shapes' ideal bodies
        def as_dict(self):
            return {"mass": 2.91}

    fig = plots.plot_joint_corner(posterior, truths={"attachment": Ideal()})
    assert truth_lines(np.asarray(fig.axes).reshape(6, 6)[-1, 0])


def test_corner_draws_the_ideal_body_apart_from_the_truth(posterior):
    def lines(ax, colour):  # positions of the vertical lines (corner adds a truth's marker)
        return sorted(
            {
                float(ln.get_xdata()[0])
                for ln in ax.get_lines()
                if ln.get_color() == colour and np.isfinite(ln.get_xdata()).all()
            }
        )

    fig = posterior.corner("weight", truths={"mass": 2.85}, ideal={"mass": 2.92, "inertia": 0.6})
    axes = np.asarray(fig.axes).reshape(5, 5)
    assert lines(axes[-1, 0], IDEAL_COLOUR) == pytest.approx([2.92])  # dashed: the ideal
    assert lines(axes[-1, 0], style.PALETTE[1]) == pytest.approx([2.85])  # solid: the truth
    ideal = [ln for ln in axes[3, 3].get_lines() if ln.get_color() == IDEAL_COLOUR]
    assert [ln.get_linestyle() for ln in ideal] == ["--"]
    joint = plots.plot_joint_corner(posterior, ideals={"weight": {"mass": 2.92}})
    assert lines(np.asarray(joint.axes).reshape(6, 6)[-1, 3], IDEAL_COLOUR) == [2.92]


def test_corner_legend_names_the_truth_and_the_ideal_lines(posterior):
    def legend(fig):
        if not fig.legends:
            return {}
        (box,) = fig.legends
        return {
            text.get_text(): (handle.get_color(), handle.get_linestyle())
            for text, handle in zip(box.get_texts(), box.legend_handles, strict=True)
        }

    both = posterior.corner(
        "weight", parameters=("mass", "com_distance"), truths={"mass": 2.85}, ideal={"mass": 2.92}
    )
    assert legend(both) == {
        TRUTH_LABEL: (style.PALETTE[1], "-"),
        IDEAL_LABEL: (IDEAL_COLOUR, "--"),
    }
    # it sits in the empty upper triangle: above the last diagonal panel, inside the figure
    both.draw_without_rendering()
    box = both.legends[0].get_window_extent()
    last = np.asarray(both.axes).reshape(2, 2)[-1, -1].get_window_extent()
    assert box.x1 <= both.bbox.x1
    assert box.y0 >= last.y1
    # the engine names only the lines it draws
    rng = np.random.default_rng(1)
    small = {
        "columns": [rng.normal(size=300), rng.normal(size=300)],
        "labels": ["a", "b"],
        "titles": ["a", "b"],
        "ranges": [(-4.0, 4.0), (-4.0, 4.0)],
        "boxes": [None, None],
        "priors": [None, None],
    }
    assert list(legend(corner_figure(**small, truths=[0.5, None]))) == [TRUTH_LABEL]
    assert list(legend(corner_figure(**small, ideals=[None, 0.2]))) == [IDEAL_LABEL]
    assert legend(corner_figure(**small, truths=[None, None], ideals=None)) == {}


def deceleration_traces(seed: int = 0) -> list[dict]:
    """:func:`synthetic_traces` with a deceleration window after each trial's constant speed."""
    traces = synthetic_traces(seed)
    for k, t in enumerate(traces):
        t1 = t["window"][1]
        t["deceleration"] = (t1 + 0.3 + 0.001 * k, t1 + 0.36 + 0.002 * k)
    return traces


def test_living_fast_trials_shade_the_deceleration_window_each_speed_used():
    from inertiafit.report.plots.living import DECELERATION_GID, deceleration_spans

    traces = deceleration_traces()
    fig = plots.plot_living_fast_trials(traces, title="B")
    spans = deceleration_spans(traces)
    assert sorted(spans) == [240.0, 270.0, 300.0]
    for speed, (lo, hi) in spans.items():
        own = [t for t in traces if t["speed"] == speed]
        starts = [t["deceleration"][0] - t["window"][0] for t in own]
        ends = [t["deceleration"][1] - t["window"][0] for t in own]
        assert (lo, hi) == (np.median(starts), np.median(ends))
    for ax in fig.axes[:2]:  # velocity and acceleration panels
        drawn = {
            a.get_gid(): (a.get_x(), a.get_x() + a.get_width())
            for a in ax.patches
            if str(a.get_gid()).startswith(DECELERATION_GID)
        }
        assert drawn == {f"{DECELERATION_GID}:{s:g}": pytest.approx(v) for s, v in spans.items()}
    one = traces[:1]  # one trial: its own window, exactly
    (patch,) = [a for a in plots.plot_living_fast_trials(one).axes[0].patches if a.get_gid()]
    t0 = one[0]["window"][0]
    start, end = one[0]["deceleration"]
    assert (patch.get_x(), patch.get_x() + patch.get_width()) == (start - t0, end - t0)
    # a rigid condition's trials have no deceleration window: nothing hatched
    rigid = plots.plot_living_fast_trials(synthetic_traces())
    assert not [a for a in rigid.axes[0].patches if a.get_gid()]
    assert "hatched = deceleration windows" in fig._suptitle.get_text()


def test_report_figures_are_300_dpi_by_default(tmp_path, monkeypatch):
    from PIL import Image

    from inertiafit.report.figures import FigureRecord
    from inertiafit.report.outputs import draw_figures

    monkeypatch.delenv("INERTIAFIT_DPI", raising=False)  # the suite's own setting
    assert style.DEFAULT_DPI == 300
    record = FigureRecord("trials", functools.partial(plots.plot_inertia_by_speed,
                          synthetic_trials()), "Trials", "")  # fmt: skip
    draw_figures([record], tmp_path, ("png",), workers=1)
    with Image.open(tmp_path / "trials.png") as image:
        assert image.info["dpi"] == pytest.approx((300, 300), abs=0.01)
        assert image.width == round(300 * record.make().get_figwidth())


def test_identification_curve_panels_box_and_physics(posterior, baseline):
    pairs = (*plots.CURVE_PAIRS, ("com_distance", "radius_of_gyration"))
    fig = plots.plot_identification_curve(posterior, "attachment", baseline=baseline, pairs=pairs)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 3
    assert [ax.get_xlabel() for ax in axes] == [
        "mass $m$ [kg]",
        "mass $m$ [kg]",
        "CoM distance $x$ [m]",
    ]
    assert axes[0].get_ylabel() == r"radius of gyration $\rho$ [m]"
    # the prior box, exactly
    (box,) = [p for p in axes[1].patches if isinstance(p, Rectangle)]
    assert box.get_xy() == pytest.approx((1.455, 0.1125))
    assert (box.get_width(), box.get_height()) == pytest.approx((2.91, 0.225))
    # the thick curve is the identification curve at the posterior medians, inside the box
    g = G
    a = np.median(posterior.draws("attachment", "gravity_moment")) / g
    i = np.median(posterior.draws("attachment", "inertia"))
    (curve,) = [ln for ln in axes[0].get_lines() if ln.get_linewidth() > 1.2]
    m, rho = curve.get_xdata(), curve.get_ydata()
    (curve_x,) = [ln for ln in axes[1].get_lines() if ln.get_linewidth() > 1.2]
    x = curve_x.get_ydata()
    np.testing.assert_allclose(m * x, a, rtol=1e-12)
    np.testing.assert_allclose(m * (rho**2 + x**2), i, rtol=1e-9)
    assert m.min() >= 1.455 - 1e-12
    assert m.max() <= 4.365 + 1e-12
    # the bound m >= (M_g/g)^2 / I
    bound = [ln for ln in axes[0].get_lines() if ln.get_color() == style.PALETTE[2]]
    assert bound[0].get_xdata()[0] == pytest.approx(a**2 / i)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "paper baseline: feasible-region mean" in labels
    assert "prior box" in labels


def test_identification_curve_rejects_bad_input(posterior):
    with pytest.raises(ValueError, match="body"):
        plots.plot_identification_curve(posterior, "forearm")
    with pytest.raises(ValueError, match="pairs"):
        plots.plot_identification_curve(posterior, "weight", pairs=[("mass", "mass")])


def test_trace_and_rank_structure(posterior):
    fig = plots.plot_trace(posterior, "weight", parameters=("mass", "inertia"), max_walkers=5)
    assert len(fig.axes) == 4
    assert fig.axes[0].get_ylabel() == "$m$ [kg]"
    assert fig.axes[2].get_ylabel() == "$I$ [kg m$^2$]"
    assert len(fig.axes[0].get_lines()) == 5
    fig = plots.plot_rank(posterior, "weight", bins=10)
    assert len(fig.axes) == 3
    uniform = [ln for ln in fig.axes[0].get_lines() if ln.get_linestyle() == "--"]
    assert uniform[0].get_ydata()[0] == pytest.approx(0.1)
    with pytest.raises(ValueError, match="parameters"):
        plots.plot_rank(posterior, "weight", parameters=("density",))


def test_rank_groups_are_uniform_for_mixed_walkers_and_not_for_stuck_ones():
    rng = np.random.default_rng(3)
    mixed = rng.normal(size=(16, 500))
    n = mixed.size
    for ranks in plots.rank_groups(mixed, 4):
        counts, _ = np.histogram(ranks, bins=10, range=(0.5, n + 0.5))
        assert counts.max() / counts.mean() < 1.3
    # negative control: each group of walkers stuck in its own part of the posterior
    stuck = mixed + 10.0 * (np.arange(16)[:, None] // 4)
    first = plots.rank_groups(stuck, 4)[0]
    assert first.max() <= n / 4 + 1


def test_save_figure_writes_vector_and_raster(posterior, tmp_path):
    fig = plots.plot_rank(posterior, "attachment")
    paths = style.save_figure(fig, tmp_path / "rank", formats=("pdf", "png", "svg"), dpi=50)
    assert [p.suffix for p in paths] == [".pdf", ".png", ".svg"]
    assert paths[0].read_bytes().startswith(b"%PDF")
    assert paths[1].read_bytes().startswith(b"\x89PNG")
    assert b"<svg" in paths[2].read_bytes()[:500]
    again = style.save_figure(fig, tmp_path / "again", formats=("pdf",), dpi=50)
    assert again[0].read_bytes() == paths[0].read_bytes()  # no dates: same bytes
    with pytest.raises(ValueError, match="formats"):
        style.save_figure(fig, tmp_path / "x", formats=("jpg",))


def test_one_check_of_figure_formats(posterior, tmp_path):
    assert style.FIGURE_FORMATS == ("pdf", "png", "svg")
    assert style.check_formats([" PDF", "png", ""]) == ("pdf", "png")
    assert style.check_formats("svg,png") == ("svg", "png")
    message = r"^formats: expected a comma-separated subset of pdf,png,svg, got "
    for bad in (["jpg"], [], ["", " "], "pdf,gif"):
        with pytest.raises(InputError, match=message):
            style.check_formats(bad)
    with pytest.raises(InputError, match=r"^--formats: .* got 'png,gif'$"):
        style.check_formats(["png", "gif"], where="--formats")
    with pytest.raises(InputError, match=message):  # save_figure checks through it too
        style.save_figure(plots.plot_rank(posterior, "weight"), tmp_path / "x", formats=("gif",))
    assert not list(tmp_path.iterdir())


def test_save_figure_restores_the_layout_engine(posterior, tmp_path):
    # the first format's layout serves the others; the figure keeps its engine afterwards
    fig = plots.plot_rank(posterior, "attachment")
    engine = fig.get_layout_engine()
    assert engine is not None
    style.save_figure(fig, tmp_path / "rank", formats=("pdf", "png"), dpi=50)
    assert fig.get_layout_engine() is engine
    with pytest.raises(ValueError, match="formats"):
        style.save_figure(fig, tmp_path / "x", formats=("jpg",))
    assert fig.get_layout_engine() is engine


def test_draws_into_a_given_figure(posterior):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    assert plots.plot_trace(posterior, "weight", fig=fig) is fig
    assert isinstance(fig.axes[0].get_lines()[0], Line2D)


def test_identification_curve_title_says_what_the_table_says(posterior):
    table = posterior.identification().set_index(["body", "parameter"])["identified_by"]
    for body in posterior.bodies:
        title = plots.plot_identification_curve(posterior, body)._suptitle.get_text()
        said = curve_verdict(posterior, body)
        assert title.endswith(f"on the curve, {said}")
        for p, symbol in (("mass", "$m$"), ("com_distance", "$x$")):
            phrase = {
                "data": "the data pin",
                "data + prior": "data and prior box together set",
                "prior": "the prior box picks",
            }[table[(body, p)]]
            clause = next(c for c in said.split("; ") if symbol in c)
            assert clause.startswith(phrase), (body, p, said)


def test_fast_trial_legend_sits_beside_the_curves():
    fig = plots.plot_fast_trials(synthetic_traces(), title="A")
    fig.draw_without_rendering()  # the layout engine places the panels and the legend
    (legend,) = fig.legends
    box = legend.get_window_extent()
    for ax in fig.axes:
        assert box.x0 >= ax.get_window_extent().x1  # right of every panel: covers no curve


def test_corner_zooms_to_the_posterior_and_shades_the_prior_box(posterior):
    # the default: a pinned parameter fills its panel instead of one bin of the whole box
    fig = posterior.corner("weight")
    axes = np.asarray(fig.axes).reshape(5, 5)
    box = posterior.prior_box("weight")
    for i, p in enumerate(PARAMETERS):
        lo, hi = axes[-1, i].get_xlim() if i < 4 else axes[i, i].get_xlim()
        draws = posterior.draws("weight", p).ravel()
        q_lo, q_hi = np.quantile(draws, [0.001, 0.999])
        width = box[p][1] - box[p][0]
        # every draw but the extreme tails is in view, as far as the box allows
        assert lo <= max(q_lo, box[p][0] - 0.05 * width) + 1e-12
        assert hi >= min(q_hi, box[p][1] + 0.05 * width) - 1e-12
        assert lo >= box[p][0] - 0.05 * width - 1e-12
        assert hi <= box[p][1] + 0.05 * width + 1e-12
        shaded = [
            patch
            for patch in axes[i, i].patches
            if patch.get_facecolor()[:3] == pytest.approx(to_rgb(style.PRIOR_COLOUR))
        ]
        assert len(shaded) == 1, p  # the box as a band on its marginal
    m_lo, m_hi = axes[-1, 0].get_xlim()
    assert m_hi - m_lo < 0.25 * (box["mass"][1] - box["mass"][0])  # the weight's m is pinned
    spanned = posterior.corner("weight", prior_box=True)
    assert not [
        patch
        for patch in np.asarray(spanned.axes).reshape(5, 5)[0, 0].patches
        if patch.get_facecolor()[:3] == pytest.approx(to_rgb(style.PRIOR_COLOUR))
    ]
    joint = plots.plot_joint_corner(posterior)
    j_lo, j_hi = np.asarray(joint.axes).reshape(6, 6)[-1, 3].get_xlim()
    assert (j_lo, j_hi) == pytest.approx((m_lo, m_hi))


def test_the_dpi_variable_sets_the_resolution_and_a_bad_one_is_one_line(tmp_path, monkeypatch):
    """INERTIAFIT_DPI: unset or empty, 300; a number from 50 to 1200, that; anything else a
    one-line error naming the variable, which the command says before any work."""
    from inertiafit.cli import main
    from inertiafit.errors import InputError
    from inertiafit.plotting.style import figure_dpi

    monkeypatch.delenv("INERTIAFIT_DPI", raising=False)
    assert figure_dpi() == 300
    for text, value in (("", 300), (" 150 ", 150), ("72.5", 72.5)):
        monkeypatch.setenv("INERTIAFIT_DPI", text)
        assert figure_dpi() == value
    fig = plots.plot_inertia_by_speed(synthetic_trials())
    monkeypatch.setenv("INERTIAFIT_DPI", "80")
    (png,) = style.save_figure(fig, tmp_path / "at80", formats=("png",))
    from PIL import Image

    with Image.open(png) as image:
        assert image.info["dpi"] == pytest.approx((80, 80), abs=0.01)
    for bad in ("high", "10", "5000", "nan"):
        monkeypatch.setenv("INERTIAFIT_DPI", bad)
        with pytest.raises(InputError, match=r"^environment variable INERTIAFIT_DPI: expected "):
            figure_dpi()
    code = main(["run", str(tmp_path / "no-such-study.toml"), "--out", str(tmp_path / "o")])
    assert code == 2
    assert not (tmp_path / "o").exists()
