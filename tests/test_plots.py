"""Plots a controls engineer reads: the settling band and labelled targets on step responses, time in
seconds on the validation plot, a colour bar on the surface, "no data" grey (not zero-white) on residual
maps. The figures are inspected before they are written."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from seagen.plotting import figure, masked_cmap


def fake_results(targets=(5.0, 10.0), n=300, angles=3, estimate=False) -> dict[str, dict]:
    """Traces shaped like seagen.control.experiment's (ticks x angles), rising to each target."""
    t = np.tile(np.arange(n)[:, None] * 0.01, (1, angles))
    out = {}
    for target in targets:
        rec = {"t_s": t, "force_n": target * (1 - np.exp(-t / 0.3))}
        rec["contact_deg"] = np.tile(np.linspace(8.0, 24.0, angles), (n, 1))  # the run's angles
        if estimate:
            rec["estimate_n"] = rec["force_n"] + 0.1
        out[f"{target:g}"] = {"trace": rec}
    return out


def test_step_figure_has_band_labelled_targets_and_estimate():
    """One shaded band per target, a 'target N' label per target, a legend entry naming the band, and the
    calibration model's estimate when the runs carry one."""
    from matplotlib.patches import Patch, Polygon, Rectangle

    from seagen.control.plots import step_figure

    fig = step_figure("mine_mcu", fake_results(estimate=True))
    ax = fig.axes[0]
    bands = [p for p in ax.patches if isinstance(p, Polygon | Rectangle)]
    assert len(bands) == 2
    labels = {t.get_text() for t in ax.texts}
    assert {"target 5 N", "target 10 N"} <= labels
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "settling band (target ± 0.3 N)" in legend
    assert "calibration model, 10 N target" in legend
    assert any(isinstance(h, Patch) for h in ax.get_legend().legend_handles)
    assert ax.get_xlabel() == "time (s)"
    assert ax.get_title() == "mine_mcu: contact at 24 deg"  # the plotted run's own angle (index 2)


def test_validation_axis_is_seconds(tmp_path, monkeypatch):
    """The validation plot's x axis is time in seconds, running on across trials."""
    from seagen.fit import plots

    val = pd.DataFrame({"t_s": np.r_[np.arange(50) * 0.01, np.arange(30) * 0.01]})
    t = plots.validation_time(val)
    assert t[0] == 0.0 and np.all(np.diff(t) > 0) and t[-1] == pytest.approx(0.79)
    assert plots.validation_time(pd.DataFrame({"x": range(5)}))[-1] == pytest.approx(0.04)
    seen = {}
    monkeypatch.setattr(plots, "save_png", lambda fig, path, **kw: seen.setdefault("fig", fig))
    monkeypatch.setattr(plots, "kinematics_predict", lambda task, v, geo=None: np.zeros(len(v)))
    monkeypatch.setattr(plots, "predict", lambda m, v: np.ones(len(v)))
    frame = val.assign(force_n=1.0, angle_set_deg=12.0)
    plots.plot_validation("calibration", {"m": {}}, frame, tmp_path / "v.png")
    ax = seen["fig"].axes[0]
    assert ax.get_xlabel() == "time (s)" and ax.lines[0].get_xdata()[-1] == pytest.approx(0.79)


def test_surface_plot_has_a_colour_bar(tmp_path, monkeypatch):
    """The SF surface figure carries a colour bar labelled with the fitted output."""
    from seagen.defaults import default_model
    from seagen.fit import plots
    from seagen.modelfile import load_model

    model = load_model(default_model("sf_calibration"))
    a, b = model["sf"]["inputs"]
    train = pd.DataFrame({a: [10.0, 20.0], b: [1.0, 2.0], model["output_name"]: [3.0, 9.0]})
    seen = {}
    monkeypatch.setattr(plots, "save_png", lambda fig, path, **kw: seen.setdefault("fig", fig))
    plots.plot_surface(model, train, tmp_path / "s.png", "sf")
    bars = [ax for ax in seen["fig"].axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 1 and "force" in bars[0].get_ylabel()


def test_no_data_is_grey_not_the_colour_of_zero():
    """Masked cells draw in the 'bad' colour (grey), which differs from the colour of a zero residual."""
    cmap = masked_cmap("RdBu_r")
    fig = figure()
    ax = fig.add_subplot()
    cells = np.ma.masked_invalid(np.array([[0.0, np.nan]]))
    mesh = ax.pcolormesh(cells, cmap=cmap, vmin=-3, vmax=3)
    rgba = mesh.to_rgba(mesh.get_array()).reshape(-1, 4)
    assert tuple(rgba[0]) == pytest.approx(cmap(0.5)) and tuple(rgba[1]) == pytest.approx(cmap.get_bad())
    assert not np.allclose(cmap(0.5), cmap.get_bad())
