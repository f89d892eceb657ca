"""Every consumer reads the actuator description: each field scaled in turn moves the consumers that use it;
the old plant.toml [motor] and disagreeing --actuator files are refused; the second design round-trips."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from seagen.actuator import ActuatorError, actuator_from_dict, default_actuator, load_actuator, to_toml
from seagen.cli import main
from seagen.control.experiment import contact_deg, targets_n
from seagen.data import protocol
from seagen.data.features import derive
from seagen.data.logimport import import_log, load_map
from seagen.data.protocol import PUSH_MOVES, Move, run_trials, scaled_move
from seagen.data.schema import save_csv
from seagen.discrepancy.bench import draw
from seagen.discrepancy.candidates import box, full_scale
from seagen.discrepancy.families import family_case
from seagen.discrepancy.recalibrate import plausible_range
from seagen.discrepancy.replay import runs_from_frames, simulate
from seagen.discrepancy.residuals import region_labels
from seagen.discrepancy.riglog import rig_csv, rig_map
from seagen.export import calib_ranges
from seagen.fit.data_summary import summarize
from seagen.fit.kinematics import compression_for, shaft_force
from seagen.geometry import geometry
from seagen.modelfile import load_model
from seagen.plant import Plant, PlantConfig, load_config
from seagen.plant.config import ConfigError
from seagen.runtime.actq import act_q
from seagen.runtime.control import ControlConfig, sensor_walk
from seagen.verify.run import enc_span
from tests.conftest import EXAMPLE_ACTUATOR as EXAMPLE

FACTORS = (1.1, 0.9, 2.0, 0.5)  # the first that gives a valid description (loop_hz must divide 1 kHz)


def _numeric_fields(d: dict, prefix: str = "") -> list[str]:
    """Dotted names of every numeric field (arrays count as one field) of a description dict."""
    out = []
    for k, v in d.items():
        if isinstance(v, dict):
            out += _numeric_fields(v, f"{prefix}{k}.")
        elif isinstance(v, list) or (isinstance(v, int | float) and not isinstance(v, bool)):
            out.append(f"{prefix}{k}")
    return out


def _scaled(field: str):
    """The paper's description with `field` scaled by the first factor that keeps it valid."""
    *tables, key = field.split(".")
    for f in FACTORS:
        d = copy.deepcopy(default_actuator().to_dict())
        t = d
        for name in tables:
            t = t[name]
        v = t[key]
        if isinstance(v, list):
            t[key] = [x * f for x in v]
        elif isinstance(v, int):
            t[key] = max(int(round(v * f)), v + 1)
        else:
            t[key] = v * f
        try:
            act = actuator_from_dict(d, field)
            protocol.sample_every(PlantConfig(actuator=act))
        except Exception:
            continue
        return act
    raise AssertionError(f"no factor of {FACTORS} keeps {field} valid")


RAW = pd.DataFrame(
    {
        "trial": 0,
        "t_s": np.arange(12) / 100.0,
        "angle_set_deg": 12.0,
        "motor_v": 3.0,
        "enc": np.array([0, 3, 9, 18, 30, 45, 60, 75, 88, 99, 108, 115]),
        "pot": np.array([1000, 1001, 1003, 1006, 1010, 1013, 1015, 1016, 1017, 1017, 1018, 1018]),
        "load_cell_n": 0.0,
        "force_n": np.linspace(0.0, 6.0, 12),
    }
)
RAW_RUNS = runs_from_frames([("raw", RAW)])
LOG_MAP = """
[columns.t_s]
column = "ms"
unit = "ms"
[columns.angle_set_deg]
value = 12.0
[columns.motor_v]
column = "pwm"
unit = "%"
[columns.enc]
column = "enc"
[columns.pot]
column = "pot_mV"
unit = "mV"
full_scale = 3300.0
[columns.load_cell_n]
column = "f"
[columns.force_n]
column = "f"
"""
LOG = "ms,pwm,enc,pot_mV,f\n0,0,0,800,0\n10,20,0,801,0\n20,20,2,802,0.1\n30,20,5,803,0.2\n"


def _consumers(act, tmp: Path) -> dict[str, object]:
    """What each threaded consumer computes for one description (exceptions count as an output)."""
    cfg = PlantConfig(actuator=act)
    geo = geometry(act)
    out: dict[str, object] = {}
    plant = Plant(cfg, np.array([8.0, 18.0]), seed=1)
    reads = []
    for k in range(320):
        plant.step(5.0 if k < 280 else -5.0)
        if k % 20 == 0:
            s = plant.read()
            reads.append(np.concatenate([s.enc, s.pot, s.load_cell_n, s.motor_current]))
    out["plant"] = np.concatenate(reads)
    frame = run_trials(cfg, [Move(12.0, 3.0, 4.0, -6.0, 0.5)], seed=2, max_s=0.4)[0]
    out["protocol"] = (
        frame.to_numpy(float),
        protocol.train_angles(geo),
        protocol.rows("train", act.loop_hz),
        scaled_move(12.0, PUSH_MOVES[0], act),  # the moves' volts and peak force, scaled to the actuator
    )
    try:
        out["features"] = derive(RAW, geo).to_numpy(float)
    except Exception as e:  # another loop rate: rows 10 ms apart are refused
        out["features"] = str(e)
    comp = np.linspace(0.0, 4.0, 9)
    out["kinematics"] = np.concatenate([shaft_force(comp, geo=geo), compression_for(comp * 4, geo)])
    runs = runs_from_frames([("x", frame.assign(trial=0))])
    out["replay"] = np.concatenate([v.ravel() for v in simulate(cfg, [{}], runs).values()])
    (tmp / "log.csv").write_text(LOG)
    (tmp / "map.toml").write_text(LOG_MAP)
    out["logimport"] = import_log(tmp / "log.csv", load_map(tmp / "map.toml"), act).to_numpy(float)
    aq = act_q(act)  # the C side: the sea_act constants the export renders and the twins read
    out["c_act"] = (aq.link, aq.struct_fields())
    ctl = ControlConfig.for_act(aq)  # the controller configuration an export renders (PID, limits, faults)
    out["controller"] = (
        ctl.pid.as_tuple(),
        ctl.force_min,
        ctl.force_max,
        ctl.enc_jump_max,
        ctl.pot_stuck_ticks,
    )
    out["experiment"] = (targets_n(act), contact_deg(act))  # simulate's targets and contact angles
    walk = sensor_walk(1, 4, pot_max=aq.pot_max)[1]  # verify's tick sequence: the pot's start, its range
    out["verify"] = (enc_span(act), walk)  # and verify's synthetic encoder range
    out["discrepancy"] = (
        box("pot_voltage_drop", "counts_per_unit_current", full_scale(cfg)),  # search box
        list(region_labels(RAW_RUNS, cfg.motor, act.control.force_max_n)["force"].ravel()),  # force regions
    )
    fx = PlantConfig(actuator=act).effects  # the catalogue's pot effects: shares of the pot's full scale
    out["catalogue"] = (
        fx.pot_voltage_drop.counts_per_unit_current,
        fx.pot_noise.sigma_counts,
        plausible_range("pot_voltage_drop", "counts_per_unit_current", full_scale(cfg)),
        draw("pot_voltage_drop", np.random.default_rng(1), act)["counts_per_unit_current"],  # bench truths
        family_case("lagged_pot_bias", 1, act)[0].gain,  # the lagged pot bias family
    )
    out["riglog"] = (rig_csv([RAW], act=act), rig_map(act))  # the rig log: PWM %, pot mV of its reference
    folder = tmp / "data"  # a data folder recorded on `act`: export --calib's ranges, data summary
    folder.mkdir(exist_ok=True)
    save_csv(RAW, folder / "train.csv")
    (folder / "actuator.toml").write_text(to_toml(act))
    try:
        out["data_folder"] = (calib_ranges(str(folder), ["angle_deg", "compression_mm"]), summarize(folder))
    except Exception as e:  # another loop rate: rows 10 ms apart are refused
        out["data_folder"] = str(e)
    return out


def _same(a, b) -> bool:
    if isinstance(a, tuple):
        return all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    return type(a) is type(b) and a == b


# Eq. 2-6 (features: angle, compression; a data folder's: export --calib's ranges, data summary)
GEOMETRY = {"plant", "protocol", "features", "replay", "c_act", "data_folder"}
MOTOR = {"plant", "protocol", "replay"}  # the simulated motor
# Which consumers each field of the description must move (a consumer that ignores one fails the test).
EXPECTED = {
    "motor.supply_v": MOTOR | {"logimport", "c_act", "riglog"},  # PWM %, +-supply, the C command limit
    "motor.no_load_rpm": MOTOR | {"c_act", "controller"},  # the C encoder-jump bound
    "motor.gear_ratio": GEOMETRY | {"verify"},  # nut travel per count: encoder, stairs, compression
    "motor.counts_per_rev": GEOMETRY | {"controller", "verify"},  # and the encoder-jump bound
    "motor.stall_force_n": MOTOR,
    "motor.time_constant_s": MOTOR,
    "transmission.lead_mm": GEOMETRY | {"verify"},
    # the simulated plant's actuator friction (and so the protocol's push estimates), the kinematics
    # baseline's, and data summary's kinematics error
    "transmission.friction_n": MOTOR | {"kinematics", "data_folder"},
    "spring.stiffness_n_per_mm": MOTOR | {"kinematics", "verify", "data_folder"},  # and its friction
    "linkage.cb_mm": GEOMETRY | {"verify"},
    "linkage.home_deg": GEOMETRY | {"verify"},
    "linkage.angle_min_deg": MOTOR
    | {"experiment"},  # R_l's origin (load cell) and the angles; not Eq. 2 or 5
    "linkage.angle_max_deg": {
        "plant",
        "protocol",
        "replay",
        "experiment",
        "verify",
    },  # friction range, angles
    "linkage.split_deg": {"plant", "protocol", "replay"},
    "linkage.h_fit": {"plant", "protocol", "replay"},  # R_l: the load cell reads tip force
    "linkage.v_fit_higher": {"plant"},  # R_l above the split: only the plant's 18 deg element is there
    "pot.full_scale_deg": GEOMETRY,
    "pot.offset_deg": GEOMETRY,
    "pot.adc_bits": {
        "plant",
        "protocol",
        "features",
        "replay",
        "logimport",
        "c_act",
        "discrepancy",
        "catalogue",
        "riglog",
        "verify",
        "data_folder",
    },
    "pot.vref_mv": {"riglog"},  # the pot in mV of a rig log
    "control.loop_hz": {
        "protocol",
        "features",
        "replay",
        "c_act",
        "controller",
        "data_folder",
    },  # replay: the protocol's rows; a data folder's rows at another rate are refused
    # faults, targets, peaks, the discrepancy report's force regions, the rows of the relative errors; the
    # plant's structure defaults at the design's scale (plant.config.DESIGN_UNITS: beta in mm/N^2)
    "control.force_max_n": {
        "controller",
        "experiment",
        "verify",
        "protocol",
        "discrepancy",
        "data_folder",
        "plant",
        "replay",
    },
    "control.kp_v_per_mm": {"controller"},
    "control.ki_v_per_mm_s": {"controller"},
    "control.kd_v_s_per_mm": {"controller"},
    "control.d_alpha": {"controller"},
    "control.margin_mm": {"controller"},
    "control.limit_v": {"controller"},
    "control.pot_avg_hz": {"c_act"},  # the ticks of the controller's pot average
}


def test_every_field_moves_the_consumers_that_read_it(tmp_path):
    """Each numeric field scaled in turn (x1.1, or the first of 0.9, 2, 0.5 that stays valid) changes the
    output of exactly the consumers listed in EXPECTED; a field nobody reads fails (~8 s)."""
    fields = _numeric_fields(default_actuator().to_dict())
    assert set(fields) == set(EXPECTED), "a description field without an expected reader (or a stale one)"
    base = _consumers(default_actuator(), tmp_path)
    moved = {}
    for field in fields:
        got = _consumers(_scaled(field), tmp_path)
        moved[field] = {c for c in base if not _same(base[c], got[c])}
    assert all(moved[f] for f in fields), f"fields nobody reads: {[f for f in fields if not moved[f]]}"
    wrong = {f: (sorted(moved[f]), sorted(EXPECTED[f])) for f in fields if moved[f] != EXPECTED[f]}
    assert not wrong, f"field: (consumers moved, expected): {wrong}"
    assert set().union(*moved.values()) == set(base), "a threaded consumer no field moves"


def test_pot_drop_search_box_follows_the_adc():
    """The discrepancy search box of the pot's voltage drop is in counts of the described ADC: 5 to 600
    counts per unit current on the paper's 12-bit ADC (unchanged), 16 times that on a 16-bit one."""
    from seagen.discrepancy.candidates import start

    d = default_actuator().to_dict()
    d["pot"]["adc_bits"] = 16
    paper, fine = PlantConfig(), PlantConfig(actuator=actuator_from_dict(d))
    key = ("pot_voltage_drop", "counts_per_unit_current")
    assert box(*key, full_scale(paper))[:2] == (5.0, 600.0)
    assert box(*key, full_scale(fine))[:2] == (80.0, 9600.0)
    for cfg in (paper, fine):  # a recalibration starts at the plant's own value, inside its box
        got = start(cfg, "pot_voltage_drop").params()["pot_voltage_drop"]["counts_per_unit_current"]
        assert got == pytest.approx(cfg.effect("pot_voltage_drop").counts_per_unit_current)


def test_old_plant_toml_with_motor_is_refused(tmp_path):
    """A plant.toml that still has [motor] is refused with one line saying where each key goes."""
    p = tmp_path / "plant.toml"
    p.write_text("[motor]\nsupply_v = 24.0\n\n[effects.backlash]\nenabled = true\n")
    with pytest.raises(ConfigError) as e:
        load_config(p)
    msg = str(e.value)
    assert str(p) in msg and "\n" not in msg and "--actuator" in msg
    assert all(f"motor.{k}" in msg for k in ("supply_v", "no_load_rpm", "counts_per_rev", "stall_force_n"))


def test_cli_refuses_old_plant_toml(tmp_path, capsys):
    """`data generate --config` with the old [motor] table: exit 2, one line, nothing written."""
    p = tmp_path / "plant.toml"
    p.write_text("[motor]\nstall_force_n = 150.0\n")
    out = tmp_path / "data"
    assert main(["data", "generate", "--out", str(out), "--config", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "plant.toml" in err and "motor.stall_force_n" in err
    assert not out.exists()


def test_generate_and_train_on_the_second_design(tmp_path, monkeypatch, capsys):
    """`data generate --actuator` keeps the description in the data folder; `train` records it in the model
    file (values + sha256), its loop rate in the feature spec; a disagreeing --actuator is refused (~10 s)."""
    act = load_actuator(EXAMPLE)
    assert act.digest() != default_actuator().digest()
    # the shortest splits that still reach the force range (data generate refuses less: 75 % of it in every
    # split): four angles, so each test trial lasts 1.5 s
    monkeypatch.setattr(protocol, "N_ANGLES", 4)
    monkeypatch.setattr(protocol, "SECONDS", {"train": 10.0, "test": 6.0, "validation": 2.5})
    data = tmp_path / "data"
    assert main(["data", "generate", "--out", str(data), "--actuator", str(EXAMPLE)]) == 0
    assert load_actuator(data / "actuator.toml") == act
    assert len(pd.read_csv(data / "train.csv")) == 2000  # 10 s at the example's 200 Hz
    model = tmp_path / "sf.pt"
    assert main(["train", "--data", str(data), "--model", "sf", "--loss", "mae", "--out", str(model)]) == 0
    saved = load_model(model)
    assert saved["actuator"] == act.record() and saved["features"]["sample_rate_hz"] == act.loop_hz
    capsys.readouterr()
    paper = str(Path(__file__).resolve().parents[1] / "seagen" / "actuators" / "paper.toml")
    other = tmp_path / "x.pt"
    cmd = ["train", "--data", str(data), "--model", "sf", "--out", str(other), "--actuator"]
    assert main([*cmd, paper]) == 2
    err = capsys.readouterr().err
    assert "actuator.toml" in err and "--actuator" in err and not other.exists()
    assert main([*cmd, str(EXAMPLE)]) == 0
    ctl = tmp_path / "ctl.pt"
    assert main(["train", "--data", str(data), "--model", "sf", "--task", "control", "--out", str(ctl)]) == 0
    _closed_loop_c_equals_twin(str(ctl), act)
    _cloud_features_of_the_model_actuator(ctl, act, tmp_path)
    capsys.readouterr()
    assert main(["simulate", "--model", str(ctl), "--config", "mlp_mcu"]) == 2  # a shipped model's config
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--config mlp_mcu" in err and str(ctl) in err and "ctl_mcu" in err
    assert main(["simulate", "--model", str(ctl), "--calibration", "default:mlp_calibration"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.count("default:mlp_calibration") == 1 and act.digest()[:12] in err


def _closed_loop_c_equals_twin(ctl: str, act) -> None:
    """The control model's export in closed loop with the plant of `act`: the C controller and its Python
    twin give the same commands and states every tick (1 s at the actuator's loop rate, 3 angles)."""
    from seagen.control.loop import run_closed_loop
    from seagen.plant import PlantConfig
    from seagen.setups.user import control_setups

    setups, _row = control_setups(ctl)
    name = next(k for k in setups if k.endswith("_mcu"))
    pred, cfg = setups[name]()
    assert cfg.act.digest == act.digest() and cfg.act.loop_hz == act.loop_hz
    plant = PlantConfig(actuator=act)
    angles = np.array([8.0, 16.0, 24.0])
    recs = {
        impl: run_closed_loop(pred, 8.0, angles, impl=impl, duration_s=1.0, plant_cfg=plant)
        for impl in ("c", "py")
    }
    assert recs["c"]["out_mv"].shape == (int(act.loop_hz), 3)
    for f in ("out_mv", "desired", "comp", "pot_avg", "fault", "enc"):
        assert np.array_equal(recs["c"][f], recs["py"][f]), f
    assert np.abs(recs["c"]["out_mv"]).max() > 0  # the loop drove the motor


def _cloud_features_of_the_model_actuator(ctl: Path, act, tmp: Path) -> None:
    """A control model's cloud configuration feeds its float model the features of the actuator the model
    file records (here one with another pot offset: other angles), not the paper's."""
    from seagen.control.gentwin import float_features
    from seagen.frontends.load import load_float_model
    from seagen.modelfile import save_model
    from seagen.reference import float_ref
    from seagen.setups.user import control_setups

    d = act.to_dict()
    d["pot"]["offset_deg"] -= 2.0
    shifted = actuator_from_dict(d, "pot offset -2 deg")
    saved = load_model(ctl)
    saved["actuator"] = shifted.record()
    save_model(saved, tmp / "ctl_shifted.pt")
    setups, _row = control_setups(str(tmp / "ctl_shifted.pt"))
    pred = setups["ctl_shifted_cloud"]()[0]
    fm = load_float_model(str(tmp / "ctl_shifted.pt"))
    names = [s.name for s in fm.inputs]
    enc, pot = np.array([[0, 90], [40, 130], [90, 180]]), np.array([[900, 1500]] * 3)
    force = np.array([6.0, 12.0])
    want = float_ref.predict(fm, float_features(names, enc, pot, force, geometry(shifted)))
    paper = float_ref.predict(fm, float_features(names, enc, pot, force, geometry()))
    assert np.array_equal(pred.fn(enc, pot, force), want) and not np.array_equal(want, paper)


def test_simulate_on_another_design_runs_the_model_free_configs(tmp_path, capsys):
    """On another --actuator simulate runs kin_mcu (no model needed; stderr says the others need --model);
    a configuration of the shipped (paper) models there, or a calibration model of the paper's, is refused
    naming it (exit 2, one line); a bad description names the file and field (~4 s)."""
    assert main(["simulate", "--actuator", str(EXAMPLE), "--json"]) == 0
    cap = capsys.readouterr()
    act = load_actuator(EXAMPLE)
    assert set(json.loads(cap.out)) == {"kin_mcu"}
    assert set(json.loads(cap.out)["kin_mcu"]) == {f"{t:g}" for t in targets_n(act)}
    assert str(EXAMPLE) in cap.err and "--model" in cap.err and "sf_mcu" in cap.err
    for config in ("sf_mcu", "mlp_cloud", "mlp_mcu"):
        assert main(["simulate", "--actuator", str(EXAMPLE), "--config", config]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and f"--config {config}" in err and "--model" in err and str(EXAMPLE) in err
    assert main(["simulate", "--actuator", str(EXAMPLE), "--calibration", "default:mlp_calibration"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "default:mlp_calibration" in err and "trained for actuator" in err
    assert f"the simulated actuator is --actuator {EXAMPLE}" in err and "motor.supply_v 24.0, not 12.0" in err
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE.read_text().replace("stiffness_n_per_mm = 8.4", "stiffness_n_per_mm = -1.0"))
    assert main(["simulate", "--actuator", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "spring.stiffness_n_per_mm" in err


def test_kin_mcu_on_another_design_uses_its_friction_spring_and_controller():
    """kin_mcu's setup on another design: the kinematic constants and controller configuration of that
    design (the paper's setup would be refused by its plant)."""
    from seagen.control.experiment import model_free_setups
    from seagen.runtime.control import KinParams, predict_kinematic
    from seagen.setups.shipped import CONFIGS

    act = load_actuator(EXAMPLE)
    pred, ctl = model_free_setups(act)["kin_mcu"]()
    assert ctl.act.digest == act.digest() and ctl == ControlConfig.for_act(act_q(act))
    force = np.array([0, 5 << 16, 10 << 16])
    want = predict_kinematic(KinParams.of(act))(force, force, force)
    paper = predict_kinematic(KinParams())(force, force, force)
    assert np.array_equal(pred.make_twin()(force, force, force), want) and not np.array_equal(want, paper)
    assert CONFIGS["kin_mcu"]()[1].act.digest == default_actuator().digest()  # the paper's stays


def test_data_folder_actuator_mismatch_is_refused(tmp_path):
    """A data folder's actuator.toml and a disagreeing description: ActuatorError naming the file."""
    from seagen.data.schema import data_actuator

    (tmp_path / "actuator.toml").write_text(EXAMPLE.read_text())
    assert data_actuator(tmp_path) == load_actuator(EXAMPLE)
    with pytest.raises(ActuatorError, match="actuator.toml"):
        data_actuator(tmp_path, default_actuator())
    assert data_actuator(tmp_path / "none") == default_actuator()  # folders written before the file


@pytest.mark.slow
@pytest.mark.parametrize("actuator", ["paper", "example"])
def test_demo_end_to_end_on_both_designs(tmp_path, actuator, capsys):
    """`seagen demo` on each shipped design: data -> four models -> export (C == numpy == torch ==
    onnxruntime on the data, or it stops) -> closed loop on the design's plant -> discrepancy (~2 min
    each)."""
    args = ["demo", "--out", str(tmp_path)]
    if actuator == "example":
        args += ["--actuator", str(EXAMPLE)]
    assert main(args) == 0
    out = capsys.readouterr().out
    name = load_actuator(EXAMPLE).name if actuator == "example" else default_actuator().name
    assert name in out and "bit for bit" in out and "verdict: explained" in out
    assert (tmp_path / "discrepancy" / "report" / "report.md").is_file()
    from seagen.discrepancy.replay import load_timing

    assert load_timing(str(tmp_path / "data"))["lag"] == 1.0  # its data declare seagen's own timing


def test_protocol_peaks_follow_the_force_range():
    """The calibration protocol's peak forces are the paper's shares of the described force range (its volts
    scaled with them, within the supply): exactly the paper's moves on its actuator; on a 30 N range every
    push at the top train angle reaches its 1.5x peak well before the time cap (~2 s)."""
    assert [scaled_move(9.0, m) for m in PUSH_MOVES] == [Move(9.0, *m) for m in PUSH_MOVES]
    d = default_actuator().to_dict()
    d["control"]["force_max_n"] = 30.0
    act = actuator_from_dict(d, "30 N")
    top = protocol.train_angles(geometry(act))[-1]
    moves = [scaled_move(top, m, act) for m in PUSH_MOVES]
    for mv, m in zip(moves, PUSH_MOVES, strict=True):
        assert mv.peak_n == pytest.approx(1.5 * m[1]) and abs(mv.retract_v) <= act.motor.supply_v
    for mv, df in zip(moves, run_trials(PlantConfig(actuator=act), moves, seed=2), strict=True):
        assert df.force_n.max() >= mv.peak_n and df.t_s.iloc[-1] < 4.0, mv


def test_a_geometry_the_c_cannot_hold_is_refused_before_any_work(tmp_path, capsys):
    """A pot offset beyond the C's Q24 degrees (|deg| < 128), given with --actuator: `data generate`
    refuses it at once (exit 2, one line naming the file, the field and the bound), writing nothing; it
    used to pass data generation and training and be refused only by `seagen export`."""
    bad = tmp_path / "wide_pot.toml"
    text = EXAMPLE.read_text()
    assert "offset_deg = " in text
    bad.write_text(
        "\n".join("offset_deg = -200.0" if x.startswith("offset_deg") else x for x in text.splitlines())
    )
    out = tmp_path / "data"
    for argv in (
        ["data", "generate", "--out", str(out)],
        ["demo", "--out", str(out)],  # it ran data, training and export first, writing into --out
        ["export", "default:sf_calibration", "--out", str(out)],  # it said: trained for another actuator
    ):
        assert main([*argv, "--actuator", str(bad)]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and str(bad) in err and "pot.offset_deg -200" in err and "|deg| < 128" in err
        assert not out.exists()
