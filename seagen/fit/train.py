"""`train`: fit one SF or MLP model on a data directory and write the model file; `train_defaults`."""

from __future__ import annotations

import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from seagen import __version__
from seagen.actuator import Actuator
from seagen.data.features import derive
from seagen.data.schema import SPLITS, data_actuator, load_split
from seagen.errors import UserError
from seagen.fit.kinematics import ERROR_SHARE, error_threshold_n
from seagen.fit.mlp import MLP_OUTPUT, RAW_SIGNALS, MlpConfig, fit_mlp, holdout_mask, unit_of
from seagen.fit.predict import TASKS, predict, task_errors
from seagen.fit.sf import SF_INPUTS, SF_OUTPUT, fit_sf
from seagen.geometry import geometry
from seagen.modelfile import FeatureSpec, save_model

KINDS = ("sf", "mlp")
DEFAULT_HIDDEN = {"calibration": (16, 32), "control": (8, 16)}  # paper Tables I and III
LOSS_CHOICES = ("mse", "mae", "any")  # "any": the search picks the loss (needs trials > 0)
# The four default models (paper's choices: SF with MAE, MLP with MSE; structures of Tables I and III).
DEFAULTS: dict[str, dict[str, Any]] = {
    "sf_calibration": {"model": "sf", "loss": "mae", "task": "calibration"},
    "mlp_calibration": {"model": "mlp", "loss": "mse", "task": "calibration", "hidden": (16, 32)},
    "sf_control": {"model": "sf", "loss": "mae", "task": "control"},
    "mlp_control": {"model": "mlp", "loss": "mse", "task": "control", "hidden": (8, 16)},
}


def load_derived(
    data_dir: str | os.PathLike[str], need: tuple[str, ...] = ("train",), actuator: Actuator | None = None
) -> dict[str, pd.DataFrame]:
    """Derived frames of every split present, with the geometry of the folder's actuator (data_actuator;
    a disagreeing `actuator` is refused); the splits in `need` must exist."""
    d = Path(data_dir)
    if not d.is_dir():
        raise UserError(f"{d}: no such data directory")
    for s in need:
        if not (d / f"{s}.csv").is_file():
            raise UserError(f"{d / (s + '.csv')}: no such file (run `seagen data generate --out {d}`)")
    geo = geometry(data_actuator(d, actuator))
    return {s: derive(load_split(d, s), geo) for s in SPLITS if (d / f"{s}.csv").is_file()}


def check_scorable(
    data_dir: str | os.PathLike[str], frames: dict[str, pd.DataFrame], act: Actuator, held: Any = None
) -> None:
    """Refuse (exit 2) data whose paper-style errors would be empty: no row above the error threshold in a
    scored split (test, validation) or, for a search (`held`: its hold-out mask), in the held-out trials."""
    threshold = error_threshold_n(act)
    parts = {f"{s}.csv": df for s, df in frames.items() if s != "train"}
    if held is not None:
        parts["train.csv (the search's held-out trials)"] = frames["train"][held]
    for name, df in parts.items():
        force = df["force_n"].to_numpy(dtype=float)
        if not (force > threshold).any():
            peak = f"{force.max():.3g} N" if len(force) else "no rows"
            raise UserError(
                f"{Path(data_dir) / name}: no row with force_n above {threshold:g} N ({ERROR_SHARE:.0%} of "
                f"control.force_max_n {act.control.force_max_n:g} N; the rows peak at {peak}), so its "
                "paper-style errors would be empty: the data do not cover the force range (see `seagen data "
                "summary`); nothing trained"
            )


def _check_args(model: str, loss: str, task: str, hidden: tuple[int, ...] | None, trials: int) -> None:
    """Reject bad option values with the option named."""
    options = (("--model", model, KINDS), ("--loss", loss, LOSS_CHOICES), ("--task", task, TASKS))
    for opt, val, choices in options:
        if val not in choices:
            raise UserError(f"{opt} {val!r}: choose one of {', '.join(choices)}")
    if hidden is not None and (not hidden or any(h < 1 for h in hidden)):
        raise UserError(f"--hidden {hidden!r}: need one or more positive layer sizes")
    if trials < 0:
        raise UserError(f"--trials {trials}: must be >= 0")
    if loss == "any" and (model != "mlp" or trials == 0):
        raise UserError("--loss any: only for --model mlp with --trials N > 0 (the search picks the loss)")


def _ranges(df: pd.DataFrame, inputs: tuple[str, ...], output: str) -> tuple[list[list[float]], list[float]]:
    """Observed raw input ranges and output range on the training rows."""
    x = df[list(inputs)].to_numpy(dtype=float)
    y = df[output].to_numpy(dtype=float)
    return [[float(lo), float(hi)] for lo, hi in zip(x.min(0), x.max(0), strict=True)], [
        float(y.min()),
        float(y.max()),
    ]


def _fit_sf_model(train_df: pd.DataFrame, task: str, loss: str) -> dict[str, Any]:
    """Model-dict body of an SF model (raw inputs; the feature spec carries no normalization)."""
    a, b = SF_INPUTS[task]
    sf = fit_sf(train_df[a].to_numpy(), train_df[b].to_numpy(), train_df[SF_OUTPUT[task]].to_numpy(), loss)
    spec = FeatureSpec(
        inputs=(a, b),
        mean=(0.0, 0.0),
        std=(1.0, 1.0),
        raw=RAW_SIGNALS[task],
        extra={"note": "SF evaluates the polynomial on raw inputs; mean/std unused"},
    )
    return {"sf": {"inputs": [a, b], **sf}, "features": spec.to_dict(), "output_name": SF_OUTPUT[task]}


def _fit_mlp_model(
    train_df: pd.DataFrame, task: str, cfg: MlpConfig, search: dict[str, Any]
) -> dict[str, Any]:
    """Model-dict body of an MLP model, optionally after an Optuna search that picks the config."""
    extra: dict[str, Any] = {}
    if search["trials"] > 0:
        from seagen.fit.search import LOSSES
        from seagen.fit.search import search as run_search

        losses = LOSSES if cfg.loss == "any" else (cfg.loss,)
        cfg, study = run_search(
            train_df,
            task,
            search["trials"],
            cfg,
            losses,
            search.get("storage"),
            search.get("study_name"),
            threshold_n=search["threshold_n"],
        )
        extra["search"] = {"study": study.study_name, "trials": len(study.trials), "best": study.best_params}
    module, spec, info = fit_mlp(train_df, task, cfg)
    return {
        "module": module,
        "features": spec.to_dict(),
        "output_name": MLP_OUTPUT[task],
        "hidden": list(cfg.hidden),
        "loss": cfg.loss,
        "activation": cfg.activation,
        "lr": cfg.lr,
        "epochs": info["epochs"],
        **extra,
    }


def train(
    data_dir: str | os.PathLike[str],
    model: str = "mlp",
    loss: str = "mse",
    task: str = "calibration",
    hidden: tuple[int, ...] | None = None,
    trials: int = 0,
    seed: int = 0,
    out: str | os.PathLike[str] | None = None,
    actuator: Actuator | None = None,
    **options: Any,
) -> dict[str, Any]:
    """Fit one model, add ranges, units and metrics (test and validation), save it atomically to `out`.

    The actuator is the data folder's (data_actuator; an `actuator` that disagrees is refused); the model
    file records it (Actuator.record()) and its feature spec runs at its control-loop rate.
    options: storage, study_name (search); activation, lr, epochs, weights (MLP config).
    """
    _check_args(model, loss, task, hidden, trials)
    frames = load_derived(data_dir, actuator=actuator)
    act = data_actuator(data_dir, actuator)
    tr, threshold = frames["train"], error_threshold_n(act)
    held = holdout_mask(tr, MlpConfig.holdout, seed) if model == "mlp" and trials else None
    check_scorable(data_dir, frames, act, held)
    t0 = time.perf_counter()
    if model == "sf":
        body = _fit_sf_model(tr, task, loss)
        body["loss"] = loss
    else:
        keys = ("activation", "lr", "epochs", "weights")
        fields = {k: options[k] for k in keys if options.get(k) is not None}
        cfg = replace(MlpConfig(seed=seed, loss=loss), hidden=hidden or DEFAULT_HIDDEN[task], **fields)
        search = {"trials": trials, **{k: options.get(k) for k in ("storage", "study_name")}}
        search["threshold_n"] = threshold
        body = _fit_mlp_model(tr, task, cfg, search)
    body["features"]["sample_rate_hz"] = act.loop_hz
    inputs = tuple(body["features"]["inputs"])
    obj: dict[str, Any] = {"kind": model, "task": task, **body, "seed": seed, "actuator": act.record()}
    obj["input_units"] = [unit_of(n) for n in inputs]
    obj["output_units"] = "N" if task == "calibration" else "mm"
    obj["input_range"], obj["output_range"] = _ranges(tr, inputs, obj["output_name"])
    obj["train_seconds"] = time.perf_counter() - t0
    obj["seagen_version"] = __version__
    scored = [s for s in frames if s != "train"]
    obj["metrics"] = {s: task_errors(task, predict(obj, frames[s]), frames[s], threshold) for s in scored}
    for s, m in obj["metrics"].items():
        if not all(np.isfinite(v) for v in m.values()):
            raise UserError(
                f"{Path(data_dir) / s}.csv: the model's errors there are not finite ({m}); nothing written"
            )
    if out is not None:
        save_model(obj, out)
    return obj


def train_defaults(
    data_dir: str | os.PathLike[str], out_dir: str | os.PathLike[str], seed: int = 0
) -> dict[str, Path]:
    """Train the four default models (SF/MLP x calibration/control) into out_dir; returns name -> path."""
    out = Path(out_dir)
    paths: dict[str, Path] = {}
    for name, kw in DEFAULTS.items():
        paths[name] = out / f"{name}.pt"
        train(data_dir, seed=seed, out=paths[name], **kw)
    return paths


def metrics_summary(obj: dict[str, Any]) -> str:
    """One line of a trained model's test/validation average errors."""
    unit = obj["output_units"]
    parts = []
    for split, m in obj["metrics"].items():
        avg = m["error_avg_mm"] if unit == "mm" else m["error_avg_n"]
        pct = f"{m['error_avg_pct']:.2f} % avg, {m['error_max_pct']:.2f} % max"
        parts.append(f"{split}: {avg:.3f} {unit} / {pct}")
    return "; ".join(parts) if parts else "no test/validation split to score"
