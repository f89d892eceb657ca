"""Closed-loop PID tuning with Optuna: how DEFAULT_PID was chosen (`python -m seagen.control.tune`)."""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from seagen.actuator import default_actuator
from seagen.control.experiment import (
    CONFIGS,
    DURATION_S,
    MLP_PRED_AVG,
    PAPER_TABLE2,
    metrics,
    runs,
    targets_n,
)
from seagen.runtime.pid import DEFAULT_PID_SI, PidParams

# The shipped choice (DEFAULT_PID, MLP_PRED_AVG) in the search's parameters: the first trial, as a baseline.
SHIPPED = {**DEFAULT_PID_SI, "pred_avg": MLP_PRED_AVG}

NEVER_S = DURATION_S  # an angle that never settles counts as the whole run


def mean_settling(name: str, pid: PidParams, pred_avg: int, seeds: tuple[int, ...]) -> dict[float, float]:
    """Per target: settling time of configuration `name` averaged over angles and seeds (NaN = the run)."""
    pred, ctl = CONFIGS[name](0.1)
    cfg = replace(ctl, pid=pid, pred_avg=pred_avg)
    out: dict[float, list[float]] = {t: [] for t in targets_n(default_actuator())}
    for seed in seeds:
        for target, rec in runs(pred, cfg, seed=seed):
            out[target].append(float(np.nan_to_num(metrics(rec)["settling_s"], nan=NEVER_S).mean()))
    return {t: float(np.mean(v)) for t, v in out.items()}


def objective(mlp: dict[float, float], sf: dict[float, float]) -> float:
    """Worst MLP-on-MCU target plus 0.3 x its mean, plus a penalty for SF outside +-50 % of the paper's."""
    paper = {float(t): s for t, (_, s) in PAPER_TABLE2["SF"].items()}
    pen = sum(max(0.0, sf[t] - 1.5 * paper[t]) + max(0.0, 0.5 * paper[t] - sf[t]) for t in paper)
    return max(mlp.values()) + 0.3 * float(np.mean(list(mlp.values()))) + 3.0 * pen


def tune(trials: int, seeds: tuple[int, ...], sampler_seed: int = 1):
    """Search gains, margin, output limit and the MLP prediction average; returns the Optuna study."""
    import optuna

    def trial_fn(trial: optuna.Trial) -> float:
        pid = PidParams.from_si(
            trial.suggest_float("kp_v_mm", 20, 40),
            trial.suggest_float("ki_v_mm_s", 2, 8),
            trial.suggest_float("kd_v_s_mm", 0.5, 1.2),
            trial.suggest_float("d_alpha", 0.5, 1.0),
            margin_mm=trial.suggest_float("margin_mm", 0.02, 0.05),
            limit_v=trial.suggest_float("limit_v", 6.0, 10.0, step=0.5),
        )
        mlp = mean_settling("mlp_mcu", pid, trial.suggest_int("pred_avg", 4, 10), seeds)
        sf = mean_settling("sf_mcu", pid, 1, seeds[:2])
        trial.set_user_attr("mlp_mcu", mlp)
        trial.set_user_attr("sf_mcu", sf)
        return objective(mlp, sf)

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=optuna.samplers.TPESampler(seed=sampler_seed))
    study.enqueue_trial(SHIPPED)
    study.optimize(trial_fn, n_trials=trials, show_progress_bar=True)
    return study


def main(argv: list[str] | None = None) -> int:
    """Run the search and print the best parameters with their settling times."""
    p = argparse.ArgumentParser(prog="python -m seagen.control.tune", description=__doc__)
    p.add_argument("--trials", type=int, default=40, help="Optuna trials (default 40, ~25 s each)")
    p.add_argument("--seeds", type=int, default=4, help="noise seeds per trial (default 4)")
    a = p.parse_args(argv)
    study = tune(a.trials, tuple(10 * k for k in range(a.seeds)))
    best = study.best_trial
    print("best:", {k: round(v, 4) for k, v in best.params.items()})
    for name in ("mlp_mcu", "sf_mcu"):
        print(f"settling s, {name}:", {f"{t:g} N": round(v, 3) for t, v in best.user_attrs[name].items()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
