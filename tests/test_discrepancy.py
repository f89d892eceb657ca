"""Discrepancy workflow: replay exactness, CLI end to end, bad input (exit 2, no partial report)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from seagen.cli import main
from seagen.data.schema import save_csv
from seagen.discrepancy.bench import case_frames, make_case, measure
from seagen.discrepancy.replay import simulate
from seagen.plant import Plant, PlantConfig, load_config


def _quiet(cfg: PlantConfig) -> PlantConfig:
    """cfg without sensor noise (so the replay must match to the rounding)."""
    cfg = cfg.with_effect("pot_noise", False)
    cfg.load_cells.horizontal_sigma_n = cfg.load_cells.vertical_sigma_n = 0.0
    return cfg


@pytest.mark.parametrize(
    "effect, params",
    [
        (None, {}),
        ("transport_delay", {"delay_s": 0.03}),
        ("backlash", {"half_width_mm": 0.1}),
        ("series_compliance", {"beta_mm_per_n2": 0.0}),
        ("load_cell_offset", {"offset_n": -0.7}),
    ],
)
def test_replay_reproduces_the_plant(effect: str | None, params: dict) -> None:
    """Replaying the recorded command through the same plant gives every signal back up to rounding."""
    cfg = _quiet(PlantConfig() if effect is None else PlantConfig().with_effect(effect, True, **params))
    runs = measure(cfg, seed=1, fast=True).take([0, 5, 11])
    sim = simulate(cfg, [{}], runs)
    for c, tol in (("enc", 0.5 + 1e-6), ("pot", 0.5 + 1e-6), ("load_cell_n", 1e-9), ("force_n", 1e-9)):
        err = np.abs(runs.meas[c] - sim[c][0])[runs.mask]
        assert err.max() <= tol, f"{effect}: {c} off by {err.max()}"


def test_plant_structure_law_accepts_per_element_parameters() -> None:
    """Per-element compliance parameters (as the replay batches them) give each element's scalar law."""
    cfg = PlantConfig()
    y = np.linspace(0.0, 6.0, 50)
    k, beta = np.where(np.arange(50) % 2 == 0, 30.0, 45.0), np.where(np.arange(50) % 3 == 0, 0.0, 0.005)
    arr = cfg.with_effect("series_compliance", True, k_n_per_mm=k, beta_mm_per_n2=beta)
    f_arr, s_arr = Plant(arr, np.full(50, 12.0)).structure_force(y)
    for i in range(50):
        one = cfg.with_effect(
            "series_compliance", True, k_n_per_mm=float(k[i]), beta_mm_per_n2=float(beta[i])
        )
        f, sl = Plant(one, 12.0).structure_force(y[i : i + 1])
        assert np.allclose(f_arr[i], f[0]) and np.allclose(s_arr[i], sl[0]), i


def _write(case_runs_cfg: PlantConfig, path, seed: int = 3) -> None:
    """A measured CSV from the plant `cfg` (two quick trials at six angles)."""
    save_csv(pd.concat(case_frames(case_runs_cfg, seed, fast=True), ignore_index=True), path)


def test_cli_names_adds_and_reports(tmp_path, capsys) -> None:
    """The command names a hidden spring preload, writes plant.toml with it on, the report, maps, JSON
    (also the fast suite's case of spring_preload named; ~10 s)."""
    _write(PlantConfig().with_effect("spring_preload", True, force_n=1.2), tmp_path / "m.csv")
    out = tmp_path / "rep"
    assert main(["discrepancy", "--measured", str(tmp_path), "--out", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert {"effects", "rms_before", "rms_after", "noise_floor", "verdict"} <= set(s)
    assert [e["name"] for e in s["effects"]] == ["spring_preload"]
    assert s["effects"][0]["params"]["force_n"] == pytest.approx(1.2, abs=0.12)
    assert s["rms_after"] < 0.5 * s["rms_before"] and s["rms_after"] <= 1.2 * s["noise_floor"]
    cfg = load_config(out / "plant.toml")
    assert cfg.on("spring_preload")
    for f in ("report.md", "residual_maps.png", "regions_before.csv", "gap_by_region.csv"):
        assert (out / f).stat().st_size > 0


@pytest.mark.parametrize(
    "make, needle",
    [
        (lambda d: None, "no such file"),
        (lambda d: (d / "m.csv").write_text("trial,t_s\n0,0.0\n"), "missing column"),
        (
            lambda d: (d / "m.csv").write_text(
                "trial,t_s,angle_set_deg,motor_v,enc,pot,load_cell_n,force_n\n0,0.0,10,2.5,0,700,x,0.1\n"
            ),
            "row 2, column 'load_cell_n'",
        ),
    ],
)
def test_bad_measured_exits_2_without_report(tmp_path, capsys, make, needle: str) -> None:
    """Missing or broken measured data: exit 2, the message names file/row/column, no report dir."""
    data = tmp_path / "data"
    if make(tmp_path) is not None or (tmp_path / "m.csv").exists():
        data = tmp_path / "m.csv"
    out = tmp_path / "rep"
    assert main(["discrepancy", "--measured", str(data), "--out", str(out)]) == 2
    assert needle in capsys.readouterr().err
    assert not out.exists()


def test_bad_base_exits_2(tmp_path, capsys) -> None:
    """A base TOML with an unknown key: exit 2 naming the file and key, no report."""
    _write(PlantConfig(), tmp_path / "m.csv")
    bad = tmp_path / "base.toml"
    bad.write_text("[effects.backlash]\nwidth = 3\n")
    out = tmp_path / "rep"
    assert (
        main(["discrepancy", "--measured", str(tmp_path / "m.csv"), "--base", str(bad), "--out", str(out)])
        == 2
    )
    err = capsys.readouterr().err
    assert "base.toml" in err and "width" in err
    assert not out.exists()


def test_case_hides_only_the_named_effects() -> None:
    """A hidden-effect case: the base lacks exactly the hidden effects, which have parameters in range."""
    case = make_case(("viscous_friction", "backlash"), seed=4, fast=True)
    assert not case.base.on("viscous_friction") and not case.base.on("backlash")
    assert case.base.on("actuator_friction") and set(case.hidden) == {"viscous_friction", "backlash"}
    assert len(case.runs.angle) == 12
