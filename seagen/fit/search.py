"""Optuna search over MLP structure x loss x learning rate (x control input weights), shareable."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import pandas as pd

from seagen.errors import UserError
from seagen.fit.mlp import CONTROL_FEATURES, MlpConfig, fit_mlp, predict_mlp
from seagen.fit.predict import task_errors

STRUCTURES: dict[str, tuple[int, ...]] = {
    "8-16": (8, 16),
    "16-32": (16, 32),
    "8-16-32": (8, 16, 32),
    "16-32-16": (16, 32, 16),
    "32-32": (32, 32),
}
LOSSES = ("mse", "mae")
# Control input weights are tuned per group (paper §VI-C): desired force, angle (pot), speeds, accelerations.
WEIGHT_GROUPS = {"w_force": ("force_n",), "w_pot": ("pot",), "w_speed": ("d_",), "w_accel": ("dd_",)}
WEIGHT_RANGE = (0.25, 4.0)


def weights_from_groups(groups: dict[str, float]) -> tuple[float, ...]:
    """Per-input weights of the control predictor from the four group weights."""
    out = []
    for name in CONTROL_FEATURES:
        if name in ("force_n", "pot"):
            out.append(groups["w_force" if name == "force_n" else "w_pot"])
        else:
            out.append(groups["w_accel" if name.startswith("dd_") else "w_speed"])
    return tuple(out)


def config_from_params(params: dict[str, Any], task: str, base: MlpConfig) -> MlpConfig:
    """An MlpConfig from a trial's (or the best) parameters."""
    cfg = replace(base, hidden=STRUCTURES[params["structure"]], loss=params["loss"], lr=params["lr"])
    if task == "control":
        cfg = replace(cfg, weights=weights_from_groups({k: params[k] for k in WEIGHT_GROUPS}))
    return cfg


def suggest(trial: Any, task: str, losses: Sequence[str]) -> dict[str, Any]:
    """Draw one trial's parameters."""
    params: dict[str, Any] = {
        "structure": trial.suggest_categorical("structure", list(STRUCTURES)),
        "loss": trial.suggest_categorical("loss", list(losses)),
        "lr": trial.suggest_float("lr", 1e-3, 1e-2, log=True),
    }
    if task == "control":
        for key in WEIGHT_GROUPS:
            params[key] = trial.suggest_float(key, *WEIGHT_RANGE, log=True)
    return params


def holdout_score(train_df: pd.DataFrame, task: str, cfg: MlpConfig, threshold_n: float) -> float:
    """Train with `cfg`; the paper-style average error (%, rows above threshold_n) on the held-out training
    trials."""
    module, spec, info = fit_mlp(train_df, task, cfg)
    held = train_df[info["holdout_mask"]]
    return task_errors(task, predict_mlp(module, spec, held), held, threshold_n)["error_avg_pct"]


def search(
    train_df: pd.DataFrame,
    task: str,
    trials: int,
    base: MlpConfig,
    losses: Sequence[str] = LOSSES,
    storage: str | None = None,
    study_name: str | None = None,
    progress: bool = True,
    *,
    threshold_n: float,
) -> tuple[MlpConfig, Any]:
    """Run `trials` more trials (seeded TPE); return the best config of the whole study, and the study.
    Trials are scored on the held-out training trials' rows above `threshold_n` (kinematics.error_threshold_n
    of the data's actuator)."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    name = study_name or f"seagen-{task}-mlp-seed{base.seed}"
    try:
        study = optuna.create_study(
            study_name=name,
            storage=storage,
            load_if_exists=True,
            direction="minimize",
            sampler=optuna.samplers.TPESampler(seed=base.seed),
        )
    except Exception as e:  # optuna / sqlalchemy raise many types for a bad URL or database
        raise UserError(f"--storage {storage!r}: cannot open the study: {e}") from None

    def objective(trial: Any) -> float:
        cfg = config_from_params(suggest(trial, task, losses), task, base)
        return holdout_score(train_df, task, cfg, threshold_n)

    study.optimize(objective, n_trials=trials, show_progress_bar=progress)
    return config_from_params(study.best_params, task, base), study
