"""The `make demo` step: measured CSVs with a hidden effect, the workflow from the default base, the gap."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from seagen.actuator import Actuator
from seagen.data.logimport import declare_own_timing
from seagen.data.schema import save_csv
from seagen.discrepancy.bench import case_frames
from seagen.plant import PlantConfig

HIDDEN = ("backlash", {"half_width_mm": 0.08})  # what the "measured" actuator has and the model lacks


def measured_csv(out: Path, seed: int, base: PlantConfig | None = None) -> tuple[Path, PlantConfig]:
    """Two trials at each of six angles from the plant `base` with HIDDEN switched on, as one data-schema
    CSV."""
    name, params = HIDDEN
    truth = (base or PlantConfig()).with_effect(name, True, **params)
    frames = case_frames(truth, seed=seed + 101)
    path = out / "measured.csv"
    save_csv(pd.concat(frames, ignore_index=True), path)
    declare_own_timing(out)  # as `data generate` does
    return path, truth


def run_demo(out: Path, seed: int = 0, act: Actuator | None = None) -> dict:
    """Run the workflow on the measured CSV exactly as `seagen discrepancy --measured` does, on the actuator
    `act` (the paper's when None); print the gap."""
    from seagen.discrepancy.replay import load_measured, load_timing, runs_from_frames
    from seagen.discrepancy.report import summary, write_report
    from seagen.discrepancy.workflow import identify

    out.mkdir(parents=True, exist_ok=True)
    base = PlantConfig() if act is None else PlantConfig(actuator=act)
    path, _ = measured_csv(out, seed, base)
    res = identify(runs_from_frames(load_measured(str(path)), load_timing(str(path))), base)
    write_report(res, out / "report", str(path))
    s = summary(res)
    print(f"hidden in the measured data: {HIDDEN[0]} {HIDDEN[1]}")
    for e in s["effects"]:
        params = ", ".join(f"{k}={v:.4g}" for k, v in e["params"].items())
        print(f"named: {e['name']} ({params}), confidence {e['confidence']:.0%}")
    print(
        f"verdict: {s['verdict']}; held-out residual RMS {s['rms_before']:.3g} -> {s['rms_after']:.3g} "
        f"noise sigmas (noise floor {s['noise_floor']:.3g}); report: {out / 'report' / 'report.md'}"
    )
    return s
