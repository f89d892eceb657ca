"""The paper's force-control experiment (§VIII-C, Table II): configurations, targets, metrics."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from seagen.control.loop import CloudPredictor, McuPredictor, run_closed_loop
from seagen.control.predictors import kinematic_cloud, kinematic_mcu

TARGETS_N = (5.0, 10.0, 15.0)
CONTACT_DEG = tuple(float(a) for a in np.linspace(7.0, 25.0, 10))  # ten contact angles
BAND_N = 0.3  # settling band around the target (paper: 0.3 N)
SMOOTH_TICKS = 5  # the reference force is judged on its 50 ms trailing mean (load-cell noise)
ERROR_WINDOW_S = 2.0  # the average error is taken over the last 2 s of the run
DURATION_S = 6.0

# Configuration name -> factory(latency_s) of its predictor; extend with sf_mcu, mlp_cloud, mlp_mcu.
CONFIGS: dict[str, Callable[[float], McuPredictor | CloudPredictor]] = {
    "kin_mcu": lambda latency_s: kinematic_mcu(predict_every=1),
    "kin_cloud": lambda latency_s: kinematic_cloud(latency_s, 10.0),
}


def smoothed(force: np.ndarray, n: int = SMOOTH_TICKS) -> np.ndarray:
    """Trailing mean over n ticks along axis 0 (shorter at the start)."""
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


def metrics(rec: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per actuator, on the smoothed reference force: settling time to the target band from contact,
    settling time to a band around the force's own final mean, and mean |error| over the last window."""
    t, f = rec["t_s"][:, 0], smoothed(rec["force_n"])
    target = rec["target_n"]
    contact = np.argmax(rec["true_force_n"] > 0, axis=0)
    win = t >= t[-1] - ERROR_WINDOW_S
    final = f[win].mean(axis=0)
    return {
        "settling_s": settling(t, f, target, contact),
        "settling_final_s": settling(t, f, np.broadcast_to(final, f.shape), contact),
        "error_avg_n": np.abs(f[win] - target[win]).mean(axis=0),
    }


def run_config(name: str, latency_s: float = 0.1, impl: str = "c", seed: int = 0) -> dict[str, dict]:
    """Every target at every contact angle for one configuration: {target: {metric: value, ...}}."""
    pred = CONFIGS[name](latency_s)
    out: dict[str, dict] = {}
    for i, target in enumerate(TARGETS_N):
        rec = run_closed_loop(
            pred, target, np.array(CONTACT_DEG), impl=impl, duration_s=DURATION_S, seed=seed + i
        )
        m = metrics(rec)
        s = m["settling_s"]
        out[f"{target:g}"] = {
            "error_avg_n": round(float(m["error_avg_n"].mean()), 4),
            "settling_s": None if np.isnan(s).any() else round(float(s.mean()), 3),
            "settled": int(np.isfinite(s).sum()),
            "settling_final_s": round(float(np.nanmean(m["settling_final_s"])), 3),
            "trace": rec,
        }
    return out
