"""Misused command lines end with exit 2 and one line naming the argument or path, before any work and
never with a traceback (a table: one row per misuse a user tried)."""

from __future__ import annotations

import pytest

from seagen.cli import main
from tests.conftest import EXAMPLE_ACTUATOR

TRAIN = ["train", "--data", "{tmp}/none", "--model", "mlp", "--loss", "mse", "--task", "calibration"]
CASES = {  # name: (argv with {tmp}, words in stderr)
    "negative seed": (["data", "generate", "--out", "{tmp}/d", "--seed", "-1"], "--seed"),
    "negative seed, train": ([*TRAIN, "--out", "{tmp}/m.pt", "--seed", "-2"], "--seed"),
    "latency nan": (["simulate", "--config", "mlp_cloud", "--latency", "nan"], "--latency"),
    "latency inf": (["simulate", "--config", "mlp_cloud", "--latency", "inf"], "--latency"),
    "negative seed, demo": (["demo", "--out", "{tmp}/d", "--seed", "-3"], "--seed"),
    "negative hidden size": ([*TRAIN, "--out", "{tmp}/m.pt", "--hidden", "-3"], "--hidden"),
    "data --out under /proc": (["data", "generate", "--out", "/proc/seagen_no"], "/proc/seagen_no"),
    "data --out is a file": (["data", "generate", "--out", "{tmp}/afile"], "afile: is a file"),
    "train --out is a folder": ([*TRAIN, "--out", "{tmp}"], "is a folder"),
    "train --out under /proc": ([*TRAIN, "--out", "/proc/seagen_no.pt"], "/proc/seagen_no.pt"),
    "loop rate not whole plant steps, data": (
        ["data", "generate", "--out", "{tmp}/d", "--actuator", "{tmp}/loop300.toml"],
        "loop300.toml ('stiff 24 V SEA, 200 Hz loop (seagen example)'): control.loop_hz 300 is not a whole",
    ),
    "loop rate not whole plant steps, simulate": (
        ["simulate", "--actuator", "{tmp}/loop300.toml", "--config", "kin_mcu"],
        "loop300.toml ('stiff 24 V SEA, 200 Hz loop (seagen example)'): control.loop_hz 300 is not a whole",
    ),
    "binary plant config": (
        ["data", "generate", "--out", "{tmp}/d", "--config", "{tmp}/bin.toml"],
        "bin.toml",
    ),
}


@pytest.mark.parametrize("case", CASES)
def test_misuse_exits_2_naming_what(case, tmp_path, capsys):
    """Exit 2, the argument or path named, no traceback, nothing written."""
    (tmp_path / "afile").write_text("keep")
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00\x01")
    example = EXAMPLE_ACTUATOR.read_text()
    assert "loop_hz = 200.0" in example
    (tmp_path / "loop300.toml").write_text(example.replace("loop_hz = 200.0", "loop_hz = 300.0"))
    argv, words = CASES[case]
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    rc = main(argv)
    err = capsys.readouterr().err.strip()
    assert rc == 2 and words in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "d").exists() and not (tmp_path / "m.pt").exists()
