"""PNG figures: the SF surface with the data (paper Fig. 13/15), validation predictions (Fig. 14/16)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from seagen.actuator import default_actuator
from seagen.fit.predict import TARGET, TASKS, UNIT, kinematics_predict, predict
from seagen.fit.sf import eval_sf
from seagen.geometry import Geometry
from seagen.plotting import figure, save_png

MAX_SCATTER = 3000
LABELS = {"angle_deg": "angle (deg)", "compression_mm": "compression (mm)", "force_n": "force (N)"}


def plot_surface(model: dict[str, Any], train: pd.DataFrame, path: Path, title: str) -> None:
    """The fitted surface over the observed input box, with (a sample of) the training rows."""
    a, b = model["sf"]["inputs"]
    out = model["output_name"]
    (alo, ahi), (blo, bhi) = model["input_range"]
    ga, gb = np.meshgrid(np.linspace(alo, ahi, 40), np.linspace(blo, bhi, 40))
    gz = eval_sf(model["sf"], ga.ravel(), gb.ravel()).reshape(ga.shape)
    rows = train.iloc[:: max(1, len(train) // MAX_SCATTER)]
    fig = figure(figsize=(7, 5), dpi=100)
    ax = fig.add_subplot(projection="3d")
    surf = ax.plot_surface(ga, gb, gz, cmap="viridis", alpha=0.6, linewidth=0)
    fig.colorbar(surf, ax=ax, shrink=0.6, pad=0.1, label=f"fitted {LABELS.get(out, out)}")
    ax.scatter(rows[a], rows[b], rows[out], s=2, c="k", alpha=0.4, label="training data")
    ax.set_xlabel(LABELS.get(a, a))
    ax.set_ylabel(LABELS.get(b, b))
    ax.set_zlabel(LABELS.get(out, out))
    ax.set_title(title)
    ax.legend(loc="upper left")
    save_png(fig, path, bbox_inches="tight")


def plot_validation(
    task: str, named: dict[str, dict[str, Any]], val: pd.DataFrame, path: Path, geo: Geometry | None = None
) -> None:
    """Measured vs predicted output per validation sample: kinematics (of the actuator `geo`, the paper's
    when None) and every model of the task."""
    fig = figure(figsize=(7, 5), dpi=100)
    ax = fig.add_subplot()
    x = validation_time(val, (geo.actuator if geo else default_actuator()).loop_hz)
    ax.plot(x, val[TARGET[task]], "k-", lw=2, label="measured")
    ax.plot(x, kinematics_predict(task, val, geo), ":", label="kinematics")
    for name, m in named.items():
        ax.plot(x, predict(m, val), "--", label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"{TARGET[task]} ({UNIT[task]})")
    angle = float(val["angle_set_deg"].iloc[0])
    kind = "force calibration" if task == "calibration" else "compression prediction"
    ax.set_title(f"{kind} on the validation set ({angle:.2f} deg contact)")
    ax.grid(alpha=0.3)
    ax.legend()
    save_png(fig, path, bbox_inches="tight")


def validation_time(val: pd.DataFrame, loop_hz: float | None = None) -> np.ndarray:
    """Seconds along the validation set: its t_s, continued across trials, else the sample index at the
    control-loop rate `loop_hz` (the paper's actuator's when None)."""
    period = 1.0 / (loop_hz or default_actuator().loop_hz)
    if "t_s" not in val.columns:
        return np.arange(len(val)) * period
    t = val["t_s"].to_numpy(dtype=float)
    step = np.diff(t, prepend=t[0])
    step[step < 0] = period  # a new trial restarts its clock: keep the axis running
    return t[0] + np.cumsum(step) if len(t) else t


def write_plots(
    named: dict[str, dict[str, Any]],
    frames: dict[str, pd.DataFrame],
    out_dir: str | os.PathLike[str],
    geo: Geometry | None = None,
) -> list[Path]:
    """All figures for the named models; returns the files written."""
    out = Path(out_dir)
    written: list[Path] = []
    for name, m in named.items():
        if m["kind"] == "sf" and "train" in frames:
            path = out / f"{name}_surface.png"
            plot_surface(m, frames["train"], path, f"{name}: 3rd-order surface fit ({m.get('loss', '?')})")
            written.append(path)
    for task in TASKS:
        of_task = {n: m for n, m in named.items() if m["task"] == task}
        if of_task and "validation" in frames:
            path = out / f"validation_{task}.png"
            plot_validation(task, of_task, frames["validation"], path, geo)
            written.append(path)
    return written
