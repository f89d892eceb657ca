"""Issue 35: any design the description accepts gets data it can use, or seagen says why not. On a slow design
(tests/slow_6v.toml: 0.42 mm/s at the nut) data that never reach the force range are refused with the reason
(exit 2, one line, nothing written); the paper's figures appear only on the paper's actuator; thresholds and
defaults follow the design; a parameter the data do not move is not called pinned."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from seagen.actuator import default_actuator, load_actuator, to_toml
from seagen.cli import main
from seagen.data import protocol
from seagen.data.schema import save_csv

SLOW = Path(__file__).with_name("slow_6v.toml")
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "actuators" / "stiff_24v.toml"
QUICK = {"train": 4.0, "test": 2.0, "validation": 1.4}  # short splits: the slow design reaches < 1 N
PAPER_FIGURES = ("34.31", "44.7", "10400", "2416", "2.1 / 2.4 / 4.45")


@pytest.fixture(scope="module")
def slow_splits() -> dict[str, pd.DataFrame]:
    """The paper's protocol, shortened and at the paper's pace (the split durations and trial cap not
    stretched for the slow design, as before seagen derived them), simulated on the slow design (~3 s)."""
    from seagen.plant import PlantConfig

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(protocol, "SECONDS", QUICK)
        mp.setattr(protocol, "pace", lambda act=None: 1.0)
        mp.setattr(protocol, "TRIAL_CAP_S", 2.0)  # longer than any split's quota per angle (1.4 s)
        return protocol.generate(PlantConfig(actuator=load_actuator(SLOW)), seed=0)


def _folder(path: Path, splits: dict[str, pd.DataFrame], act, boost: dict[str, float] | None = None) -> Path:
    """A data folder of `splits` recorded on `act`, force_n raised by boost[split] N (a made-up load)."""
    path.mkdir(parents=True)
    for s, df in splits.items():
        save_csv(df.assign(force_n=df["force_n"] + (boost or {}).get(s, 0.0)), path / f"{s}.csv")
    (path / "actuator.toml").write_text(to_toml(act))
    return path


def _exit_2(capsys, *argv: str) -> str:
    """Run the CLI; it must exit 2 with a one-line message (after any progress bar) and no traceback;
    returns that line."""
    capsys.readouterr()
    assert main(list(argv)) == 2
    cap = capsys.readouterr()
    *bar, err = cap.err.strip().split("\n")
    assert all("split/s" in b for b in bar) and err.startswith("seagen: error: "), cap.err
    assert "Traceback" not in cap.err and "nan" not in (cap.out + err).lower(), cap.out + cap.err
    return err.removeprefix("seagen: error: ")


def test_generate_refuses_data_short_of_the_force_range(slow_splits, tmp_path, monkeypatch, capsys):
    """`data generate` on the slow design: exit 2 naming each split's peak force against its share of
    control.force_max_n (75 % in every split: a rig's log's held-out splits are asked half), the rows in
    contact and the design's nut speed; the folder is not created."""
    monkeypatch.setattr(protocol, "generate", lambda cfg, seed=0, progress=None: dict(slow_splits))
    out = tmp_path / "data"
    err = _exit_2(capsys, "data", "generate", "--actuator", str(SLOW), "--out", str(out))
    assert str(out) in err and "nothing written" in err
    assert "peak force train" in err and "(need 15 N, 75%)" in err and "50%" not in err
    assert all(f" {s} " in err.split("peak force")[1].split(" of control")[0] for s in ("test", "validation"))
    assert "of control.force_max_n 20 N" in err and "rows in contact (force > 0.3 N)" in err
    assert "0.42 mm/s" in err
    assert not out.exists()


def test_import_refuses_a_log_short_of_the_force_range(tmp_path, capsys):
    """`data import` of a log whose trials peak at a fifth of the range: exit 2 naming the log and the
    splits' peaks; neither the loop-rate copy nor logged/ is written."""
    from seagen.discrepancy.bench import case_frames
    from seagen.plant import PlantConfig
    from tests.test_logimport import MAP, _rig_log, import_argv

    frames = [
        f.assign(force_n=f["force_n"] / 5, load_cell_n=f["load_cell_n"] / 5)
        for f in case_frames(PlantConfig(), seed=7, fast=True)[:4]
    ]
    _rig_log(frames).to_csv(tmp_path / "rig.csv", index=False)
    (tmp_path / "map.toml").write_text(MAP)
    out = tmp_path / "data"
    err = _exit_2(capsys, *import_argv(tmp_path, out))
    assert err.startswith(f"{tmp_path / 'rig.csv'}: nothing written") and "peak force train" in err
    assert "the log's trials do not load the spring that far" in err
    assert "(need 15 N, 75%)" in err and "(need 10 N, 50%)" in err  # held-out splits as the rig logged them
    assert not out.exists()


def test_train_refuses_data_short_of_the_force_range_before_any_search(
    slow_splits, tmp_path, monkeypatch, capsys
):
    """`train --trials 2` on data that never exceed 5 N: exit 2 naming test.csv and the threshold, before
    the search (which would fail with "No trials are completed yet"); no model file."""
    from seagen.fit import search

    monkeypatch.setattr(search, "search", lambda *a, **k: pytest.fail("the search ran"))
    data = _folder(tmp_path / "slow", slow_splits, load_actuator(SLOW))
    model = tmp_path / "m.pt"
    err = _exit_2(
        capsys, "train", "--data", str(data), "--model", "mlp", "--trials", "2", "--out", str(model)
    )
    assert f"{data / 'test.csv'}: no row with force_n above 5 N" in err and "25%" in err
    assert not model.exists()


def test_train_refuses_a_search_whose_held_out_trials_stay_below_the_threshold(slow_splits, tmp_path, capsys):
    """Test and validation loaded past 5 N but not the training trials the search holds out: the search is
    refused naming them; an SF (no search) trains on the same folder."""
    from seagen.fit.mlp import MlpConfig, holdout_mask

    train = slow_splits["train"]
    held = holdout_mask(train, MlpConfig.holdout, 0)
    splits = {**slow_splits, "train": train.assign(force_n=np.where(held, 0.0, train["force_n"] + 12.0))}
    data = _folder(tmp_path / "d", splits, load_actuator(SLOW), {"test": 12.0, "validation": 12.0})
    argv = ["train", "--data", str(data), "--out", str(tmp_path / "m.pt")]
    err = _exit_2(capsys, *argv, "--model", "mlp", "--trials", "2")
    assert "train.csv (the search's held-out trials): no row with force_n above 5 N" in err
    assert main([*argv, "--model", "sf"]) == 0


def test_paper_figures_only_on_the_papers_actuator(slow_splits, tmp_path, capsys):
    """The same rows, loaded past 5 N, recorded on the paper's actuator and on the slow design: `data
    summary` and `evaluate` print the paper's figures for the first only; the slow design's own (unloaded)
    data say what is missing instead of "nan %", with no numpy warning."""
    boost = {"train": 12.0, "test": 12.0, "validation": 12.0}
    texts = {}
    for name, act in (("paper", default_actuator()), ("slow", load_actuator(SLOW))):
        data = _folder(tmp_path / name, slow_splits, act, boost)
        model = tmp_path / f"{name}.pt"
        assert main(["train", "--data", str(data), "--model", "sf", "--out", str(model)]) == 0
        capsys.readouterr()
        assert main(["data", "summary", str(data)]) == 0
        assert main(["evaluate", str(model), "--data", str(data)]) == 0
        texts[name] = capsys.readouterr().out
    assert all(f in texts["paper"] for f in PAPER_FIGURES[:4]), texts["paper"]
    assert not any(f in texts["slow"] for f in PAPER_FIGURES), texts["slow"]
    bare = _folder(tmp_path / "bare", slow_splits, load_actuator(SLOW))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["data", "summary", str(bare)]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out.lower() and not any(f in out for f in PAPER_FIGURES)
    assert "these data do not cover the force range: peak force train" in out
    assert "not measured: no row above 5 N" in out


def test_simulate_refuses_targets_outside_the_control_models_range(slow_splits, tmp_path, capsys):
    """A control model trained on desired forces up to ~11 N, simulated at 5/10/15 N: exit 2 naming 15 N (not
    5 or 10) and the model's range (the C clamped its input there silently)."""
    scaled = {s: df.assign(force_n=df["force_n"] * 40.0) for s, df in slow_splits.items()}  # up to ~11 N
    data = _folder(tmp_path / "d", scaled, load_actuator(SLOW))
    model = tmp_path / "ctl.pt"
    argv = ["train", "--data", str(data), "--model", "sf", "--task", "control", "--out", str(model)]
    assert main(argv) == 0
    err = _exit_2(capsys, "simulate", "--model", str(model))
    assert f"--model {model}: trained on desired forces" in err
    assert "but 15 N of the experiment's targets 5, 10, 15 N" in err
    assert "control.force_max_n 20 N" in err


def test_limit_note_advises_a_higher_limit_only_below_the_supply():
    """Runs stuck at the command limit: a higher control.limit_v is advised where the limit is below the
    supply (the paper's 6.5 of 12 V), not where it is the supply already (the slow design's 6 of 6 V)."""
    from seagen.cli.control import limit_notes

    table = {"kin_mcu": {"15": {"settled": 0, "angles": 10, "at_limit": 0.9}}}
    paper, slow = limit_notes(table, default_actuator()), limit_notes(table, load_actuator(SLOW))
    assert len(paper) == len(slow) == 1
    assert "a higher control.limit_v" in paper[0] and "a higher control.limit_v" not in slow[0]
    assert "already the whole supply" in slow[0]


def test_pil_ticks_and_plot_follow_the_experiment_and_the_loop_rate(monkeypatch):
    """`pil --ticks` defaults to the experiment's 6 s at the actuator's loop rate (600 at the paper's 100 Hz,
    1200 at the example's 200 Hz); the comparison plot's time axis spans the runs (6 s, not 4)."""
    from seagen.cli import build_parser
    from seagen.control import plots
    from seagen.verify.pil import default_ticks
    from tests.test_plots import fake_results

    assert default_ticks(default_actuator()) == 600 and default_ticks(load_actuator(EXAMPLE)) == 1200
    args = build_parser().parse_args(["pil", "d", "--model", "m.pt", "--core", "cortex-m4"])
    assert args.ticks is None
    seen = {}
    monkeypatch.setattr(plots, "save_png", lambda fig, path, **kw: seen.setdefault("fig", fig))
    plots.comparison_plot({"a": fake_results(n=600)}, Path("unused.png"))
    assert seen["fig"].axes[0].get_xlim() == pytest.approx((0.0, 5.99))


def _dead_jacobian(monkeypatch, cols: dict[int, float]):
    """base_check on the default base with a constructed Jacobian: random columns, those in `cols` scaled by
    their factor (0: the data do not move that parameter); returns (BaseCheck, Jacobian, keys)."""
    from seagen.discrepancy import recalibrate
    from seagen.plant import PlantConfig

    rng = np.random.default_rng(0)
    got: dict = {}

    def fake(cfg, jobs, runs, sigma):
        ((cand, us),) = jobs
        jac = rng.normal(size=(200, len(us) - 1))
        for j, f in cols.items():
            jac[:, j] *= f
        got.update(jac=jac, keys=cand.keys)
        r0 = rng.normal(size=200)
        return [[r0 + jac @ (u - us[0]) for u in us]]

    monkeypatch.setattr(recalibrate, "residual_vectors", fake)
    check = recalibrate.base_check(PlantConfig(), None, {})  # type: ignore[arg-type]  # runs: faked
    return check, got["jac"], [f"{e}.{p}" for e, p in got["keys"]]


def test_a_parameter_the_data_do_not_move_is_not_pinned(monkeypatch):
    """A zero (or numerically zero) Jacobian column gets 1-sigma infinite and the report says "not pinned:
    the data do not exercise it" (the pseudo-inverse alone gave it 0, "pinned"); the others keep the
    sigmas of the Jacobian without it."""
    from seagen.discrepancy.recalibrate import unit_sigmas
    from seagen.discrepancy.report import unpinned_words

    check, jac, keys = _dead_jacobian(monkeypatch, {0: 0.0, 2: 1e-13})
    assert math.isinf(check.sigma[keys[0]]) and math.isinf(check.sigma[keys[2]])
    assert check.unexercised == [keys[0], keys[2]] and keys[0] in check.unpinned
    words = unpinned_words(SimpleNamespace(check=check))
    assert f"{keys[0]}, {keys[2]} not pinned: the data do not exercise it" in words
    live = unit_sigmas(np.delete(jac, [0, 2], axis=1))
    sig = unit_sigmas(jac)
    assert np.isinf(sig[[0, 2]]).all() and np.allclose(np.delete(sig, [0, 2]), live, rtol=1e-6)
    assert np.isfinite(live).all() and (live > 0).all()


def test_discrepancy_classes_scale_with_the_design():
    """The signature's still/fast speed classes and force band, and the region labels' still band, are
    shares of the design's no-load nut speed and force range: exactly 0.2 / 2 mm/s and 0.5 N on the
    paper's actuator, ten times higher speeds on a motor ten times faster, another band at another range."""
    import dataclasses

    from seagen.discrepancy.bench import make_case
    from seagen.discrepancy.residuals import FAST_MM_S, STILL_MM_S, nut_speed, region_labels
    from seagen.discrepancy.signature import features

    case = make_case(("load_cell_offset",), 11, fast=True)
    paper = case.base.motor
    fast = dataclasses.replace(paper, no_load_rpm=paper.no_load_rpm * 10)
    assert (nut_speed(paper, STILL_MM_S), nut_speed(paper, FAST_MM_S)) == (0.2, 2.0)
    assert nut_speed(fast, STILL_MM_S) == pytest.approx(2.0)
    runs, top = case.runs, case.base.actuator.control.force_max_n
    mine, faster = features(runs, paper, top), features(runs, fast, top)
    assert not np.array_equal(mine["speed"], faster["speed"])
    assert not np.array_equal(mine["force"], features(runs, paper, 2 * top)["force"])
    a, b = region_labels(runs, paper, top)["speed"], region_labels(runs, fast, top)["speed"]
    assert (b == "still").sum() > (a == "still").sum()


def test_a_pot_too_coarse_to_hold_the_band_is_refused_at_the_description(tmp_path, capsys):
    """A 17.9 N/mm spring read by a 10-bit pot over 140 deg (a drawn design: its MAE SF loop settled 0 of 10
    at every target, 0.6-3.6 N off): one pot count is 0.81 N of spring force at the top angle, more than the
    0.18 N the +-0.3 N band leaves beside the dead band, so every command refuses it where the description
    is given (exit 2, one line naming the fields and the numbers, nothing written); so is a 16-count
    encoder behind 4:1 and a 2.93 mm lead on a 7.77 N/mm spring, 0.36 N a count (a drawn design whose loop
    held its setpoint and settled 2 / 3 / 0 of 10, 0.43-0.46 N off); the shipped designs' two steps
    together are 0.012-0.035 N."""
    from seagen.actuator import actuator_from_dict
    from seagen.control.tune import enc_step_n, hold_problem, pot_step_n

    d = load_actuator(EXAMPLE).to_dict()
    d["spring"]["stiffness_n_per_mm"] = 17.9
    d["pot"].update(full_scale_deg=140.0, adc_bits=10)
    d["linkage"]["cb_mm"] = 40.3
    d["control"]["force_max_n"] = 31.8
    bad = tmp_path / "coarse.toml"
    bad.write_text(to_toml(actuator_from_dict(d, "coarse.toml")))
    out = tmp_path / "data"
    err = _exit_2(capsys, "data", "generate", "--actuator", str(bad), "--out", str(out))
    assert str(bad) in err and "one pot count 0.81 N at the linkage's top angle 28 deg" in err
    assert "pot.adc_bits" in err and "pot.full_scale_deg" in err and "spring.stiffness_n_per_mm" in err
    assert not out.exists()
    roots = [EXAMPLE.parent / f"{n}.toml" for n in ("stiff_24v", "micro_6v", "fast_48v")] + [SLOW]
    for act in [default_actuator(), *map(load_actuator, roots)]:
        assert hold_problem(act) is None and pot_step_n(act) + enc_step_n(act) < 0.05, act.name
    d = default_actuator().to_dict()  # a drawn design: 3.7 V, 4:1, 16 counts, 2.93 mm lead, 7.77 N/mm
    d["motor"].update(
        supply_v=3.7, no_load_rpm=3640.0, gear_ratio=4.0, counts_per_rev=16, stall_force_n=162.0
    )
    d["transmission"]["lead_mm"] = 2.93
    d["spring"]["stiffness_n_per_mm"] = 7.77
    d["control"]["force_max_n"] = 73.8
    why = hold_problem(actuator_from_dict(d, "coarse_enc.toml"))
    assert why and "one encoder count 0.36 N" in why and "motor.counts_per_rev" in why
