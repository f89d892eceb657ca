"""Closed-loop PID tuning with Optuna: the shipped gains' search, and gains for your design (seagen tune)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from decimal import ROUND_FLOOR, Decimal
from typing import Any

import numpy as np

from seagen.actuator import Actuator, default_actuator, is_default
from seagen.control.experiment import (
    BAND_N,
    DURATION_S,
    PAPER_TABLE2,
    Setup,
    Setups,
    duration_s,
    metrics,
    runs,
    targets_n,
)
from seagen.data.protocol import PUSH_MOVES, force_scale, scaled_move, volts_scale
from seagen.plant import PlantConfig
from seagen.plant.config import Motor
from seagen.runtime.actq import ActQ, act_q_of
from seagen.runtime.control import MLP_PRED_AVG
from seagen.runtime.pid import DEFAULT_PID_SI, SI_FIELDS, PidParams, gain_max_si, pid_si

# The shipped choice (DEFAULT_PID, MLP_PRED_AVG) in the search's parameters: the first trial, as a baseline.
SHIPPED = {**DEFAULT_PID_SI, "pred_avg": MLP_PRED_AVG}

NEVER_S = DURATION_S  # an angle that never settles counts as the whole run

# The search's ranges on the paper's actuator (PidParams.from_si's arguments); search_space carries them.
PAPER_SPACE = {
    "kp_v_mm": (20.0, 40.0),
    "ki_v_mm_s": (2.0, 8.0),
    "kd_v_s_mm": (0.5, 1.2),
    "d_alpha": (0.5, 1.0),
    "margin_mm": (0.02, 0.05),
    "limit_v": (6.0, 10.0),
}
# The margin's top as a force on the spring: the paper's 0.05 mm on its 4.2 N/mm, 0.21 N, 70 % of the
# settling band (experiment.BAND_N): a dead band wider than the band stops the loop outside it.
MARGIN_TOP_N = PAPER_SPACE["margin_mm"][1] * default_actuator().stiffness_n_per_mm
GAIN_HEADROOM = 0.99  # the search's gains stay this share of the largest the C holds
LIMIT_STEPS = 8  # the limit's grid: 0.5 V steps over the paper's 6-10 V (as many steps on any range)


def pot_step_n(act: Actuator) -> float:
    """The spring force one pot count spans at the top of `act`'s linkage range, where it is widest (Eq. 2:
    the compression moves by CB sin(angle) per radian of the pot's angle): the finest step in which the
    force loop reads a force."""
    lk = act.linkage
    per_rad = lk.cb_mm * math.sin(math.radians(lk.angle_max_deg))
    return act.stiffness_n_per_mm * per_rad * math.radians(act.pot_deg_per_count)


def enc_step_n(act: Actuator) -> float:
    """The spring force one encoder count spans (Eq. 3: the nut moves lead / (gear x counts) a count)."""
    return act.stiffness_n_per_mm * act.mm_per_count


def hold_problem(act: Actuator) -> str | None:
    """Why the force loop on `act` cannot hold a force within the settling band, with the numbers, or None.
    It reads the compression from an encoder count and a pot count (Eq. 2-5), each off by up to half its
    step; the band (+-experiment.BAND_N) must hold those and the margin's dead band (up to MARGIN_TOP_N), so
    the two steps together may be at most 2 x (BAND_N - MARGIN_TOP_N) of spring force."""
    enc, pot = enc_step_n(act), pot_step_n(act)
    most = 2.0 * (BAND_N - MARGIN_TOP_N)
    if enc + pot <= most:
        return None
    m, p, lk = act.motor, act.pot, act.linkage
    return (
        f"the force loop reads the spring force in steps of {enc + pot:.2g} N: one encoder count "
        f"{enc:.2g} N (transmission.lead_mm {act.lead_mm:g} / (motor.gear_ratio {m.gear_ratio:g} x "
        f"motor.counts_per_rev {m.counts_per_rev}) on the {act.stiffness_n_per_mm:g} N/mm spring) and one "
        f"pot count {pot:.2g} N at the linkage's top angle {lk.angle_max_deg:g} deg (pot.full_scale_deg "
        f"{p.full_scale_deg:g} over pot.adc_bits {p.adc_bits}, through linkage.cb_mm {lk.cb_mm:g}), more "
        f"than the {most:.2g} N the +-{BAND_N:g} N settling band leaves beside the controller's dead band "
        f"(up to {MARGIN_TOP_N:.2g} N): it cannot hold a force within the band: a finer encoder or pot "
        "(motor.counts_per_rev, pot.adc_bits), a higher motor.gear_ratio, a finer transmission.lead_mm, a "
        "smaller pot.full_scale_deg or a softer spring (spring.stiffness_n_per_mm)"
    )


def search_space(act: Actuator) -> dict[str, tuple[float, float]]:
    """PAPER_SPACE carried to `act` (the paper's own for it), widened rather than moved, since how the
    loop settles depends on more than these ratios: the gains' range stretched by the ratio of the nut's
    speed per volt (the paper's over `act`'s: the same loop gain while the nut moves) and kp's and ki's
    also by the ratio of the spring compression the stalled motor holds per volt (the same static loop
    gain while it holds a force: the proportional droop and the integrator's time to remove it), the
    command limit's up to the calibration pushes' volts (data.protocol: the same stall margin at the same
    share of the force range); the limit within the supply and the gains within what the C's Q12 int32
    holds at the loop rate. The margin's range is moved with the springs' ratio at its top, so its dead
    band is at most the paper's top as a force (MARGIN_TOP_N, inside the settling band), and widened at
    its bottom."""
    r = _ratios(act)
    gain, hold, springs = r["gain"], r["hold"], r["springs"]
    scale = {
        "kp_v_mm": (gain, hold),
        "ki_v_mm_s": (gain, hold),
        "kd_v_s_mm": (gain,),
        "d_alpha": (1.0,),
        "limit_v": (r["volts"], r["push"]),
    }
    top = {"limit_v": act.motor.supply_v} | {
        k: GAIN_HEADROOM * v for k, v in gain_max_si(1.0 / act.loop_hz).items()
    }
    out = {}
    for k, (lo, hi) in PAPER_SPACE.items():
        if k == "margin_mm":  # the top in force: exactly the paper's on its spring (springs == 1.0)
            out[k] = (lo * min(springs, 1.0), hi * springs)
            continue
        cap = top.get(k, np.inf)
        out[k] = (min(lo * min(*scale[k], 1.0), cap), min(hi * max(*scale[k], 1.0), cap))
    return out


def _ratios(act: Actuator) -> dict[str, float]:
    """The paper's settings' ratios to `act` that carry them (search_space widens by them, carried_trial
    moves by them): gain (the nut's speed per volt, the paper's over act's), hold (the compression the
    stalled motor holds per volt, likewise), springs (the paper's spring over act's), volts (the protocol's
    volts and force scale) and push (the calibration pushes' most raised volts)."""
    paper = default_actuator()
    return {
        "gain": _speed_per_volt(paper) / _speed_per_volt(act),
        "hold": _held_per_volt(paper) / _held_per_volt(act),
        "springs": paper.stiffness_n_per_mm / act.stiffness_n_per_mm,
        "volts": volts_scale(act) * force_scale(act),
        "push": _push_raise(act),
    }


def _push_raise(a: Actuator) -> float:
    """The most the calibration protocol raises a push's volts over the paper's same move on `a` (its
    stall force per volt and range, raised where the push would be slower than the paper's: reach.push_volts;
    the supply on a design paced slower, whose experiment runs are paced by pushes at full supply)."""
    return max(scaled_move(0.0, m, a).push_v / m[0] for m in PUSH_MOVES)


def _speed_per_volt(a: Actuator) -> float:
    """The nut's no-load speed per volt of supply (mm/s per V)."""
    return Motor.of(a).v_max_mm_s / a.motor.supply_v


def _held_per_volt(a: Actuator) -> float:
    """The spring compression the stalled motor holds per volt (mm per V: stall force per volt over the
    spring rate): with kp, the static loop gain that sets the proportional droop F / (1 + gain)."""
    return a.motor.stall_force_n / a.motor.supply_v / a.stiffness_n_per_mm


def mean_settling(
    setup: Setup,
    pid: PidParams,
    pred_avg: int | None,
    seeds: tuple[int, ...],
    plant_cfg: PlantConfig,
    metric: str = "settling_s",
) -> dict[float, float]:
    """Per target: settling time (`metric` of experiment.metrics) of a configuration averaged over angles
    and seeds (NaN = the run)."""
    pred, ctl = setup
    cfg = replace(ctl, pid=pid) if pred_avg is None else replace(ctl, pid=pid, pred_avg=pred_avg)
    out: dict[float, list[float]] = {t: [] for t in targets_n(plant_cfg.actuator)}
    never = NEVER_S * duration_s(plant_cfg.actuator) / DURATION_S  # the whole run
    for seed in seeds:
        for target, rec in runs(pred, cfg, seed=seed, plant_cfg=plant_cfg):
            got = metrics(rec, plant_cfg.actuator.stiffness_n_per_mm)[metric]
            out[target].append(float(np.nan_to_num(got, nan=never).mean()))
    return {t: float(np.mean(v)) for t, v in out.items()}


def objective(mlp: dict[float, float], sf: dict[float, float]) -> float:
    """Worst MLP-on-MCU target plus 0.3 x its mean, plus a penalty for SF outside +-50 % of the paper's."""
    paper = {float(t): s for t, (_, s) in PAPER_TABLE2["SF"].items()}
    pen = sum(max(0.0, sf[t] - 1.5 * paper[t]) + max(0.0, 0.5 * paper[t] - sf[t]) for t in paper)
    return worst_plus_mean(mlp) + 3.0 * pen


def worst_plus_mean(settling: dict[float, float]) -> float:
    """The worst target's settling time plus 0.3 x the mean over the targets (s)."""
    return max(settling.values()) + 0.3 * float(np.mean(list(settling.values())))


def _pid(trial: Any, space: dict[str, tuple[float, float]], aq: ActQ) -> PidParams:
    """A trial's PID in the search space `space` (the gains and margin log-uniform where it was widened
    from the paper's), quantized at the tick and within the motor range of actuator `aq`."""
    widened = {k for k in PAPER_SPACE if k != "limit_v" and space[k] != PAPER_SPACE[k] and space[k][0] > 0}
    si = {k: trial.suggest_float(k, *space[k], log=k in widened) for k in PAPER_SPACE if k != "limit_v"}
    lo, hi, step = _limit_grid(*space["limit_v"])
    si["limit_v"] = trial.suggest_float("limit_v", lo, hi, step=step) if step > 0 else hi
    return PidParams.from_si(**si, max_mv=aq.motor_max_mv, tick_s=1.0 / aq.loop_hz)


def tune(
    trials: int,
    seeds: tuple[int, ...],
    sampler_seed: int = 1,
    setup: Callable[[], Setup] | None = None,
    act: Actuator | None = None,
    progress: bool = True,
    name: str = "mine",
    metric: str = "settling_s",
    shipped: Setups | None = None,
):
    """Search gains, margin and output limit; returns the Optuna study. On the paper's actuator with no
    `setup`: the search of `shipped` (setups.shipped.CONFIGS: the MLP's settling, its prediction average
    searched too, the SF within +-50 % of the paper's Table II; the first trial is what ships). Otherwise
    `setup` (a configuration factory, `name`: your control model, or kin_mcu) on `act`, its `metric`
    (experiment.metrics: settling to the target, or for a biased estimate such as kin_mcu's
    settling_held_s: to the force's own final level with the loop at its own setpoint) scored by
    worst_plus_mean; the first trial is the description's own [control]."""
    import optuna

    act = act or default_actuator()
    plant_cfg = PlantConfig(actuator=act)
    paper = shipped if setup is None and is_default(act) else None  # the shipped search's configurations
    if setup is None and not paper:
        raise ValueError("tune: another actuator needs its configuration (setup), the paper's `shipped`")
    space, aq = search_space(act), act_q_of(act)
    mlp_setup, sf_setup = (paper["mlp_mcu"](), paper["sf_mcu"]()) if paper else (None, None)
    mine_setup = None if setup is None else setup()

    def trial_fn(trial: optuna.Trial) -> float:
        pid = _pid(trial, space, aq)
        if mlp_setup is not None and sf_setup is not None:
            mlp = mean_settling(mlp_setup, pid, trial.suggest_int("pred_avg", 4, 10), seeds, plant_cfg)
            sf = mean_settling(sf_setup, pid, 1, seeds[:2], plant_cfg)
            trial.set_user_attr("mlp_mcu", mlp)
            trial.set_user_attr("sf_mcu", sf)
            return objective(mlp, sf)
        assert mine_setup is not None
        mine = mean_settling(mine_setup, pid, None, seeds, plant_cfg, metric)
        trial.set_user_attr(name, mine)
        return worst_plus_mean(mine)

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=optuna.samplers.TPESampler(seed=sampler_seed))
    own = SHIPPED if paper else own_trial(act)
    study.enqueue_trial(own)
    if not paper and (carried := carried_trial(act)) != own:
        study.enqueue_trial(carried)
    study.optimize(trial_fn, n_trials=trials, show_progress_bar=progress)
    return study


def own_trial(act: Actuator) -> dict[str, float]:
    """The description's own [control] PID settings as a trial of its search space (clipped into it, the
    limit onto its grid): the baseline a search starts from."""
    return _onto(act, pid_si(act.control))


def carried_trial(act: Actuator) -> dict[str, float]:
    """The paper's shipped settings carried to `act` by the ratios that widen its search space (kp and ki
    by the compression the stalled motor holds per volt: the same static loop gain; kd by the nut's speed
    per volt; the margin by the springs: the same force; the limit by the calibration pushes' volts), into
    the space and the limit onto its grid: the second trial, after the description's own (a description
    that leaves [control] out has the paper's settings, made for its 12 V motor and 4.2 N/mm spring)."""
    r = _ratios(act)
    ratio = {
        "kp_v_mm": r["hold"],
        "ki_v_mm_s": r["hold"],
        "kd_v_s_mm": r["gain"],
        "d_alpha": 1.0,
        "margin_mm": r["springs"],
        "limit_v": max(r["volts"], r["push"]),
    }
    return _onto(act, {k: DEFAULT_PID_SI[k] * ratio[k] for k in PAPER_SPACE})


def _onto(act: Actuator, si: dict[str, float]) -> dict[str, float]:
    """Settings `si` clipped into `act`'s search space, the limit onto its grid."""
    space = search_space(act)
    out = {k: float(np.clip(si[k], *space[k])) for k in PAPER_SPACE}
    lo, hi, step = _limit_grid(*space["limit_v"])
    if step > 0:
        k = min(max(round((out["limit_v"] - lo) / step), 0), LIMIT_STEPS)
        out["limit_v"] = float(Decimal(str(lo)) + k * Decimal(str(step)))
    return out


def _limit_grid(lo: float, hi: float) -> tuple[float, float, float]:
    """The limit's grid on a range carried from the paper's: (low, high, step), LIMIT_STEPS steps down from
    `hi` (to 0.1 mV, never above it) to about `lo`, in decimals whose range optuna finds divisible by the
    step (it compares them as Decimal(str(x)) and otherwise cuts the top, the supply, off the search); the
    paper's 6-10 V by 0.5 V exactly. A step of 0: a range too narrow for a grid (search `hi` alone)."""
    q = Decimal("0.0001")
    top = Decimal(str(hi)).quantize(q, rounding=ROUND_FLOOR)
    step = max((top - Decimal(str(lo))) / LIMIT_STEPS, Decimal(0)).quantize(q, rounding=ROUND_FLOOR)
    return float(top - LIMIT_STEPS * step), float(top), float(step)


def control_table(params: dict[str, float]) -> str:
    """The best trial's PID settings as lines for the description's [control] table (a comment first)."""
    lines = [f"{SI_FIELDS[k]} = {params[k]:.4g}" for k in PAPER_SPACE if k in params]
    head = (
        "# seagen tune: set these in your description's [control] table, then regenerate the data and retrain"
    )
    return "\n".join([head, *lines])
