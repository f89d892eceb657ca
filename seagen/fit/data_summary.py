"""What a data directory holds: rows per split, naive kinematics error, friction by contact angle."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from seagen.data.features import derive
from seagen.data.friction import friction_from_trial
from seagen.data.schema import SPLITS, DataError, data_actuator, load_split
from seagen.fit.kinematics import error_threshold_n, kinematics_errors
from seagen.geometry import geometry


def summarize(data_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """Summary of a data directory; the kinematics error is taken on `test` (else the first split found)."""
    d = Path(data_dir)
    if not d.is_dir():
        raise DataError(f"{d}: no such directory")
    frames = {s: load_split(d, s) for s in SPLITS if (d / f"{s}.csv").is_file()}
    if not frames:
        raise DataError(f"{d}: no {', '.join(s + '.csv' for s in SPLITS)} found")
    split = "test" if "test" in frames else next(iter(frames))
    act = data_actuator(d)
    geo = geometry(act)
    derived = derive(frames[split], geo)
    errs = kinematics_errors(derived, geo)
    friction: dict[str, float] = {}
    for angle, rows in derive(frames.get("train", frames[split]), geo).groupby("angle_set_deg"):
        vals = [friction_from_trial(t, geo.spring_n_per_mm) for _, t in rows.groupby("trial")]
        vals = [v for v in vals if np.isfinite(v)]
        if vals:
            friction[f"{angle:.2f}"] = float(np.median(vals))
    return {
        "rows": {s: len(f) for s, f in frames.items()},
        "kinematics_split": split,
        "kinematics_error_avg_pct": errs["error_avg_pct"],
        "kinematics_error_max_pct": errs["error_max_pct"],
        "kinematics_threshold_n": error_threshold_n(act),
        "friction_n_by_angle": friction,
    }


def format_summary(s: dict[str, Any]) -> str:
    """Human-readable summary with the paper's figures beside the measured ones."""
    lines = ["rows: " + ", ".join(f"{k} {v}" for k, v in s["rows"].items()) + "   (paper: 10400, 2416, 140)"]
    lines.append(
        f"naive kinematics error on {s['kinematics_split']} "
        f"(rows with force > {s['kinematics_threshold_n']:g} N): "
        f"average {s['kinematics_error_avg_pct']:.1f} %  (paper 34.31 %), "
        f"maximum {s['kinematics_error_max_pct']:.1f} %  (paper 44.7 %)"
    )
    fr = s["friction_n_by_angle"]
    if fr:
        lines.append(
            "friction by contact angle (N, the paper's way; paper: 2.1 / 2.4 / 4.45 N at three angles):"
        )
        lines.append("  " + "  ".join(f"{a}°: {v:.2f}" for a, v in fr.items()))
    return "\n".join(lines)
