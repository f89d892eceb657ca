"""What a data directory holds: rows per split, the force range they cover, naive kinematics error, friction
by contact angle; the paper's figures beside them only on the paper's actuator."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from seagen.actuator import is_default
from seagen.data.coverage import coverage, shortfalls
from seagen.data.features import derive
from seagen.data.friction import ONSET_BAND_N, friction_from_trial
from seagen.data.schema import SPLITS, DataError, data_actuator, load_split
from seagen.fit.kinematics import error_threshold_n, kinematics_errors
from seagen.geometry import Geometry, geometry


def summarize(data_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """Summary of a data directory; the kinematics error is taken on `test` (else the first split found),
    None with no row above the threshold."""
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
    threshold = error_threshold_n(act)
    above = int((derived["force_n"] > threshold).sum())
    errs = kinematics_errors(derived, geo) if above else {}
    cov = coverage(frames, act)
    return {
        "actuator": act.name,
        "rows": {s: len(f) for s, f in frames.items()},
        "force_max_n": act.control.force_max_n,
        "peak_force_n": {s: c.peak_n for s, c in cov.items()},
        "contact_share": {s: round(c.contact, 4) for s, c in cov.items()},
        "missing": shortfalls(cov, act),
        "kinematics_split": split,
        "kinematics_rows": above,
        "kinematics_error_avg_pct": errs.get("error_avg_pct"),
        "kinematics_error_max_pct": errs.get("error_max_pct"),
        "kinematics_threshold_n": threshold,
        **_friction(derive(frames["train"], geo) if split != "train" and "train" in frames else derived, geo),
    }


def _friction(df, geo: Geometry) -> dict[str, Any]:
    """Median friction the paper's way per contact angle, and the angles with no trial to measure it."""
    out: dict[str, float] = {}
    for angle, rows in df.groupby("angle_set_deg"):
        vals = [friction_from_trial(t, geo.spring_n_per_mm) for _, t in rows.groupby("trial")]
        vals = [v for v in vals if np.isfinite(v)]
        if vals:
            out[f"{angle:.2f}"] = float(np.median(vals))
    angles = [f"{a:.2f}" for a in sorted(df["angle_set_deg"].unique())]
    return {"friction_n_by_angle": out, "friction_unmeasured": [a for a in angles if a not in out]}


def paper_data(data_dir: str | os.PathLike[str]) -> bool:
    """Whether a data directory was recorded on the paper's actuator (its figures then stand beside ours)."""
    return is_default(data_actuator(data_dir))


def format_summary(s: dict[str, Any], paper: bool = False) -> str:
    """Human-readable summary; with `paper` (data of the paper's actuator: paper_data) the paper's figures
    beside the measured ones."""
    rows = "rows: " + ", ".join(f"{k} {v}" for k, v in s["rows"].items())
    lines = [rows + ("   (paper: 10400, 2416, 140)" if paper else "")]
    top = s["force_max_n"]
    lines.append(
        f"force reached (control.force_max_n {top:g} N): "
        + ", ".join(f"{k} {v:.3g} N" for k, v in s["peak_force_n"].items())
        + "; rows in contact: "
        + ", ".join(f"{k} {v:.0%}" for k, v in s["contact_share"].items())
    )
    if s["missing"]:
        lines.append("these data do not cover the force range: " + "; ".join(s["missing"]))
    lines.append(_kinematics_line(s, paper))
    lines += _friction_lines(s, paper)
    return "\n".join(lines)


def _kinematics_line(s: dict[str, Any], paper: bool) -> str:
    """The naive kinematics error, or why there is none."""
    split, above = s["kinematics_split"], s["kinematics_threshold_n"]
    where = f"naive kinematics error on {split} (rows with force > {above:g} N)"
    if not s["kinematics_rows"]:
        peak = s["peak_force_n"][split]
        return f"{where}: not measured: no row above {above:g} N (the split peaks at {peak:.3g} N)"
    avg, mx = s["kinematics_error_avg_pct"], s["kinematics_error_max_pct"]
    if not paper:
        return f"{where}: average {avg:.1f} %, maximum {mx:.1f} %"
    return f"{where}: average {avg:.1f} %  (paper 34.31 %), maximum {mx:.1f} %  (paper 44.7 %)"


def _friction_lines(s: dict[str, Any], paper: bool) -> list[str]:
    """The friction table, or what is missing for it."""
    fr, gone = s["friction_n_by_angle"], s.get("friction_unmeasured", [])
    lo, hi = ONSET_BAND_N
    why = f"no training trial loads the spring through {lo:g}-{hi:g} N (where the paper's way reads it)"
    if not fr:
        return [f"friction by contact angle: not measured: {why}"]
    head = "friction by contact angle (N, the paper's way"
    head += "; paper: 2.1 / 2.4 / 4.45 N at three angles):" if paper else "):"
    out = [head, "  " + "  ".join(f"{a}°: {v:.2f}" for a, v in fr.items())]
    if gone:
        out.append(
            f"  not measured at {len(gone)} of {len(gone) + len(fr)} angles ({', '.join(gone)}°): {why}"
        )
    return out
