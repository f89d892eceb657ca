"""`seagen discrepancy bench --actuator FILE`: the cases simulate that design and its rig logs are imported
with it; a description that cannot be read is refused (exit 2, naming the file)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from seagen.actuator import default_actuator, load_actuator
from seagen.cli import main
from seagen.discrepancy import bench as dbench
from seagen.discrepancy import rigbench

STIFF = Path(__file__).resolve().parents[1] / "examples" / "actuators" / "stiff_24v.toml"


def test_case_angles_come_from_the_linkage_range() -> None:
    """The paper's six case angles are kept; a narrower linkage range moves them inside it."""
    assert dbench.case_angles() == (6.0, 10.0, 14.0, 18.0, 22.0, 26.0)
    act = default_actuator()
    narrow = dataclasses.replace(
        act, linkage=dataclasses.replace(act.linkage, angle_min_deg=8.0, angle_max_deg=20.0, split_deg=14.0)
    )
    angles = dbench.case_angles(narrow)
    assert angles[0] == 9.0 and angles[-1] == 18.0 and len(angles) == 6
    assert {m.angle_deg for m in dbench.case_moves(act=narrow)} == set(angles)


def test_default_mode_cases_run_on_the_given_design() -> None:
    """A case of `bench --actuator` simulates that design: its base carries it, rows at its loop rate."""
    act = load_actuator(STIFF)
    case = dbench.make_case(("backlash",), 3, fast=True, act=act)
    assert case.base.actuator == act
    dt = np.diff(case.runs.t[0][case.runs.mask[0]])
    assert np.allclose(dt, 1.0 / act.loop_hz)


def test_rig_bench_on_the_second_design_leaves_nothing_hidden_alone(monkeypatch, capsys) -> None:
    """`bench --rig --quick --actuator stiff_24v.toml` (two of its nothing-hidden cases, 200 Hz, both
    conventions and both dialects; ~5 s): logs written in % of the 24 V supply and imported with that
    actuator, verdict none, nothing added or recalibrated, the command timing found."""
    seen = []
    real_import = rigbench.import_log

    def spy(log, mapping, act=None):
        seen.append(act)
        return real_import(log, mapping, act)

    full = rigbench.plan
    monkeypatch.setattr(rigbench, "plan", lambda seeds: [c for c in full(seeds) if c[0] == "control"][:2])
    monkeypatch.setattr(rigbench, "import_log", spy)
    args = ["discrepancy", "bench", "--rig", "--quick", "--seeds", "1", "--jobs", "1", "--json"]
    assert main([*args, "--actuator", str(STIFF)]) == 0
    out = json.loads(capsys.readouterr().out)
    act = load_actuator(STIFF)
    assert out["actuator"] == act.name and seen == [act, act]
    assert [c["dialect"] for c in out["cases"]] == [0, 1]
    assert out["control_untouched_rate"] == 1.0, out["cases"]
    assert out["lag_found_rate"] == 1.0, out["cases"]


@pytest.mark.parametrize("flags", [[], ["--rig"], ["--families"]])
def test_bad_actuator_exits_2_naming_the_file(tmp_path, capsys, flags) -> None:
    """A description that cannot be used stops the bench before any case runs."""
    bad = tmp_path / "bad.toml"
    bad.write_text(STIFF.read_text().replace("stiffness_n_per_mm = 8.4", "stiffness_n_per_mm = -8.4"))
    assert main(["discrepancy", "bench", *flags, "--seeds", "1", "--actuator", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "stiffness_n_per_mm" in err and "Traceback" not in err
    missing = tmp_path / "none.toml"
    assert main(["discrepancy", "bench", *flags, "--actuator", str(missing)]) == 2
    assert str(missing) in capsys.readouterr().err
