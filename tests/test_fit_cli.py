"""`seagen train` / `seagen evaluate` end to end, and bad input: exit 2, a named problem, no output file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
from conftest_fit import default_models, fit_data  # noqa: F401  (session fixtures)

from seagen.cli import main
from seagen.modelfile import load_model

JSON_KEYS = ("error_avg_n", "error_max_n", "error_avg_pct", "error_max_pct")


def test_cli_train_then_evaluate(fit_data: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    """train writes a loadable model; evaluate --json has the paper keys on test + validation; plots."""
    out = tmp_path / "sf.pt"
    args = ["train", "--data", str(fit_data), "--model", "sf", "--loss", "mse", "--task", "calibration"]
    assert main([*args, "--out", str(out)]) == 0
    assert load_model(out)["loss"] == "mse"
    capsys.readouterr()
    assert (
        main(["evaluate", str(out), "--data", str(fit_data), "--json", "--plots", str(tmp_path / "p")]) == 0
    )
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {"sf", "kinematics_calibration"}
    for entry in result.values():
        assert all(k in entry and k in entry["validation"] for k in JSON_KEYS)
    assert result["sf"]["error_avg_pct"] < result["kinematics_calibration"]["error_avg_pct"]
    pngs = sorted(p.name for p in (tmp_path / "p").glob("*.png"))
    assert pngs == ["sf_surface.png", "validation_calibration.png"]


def test_cli_train_mlp_control(fit_data: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    """An MLP control predictor trains from the CLI with --hidden and reports mm."""
    out = tmp_path / "ctl.pt"
    argv = ["train", "--data", str(fit_data), "--model", "mlp", "--task", "control", "--hidden", "8,16"]
    assert main([*argv, "--out", str(out)]) == 0
    assert "mm" in capsys.readouterr().out
    model = load_model(out)
    assert model["hidden"] == [8, 16] and model["output_units"] == "mm"


def test_cli_evaluate_table_layout(default_models: dict, fit_data: Path, capsys) -> None:  # noqa: F811
    """The text output has Table IV and Table V blocks, test and validation, kinematics and the paper rows."""
    assert main(["evaluate", *map(str, default_models.values()), "--data", str(fit_data)]) == 0
    text = capsys.readouterr().out
    for needle in ("Table IV", "Table V", "test set", "validation set", "Kinematics Calc", "paper SF(MAE)"):
        assert needle in text, needle
    assert main(["evaluate", *map(str, default_models.values()), "--data", str(fit_data), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert {"error_avg_mm", "error_max_mm"} <= set(result["mlp_control"]["validation"])


def _bad_model(tmp_path: Path) -> Path:
    """A torch file that is not a seagen model."""
    p = tmp_path / "plain.pt"
    torch.save({"format": "seagen-model/1", "kind": "sf"}, p)
    return p


BAD_TRAIN = (
    (["--data", "{missing}", "--model", "sf"], "no such data directory"),
    (["--data", "{data}", "--model", "mlp", "--hidden", "16,x"], "--hidden"),
    (["--data", "{data}", "--model", "mlp", "--hidden", "0"], "--hidden"),
    (["--data", "{data}", "--model", "sf", "--trials", "3"], "--trials"),
    (["--data", "{data}", "--model", "sf", "--loss", "any"], "--loss any"),
)


@pytest.mark.parametrize(("argv", "needle"), BAD_TRAIN)
def test_bad_train_input_exits_2(argv, needle, fit_data: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    """Bad train input: exit 2, stderr names the option or path, no model file written."""
    out = tmp_path / "m.pt"
    argv = [a.format(missing=tmp_path / "nope", data=fit_data) for a in argv]
    assert main(["train", *argv, "--out", str(out)]) == 2
    assert needle in capsys.readouterr().err
    assert not out.exists() and not list(tmp_path.glob(".m.pt*"))


@pytest.mark.parametrize("case", ("garbage", "missing", "no_field", "torchscript"))
def test_bad_evaluate_input_exits_2(case: str, fit_data: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    """Unreadable, missing or incomplete model files: exit 2 naming the file (and field); no plots written."""
    path = {
        "garbage": tmp_path / "g.pt",
        "missing": tmp_path / "none.pt",
        "no_field": _bad_model(tmp_path),
        "torchscript": tmp_path / "ts.pt",
    }[case]
    if case == "garbage":
        path.write_bytes(b"not a torch file")
    if case == "torchscript":
        torch.jit.script(torch.nn.Sequential(torch.nn.Linear(2, 1))).save(str(path))
    plots = tmp_path / "plots"
    assert main(["evaluate", str(path), "--data", str(fit_data), "--plots", str(plots)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err
    if case == "no_field":
        assert "'task'" in err
    if case == "torchscript":
        assert "reads the model.pt of `seagen train`" in err
    assert not plots.exists()


def test_evaluate_names_a_checkpoint_for_what_it_is(tmp_path, capsys):
    """`seagen evaluate` on a training checkpoint or a bare state_dict: exit 2, one line saying what the
    file is and what to pass instead (not "not a seagen model file")."""
    import torch

    from seagen.cli import main

    net = torch.nn.Sequential(torch.nn.Linear(2, 3), torch.nn.ReLU(), torch.nn.Linear(3, 1))
    opt = torch.optim.Adam(net.parameters())
    ckpt, sd = tmp_path / "ckpt.pt", tmp_path / "sd.pt"
    torch.save(
        {"model_state_dict": net.state_dict(), "optimizer_state_dict": opt.state_dict(), "epoch": 1}, ckpt
    )
    torch.save(net.state_dict(), sd)
    for path, what in ((ckpt, "a training checkpoint"), (sd, "a bare state_dict")):
        assert main(["evaluate", str(path), "--data", str(tmp_path)]) == 2
        err = capsys.readouterr().err.strip()
        assert what in err and str(path) in err and "pass the network itself" in err and "\n" not in err
