"""A rig's log -> seagen's CSV schema: a TOML column map with units, trials, each row at its own time.

The map (see README "Data from your rig"):

    [columns.t_s]            column = "time_ms", unit = "ms"      # required: time, any rate >= MIN_RATE_HZ
    [columns.trial]          column = "run"                        # optional
    [columns.angle_set_deg]  column = "contact", unit = "rad"      # or: value = 14.0
    [columns.motor_v]        column = "pwm", unit = "%"            # % of the motor supply, V or mV
    [columns.enc]            column = "enc", unit = "counts"
    [columns.pot]            column = "pot_mV", unit = "mV", full_scale = 3300.0
    [columns.load_cell_n]    column = "tip_kgf", unit = "kgf"
    [columns.force_n]        column = "shaft_lbf", unit = "lbf"
    [trials]                 gap_s = 1.0    # without a trial column: a new trial where time jumps or resets
    [log]                    comment = "#", command = "from_row"   # both optional

Every mapped value is read as `raw * scale + offset` (both optional) in the given unit, then converted.
Ranges and units read the actuator description (--actuator; the paper's by default): pot counts within its
ADC, a PWM duty in % of its motor supply, motor volts within +-supply.
The --out folder gets the trials resampled to the description's control-loop rate (what train, evaluate
and export read: the features difference consecutive loop samples) and, in logged/, the rows as logged:
t_s is each row's own time from its trial's first row; the discrepancy replay reads those and applies each
logged command at its own instant. `[log] command` pins which interval a logged command covers
("from_row": applied from its row on, the usual rig loop; "up_to_row": applied up to its
row, seagen's own data); without it the discrepancy workflow finds it from the data.
"""

from __future__ import annotations

import itertools
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from seagen.actuator import Actuator, default_actuator
from seagen.data.schema import RAW_COLUMNS, DataError
from seagen.errors import not_a_file
from seagen.fields import read_toml

_LBF_N = 4.4482216152605
COMMAND_TIMING = {"from_row": 0.0, "up_to_row": 1.0}  # [log] command -> the replay's command lag
# seagen's own rows (data.protocol.run_trials): a row's command is the one applied since the row before
OWN_COMMAND = "up_to_row"
TIMING_FILE = "timing.json"  # what is known of a data folder's timing, beside its CSVs
LOGGED = "logged"  # `data import`'s folder of the rows as logged, beside the copy on the loop-rate grid
_KGF_N = 9.80665
# Per schema column: accepted units and the factor to seagen's unit (nan: from the actuator description,
# pot 'mV'/'V' with the map's full_scale, motor_v '%' of the motor supply).
UNITS: dict[str, dict[str, float]] = {
    "t_s": {"s": 1.0, "ms": 1e-3, "us": 1e-6},
    "trial": {"": 1.0},
    "angle_set_deg": {"deg": 1.0, "rad": 180.0 / np.pi},
    "motor_v": {"V": 1.0, "mV": 1e-3, "%": np.nan},
    "enc": {"counts": 1.0},
    "pot": {"counts": 1.0, "mV": np.nan, "V": np.nan},
    "load_cell_n": {"N": 1.0, "kgf": _KGF_N, "gf": _KGF_N * 1e-3, "lbf": _LBF_N},
    "force_n": {"N": 1.0, "kgf": _KGF_N, "gf": _KGF_N * 1e-3, "lbf": _LBF_N},
}
ENTRY_KEYS = {"column", "value", "unit", "scale", "offset", "full_scale"}
DEFAULT_GAP_S = 1.0


def load_map(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read and check a column map; errors name the map file and the key."""
    p = Path(path)
    data = read_toml(p, DataError)
    unknown = set(data) - {"columns", "trials", "log"}
    if unknown:
        raise DataError(f"{p}: unknown table '{sorted(unknown)[0]}' (known: columns, trials, log)")
    cols = data.get("columns", {})
    for name, entry in cols.items():
        _check_entry(p, name, entry)
    need = [c for c in RAW_COLUMNS if c != "trial" and c not in cols]
    if need:
        raise DataError(f"{p}: columns.{need[0]} is not mapped (need {', '.join(RAW_COLUMNS)})")
    gap = data.get("trials", {}).get("gap_s", DEFAULT_GAP_S)
    if isinstance(gap, bool) or not isinstance(gap, int | float) or gap <= 0:
        raise DataError(f"{p}: trials.gap_s must be a positive number, got {gap!r}")
    log = data.get("log", {})
    bad = set(log) - {"comment", "command"}
    if bad:
        raise DataError(f"{p}: log: unknown key '{sorted(bad)[0]}' (known: comment, command)")
    comment = log.get("comment")
    if comment is not None and (not isinstance(comment, str) or len(comment) != 1):
        raise DataError(f'{p}: log.comment must be one character (e.g. "#"), got {comment!r}')
    command = log.get("command")
    if command is not None and command not in COMMAND_TIMING:
        raise DataError(f"{p}: log.command must be one of {', '.join(COMMAND_TIMING)}, got {command!r}")
    return {"columns": cols, "gap_s": float(gap), "path": p, "comment": comment, "command": command}


def _check_entry(p: Path, name: str, entry: Any) -> None:
    """One columns.<name> table: known schema column, a column or a constant value, a known unit."""
    where = f"{p}: columns.{name}"
    if name not in UNITS:
        raise DataError(f"{where}: not a schema column (known: {', '.join(RAW_COLUMNS)})")
    if not isinstance(entry, dict):
        raise DataError(f"{where} must be a table")
    bad = set(entry) - ENTRY_KEYS
    if bad:
        raise DataError(f"{where}: unknown key '{sorted(bad)[0]}' (known: {', '.join(sorted(ENTRY_KEYS))})")
    if ("column" in entry) == ("value" in entry):
        raise DataError(f"{where}: give exactly one of 'column' or 'value'")
    if name == "t_s" and "column" not in entry:
        raise DataError(f"{where}: time must come from a column")
    unit = entry.get("unit", next(iter(UNITS[name])))
    if unit not in UNITS[name]:
        raise DataError(f"{where}.unit: unknown unit {unit!r} (known: {', '.join(UNITS[name])})")
    if name == "pot" and unit != "counts" and not isinstance(entry.get("full_scale"), int | float):
        raise DataError(f"{where}.full_scale: the {unit} reading at the ADC's full scale is required")
    for k in ("scale", "offset", "full_scale"):
        if k in entry and (isinstance(entry[k], bool) or not isinstance(entry[k], int | float)):
            raise DataError(f"{where}.{k} must be a number, got {entry[k]!r}")


def _numbers(path: Path, df: pd.DataFrame, col: str, target: str) -> np.ndarray:
    """A log column as floats; errors name the log file, its row (header = line 1) and column."""
    if col not in df.columns:
        raise DataError(
            f"{path}: column '{col}' (mapped to {target}) not in the log (has: {', '.join(df.columns)})"
        )
    num = pd.to_numeric(df[col].str.strip(), errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(num)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataError(
            f"{path}, row {_row(df, i)}, column '{col}': not a finite number: {df[col].iloc[i]!r}"
        )
    return num


def _convert(path: Path, df: pd.DataFrame, name: str, entry: dict[str, Any], act: Actuator) -> np.ndarray:
    """One schema column in seagen's unit (pot counts of `act`'s ADC, PWM % of its supply)."""
    raw = (
        _numbers(path, df, entry["column"], name)
        if "column" in entry
        else np.full(len(df), float(entry["value"]))
    )
    x = raw * float(entry.get("scale", 1.0)) + float(entry.get("offset", 0.0))
    unit = entry.get("unit", next(iter(UNITS[name])))
    if name == "pot" and unit != "counts":
        return x / float(entry["full_scale"]) * act.adc_max
    if name == "motor_v" and unit == "%":
        return x * (act.motor.supply_v / 100.0)
    return x * UNITS[name][unit]


def _row(df: pd.DataFrame, i: int) -> int:
    """The log's line number of data row i (header = line 1; comment and blank lines counted); a chunk of
    the log carries its first row's number in attrs['offset']."""
    lines = df.attrs.get("lines")
    return int(lines[i]) if lines is not None else i + 2 + int(df.attrs.get("offset", 0))


def _fields(path: Path, line: int) -> list[str]:
    """The fields of one line of the log (1 = header), stripped."""
    with path.open("r", newline="") as f:
        text = next(itertools.islice(f, line - 1, None), "")
    return [x.strip() for x in text.rstrip("\r\n").split(",")]


def _line_numbers(path: Path, comment: str | None) -> np.ndarray:
    """Line number of every data row pandas reads (skipping blank lines and whole-line comments)."""
    keep = []
    with path.open("rb") as f:
        for n, raw in enumerate(f, 1):
            line = raw.strip()
            if not line or (comment and line.startswith(comment.encode())):
                continue
            keep.append(n)
    return np.asarray(keep[1:], dtype=np.int64)


def _trial_ids(
    path: Path, df: pd.DataFrame, cols: dict, t: np.ndarray, gap_s: float, mapped: np.ndarray | None
) -> np.ndarray:
    """Trial number per row: the mapped column (`mapped`), else a new trial where time jumps by > gap_s or
    resets (goes back by > gap_s); inside a trial time must increase."""
    col = cols["t_s"]["column"]
    if mapped is not None:
        trial = mapped
        same = trial[1:] == trial[:-1]
    else:
        dt = np.diff(t)
        same = (dt >= -gap_s) & (dt <= gap_s)
        trial = np.r_[0, np.cumsum(~same)].astype(float)
    dt = np.diff(t)
    for bad, what in ((same & (dt < 0), "goes backwards"), (same & (dt == 0), "repeats")):
        if bad.any():
            i = int(np.argmax(bad)) + 1
            dup = _fields(path, _row(df, i)) == _fields(path, _row(df, i - 1))
            extra = f" (the whole row repeats row {_row(df, i - 1)})" if dup else ""
            raise DataError(f"{path}, row {_row(df, i)}, column '{col}': time {what} inside a trial{extra}")
    return trial


MIN_RATE_HZ = 50.0  # slower logs cannot time the command switches the replay needs (documented in README)
REST_COUNTS = 3  # a trial whose encoder moves more than this between its first two rows ...
REST_RATIO = 0.6  # ... at more than this share of the next interval's speed starts in motion


def sensor_range(act: Actuator) -> dict[str, tuple[float, float]]:
    """Per column, the range the actuator's sensors and motor can produce."""
    return {"pot": (0.0, float(act.adc_max)), "motor_v": (-act.motor.supply_v, act.motor.supply_v)}


def _check_rate_unit(path: Path, cols: dict, t: np.ndarray, gap_s: float) -> None:
    """The time unit and the sample rate over the whole log (a step longer than trials.gap_s would make
    every row its own trial: almost always a wrong unit)."""
    col, unit = cols["t_s"]["column"], cols["t_s"].get("unit", "s")
    d = np.diff(t)
    d = d[d > 0]
    if not d.size:
        return
    step = float(np.median(d))
    if step > gap_s or step > 1.0 / MIN_RATE_HZ:
        hint = ""
        for u, f in UNITS["t_s"].items():
            rate = 1.0 / (step / UNITS["t_s"][unit] * f)
            if u != unit and MIN_RATE_HZ <= rate <= 20_000:
                hint = f'; with unit = "{u}" it would be {rate:.0f} Hz: is the column in {u}?'
        raise DataError(
            f"{path}, column '{col}': the median time step is {step:.6g} s ({1 / step:.3g} Hz with unit "
            f'"{unit}"); at least {MIN_RATE_HZ:g} Hz is needed to time the command switches{hint}'
        )


def _check_trial(path: Path, df: pd.DataFrame, cols: dict, sel: np.ndarray, conv: dict, k: int) -> None:
    """One trial: logged at >= MIN_RATE_HZ and starting at rest (the replay starts the plant at rest)."""
    t = conv["t_s"][sel]
    step = float(np.median(np.diff(t)))
    where = f"{path}, row {_row(df, int(sel[0]))}"
    if step > 1.0 / MIN_RATE_HZ:
        raise DataError(
            f"{where}, column '{cols['t_s']['column']}': trial {k} is logged at {1 / step:.3g} Hz (median "
            f"step {step * 1000:.4g} ms); at least {MIN_RATE_HZ:g} Hz is needed"
        )
    e = conv["enc"][sel]
    d1, d2 = abs(e[1] - e[0]) / (t[1] - t[0]), abs(e[2] - e[1]) / (t[2] - t[1])
    if "column" in cols["enc"] and abs(e[1] - e[0]) > REST_COUNTS and d1 > REST_RATIO * d2:
        raise DataError(
            f"{where}, column '{cols['enc']['column']}': trial {k} does not start at rest (the encoder "
            f"already runs at {d1:.0f} counts/s); a gap inside a trial? (see trials.gap_s)"
        )


def _check_range(path: Path, df: pd.DataFrame, cols: dict, conv: dict, act: Actuator) -> None:
    """Values outside the actuator's sensor range (pot counts beyond its ADC, volts beyond its supply)."""
    for name, (lo, hi) in sensor_range(act).items():
        x = conv[name]
        bad = (x < lo - 0.5) | (x > hi + 0.5)
        if bad.any() and "column" in cols[name]:
            i = int(np.argmax(bad))
            raise DataError(
                f"{path}, row {_row(df, i)}, column '{cols[name]['column']}': {name} {x[i]:.6g} is outside "
                f"the range {lo:g}..{hi:g} of actuator '{act.name}' (check unit / full_scale / --actuator)"
            )


CHUNK_ROWS = 100_000  # log rows held as text at a time (a 100 MB log imports in well under 500 MB)


def _read(path: Path, mapping: dict[str, Any], act: Actuator) -> tuple[dict[str, np.ndarray], pd.DataFrame]:
    """Every mapped schema column in seagen's units, the log parsed CHUNK_ROWS rows at a time (only the
    mapped columns, as text, then numbers); and a frame of the log's rows without columns, whose attrs
    give each row's line number for the messages."""
    cols = mapping["columns"]
    names = [k for k in RAW_COLUMNS if k in cols]
    opts: dict[str, Any] = {
        "dtype": str,
        "keep_default_na": False,
        "skipinitialspace": True,
        "comment": mapping.get("comment"),
    }
    try:
        head = pd.read_csv(path, nrows=0, **opts)
        for k in names:  # a mapped column missing from the header: named before any row is read
            if "column" in cols[k]:
                _numbers(path, head, cols[k]["column"], k)
        use = list(dict.fromkeys(cols[k]["column"] for k in names if "column" in cols[k]))
        lines = _line_numbers(path, mapping.get("comment"))
        parts: dict[str, list[np.ndarray]] = {k: [] for k in names}
        n = 0
        for chunk in pd.read_csv(path, usecols=use, chunksize=CHUNK_ROWS, **opts):
            chunk.attrs["offset"] = n
            if len(lines) >= n + len(chunk):
                chunk.attrs["lines"] = lines[n : n + len(chunk)]
            for k in names:
                parts[k].append(_convert(path, chunk, k, cols[k], act))
            n += len(chunk)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
        raise DataError(f"{path}: not a readable CSV: {e}") from None
    if n == 0:
        raise DataError(f"{path}: no data rows")
    rows = pd.DataFrame(index=pd.RangeIndex(n))
    if len(lines) == n:
        rows.attrs["lines"] = lines
    return {k: np.concatenate(v) for k, v in parts.items()}, rows


def import_log(
    log: str | os.PathLike[str], mapping: dict[str, Any], act: Actuator | None = None
) -> pd.DataFrame:
    """The log as one schema frame: trials renumbered 0..n-1, each row at its own time (from trial start);
    units and ranges of the actuator `act` (the paper's when None)."""
    act = act or default_actuator()
    path = Path(log)
    if not path.is_file():
        raise DataError(not_a_file(path, "log file"))
    conv, df = _read(path, mapping, act)
    cols = mapping["columns"]
    mapped = conv.pop("trial", None)
    _check_rate_unit(path, cols, conv["t_s"], mapping["gap_s"])
    _check_range(path, df, cols, conv, act)
    trial = _trial_ids(path, df, cols, conv["t_s"], mapping["gap_s"], mapped)
    parts = []
    for i, key in enumerate(pd.unique(trial)):
        sel = np.flatnonzero(trial == key)
        if len(sel) < 3:
            row = _row(df, int(sel[0]))
            raise DataError(f"{path}, row {row}: trial {key:g} has {len(sel)} samples (need >= 3)")
        _check_trial(path, df, cols, sel, conv, i)
        frame = pd.DataFrame({k: v[sel] for k, v in conv.items()})
        frame["t_s"] = frame["t_s"] - frame["t_s"].iloc[0]
        for k in ("enc", "pot"):
            frame[k] = np.rint(frame[k]).astype(np.int64)
        parts.append(frame.assign(trial=i))
    return pd.concat(parts, ignore_index=True)[list(RAW_COLUMNS)]


def clock_resolution(t: np.ndarray) -> float:
    """The log clock's resolution (s): 0 when the samples are evenly spaced (the clock's own ticks, e.g.
    seagen's loop-rate grid), else the coarsest of 10 ms, 1 ms, 100 us, 10 us, 1 us that every time is a
    multiple of (an integer-ms clock under a jittered loop: 1 ms)."""
    d = np.diff(t)
    if len(d) == 0 or np.ptp(d) <= 1e-9 * max(1.0, float(np.max(np.abs(t)))):
        return 0.0
    for r in (1e-2, 1e-3, 1e-4, 1e-5, 1e-6):
        q = t / r
        if np.all(np.abs(q - np.rint(q)) < 1e-6):
            return r
    return 0.0


def timing(df: pd.DataFrame, mapping: dict[str, Any]) -> dict[str, Any]:
    """What the import knows about the log's timing (written as TIMING_FILE beside the splits)."""
    periods, res = [], []
    for _, part in df.groupby("trial", sort=False):
        t = part["t_s"].to_numpy(dtype=float)
        periods.append(np.diff(t))
        res.append(clock_resolution(t))
    d = np.concatenate(periods)
    out: dict[str, Any] = {
        "median_period_s": float(np.median(d)),
        "period_range_s": [float(d.min()), float(d.max())],
        "clock_resolution_s": float(max(res)),
        "command": mapping.get("command"),
    }
    if mapping.get("command"):
        out["lag"] = COMMAND_TIMING[mapping["command"]]
    return out


def own_timing() -> dict[str, Any]:
    """The timing of seagen's own logs (`data generate`, the benches): the command declared, so pinned."""
    return {"command": OWN_COMMAND, "lag": COMMAND_TIMING[OWN_COMMAND], "source": "seagen's protocol"}


def timing_text(info: dict[str, Any]) -> str:
    """A timing dict (`timing`, `own_timing`) as the TIMING_FILE's text."""
    import json

    return json.dumps(info, indent=2) + "\n"


def declare_own_timing(folder: Path) -> None:
    """Write seagen's own logs' timing (own_timing) as `folder`'s TIMING_FILE (atomically), as `data
    generate` does beside its splits."""
    from seagen.atomic import write_text

    write_text(folder / TIMING_FILE, timing_text(own_timing()))


def resample(df: pd.DataFrame, hz: float) -> pd.DataFrame:
    """Every trial on a 1/hz grid from its first row (the control loop's samples, which the feature pipeline
    differences): sensors interpolated linearly between the logged instants (counts rounded), the command
    and the contact angle held from the last row at or before each instant."""
    parts = []
    for k, part in df.groupby("trial", sort=False):
        t = part["t_s"].to_numpy(dtype=float)
        grid = np.arange(int(np.floor(t[-1] * hz + 1e-9)) + 1) / hz
        held = np.clip(np.searchsorted(t, grid + 1e-12, side="right") - 1, 0, len(t) - 1)
        out = {"trial": np.full(len(grid), k), "t_s": grid}
        for c in ("angle_set_deg", "motor_v"):
            out[c] = part[c].to_numpy(dtype=float)[held]
        for c in ("enc", "pot", "load_cell_n", "force_n"):
            out[c] = np.interp(grid, t, part[c].to_numpy(dtype=float))
        for c in ("enc", "pot"):
            out[c] = np.rint(out[c]).astype(np.int64)
        parts.append(pd.DataFrame(out))
    return pd.concat(parts, ignore_index=True)[list(RAW_COLUMNS)]


def split_trials(df: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """train / test / validation by trial: the last trial validates, every 4th other trial tests."""
    ids = list(pd.unique(df["trial"]))
    if len(ids) < 3:
        raise DataError(f"the log holds {len(ids)} trial(s); train, test and validation need at least 3")
    val, rest = ids[-1:], ids[:-1]
    test = rest[3::4] or rest[-1:]
    train = [i for i in rest if i not in test]
    out = {}
    for name, keep in (("train", train), ("test", test), ("validation", val)):
        part = df[df["trial"].isin(keep)].copy()
        part["trial"] = pd.factorize(part["trial"])[0]
        out[name] = part.reset_index(drop=True)
    return out
