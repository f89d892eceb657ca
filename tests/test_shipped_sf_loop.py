"""Every shipped example design: its SF control model, trained as the shipped one is (MAE, the paper's SF
loss), settles its closed loop at 25, 50 and 75 % of force_max_n (the issue's promise for shipped designs)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import run_cli

EXAMPLES = Path(__file__).parents[1] / "examples" / "actuators"


@pytest.mark.slow  # ~1-2 min each: data generate, a surface fit, 60 closed-loop runs
@pytest.mark.parametrize(
    "name",
    ["micro_6v", "stiff_24v", "fast_48v"],
)
def test_shipped_design_sf_control_loop_settles(name, tmp_path):
    """With the MAE surface fit the loop follows the loading branch of the friction loop, where it ends
    (on micro_6v an MSE fit sits between the branches: 0.85-1.1 N off, none settled): at each target at
    least 9 of the 10 contact angles settle within the +-0.3 N band and the average error is under it
    (micro_6v measured: 10 of 10, 0.08 / 0.09 / 0.15 N). fast_48v settles since seagen tune's margin is at
    most 0.21 N on any spring and its kp and ki reach the gain the stalled motor needs (its earlier 0.59 N
    dead band and 1.6 N proportional droop at 45 N left it 0.46-0.48 N off, none settled)."""
    data, model = tmp_path / "data", tmp_path / "control.pt"
    act = EXAMPLES / f"{name}.toml"
    code, _, err = run_cli("data", "generate", "--actuator", str(act), "--out", str(data))
    assert code == 0, err
    args = ("--data", str(data), "--model", "sf", "--task", "control", "--loss", "mae", "--out", str(model))
    code, _, err = run_cli("train", *args)
    assert code == 0, err
    code, out, err = run_cli("simulate", "--model", str(model), "--seeds", "1", "--json")
    assert code == 0, err
    (rows,) = [v for k, v in json.loads(out).items() if k.endswith("_mcu")]
    assert len(rows) == 3
    for row in rows.values():
        assert row["settled"] >= 9 and row["error_avg_n"] < 0.3, row
