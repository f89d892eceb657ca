"""`seagen simulate --model CONTROL_MODEL [--calibration CAL_MODEL]`: the paper's experiment on a user's own
models (trained here with `seagen train`), the same table and plots; shortened to one target, two contact
angles and 3 s so that it runs in seconds (the full experiment is the same code with the paper's grid)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest_fit import fit_data  # noqa: F401  (session fixture)

from seagen.cli import main
from seagen.control import experiment


@pytest.fixture
def short_experiment(monkeypatch):
    """One target (half the force range: 10 N), two contact angles (the ends of the grid), 3 s runs."""
    monkeypatch.setattr(experiment, "TARGET_FRACTIONS", (0.5,))
    monkeypatch.setattr(experiment, "N_CONTACT", 2)
    monkeypatch.setattr(experiment, "DURATION_S", 3.0)


@pytest.fixture(scope="module")
def trained(fit_data, tmp_path_factory) -> dict[str, Path]:  # noqa: F811
    """A control MLP (the default 8-16) and a calibration SF written by `seagen train`."""
    out = tmp_path_factory.mktemp("models")
    ctl, cal = out / "my_ctl.pt", out / "my_cal.pt"
    base = ["train", "--data", str(fit_data)]
    assert main([*base, "--model", "mlp", "--task", "control", "--out", str(ctl)]) == 0
    assert main([*base, "--model", "sf", "--task", "calibration", "--out", str(cal)]) == 0
    return {"control": ctl, "calibration": cal}


def test_simulate_a_model_trained_with_seagen_train(trained, short_experiment, tmp_path, capsys):
    """--model and --calibration: NAME_mcu and NAME_cloud rows with error, settling and the calibration
    model's force-estimate error; the step plots of each and the comparison; the text table too."""
    plots = tmp_path / "plots"
    argv = ["simulate", "--model", str(trained["control"]), "--calibration", str(trained["calibration"])]
    capsys.readouterr()
    assert main([*argv, "--json", "--plots", str(plots)]) == 0
    table = json.loads(capsys.readouterr().out)
    assert set(table) == {"my_ctl_mcu", "my_ctl_cloud"}
    for row in table.values():
        r = row["10"]
        assert r["error_avg_n"] < 2.0 and r["settled"] >= 1 and 0 <= r["estimate_error_n"] < 2.0, table
    assert {p.name for p in plots.iterdir()} == {"step_my_ctl_mcu.png", "step_my_ctl_cloud.png"} | {
        "step_compare.png"
    }
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "my_ctl_mcu" in text and "est. err N" in text and "paper" in text


def test_simulate_model_equals_the_shipped_configuration(short_experiment, capsys):
    """--model default:mlp_control gives exactly the numbers of the shipped mlp_mcu and mlp_cloud rows."""
    argv = ["simulate", "--model", "default:mlp_control", "--config", "mlp_mcu", "--config", "mlp_cloud"]
    assert main([*argv, "--json"]) == 0
    table = json.loads(capsys.readouterr().out)
    assert table["mlp_control_mcu"] == table["mlp_mcu"] and table["mlp_control_cloud"] == table["mlp_cloud"]


@pytest.mark.parametrize(
    "flag, model, message",
    [
        ("--model", "default:mlp_calibration", "--model needs a control model"),
        ("--calibration", "default:mlp_control", "--calibration needs a calibration model"),
        ("--model", "no/such.pt", "no/such.pt"),
    ],
    ids=["calibration model as control", "control model as calibration", "missing file"],
)
def test_simulate_wrong_model_exits_2(flag, model, message, capsys):
    """A model of the wrong kind or a missing file: exit 2, one line naming it, before any run."""
    argv = ["simulate", flag, model] + (["--config", "sf_mcu"] if flag == "--calibration" else [])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
