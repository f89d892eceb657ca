"""`seagen data import`: a rig's log in other names, units and rate comes back as the schema's data."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from seagen.cli import main
from seagen.data.logimport import import_log, load_map
from seagen.data.schema import RAW_COLUMNS, load_csv
from seagen.discrepancy.bench import case_frames
from seagen.plant import PlantConfig

MAP = """
[columns.t_s]
column = "time_ms"
unit = "ms"
[columns.angle_set_deg]
column = "contact_rad"
unit = "rad"
[columns.motor_v]
column = "cmd_mV"
unit = "mV"
[columns.enc]
column = "enc"
unit = "counts"
[columns.pot]
column = "pot_mV"
unit = "mV"
full_scale = 3300.0
[columns.load_cell_n]
column = "tip_kgf"
unit = "kgf"
[columns.force_n]
column = "shaft_lbf"
unit = "lbf"
[trials]
gap_s = 0.5
"""


@pytest.fixture(scope="module")
def original() -> list[pd.DataFrame]:
    """Four simulated trials in seagen's schema (quick moves)."""
    return case_frames(PlantConfig(), seed=7, fast=True)[:4]


def _rig_log(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """The trials as a rig would log them: 200 Hz, ms clock from power-on, mV, rad, kgf, lbf, no trial column;
    the in-between samples hold the command and the counts and interpolate the forces."""
    rows, t0 = [], 12_345.0
    for df in frames:
        n = len(df)
        t = np.arange(2 * n - 1) * 5.0
        k = np.arange(2 * n - 1) // 2
        mid = (np.arange(2 * n - 1) % 2).astype(bool)

        nxt = np.minimum(k + 1, n - 1)
        lin = {
            c: np.where(
                mid, 0.5 * (df[c].to_numpy(float)[k] + df[c].to_numpy(float)[nxt]), df[c].to_numpy(float)[k]
            )
            for c in ("load_cell_n", "force_n")
        }

        rows.append(
            pd.DataFrame(
                {
                    "time_ms": t0 + t,
                    "contact_rad": np.radians(df["angle_set_deg"].to_numpy(float))[k],
                    "cmd_mV": df["motor_v"].to_numpy(float)[k] * 1000.0,
                    "enc": df["enc"].to_numpy()[k],
                    "pot_mV": df["pot"].to_numpy(float)[k] * 3300.0 / 4095.0,
                    "tip_kgf": lin["load_cell_n"] / 9.80665,
                    "shaft_lbf": lin["force_n"] / 4.4482216152605,
                }
            )
        )
        t0 += t[-1] + 2000.0  # two seconds between trials
    return pd.concat(rows, ignore_index=True)


def test_import_keeps_every_row_at_its_own_time(tmp_path, original) -> None:
    """A 200 Hz log in other units is cut into its trials and kept row for row: each row's time from its
    trial's start, the counts and the command exactly as logged, forces and angles to float rounding (<1 s)."""
    log = tmp_path / "rig.csv"
    rig = _rig_log(original)
    rig.to_csv(log, index=False, float_format="%.17g")
    (tmp_path / "map.toml").write_text(MAP)
    got = import_log(log, load_map(tmp_path / "map.toml"))
    assert sorted(got["trial"].unique()) == list(range(len(original)))
    assert len(got) == len(rig)
    for i, df in enumerate(original):
        part = got[got["trial"] == i].reset_index(drop=True)
        assert len(part) == 2 * len(df) - 1
        assert np.allclose(part["t_s"], np.arange(len(part)) * 0.005, rtol=0, atol=1e-12)
        even = part.iloc[::2].reset_index(drop=True)
        for c in ("enc", "pot"):
            assert np.array_equal(even[c].to_numpy(), df[c].to_numpy()), c
        for c in ("angle_set_deg", "motor_v", "load_cell_n", "force_n"):
            assert np.allclose(even[c], df[c], rtol=1e-9, atol=1e-9), c


def test_cli_writes_splits_train_and_discrepancy_accept(tmp_path, original, capsys) -> None:
    """`seagen data import` writes train/test/validation CSVs that load with the schema, derive for
    training and replay for the discrepancy workflow (<2 s)."""
    from seagen.discrepancy.replay import load_measured, runs_from_frames
    from seagen.fit.train import load_derived

    log = tmp_path / "rig.csv"
    _rig_log(original).to_csv(log, index=False)
    (tmp_path / "map.toml").write_text(MAP)
    out = tmp_path / "data"
    assert main(["data", "import", str(log), "--map", str(tmp_path / "map.toml"), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["import.json", "test.csv", "train.csv", "validation.csv"]
    assert all(list(load_csv(out / f"{s}.csv").columns) == list(RAW_COLUMNS) for s in ("train", "test"))
    assert set(load_derived(out)) == {"train", "test", "validation"}
    assert len(runs_from_frames(load_measured(str(out))).angle) == len(original)


@pytest.mark.parametrize(
    "edit, needle",
    [
        (lambda log, m: log.replace("\n1", "\nx1", 1), "rig.csv, row 2, column 'time_ms': not a finite"),
        (lambda log, m: log, "columns.load_cell_n.unit: unknown unit 'stone'"),
        (lambda log, m: log.replace("tip_kgf", "tip"), "column 'tip_kgf' (mapped to load_cell_n) not in"),
    ],
)
def test_bad_log_or_map_exits_2_and_writes_nothing(tmp_path, original, capsys, edit, needle) -> None:
    """A bad cell, unit or column: exit 2, one line naming file, row and column; no output folder (<1 s)."""
    text = _rig_log(original[:3]).to_csv(index=False)
    mapping = MAP.replace('unit = "kgf"', 'unit = "stone"') if "stone" in needle else MAP
    (tmp_path / "rig.csv").write_text(edit(text, mapping))
    (tmp_path / "map.toml").write_text(mapping)
    out = tmp_path / "data"
    args = [
        "data",
        "import",
        str(tmp_path / "rig.csv"),
        "--map",
        str(tmp_path / "map.toml"),
        "--out",
        str(out),
    ]
    assert main(args) == 2
    assert needle in capsys.readouterr().err
    assert not out.exists()
