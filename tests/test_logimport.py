"""`seagen data import`: a rig's log in other names, units and rate comes back as the schema's data."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from seagen.cli import main
from seagen.data.logimport import import_log, load_map
from seagen.data.schema import RAW_COLUMNS, DataError, load_csv
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


def import_argv(d, out) -> list[str]:
    """`seagen data import d/rig.csv --map d/map.toml --out out` as an argument list."""
    return ["data", "import", str(d / "rig.csv"), "--map", str(d / "map.toml"), "--out", str(out)]


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
    trial's start, counts and command exactly as logged, forces and angles to float rounding (<1 s)."""
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
    files = ["actuator.toml", "test.csv", "timing.json", "train.csv", "validation.csv"]
    assert sorted(p.name for p in out.iterdir()) == sorted([*files, "logged"])
    assert sorted(p.name for p in (out / "logged").iterdir()) == files
    assert all(list(load_csv(out / f"{s}.csv").columns) == list(RAW_COLUMNS) for s in ("train", "test"))
    assert set(load_derived(out)) == {"train", "test", "validation"}
    measured = load_measured(str(out))
    assert [n for n, _ in measured] == ["test.csv", "train.csv", "validation.csv"]
    assert sum(len(f) for _, f in measured) == len(_rig_log(original)), "the discrepancy reads logged/"
    assert len(runs_from_frames(measured).angle) == len(original)


def test_import_writes_the_control_loops_100_hz_for_training(tmp_path, original) -> None:
    """The 200 Hz log's 100 Hz copy is the original trials again (10 ms grid from each trial's start:
    counts exact, the rest to the CSV's 6 digits), so derive() gives the features the firmware computes at
    its 10 ms loop; the logged rows give a 5 ms step, which derive() refuses naming the file (<1 s)."""
    from seagen.data.features import derive
    from seagen.data.logimport import split_trials

    log = tmp_path / "rig.csv"
    _rig_log(original).to_csv(log, index=False, float_format="%.17g")
    (tmp_path / "map.toml").write_text(MAP)
    out = tmp_path / "data"
    assert main(["data", "import", str(log), "--map", str(tmp_path / "map.toml"), "--out", str(out)]) == 0
    truth = split_trials(pd.concat([f.assign(trial=i) for i, f in enumerate(original)], ignore_index=True))
    for s in ("train", "test", "validation"):
        got, want = derive(load_csv(out / f"{s}.csv")), derive(truth[s])
        assert len(got) == len(want), s
        for c in ("trial", "enc", "pot", "d_enc", "dd_enc", "d_pot", "dd_pot"):
            assert np.array_equal(got[c].to_numpy(), want[c].to_numpy()), (s, c)
        for c in ("t_s", "motor_v", "angle_set_deg", "load_cell_n", "d_compression_mm"):
            assert np.allclose(got[c], want[c], rtol=1e-5, atol=1e-6), (s, c)  # the CSV's %.6g
    with pytest.raises(DataError, match=r"logged/train\.csv: rows are 5 ms apart \(200 Hz\).*10 ms grid"):
        derive(load_csv(out / "logged" / "train.csv"))


def test_250_hz_rig_log_trains_on_the_100_hz_copy_or_exits_2(tmp_path, capsys) -> None:
    """A jittered ~250 Hz rig log (integer-ms clock) through `data import` and `train`: on the --out folder
    the model trains with every trial on the 10 ms grid; on logged/ `train` exits 2 with one line naming
    the file and the 100 Hz copy, and writes no model (~3 s)."""
    from seagen.discrepancy.bench import FAST_MOVES, case_moves
    from seagen.discrepancy.riglog import RIG_MAP, rig_csv, rig_trials

    frames = rig_trials(PlantConfig(), case_moves(FAST_MOVES)[:4], seed=3, convention="from_row")
    (tmp_path / "rig.csv").write_text(rig_csv(frames))
    (tmp_path / "map.toml").write_text(RIG_MAP)
    data = tmp_path / "data"
    assert (
        main(
            [
                "data",
                "import",
                str(tmp_path / "rig.csv"),
                "--map",
                str(tmp_path / "map.toml"),
                "--out",
                str(data),
            ]
        )
        == 0
    )
    grid = load_csv(data / "train.csv")
    for _, part in grid.groupby("trial"):
        assert np.allclose(np.diff(part["t_s"]), 0.01, rtol=0, atol=1e-12)
    capsys.readouterr()
    bad = tmp_path / "bad.pt"
    args = ["train", "--model", "sf", "--loss", "mse", "--task", "calibration"]
    assert main([*args, "--data", str(data / "logged"), "--out", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{data / 'logged' / 'train.csv'}: rows are " in err[0], err
    assert "Hz), but the feature pipeline" in err[0] and "copy `seagen data import` writes" in err[0]
    assert not bad.exists()
    assert main([*args, "--data", str(data), "--out", str(tmp_path / "sf.pt")]) == 0
    assert (tmp_path / "sf.pt").is_file()


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
    args = import_argv(tmp_path, out)
    assert main(args) == 2
    assert needle in capsys.readouterr().err
    assert not out.exists()


@pytest.fixture(scope="module")
def rig_lines() -> list[str]:
    """A rig-style log (jittered ~250 Hz loop, integer-ms clock, three trials) as its CRLF lines."""
    from seagen.discrepancy.bench import FAST_MOVES, case_moves
    from seagen.discrepancy.riglog import rig_csv, rig_trials

    frames = rig_trials(PlantConfig(), case_moves(FAST_MOVES)[:3], seed=4)
    return rig_csv(frames).split("\r\n")[:-1]


def _set(lines: list[str], i: int, col: int, value: str) -> list[str]:
    """lines with data row i's (0-based, header excluded) field col replaced."""
    out = list(lines)
    cells = out[i + 1].split(",")
    cells[col] = value
    out[i + 1] = ",".join(cells)
    return out


def _ms(lines: list[str], i: int) -> int:
    """The millis of data row i."""
    return int(lines[i + 1].split(",")[0])


def _gap(lines: list[str], i: int, ms: int) -> list[str]:
    """A pause of `ms` before data row i (every later time moved)."""
    out = list(lines)
    for j in range(i, len(lines) - 1):
        out = _set(out, j, 0, str(_ms(lines, j) + ms))
    return out


BROKEN = [
    # (what, edit of the lines, map edit, what the one line must say)
    (
        "two swapped timestamps",
        lambda x: _set(_set(x, 10, 0, str(_ms(x, 11))), 11, 0, str(_ms(x, 10))),
        None,
        "row 13, column 'millis': time goes backwards inside a trial",
    ),
    (
        "a duplicated row",
        lambda x: x[:21] + [x[21]] + x[21:],
        None,
        "row 23, column 'millis': time repeats inside a trial (the whole row repeats row 22)",
    ),
    (
        "a repeated timestamp with other values",
        lambda x: _set(x, 30, 0, str(_ms(x, 29))),
        None,
        "row 32, column 'millis': time repeats inside a trial",
    ),
    (
        "a 2 s gap mid-push",
        lambda x: _gap(x, 40, 2000),
        None,
        "row 42, column 'enc': trial 1 does not start at rest",
    ),
    ("a 5 Hz log", lambda x: x[:1] + x[1::50], None, "at least 50 Hz is needed"),
    ("a 20 Hz log", lambda x: x[:1] + x[1::12], None, "at least 50 Hz is needed"),
    (
        "pot counts beyond full scale",
        lambda x: x,
        lambda m: m.replace("full_scale = 3300.0", "full_scale = 500.0"),
        "column 'pot_mV': pot",
    ),
    (
        "a comment line the map does not declare",
        lambda x: ["# rig 3, firmware 1.2"] + x,
        None,
        "column 'millis' (mapped to t_s) not in the log",
    ),
    (
        "unit = s on a millisecond column",
        lambda x: x,
        lambda m: m.replace('unit = "ms"', 'unit = "s"'),
        "column 'millis': the median time step is 4 s (0.25 Hz with unit \"s\"); at least 50 Hz is needed",
    ),
]


@pytest.mark.parametrize("what, edit, map_edit, needle", BROKEN, ids=[b[0] for b in BROKEN])
def test_broken_rig_log_is_refused(tmp_path, capsys, rig_lines, what, edit, map_edit, needle) -> None:
    """Every broken log: exit 2, one line naming the file, row and column, nothing written (<1 s each)."""
    from seagen.discrepancy.riglog import RIG_MAP

    (tmp_path / "rig.csv").write_text("\r\n".join(edit(rig_lines)) + "\r\n")
    (tmp_path / "map.toml").write_text(map_edit(RIG_MAP) if map_edit else RIG_MAP)
    out = tmp_path / "data"
    args = import_argv(tmp_path, out)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "rig.csv" in err and needle in err, err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_comment_lines_are_skipped_when_the_map_says_so(tmp_path, rig_lines) -> None:
    """`[log] comment = "#"`: comment lines are skipped and row numbers still count them."""
    from seagen.discrepancy.riglog import RIG_MAP

    lines = ["# rig 3, firmware 1.2"] + rig_lines
    (tmp_path / "rig.csv").write_text("\r\n".join(lines) + "\r\n")
    (tmp_path / "map.toml").write_text(RIG_MAP + '[log]\ncomment = "#"\n')
    got = import_log(tmp_path / "rig.csv", load_map(tmp_path / "map.toml"))
    assert len(got) == len(rig_lines) - 1 and sorted(got["trial"].unique()) == [0, 1, 2]
    bad = _set(rig_lines, 5, 3, "x")
    (tmp_path / "rig.csv").write_text("\r\n".join(["# rig 3"] + bad) + "\r\n")
    with pytest.raises(Exception, match=r"row 8, column 'enc'"):
        import_log(tmp_path / "rig.csv", load_map(tmp_path / "map.toml"))
