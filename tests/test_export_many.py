"""`seagen export A B ... --out fw`: several models into one package in one run, all checked before any is
written (issue 37: one command for the calibration and the control model of an actuator)."""

from __future__ import annotations

import json

from tests.conftest import run_cli


def test_two_models_go_into_one_package_with_the_controller_for_the_control_one(tmp_path):
    """Calibration and control SF in one run with --controller: both exported into the folder, one runtime,
    the controller only for the control model (the calibration one is not refused); the export lists files
    in sub-folders with their folder."""
    out = tmp_path / "fw"
    code, text, err = run_cli(
        "export", "default:sf_calibration", "default:sf_control", "--controller", "--out", str(out)
    )
    assert code == 0, err
    assert text.count("seagen export: ") == 2 and "zephyr/module.yml" in text
    names = {p.name for p in out.iterdir()}
    assert {"sf_calibration.c", "sf_control.c", "sf_control_controller.c", "sea_nn.c"} <= names
    assert "sf_calibration_controller.c" not in names
    cal = json.loads((out / "sf_calibration.seagen.json").read_text())
    ctl = json.loads((out / "sf_control.seagen.json").read_text())
    assert cal["options"]["controller"] is False and ctl["options"]["controller"] is True


def test_several_models_refusals_write_nothing(tmp_path, capsys):
    """--prefix with several models, two models of one C name, and an unreadable second model: exit 2 with
    one line naming the cause; the folder is not created."""
    out = tmp_path / "fw"
    bad = tmp_path / "broken.onnx"
    bad.write_bytes(b"not a model")
    cases = [
        (["default:sf_calibration", "default:sf_control", "--prefix", "x"], "--prefix names one export"),
        (["default:sf_calibration", "default:sf_calibration"], "also"),
        (["default:sf_calibration", str(bad)], str(bad)),
    ]
    for argv, words in cases:
        code, _, err = run_cli("export", *argv, "--out", str(out))
        assert code == 2 and words in err and "Traceback" not in err, err
        assert not out.exists()
