"""seagen data generate / summary and validated loading: exact row counts, JSON keys, clear errors."""

from __future__ import annotations

import json

import pytest

from seagen.cli import main
from seagen.data.schema import RAW_COLUMNS, load_csv
from tests.conftest import run_cli


def test_generated_splits_have_paper_row_counts(data_dir):
    """train 10,400, test 2,416, validation 140 rows; the raw columns exactly as specified; 12 + 1 angles."""
    rows = {s: load_csv(data_dir / f"{s}.csv") for s in ("train", "test", "validation")}
    assert {s: len(df) for s, df in rows.items()} == {"train": 10400, "test": 2416, "validation": 140}
    for df in rows.values():
        assert list(df.columns)[: len(RAW_COLUMNS)] == list(RAW_COLUMNS)
    assert rows["train"].angle_set_deg.nunique() == 12 and rows["test"].angle_set_deg.nunique() == 12
    assert rows["validation"].angle_set_deg.nunique() == 1
    assert rows["validation"].angle_set_deg.iloc[0] not in set(rows["train"].angle_set_deg)


def test_summary_json(data_dir, capsys):
    """`seagen data summary --json` prints rows per split and the kinematics errors."""
    assert main(["data", "summary", str(data_dir), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["rows"] == {"train": 10400, "test": 2416, "validation": 140}
    assert 30 <= s["kinematics_error_avg_pct"] <= 40 and 40 <= s["kinematics_error_max_pct"] <= 50


def _corrupt(data_dir, tmp_path, edit):
    lines = (data_dir / "test.csv").read_text().splitlines()
    edit(lines)
    p = tmp_path / "test.csv"
    p.write_text("\n".join(lines) + "\n")
    return p


def _set_cell(lines, row, col, value):
    header = lines[0].split(",")
    cells = lines[row - 1].split(",")
    cells[header.index(col)] = value
    lines[row - 1] = ",".join(cells)


BAD_CSV = {
    "missing column": (
        lambda L: L.__setitem__(0, L[0].replace("pot", "pott")),
        "column 'pot'",
        "missing column",
    ),
    "non-numeric": (lambda L: _set_cell(L, 7, "enc", "abc"), "row 7, column 'enc'", "not a number"),
    "nan": (lambda L: _set_cell(L, 9, "force_n", "nan"), "row 9, column 'force_n'", "NaN"),
    "time backwards": (lambda L: _set_cell(L, 12, "t_s", "-1"), "row 12, column 't_s'", "backwards"),
    "fractional count": (lambda L: _set_cell(L, 5, "pot", "12.5"), "row 5, column 'pot'", "not an integer"),
}


@pytest.mark.parametrize("case", sorted(BAD_CSV))
def test_bad_csv_names_file_row_column_exit_2(case, data_dir, tmp_path):
    """A bad cell or column: message names file, row and column; exit 2; no traceback."""
    edit, where, what = BAD_CSV[case]
    p = _corrupt(data_dir, tmp_path, edit)
    code, _, err = run_cli("data", "summary", str(tmp_path), "--json")
    assert code == 2 and "Traceback" not in err
    assert str(p) in err and where in err and what in err, err


def test_generate_with_bad_config_writes_nothing(tmp_path):
    """A bad --config: exit 2 with the key named, and no output files."""
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[effects.nope]\nenabled = true\n")
    out = tmp_path / "out"
    code, _, err = run_cli("data", "generate", "--out", str(out), "--config", str(cfg))
    assert code == 2 and "effects.nope" in err
    assert not out.exists() or not any(out.iterdir())


def test_generate_cli_and_seed(tmp_path, data_dir):
    """`seagen data generate` writes the three splits; the same seed gives identical files (here: the CLI's
    seed 0 and the session's seed-0 set, written by the library, maybe in another process); beside them
    the command timing of seagen's own rows (up_to_row), which the discrepancy replay then pins."""
    from seagen.discrepancy.replay import load_measured, load_timing, runs_from_frames

    assert main(["data", "generate", "--out", str(tmp_path / "a"), "--seed", "0"]) == 0
    for s in ("train", "test", "validation"):
        assert (tmp_path / "a" / f"{s}.csv").read_bytes() == (data_dir / f"{s}.csv").read_bytes()
    timing = load_timing(str(tmp_path / "a"))
    assert timing["command"] == "up_to_row" and timing["lag"] == 1.0
    assert runs_from_frames(load_measured(str(tmp_path / "a" / "test.csv")), timing).declared == 1.0


def test_stair_move_holds_at_rest_on_the_loading_side():
    """A stair move climbs in position-held steps after contact: most of its loaded rows are at rest
    (|d_enc| <= 1 count), the force of successive holds rises, and a constant-volts move has no such rows."""
    import numpy as np

    from seagen.data.features import derive
    from seagen.data.protocol import Move, run_trials
    from seagen.plant import PlantConfig

    moves = [Move(16.0, 3.0, 14.0, -6.0, 0.5), Move(16.0, 3.0, 14.0, -6.0)]
    stair, plain = (derive(df.assign(trial=0)) for df in run_trials(PlantConfig(), moves, 2))
    for df, want in ((stair, True), (plain, False)):
        loaded = df[(df["force_n"] > 2.0) & (df["d_enc"] >= -1)]
        rest = loaded[loaded["d_enc"].abs() <= 1]
        assert (len(rest) > 0.4 * len(loaded)) is want
    rest = stair[(stair["force_n"] > 2.0) & (stair["d_enc"].abs() <= 1)]
    holds = rest.groupby((rest.index.to_series().diff() != 1).cumsum())["force_n"].median()
    assert len(holds) >= 4 and np.all(np.diff(holds.to_numpy()) > 0.5)
