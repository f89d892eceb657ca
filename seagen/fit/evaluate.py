"""`seagen evaluate`: the paper's Table IV (calibration) and Table V (control) for trained model files."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pandas as pd

from seagen.data.schema import data_actuator
from seagen.errors import UserError
from seagen.fit.kinematics import error_threshold_n
from seagen.fit.predict import TASKS, UNIT, kinematics_predict, predict, task_errors
from seagen.fit.train import check_scorable, load_derived
from seagen.geometry import geometry
from seagen.modelfile import load_model, model_actuator

SCORED_SPLITS = ("test", "validation")
REQUIRED_KEYS = ("kind", "task", "features", "output_name")
# The paper's rows (Tables IV and V): (label, avg, max, avg %, max %).
PAPER = {
    "calibration": (
        ("Kinematics Calc", 3.55, 9.38, 34.31, 44.7),
        ("SF(MAE)", 0.886, 7.261, 8.06, 35.72),
        ("MLP(MSE)", 1.120, 5.304, 10.18, 29.13),
    ),
    "control": (("SF(MAE)", 0.347, 1.946, 7.99, 38.15), ("MLP(MSE)", 0.409, 1.505, 9.38, 30.00)),
}
TITLES = {
    "calibration": "Table IV  force calibration (error in N)",
    "control": "Table V  force control: compression predictor (error in mm)",
}


def load_checked(path: str | os.PathLike[str], allow_pickle: bool = False) -> dict[str, Any]:
    """Load a model file (no code runs unless allow_pickle) and check the keys evaluation needs."""
    obj = load_model(path, allow_pickle)
    for key in REQUIRED_KEYS:
        if key not in obj:
            raise UserError(f"{path}: model file has no '{key}' field")
    if obj["task"] not in TASKS:
        raise UserError(f"{path}: field 'task' is {obj['task']!r}, not one of {', '.join(TASKS)}")
    if obj["kind"] == "mlp" and "module" not in obj:
        raise UserError(f"{path}: MLP model file has no 'module' field")
    if obj["kind"] == "sf" and "sf" not in obj:
        raise UserError(f"{path}: SF model file has no 'sf' field")
    return obj


def model_names(paths: list[str]) -> list[str]:
    """File stems as model names; the full path where stems collide."""
    stems = [Path(p).stem for p in paths]
    return [s if stems.count(s) == 1 else str(p) for s, p in zip(stems, paths, strict=True)]


def _scores(task: str, pred_of: Any, frames: dict[str, pd.DataFrame], threshold_n: float) -> dict[str, Any]:
    """Test errors at top level and validation errors under 'validation' (the --json layout)."""
    out: dict[str, Any] = {}
    for split in SCORED_SPLITS:
        if split not in frames:
            continue
        errs = task_errors(task, pred_of(frames[split]), frames[split], threshold_n)
        if split == "test":
            out.update(errs)
        else:
            out[split] = errs
    return out


def evaluate(
    paths: list[str], data_dir: str | os.PathLike[str], allow_pickle: bool = False
) -> dict[str, dict[str, Any]]:
    """Scores of each model and of the kinematics baseline of each task present, keyed by name."""
    if not paths:
        raise UserError("evaluate: name at least one model file")
    models = [load_checked(p, allow_pickle) for p in paths]
    frames = load_derived(data_dir, need=("test",))
    act = data_actuator(data_dir)
    for p, m in zip(paths, models, strict=True):
        model_actuator(m, str(p), act)  # a model of another actuator is refused
    check_scorable(data_dir, frames, act)  # no row to score: refused, not "nan %"
    geo, threshold = geometry(act), error_threshold_n(act)
    result: dict[str, dict[str, Any]] = {}
    for task in TASKS:
        if any(m["task"] == task for m in models):
            base = _scores(task, lambda df, t=task: kinematics_predict(t, df, geo), frames, threshold)
            result[f"kinematics_{task}"] = {"task": task, "kind": "kinematics", "unit": UNIT[task], **base}
    for name, m in zip(model_names(paths), models, strict=True):
        scores = _scores(m["task"], lambda df, m=m: predict(m, df), frames, threshold)
        meta = {"task": m["task"], "kind": m["kind"], "loss": m.get("loss"), "unit": UNIT[m["task"]]}
        result[name] = {**meta, "hidden": m.get("hidden"), **scores}
    return result


def _label(name: str, r: dict[str, Any]) -> str:
    """Row label: name and method, e.g. 'sf_calibration  SF(MAE)'."""
    if r["kind"] == "kinematics":
        return "Kinematics Calc"
    method = f"{r['kind'].upper()}({str(r.get('loss') or '?').upper()})"
    if r.get("hidden"):
        method += " " + "-".join(str(h) for h in r["hidden"])
    return f"{name}  {method}"


def _row(label: str, vals: tuple[float, ...], unit: str) -> str:
    """One table row: avg, max (unit) and avg, max (%)."""
    a, m, ap, mp = vals
    return f"  {label:<38}{a:>9.3f} {unit:<3}{m:>9.3f} {unit:<3}{ap:>9.2f} %{mp:>9.2f} %"


def format_tables(result: dict[str, dict[str, Any]], paper: bool, threshold_n: float) -> str:
    """The Table IV / V layout: one block per task and split (rows with force above `threshold_n`: the data's
    kinematics.error_threshold_n), methods side by side, the paper's rows below when `paper` (data of the
    paper's actuator: fit.data_summary.paper_data)."""
    lines: list[str] = []
    keys = ("error_avg_n", "error_max_n", "error_avg_pct", "error_max_pct")
    for task in TASKS:
        rows = {n: r for n, r in result.items() if r["task"] == task}
        if not rows:
            continue
        unit = UNIT[task]
        for split in SCORED_SPLITS:
            scored = {n: (r if split == "test" else r.get(split)) for n, r in rows.items()}
            if not any(v and "error_avg_n" in v for v in scored.values()):
                continue
            n_rows = next(v["rows"] for v in scored.values() if v and "rows" in v)
            lines.append(f"{TITLES[task]} — {split} set, {n_rows} rows with force > {threshold_n:g} N")
            lines.append(
                f"  {'method':<38}{'error avg':>13}{'error max':>13}{'error avg':>11}{'error max':>11}"
            )
            for name, v in scored.items():
                if v and "error_avg_n" in v:
                    lines.append(_row(_label(name, rows[name]), tuple(v[k] for k in keys), unit))
            lines.append("")
        if paper:
            lines.append(f"  paper ({'Table IV, test' if task == 'calibration' else 'Table V, validation'}):")
            lines += [_row(f"paper {p[0]}", p[1:], unit) for p in PAPER[task]]
            lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def frames_and_models(
    paths: list[str], data_dir: str | os.PathLike[str], allow_pickle: bool = False
) -> tuple[dict, list[dict]]:
    """Derived splits and loaded models (for the plots)."""
    return load_derived(data_dir, need=("test",)), [load_checked(p, allow_pickle) for p in paths]
