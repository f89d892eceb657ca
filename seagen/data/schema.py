"""The CSV schema of a data set and its validated loading (errors name file, row and column)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from seagen.actuator import Actuator, ActuatorError, default_actuator, load_actuator
from seagen.atomic import write_with
from seagen.errors import UserError

RAW_COLUMNS: dict[str, str] = {
    "trial": "int",  # trial number within the split
    "t_s": "float",  # time since the trial started (s)
    "angle_set_deg": "float",  # contact angle of the set-up (deg)
    "motor_v": "float",  # motor command (V)
    "enc": "int",  # encoder counts
    "pot": "int",  # pot ADC counts (0 .. 2^pot.adc_bits - 1 of the actuator description)
    "load_cell_n": "float",  # measured tip force (N)
    "force_n": "float",  # reference force at the SEA output shaft (N)
}
SPLITS = ("train", "test", "validation")
ACTUATOR_FILE = "actuator.toml"  # the description the data came from (written by data generate / import)


class DataError(UserError):
    """A data file that cannot be used; the message names file, row and column."""


def _fail(path: Path, row: int | None, col: str | None, what: str) -> DataError:
    where = str(path)
    if row is not None:
        where += f", row {row}"
    if col is not None:
        where += f", column '{col}'"
    return DataError(f"{where}: {what}")


def load_csv(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Load and validate one split; rows are reported as file line numbers (the header is line 1)."""
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: no such file")
    try:
        df = pd.read_csv(p, dtype=str, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
        raise DataError(f"{p}: not a readable CSV: {e}") from None
    missing = [c for c in RAW_COLUMNS if c not in df.columns]
    if missing:
        raise _fail(p, None, missing[0], f"missing column (need {', '.join(RAW_COLUMNS)})")
    if len(df) == 0:
        raise _fail(p, None, None, "no data rows")
    out = {}
    for col, kind in RAW_COLUMNS.items():
        num = pd.to_numeric(df[col].str.strip(), errors="coerce")
        bad = num.isna().to_numpy()
        if bad.any():
            i = int(np.argmax(bad))
            raw = df[col].iloc[i]
            what = "NaN" if raw.strip().lower() == "nan" else f"not a number: {raw!r}"
            raise _fail(p, i + 2, col, what)
        vals = num.to_numpy(dtype=float)
        if not np.isfinite(vals).all():
            i = int(np.argmax(~np.isfinite(vals)))
            raise _fail(p, i + 2, col, f"not finite: {df[col].iloc[i]!r}")
        if kind == "int":
            frac = vals != np.round(vals)
            if frac.any():
                i = int(np.argmax(frac))
                raise _fail(p, i + 2, col, f"not an integer: {df[col].iloc[i]!r}")
            out[col] = vals.astype(np.int64)
        else:
            out[col] = vals
    clean = pd.DataFrame(out)
    _check_time(p, clean)
    clean.attrs["source"] = str(p)
    return clean


def _check_time(p: Path, df: pd.DataFrame) -> None:
    """Time must not go backwards inside a trial."""
    trial = df["trial"].to_numpy()
    t = df["t_s"].to_numpy()
    same = trial[1:] == trial[:-1]
    back = same & (t[1:] < t[:-1])
    if back.any():
        i = int(np.argmax(back)) + 1
        raise _fail(p, i + 2, "t_s", f"time goes backwards inside trial {trial[i]} ({t[i - 1]} -> {t[i]})")


def load_split(data_dir: str | os.PathLike[str], split: str) -> pd.DataFrame:
    """Load `split`.csv from a data directory."""
    return load_csv(Path(data_dir) / f"{split}.csv")


def save_csv(df: pd.DataFrame, path: str | os.PathLike[str]) -> None:
    """Write a split atomically, raw columns first, with fixed float formatting."""
    cols = list(RAW_COLUMNS) + [c for c in df.columns if c not in RAW_COLUMNS]
    write_with(path, lambda tmp: df[cols].to_csv(tmp, index=False, float_format="%.6g"))


def data_actuator(
    data_dir: str | os.PathLike[str],
    given: Actuator | None = None,
    given_as: str = "--actuator gives",
    remedy: str = "drop --actuator or use data of that actuator",
) -> Actuator:
    """The actuator a data folder was recorded on (its actuator.toml; the paper's in folders written before
    it existed). A `given` description that disagrees is refused (ActuatorError, exit 2), the message
    saying where it came from (`given_as`) and what to do (`remedy`)."""
    path = Path(data_dir) / ACTUATOR_FILE
    act = load_actuator(path) if path.is_file() else default_actuator()
    if given is not None and given.digest() != act.digest():
        shown = path if path.is_file() else f"{data_dir} (no {ACTUATOR_FILE}: the paper's actuator)"
        raise ActuatorError(
            f"{shown}: the data were recorded on actuator '{act.name}' (sha256 {act.digest()[:12]}), but "
            f"{given_as} '{given.name}' (sha256 {given.digest()[:12]}: {act.differences(given)}); {remedy}"
        )
    return act
