"""Closed-loop PID tuning with Optuna: how DEFAULT_PID was chosen (`python -m seagen.control.tune`), and the
gains of another described actuator (`--actuator FILE`: the model-free kin_mcu on its simulated plant)."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

import numpy as np

from seagen.actuator import Actuator, default_actuator, is_default, load_actuator
from seagen.control.experiment import (
    CONFIGS,
    DURATION_S,
    MLP_PRED_AVG,
    PAPER_TABLE2,
    metrics,
    model_free_setups,
    runs,
    targets_n,
)
from seagen.errors import UserError
from seagen.plant import PlantConfig
from seagen.runtime.actq import act_q
from seagen.runtime.pid import DEFAULT_PID_SI, MOTOR_MAX_MV, TICK_S, PidParams, pid_si

# The shipped choice (DEFAULT_PID, MLP_PRED_AVG) in the search's parameters: the first trial, as a baseline.
SHIPPED = {**DEFAULT_PID_SI, "pred_avg": MLP_PRED_AVG}

NEVER_S = DURATION_S  # an angle that never settles counts as the whole run
# Another actuator's search: each gain and the margin within these factors of its description's own value
# (log scale), the derivative filter and the command limit (share of its supply) within these bounds.
SCALE = (0.5, 2.0)
D_ALPHA = (0.5, 1.0)
LIMIT_SHARE = (0.3, 1.0)


def mean_settling(
    name: str,
    pid: PidParams,
    pred_avg: int,
    seeds: tuple[int, ...],
    act: Actuator | None = None,
    metric: str = "settling_s",
) -> dict[float, float]:
    """Per target: settling time (`metric` of experiment.metrics) of configuration `name` averaged over
    angles and seeds (NaN = the run), on the plant of `act` (the paper's when None; then `name` may be a
    shipped model's configuration)."""
    setups = CONFIGS if act is None else model_free_setups(act)
    plant = None if act is None else PlantConfig(actuator=act)
    pred, ctl = setups[name](0.1)
    cfg = replace(ctl, pid=pid, pred_avg=pred_avg)
    out: dict[float, list[float]] = {t: [] for t in targets_n(act or default_actuator())}
    for seed in seeds:
        for target, rec in runs(pred, cfg, seed=seed, plant_cfg=plant):
            out[target].append(float(np.nan_to_num(metrics(rec)[metric], nan=NEVER_S).mean()))
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
            max_mv=MOTOR_MAX_MV,
            tick_s=TICK_S,
        )
        mlp = mean_settling("mlp_mcu", pid, trial.suggest_int("pred_avg", 4, 10), seeds)
        sf = mean_settling("sf_mcu", pid, 1, seeds[:2])
        trial.set_user_attr("mlp_mcu", mlp)
        trial.set_user_attr("sf_mcu", sf)
        return objective(mlp, sf)

    return _study(trial_fn, SHIPPED, trials, sampler_seed)


def tune_actuator(act: Actuator, trials: int, seeds: tuple[int, ...], sampler_seed: int = 1):
    """Search the PID of another actuator: kin_mcu on its plant, its targets, each setting near its
    description's (SCALE, D_ALPHA, LIMIT_SHARE of its supply; a setting of 0 stays 0); worst target plus
    0.3 x the mean of the settling time to the force's own final level (the loop's speed: kin_mcu's
    estimate is biased, so it need not reach the target band). The first trial is the description's own
    setting (limit capped at the supply)."""
    import optuna

    aq, supply = act_q(act), act.motor.supply_v
    own = {**pid_si(act.control), "limit_v": min(act.control.limit_v, supply)}
    ranges = {k: (SCALE[0] * v, SCALE[1] * v) for k, v in own.items() if k not in ("d_alpha", "limit_v")}
    ranges["d_alpha"] = (min(D_ALPHA[0], own["d_alpha"]), D_ALPHA[1])
    ranges["limit_v"] = (min(LIMIT_SHARE[0] * supply, own["limit_v"]), LIMIT_SHARE[1] * supply)
    searched = [k for k, (lo, hi) in ranges.items() if hi > 0]

    def trial_fn(trial: optuna.Trial) -> float:
        si = dict(own)
        for k in searched:
            si[k] = trial.suggest_float(k, *ranges[k], log=k not in ("d_alpha", "limit_v"))
        pid = PidParams.from_si(**si, max_mv=aq.motor_max_mv, tick_s=1.0 / aq.loop_hz)
        kin = mean_settling("kin_mcu", pid, 1, seeds, act, "settling_final_s")
        trial.set_user_attr("kin_mcu", kin)
        return max(kin.values()) + 0.3 * float(np.mean(list(kin.values())))

    return _study(trial_fn, {k: own[k] for k in searched}, trials, sampler_seed)


def _study(trial_fn, first: dict, trials: int, sampler_seed: int):
    """An Optuna study of `trials` trials, `first` as its first (the baseline)."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=optuna.samplers.TPESampler(seed=sampler_seed))
    study.enqueue_trial(first)
    study.optimize(trial_fn, n_trials=trials, show_progress_bar=True)
    return study


# The study's parameter names -> the description's [control] fields.
CONTROL_FIELDS = {
    "kp_v_mm": "kp_v_per_mm",
    "ki_v_mm_s": "ki_v_per_mm_s",
    "kd_v_s_mm": "kd_v_s_per_mm",
    "d_alpha": "d_alpha",
    "margin_mm": "margin_mm",
    "limit_v": "limit_v",
}


def main(argv: list[str] | None = None) -> int:
    """Run the search and print the best parameters with their settling times."""
    p = argparse.ArgumentParser(prog="python -m seagen.control.tune", description=__doc__)
    p.add_argument("--trials", type=int, default=40, help="Optuna trials (default 40, ~25 s each)")
    p.add_argument("--seeds", type=int, default=4, help="noise seeds per trial (default 4)")
    p.add_argument("--actuator", metavar="FILE", help="tune the PID of this actuator description instead")
    a = p.parse_args(argv)
    seeds = tuple(10 * k for k in range(a.seeds))
    try:
        act = None if a.actuator is None else load_actuator(a.actuator)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if act is not None and not is_default(act):
        best = tune_actuator(act, a.trials, seeds).best_trial
        kin = {f"{t:g} N": round(v, 3) for t, v in best.user_attrs["kin_mcu"].items()}
        print("kin_mcu's settling time to its final force, s:", kin)
        print(f"[control] of {a.actuator}, tuned:")
        for k, v in best.params.items():
            print(f"{CONTROL_FIELDS[k]} = {v:.4g}")
        return 0
    best = tune(a.trials, seeds).best_trial
    print("best:", {k: round(v, 4) for k, v in best.params.items()})
    for name in ("mlp_mcu", "sf_mcu"):
        print(f"settling s, {name}:", {f"{t:g} N": round(v, 3) for t, v in best.user_attrs[name].items()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
