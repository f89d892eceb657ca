"""The steps of `make demo`: data, models, export with equivalence check, closed loop, discrepancy."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from seagen.actuator import Actuator


def _banner(title: str) -> None:
    print(f"\n=== {title} " + "=" * max(0, 96 - len(title)), flush=True)


def step_data(out: Path, seed: int, act: Actuator | None = None) -> Path:
    """Generate the three splits on the actuator `act` (the paper's when None; kept as data/actuator.toml)
    and print the paper-figure table."""
    from seagen.actuator import default_actuator, to_toml
    from seagen.atomic import write_text
    from seagen.data.friction import measure_friction
    from seagen.data.logimport import declare_own_timing
    from seagen.data.protocol import generate
    from seagen.data.schema import ACTUATOR_FILE, save_csv
    from seagen.fit.data_summary import format_summary, paper_data, summarize
    from seagen.plant import PlantConfig

    cfg = PlantConfig(actuator=act or default_actuator())
    _banner(f"1. data on the simulated SEA (paper §VIII-A protocol; actuator: {cfg.actuator.name})")
    data = out / "data"
    for split, df in generate(cfg, seed=seed).items():
        save_csv(df, data / f"{split}.csv")
    write_text(data / ACTUATOR_FILE, to_toml(cfg.actuator, "the actuator these data were simulated on"))
    declare_own_timing(data)  # as `data generate` does
    paper = paper_data(data)
    print(format_summary(summarize(data), paper))
    fr = measure_friction(cfg)
    print(
        "friction at three angles, slow push"
        + (" (paper Fig. 8: 2.1 / 2.4 / 4.45 N): " if paper else ": ")
        + ", ".join(f"{a:g}°: {v:.2f} N" for a, v in fr.items())
    )
    return data


def step_models(out: Path, data: Path, seed: int) -> dict[str, Path]:
    """Train the four default models and print Tables IV and V."""
    from seagen.data.schema import data_actuator
    from seagen.fit.data_summary import paper_data
    from seagen.fit.evaluate import evaluate, format_tables, frames_and_models, model_names
    from seagen.fit.kinematics import error_threshold_n
    from seagen.fit.plots import write_plots
    from seagen.fit.train import train_defaults

    _banner("2. calibration and control models (paper Tables IV, V)")
    t = time.time()
    models = train_defaults(data, out / "models", seed=seed)
    print(f"trained {', '.join(models)} in {time.time() - t:.1f} s")
    paths = [str(p) for p in models.values()]
    threshold = error_threshold_n(data_actuator(data))
    print(format_tables(evaluate(paths, data), paper_data(data), threshold), end="")
    frames, loaded = frames_and_models(paths, data)
    write_plots(dict(zip(model_names(paths), loaded, strict=True)), frames, out / "plots")
    return models


def step_export(out: Path, data: Path, models: dict[str, Path]) -> None:
    """Export every model to C and check C == numpy == torch == onnxruntime on the data."""
    from seagen.datacheck import check_data_dir
    from seagen.demo import export_defaults

    _banner("3. seagen export: integer-only C, checked bit for bit")
    for prefix, ex in export_defaults(models, out / "generated").items():
        print(f"{prefix}: " + ex.lines[-2] + "; " + ex.lines[-1])
        rep = check_data_dir(ex, str(data))
        print("  " + rep.report().replace("\n", "\n  "))
        if not rep.ok:
            raise SystemExit(f"equivalence check failed for {prefix}")


DEMO_SEEDS = 4  # plant-noise seeds of the closed-loop table (single seeds vary by up to 0.3 s)


def cloud_note() -> str:
    """What the mlp_cloud rows are (docs/cloud.md holds the sources and the sensitivity table)."""
    from seagen.control.link import INTERVAL_S, JITTER_S

    return (
        "mlp_cloud: the float MLP on a PC over the paper's 10 Hz Bluetooth LE rounds "
        f"({INTERVAL_S * 1e3:g} ms connection interval,\nup to {JITTER_S * 1e3:g} ms of the PC's timer "
        "jitter, the paper's 0.1 mm margin on the MCU);\ncompare it with mlp_mcu, the same MLP in C at "
        "100 Hz. No sourced link parameter makes it as slow as\nthe paper's 2.7-3.2 s: the paper's "
        "round-by-round predictor is what the simulation lacks (docs/cloud.md)."
    )


def step_control(out: Path, seed: int, models: dict[str, Path], act: Actuator | None = None) -> None:
    """The paper's force-control experiment in closed loop (Table II), mean and range over noise seeds:
    the shipped configurations on the paper's actuator, the control models just trained on another."""
    from seagen.actuator import is_default
    from seagen.control import experiment as exp
    from seagen.plant import PlantConfig
    from seagen.setups.shipped import CONFIGS
    from seagen.setups.user import control_setups

    _banner(f"4. closed-loop force control (paper Table II; {DEMO_SEEDS} noise seeds)")
    plots = str(out / "plots")
    if act is None or is_default(act):
        print(exp.format_table2(exp.sweep(CONFIGS, seeds=DEMO_SEEDS, seed=seed, plots=plots)))
        print(cloud_note())
    else:  # the shipped models are the paper's actuator's: run the ones trained above, on the MCU
        setups: dict = {}
        rows: dict[str, str] = {}
        for name in ("sf_control", "mlp_control"):
            mine, row = control_setups(str(models[name]))
            setups |= {k: v for k, v in mine.items() if k.endswith("_mcu")}
            rows |= dict.fromkeys(setups.keys() - rows.keys(), row)
        cfg = PlantConfig(actuator=act)
        table = exp.sweep(setups, tuple(setups), DEMO_SEEDS, seed=seed, plots=plots, plant_cfg=cfg)
        print(exp.format_table2(table, rows, paper_figures=False))
    print(f"step-response plots (first seed): {out / 'plots'}/step_*.png")


def step_discrepancy(out: Path, seed: int, act: Actuator | None = None) -> None:
    """The discrepancy workflow on data with a hidden effect (on the actuator `act`)."""
    from seagen.discrepancy.demo import run_demo as discrepancy_demo

    _banner("5. discrepancy workflow: a hidden effect found, named, added")
    discrepancy_demo(out / "discrepancy", seed, act)


def run_demo(out: Path, seed: int = 0, act: Actuator | None = None) -> None:
    """All steps in order, on the actuator `act` (the paper's when None)."""

    t = time.time()
    data = step_data(out, seed, act)
    models = step_models(out, data, seed)
    step_export(out, data, models)
    step_control(out, seed, models, act)
    step_discrepancy(out, seed, act)
    print(f"\ndemo finished in {time.time() - t:.0f} s; outputs in {out}/")
