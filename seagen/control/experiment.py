"""The paper's force-control experiment (§VIII-C, Table II): configurations, targets, metrics."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from seagen.actuator import Actuator
from seagen.control.loop import CloudPredictor, Impl, McuPredictor, run_closed_loop
from seagen.control.predictors import kinematic_mcu
from seagen.data.reach import pace
from seagen.plant import PlantConfig
from seagen.runtime.control import ControlConfig
from seagen.runtime.fixed import COMP_FRAC_BITS

# The grid, per actuator description: targets at these fractions of its desired-force range (control.
# force_max_n: 5, 10, 15 N on the paper's 20 N), N_CONTACT contact angles evenly over its linkage range less
# CONTACT_MARGIN_DEG (bottom, top) (7 to 25 deg on the paper's 5 to 28 deg).
TARGET_FRACTIONS = (0.25, 0.5, 0.75)
N_CONTACT = 10
CONTACT_MARGIN_DEG = (2.0, 3.0)
BAND_N = 0.3  # settling band around the target (paper: 0.3 N)
SMOOTH_S = 0.05  # the reference force is judged on its 50 ms trailing mean (load-cell noise), any loop rate
ERROR_WINDOW_S = 2.0  # the average error is taken over the last 2 s of the run
DURATION_S = 6.0

Setup = tuple[McuPredictor | CloudPredictor, ControlConfig]
# Configuration name -> factory() of its predictor and controller configuration: the shipped ones
# (Table II rows and the kin_mcu baseline) are seagen.setups.shipped.CONFIGS.
Setups = dict[str, Callable[[], Setup]]
TABLE2_CONFIGS = ("sf_mcu", "mlp_cloud", "mlp_mcu")
PAPER_TABLE2 = {  # paper Table II: (average force error N, average settling time s) per method and target
    "SF": {"5": (0.29, 0.32), "10": (0.41, 0.50), "15": (0.18, 0.58)},
    "MLP": {"5": (0.24, 2.72), "10": (0.30, 3.22), "15": (0.10, 3.15)},
}
PAPER_ROW = {"sf_mcu": "SF", "mlp_cloud": "MLP", "mlp_mcu": "MLP", "kin_mcu": "SF"}


def model_free_setups(act: Actuator) -> dict[str, Callable[[], Setup]]:
    """The model-free configurations (kin_mcu) on actuator `act`: the kinematic inverse with its friction
    and spring, the controller configuration of its description."""
    from seagen.runtime.actq import act_q
    from seagen.runtime.control import KinParams

    ctl = ControlConfig.for_act(act_q(act))
    return {"kin_mcu": lambda: (kinematic_mcu(1, KinParams.of(act)), ctl)}


def duration_s(act: Actuator) -> float:
    """Seconds of one run on `act`: DURATION_S, longer by the calibration protocol's pace on a design whose
    pushes are slower than the paper's (seagen.data.reach.pace; exactly DURATION_S on a design near it)."""
    return DURATION_S * pace(act)


def targets_n(act: Actuator) -> tuple[float, ...]:
    """The experiment's force targets (N at the shaft) on actuator `act`."""
    return tuple(f * act.control.force_max_n for f in TARGET_FRACTIONS)


def contact_deg(act: Actuator, n: int | None = None) -> tuple[float, ...]:
    """`n` (default N_CONTACT) contact angles (deg) evenly over `act`'s linkage range less the margins (a
    range narrower than the margins: its middle)."""
    lo = act.linkage.angle_min_deg + CONTACT_MARGIN_DEG[0]
    hi = act.linkage.angle_max_deg - CONTACT_MARGIN_DEG[1]
    if hi < lo:
        lo = hi = 0.5 * (act.linkage.angle_min_deg + act.linkage.angle_max_deg)
    return tuple(float(a) for a in np.linspace(lo, hi, N_CONTACT if n is None else n))


def smoothed(rec: dict[str, np.ndarray], key: str = "force_n") -> np.ndarray:
    """Trailing mean of rec[key] over SMOOTH_S along axis 0, in ticks of the record's loop (shorter at the
    start)."""
    force, t = rec[key], rec["t_s"][:, 0]
    n = max(1, round(SMOOTH_S / float(t[1] - t[0]))) if len(t) > 1 else 1
    c = np.cumsum(np.vstack([np.zeros((1, force.shape[1])), force]), axis=0)
    k = np.arange(1, force.shape[0] + 1)
    lo = np.maximum(k - n, 0)
    return (c[k] - c[lo]) / (k - lo)[:, None]


def settling(t: np.ndarray, f: np.ndarray, ref: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Per column: time from `start` until |f - ref| <= BAND_N for good (NaN if the last sample is out)."""
    outside = np.abs(f - ref) > BAND_N
    n = f.shape[0]
    last_out = np.where(outside.any(axis=0), n - 1 - np.argmax(outside[::-1], axis=0), -1)
    settle = np.where(last_out >= n - 1, np.nan, t[np.minimum(last_out + 1, n - 1)])
    return np.maximum(settle - t[start], 0.0)


def metrics(rec: dict[str, np.ndarray], spring_n_per_mm: float | None = None) -> dict[str, np.ndarray]:
    """Per actuator, on the smoothed reference force: settling time to the target band from contact,
    settling time to a band around the force's own final mean, and mean |error| over the last window; with
    the spring's rate also settling_held_s (held_settling)."""
    t, f = rec["t_s"][:, 0], smoothed(rec)
    target = rec["target_n"]
    contact = np.argmax(rec["true_force_n"] > 0, axis=0)
    win = t >= t[-1] - ERROR_WINDOW_S
    final = f[win].mean(axis=0)
    out = {
        "settling_s": settling(t, f, target, contact),
        "settling_final_s": settling(t, f, np.broadcast_to(final, f.shape), contact),
        "error_avg_n": np.abs(f[win] - target[win]).mean(axis=0),
    }
    if spring_n_per_mm is not None:
        out["settling_held_s"] = held_settling(rec, spring_n_per_mm, out["settling_final_s"], contact)
    return out


def held_settling(
    rec: dict[str, np.ndarray], spring_n_per_mm: float, final_s: np.ndarray, contact: np.ndarray
) -> np.ndarray:
    """Per column: the later of `final_s` (the force settled to its own final level) and the loop's own
    settling: the compression it measures (comp) within the band, as a force on the spring, of the
    compression it is asked for (desired, both Q16 mm, smoothed like the force) for good; NaN if either
    never does. A loop held off its setpoint (a proportional droop, a dead band wider than the band, a
    command at its limit) does not settle however steady its force, whatever the predictor's bias."""
    per_q = spring_n_per_mm / float(1 << COMP_FRAC_BITS)  # N per Q16 mm of compression
    off = {"t_s": rec["t_s"], "n": (rec["desired"] - rec["comp"]) * per_q}
    t = rec["t_s"][:, 0]
    loop = settling(t, smoothed(off, "n"), np.zeros_like(off["n"]), contact)
    return np.where(np.isnan(loop) | np.isnan(final_s), np.nan, np.maximum(loop, final_s))


def _mean_or_none(x: np.ndarray) -> float | None:
    """The mean of the finite values (3 decimals), None when there are none."""
    return None if np.isnan(x).all() else round(float(np.nanmean(x)), 3)


def limit_share(rec: dict[str, np.ndarray], settling_s: np.ndarray, lim_mv: int) -> float:
    """Share of the ticks after contact, over the runs that never settle, at which the command sits at
    the controller's limit `lim_mv` (its PID's out_max); 0 when every run settles."""
    never = np.isnan(settling_s)
    if not never.any():
        return 0.0
    after = rec["true_force_n"] > 0
    at = (np.abs(rec["out_mv"]) >= lim_mv) & after
    return float(at[:, never].sum() / max(int(after[:, never].sum()), 1))


def runs(
    pred: McuPredictor | CloudPredictor,
    ctl: ControlConfig,
    impl: Impl = "c",
    seed: int = 0,
    plant_cfg: PlantConfig | None = None,
) -> Iterator[tuple[float, dict[str, np.ndarray]]]:
    """The experiment for one predictor and controller: (target, record) per target, all contact angles
    at once, plant-noise seed `seed + i` for the i-th target, on the plant `plant_cfg` (default: the
    paper's actuator); the targets and angles are those of the plant's actuator. Each record also holds
    its contact angles (`contact_deg`, ticks x actuators)."""
    act = (plant_cfg or PlantConfig()).actuator
    angles, run_s = np.array(contact_deg(act)), duration_s(act)
    for i, target in enumerate(targets_n(act)):
        rec = run_closed_loop(
            pred,
            target,
            angles,
            impl=impl,
            duration_s=run_s,
            seed=seed + i,
            plant_cfg=plant_cfg,
            control_cfg=ctl,
        )
        rec["contact_deg"] = np.broadcast_to(angles, rec["t_s"].shape).copy()
        yield target, rec


def estimate_error(rec: dict[str, np.ndarray]) -> float:
    """Mean |estimated - load-cell force| over the last window (both smoothed), over the contact angles."""
    t = rec["t_s"][:, 0]
    win = t >= t[-1] - ERROR_WINDOW_S
    return float(np.abs(smoothed(rec, "estimate_n")[win] - smoothed(rec)[win]).mean())


def run_config(
    setups: Setups,
    name: str,
    impl: Impl = "c",
    seed: int = 0,
    estimator: Callable[[dict[str, np.ndarray]], np.ndarray] | None = None,
    plant_cfg: PlantConfig | None = None,
) -> dict[str, dict]:
    """Every target at every contact angle for one configuration (of `setups`, e.g. the shipped CONFIGS):
    {target: {metric: value, ...}}; settling_s is the mean over the angles that settle (`settled` of them),
    None if none does. `estimator` (a calibration model) adds its force estimate and its error."""
    out: dict[str, dict] = {}
    pred, ctl = setups[name]()
    for target, rec in runs(pred, ctl, impl=impl, seed=seed, plant_cfg=plant_cfg):
        m = metrics(rec)
        s = m["settling_s"]
        out[f"{target:g}"] = {
            "error_avg_n": round(float(m["error_avg_n"].mean()), 4),
            "settling_s": _mean_or_none(s),
            "settled": int(np.isfinite(s).sum()),
            "angles": len(s),
            "settling_final_s": _mean_or_none(m["settling_final_s"]),
            "at_limit": round(limit_share(rec, s, ctl.pid.out_max), 3),
            "trace": rec,
        }
        if estimator is not None:
            rec["estimate_n"] = estimator(rec)
            out[f"{target:g}"]["estimate_error_n"] = round(estimate_error(rec), 4)
    return out


def simulate(
    setups: Setups,
    names: tuple[str, ...] = TABLE2_CONFIGS,
    impl: Impl = "c",
    seed: int = 0,
    plots: str | None = None,
    estimator: Callable[[dict[str, np.ndarray]], np.ndarray] | None = None,
    plant_cfg: PlantConfig | None = None,
) -> dict[str, dict[str, dict]]:
    """Run the configurations (of `setups`, e.g. the shipped CONFIGS) on the plant `plant_cfg`, write a
    step-response plot of each into `plots`, return Table II."""
    results = {n: run_config(setups, n, impl, seed, estimator, plant_cfg) for n in names}
    if plots:
        from pathlib import Path

        from seagen.control.plots import comparison_plot, step_plot

        for n, res in results.items():
            step_plot(n, res, Path(plots) / f"step_{n}.png")
        comparison_plot(results, Path(plots) / "step_compare.png")
    return {
        n: {t: {k: v for k, v in r.items() if k != "trace"} for t, r in x.items()} for n, x in results.items()
    }


def sweep(
    setups: Setups,
    names: tuple[str, ...] = TABLE2_CONFIGS,
    seeds: int = 5,
    impl: Impl = "c",
    seed: int = 0,
    progress: Callable[[int], None] | None = None,
    plots: str | None = None,
    estimator: Callable[[dict[str, np.ndarray]], np.ndarray] | None = None,
    plant_cfg: PlantConfig | None = None,
) -> dict[str, dict[str, dict]]:
    """Table II over plant-noise seeds seed..seed+seeds-1: per configuration and target the mean over seeds
    of error and settling time, the settling range over seeds, and the angles settled out of all runs
    (plots, if asked for, are of the first seed)."""
    runs = []
    for k in range(seeds):
        runs.append(simulate(setups, names, impl, seed + k, plots if k == 0 else None, estimator, plant_cfg))
        if progress:
            progress(k)
    out: dict[str, dict[str, dict]] = {}
    for n in names:
        out[n] = {}
        for t in runs[0][n]:
            rows = [r[n][t] for r in runs]
            st = [r["settling_s"] for r in rows if r["settling_s"] is not None]
            out[n][t] = {
                "error_avg_n": round(float(np.mean([r["error_avg_n"] for r in rows])), 4),
                "settling_s": round(float(np.mean(st)), 3) if st else None,
                "settling_min_s": round(min(st), 3) if st else None,
                "settling_max_s": round(max(st), 3) if st else None,
                "settled": sum(r["settled"] for r in rows),
                "angles": sum(r["angles"] for r in rows),
                "settling_final_s": _mean_or_none(np.array([r["settling_final_s"] for r in rows], float)),
                "at_limit": round(float(np.mean([r["at_limit"] for r in rows])), 3),
                "seeds": seeds,
            }
            if "estimate_error_n" in rows[0]:
                est = np.mean([r["estimate_error_n"] for r in rows])
                out[n][t]["estimate_error_n"] = round(float(est), 4)
    return out


def format_table2(
    table: dict[str, dict[str, dict]], paper_rows: dict[str, str] | None = None, paper_figures: bool = True
) -> str:
    """Table II as text: measured error and settling time per configuration and target beside the paper's
    (a seed sweep adds the settling range over seeds; a calibration model its force-estimate error; the
    paper columns are left out when the paper has no figure for any target shown, or `paper_figures` is
    False: a plant of another design than the paper's).
    `paper_rows`: configuration -> the paper's row (SF or MLP) for configurations not in PAPER_ROW."""
    rows_of = {**PAPER_ROW, **(paper_rows or {})}
    ranged = any("settling_min_s" in r for rows in table.values() for r in rows.values())
    est = any("estimate_error_n" in r for rows in table.values() for r in rows.values())
    paper_shown = paper_figures and any(
        t in PAPER_TABLE2[rows_of.get(n, "SF")] for n, rows in table.items() for t in rows
    )
    fw = max([6, *(len(t) + 3 for rows in table.values() for t in rows)])  # "11.25 N" and a space
    head = f"{'config':<11}{'force':>{fw}}{'error N':>9}{'settling s':>12}"
    head += f"{'range s':>12}" if ranged else ""
    head += f"{'settled':>9}{'to final s':>12}" + (f"{'est. err N':>12}" if est else "")
    lines = [head + (f"{'paper':>8}{'error N':>9}{'settling s':>12}" if paper_shown else "")]
    width = max([11, *(len(n) + 1 for n in table)])
    lines[0] = f"{'config':<{width}}" + lines[0][11:]
    for name, rows in table.items():
        paper = PAPER_TABLE2[rows_of.get(name, "SF")]
        for t, r in rows.items():
            s = "never" if r["settling_s"] is None else f"{r['settling_s']:.2f}"
            rng = ""
            if ranged:
                lo, hi = r.get("settling_min_s"), r.get("settling_max_s")
                rng = f"{'-' if lo is None else f'{lo:.2f}-{hi:.2f}':>12}"
            pe, ps = paper.get(t, (np.nan, np.nan))  # a target the paper did not run: nan
            settled, fs = f"{r['settled']}/{r['angles']}", r["settling_final_s"]
            e = f"{r['estimate_error_n']:>12.2f}" if est else ""
            p = f"{rows_of.get(name, 'SF'):>8}{pe:>9.2f}{ps:>12.2f}" if paper_shown else ""
            lines.append(
                f"{name:<{width}}{t + ' N':>{fw}}{r['error_avg_n']:>9.2f}{s:>12}{rng}{settled:>9}"
                f"{'never' if fs is None else f'{fs:.2f}':>12}{e}{p}"
            )
    return "\n".join(lines)
