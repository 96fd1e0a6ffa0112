"""The report's fits of each trial (issue 34 item 3): every fast trial's tau-alpha line, every
rigid sweep's gravity model with its residuals. Numbers read back from the drawn artists."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from inertiafit.pipeline.redraw import load_result
from inertiafit.processing.study import usable_trials
from inertiafit.report.figures import figure_records


@pytest.fixture(scope="module")
def study(study_out):
    return load_result(study_out)


def _records(result, prefix):
    return [r for r in figure_records(result) if r.stem.startswith(prefix)]


def test_tau_alpha_lines_have_each_trials_inertia_as_slope(study, study_out):
    trials = usable_trials(pd.read_csv(study_out / "trials.csv"))
    records = _records(study, "tau-alpha-")
    assert [r.stem for r in records] == ["tau-alpha-attachment", "tau-alpha-attachment+weight"]
    for record in records:
        assert record.section == "Trials"
        assert (study_out / f"{record.stem}.png").is_file()  # saved by `run`
        cond = record.stem.removeprefix("tau-alpha-")
        fast = trials[(trials["kind"] == "fast") & (trials["condition"] == cond)]
        fig = record.make()
        panels = [ax for ax in fig.axes if ax.get_visible()]
        assert len(panels) == fast["speed"].nunique() == 2  # a panel per speed
        lines = {}
        for ax in panels:
            for line in ax.get_lines():
                lines[line.get_gid(), line.get_label()] = (ax, line)
        assert len({gid for gid, _ in lines}) == len(fast) == 6  # every trial drawn
        for k, (_, row) in enumerate(fast.iterrows()):
            ax, line = lines[f"trial-{k}", "I alpha"]
            assert ax.get_title().startswith(f"{row['speed']:g} °/s")  # in its speed's panel
            x, y = (np.asarray(v, float) for v in line.get_data())
            assert x[0] <= 0 < x[-1]
            slope = (y[-1] - y[0]) / (x[-1] - x[0])
            np.testing.assert_allclose(slope, row["inertia"], rtol=1e-12)
            np.testing.assert_allclose(y, row["inertia"] * x, rtol=1e-12, atol=1e-12)
            # the filled dots are the window's samples the inertia was fitted to: their own
            # least squares through the origin gives it back (decimated to the trace's
            # points, so not to the last digit)
            _, dots = lines[f"trial-{k}", "acceleration window"]
            a, tau = (np.asarray(v, float) for v in dots.get_data())
            assert a.size > 30
            np.testing.assert_allclose((a @ tau) / (a @ a), row["inertia"], rtol=2e-3)
            assert a.min() > 0  # the acceleration window, moves plotted as positive
        plt.close(fig)


def test_tau_alpha_needs_the_stored_torque(study):
    """A traces.csv written before the fitted torque was stored draws no tau-alpha figure."""
    import dataclasses

    old = dataclasses.replace(study, traces=study.traces.assign(inertial_torque=np.nan))
    assert not _records(old, "tau-alpha-")
    assert _records(old, "fast-trials-")


def test_gravity_fit_residuals_are_data_less_the_fitted_model(study, study_out):
    (record,) = _records(study, "gravity-fit")
    assert record.section == "Trials"
    assert (study_out / "gravity-fit.png").is_file()
    trials = pd.read_csv(study_out / "trials.csv").set_index("file")
    sweeps = pd.read_csv(study_out / "sweeps.csv")
    files = list(dict.fromkeys(sweeps["file"]))
    assert files == list(trials.index[trials["kind"] == "quasi-static"])
    fig = record.make()
    top, bottom = fig.axes
    dots = [line for line in top.get_lines() if line.get_linestyle() == "None"]
    fits = [line for line in top.get_lines() if line.get_linestyle() == "-"]
    residuals = [line for line in bottom.get_lines() if line.get_linestyle() == "None"]
    assert len(dots) == len(fits) == len(residuals) == len(files) == 2
    for file, dot, fit, res in zip(files, dots, fits, residuals, strict=True):
        row = trials.loc[file]
        theta = np.radians(np.asarray(dot.get_xdata(), float))
        torque = np.asarray(dot.get_ydata(), float)
        sweep = sweeps[sweeps["file"] == file]
        np.testing.assert_allclose(torque, sweep["torque"], rtol=1e-12)
        np.testing.assert_allclose(theta, sweep["angle"], rtol=1e-12, atol=1e-12)
        model = row["gravity_moment"] * np.sin(theta + row["gravity_phase"]) + row["offset"]
        np.testing.assert_allclose(res.get_ydata(), torque - model, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(np.radians(res.get_xdata()), theta, rtol=1e-12)
        # the line is the same model, and the residuals are of noise size, centred on zero
        x_fit = np.radians(np.asarray(fit.get_xdata(), float))
        model_fit = row["gravity_moment"] * np.sin(x_fit + row["gravity_phase"]) + row["offset"]
        np.testing.assert_allclose(fit.get_ydata(), model_fit, rtol=1e-12)
        r = torque - model
        assert abs(r.mean()) < 0.01 * row["gravity_moment"]
        assert np.sqrt(np.mean(r**2)) <= row["residual_rms"]  # block means average noise
    plt.close(fig)
