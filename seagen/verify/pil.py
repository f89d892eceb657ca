"""`seagen pil`: an export's controller (and calibration model) as firmware on an emulated board, closing
the paper's force loop with the Python plant; every tick compared with the Python twins bit for bit."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from seagen.control.loop import PyController, plant_steps_per_tick
from seagen.errors import UserError
from seagen.pil.controller import MAX_ACTUATORS, PilController
from seagen.runtime.control import q16
from seagen.verify.result import Verdict

COMPARED = ("out", "desired", "comp", "pot_avg", "fault")  # the command (mV) and the controller state


@dataclass
class PilResult:
    """The verdict and the firmware's own instruction counts per tick (all actuators)."""

    verdict: Verdict
    core: str
    machine: str
    actuators: int
    instructions: list[int] = field(default_factory=list)

    def summary(self) -> dict:
        """Instructions per tick: mean, max, and mean per actuator."""
        x = np.asarray(self.instructions or [0])
        return {
            "core": self.core,
            "board": self.machine,
            "ticks": len(self.instructions),
            "instr_mean": round(float(x.mean()), 1),
            "instr_max": int(x.max()),
            "instr_per_actuator": round(float(x.mean()) / max(self.actuators, 1), 1),
        }


class CalTwin:
    """Twin of NAME_step of a calibration model for a batch, one call per tick (starts reset)."""

    def __init__(self, qm, act=None) -> None:
        from seagen.runtime import features as F
        from seagen.runtime.actq import act_q_of

        self.qm, self.F, self.act = qm, F, act or act_q_of()
        self.pipeline = F.Pipeline(self.act)

    def __call__(self, enc: np.ndarray, pot: np.ndarray) -> np.ndarray:
        """The force estimates (int16 in Q out_frac) of this tick."""
        from seagen.reference import numpy_ref

        b, d, dd = self.pipeline.step(enc, pot)
        return numpy_ref.infer(self.qm, self.F.inputs(self.act, self.qm.inputs, b, d, dd, None)).astype(
            np.int64
        )


def _mismatch(k: int, enc, pot, force, got: dict[str, np.ndarray], want: dict[str, np.ndarray]) -> str | None:
    """The first field and actuator where the board and the twin differ at tick k, with the tick's inputs."""
    for name in want:
        bad = np.flatnonzero(got[name] != want[name])
        if bad.size:
            i = int(bad[0])
            return (
                f"tick {k}, actuator {i} (enc {enc[i]}, pot {pot[i]}, force_q16 {force[i]}): "
                f"{name} board {got[name][i]} vs twin {want[name][i]}"
            )
    return None


def closed_loop(
    board: PilController,
    twin_cfg,
    cal_qm,
    contact_deg: np.ndarray,
    target_n: float,
    ticks: int,
    seed: int,
    plant_cfg=None,
) -> tuple[str | None, int]:
    """One run of the experiment in lock step with the twins on the plant `plant_cfg` (the paper's actuator
    when None); (first mismatch or None, ticks run)."""
    from seagen.plant import Plant, PlantConfig

    plant = Plant(plant_cfg or PlantConfig(), contact_deg, seed=seed)
    twin, cal = PyController(twin_cfg), CalTwin(cal_qm, twin_cfg.act) if cal_qm is not None else None
    s = plant.read()
    board.reset(s.enc, s.pot)
    twin.reset(s.enc, s.pot)
    force = np.full(len(contact_deg), q16(target_n), dtype=np.int64)
    for k in range(ticks):
        s = plant.read()
        out = board.step(s.enc, s.pot, force)
        want = {"out": twin.step(s.enc, s.pot, force)}
        want.update({f: twin.field(f) for f in COMPARED[1:]})
        if cal is not None:
            want["force_est"] = cal(s.enc, s.pot)
        got = {f: board.field(f) for f in want}
        if problem := _mismatch(k, s.enc, s.pot, force, got, want):
            return problem, k + 1
        for _ in range(plant_steps_per_tick(plant.cfg)):
            plant.step(out / 1000.0)
    return None, ticks


def _export(
    folder: Path, model: str, prefix: str | None, v: Verdict, allow_pickle: bool = False, actuator=None
):
    """(files on disk, rebuilt export, manifest) of MODEL's export in DIR; its drift recorded in `v`."""
    from seagen.defaults import resolve_model
    from seagen.verify.drift import (
        changed_files,
        check_files,
        check_model,
        check_stray,
        check_version,
        select,
    )
    from seagen.verify.run import disk_files, rebuild

    model = resolve_model(model)
    man, matches = select(folder, Path(model), prefix)
    check_version(v, man)
    check_model(v, man, Path(model), matches)
    check_files(v, folder, man, changed_files(folder, man), None)
    check_stray(v, folder, man)
    return disk_files(folder, man), rebuild(man, Path(model), None, allow_pickle, actuator=actuator), man


def default_ticks(act) -> int:
    """Ticks of one run of the experiment on actuator `act`: its duration at the control-loop rate."""
    from seagen.control.experiment import duration_s

    return round(duration_s(act) * act.loop_hz)


def run_pil(
    folder: str,
    model: str,
    core: str,
    ticks: int | None = None,
    actuators: int = 10,
    cal_model: str | None = None,
    prefix: str | None = None,
    allow_pickle: bool = False,
    actuator=None,
) -> PilResult:
    """The experiment (the actuator's targets, `actuators` contact angles over its linkage range, `ticks`
    per run, default_ticks by default) on the board."""
    from seagen.codegen.actfile import export_actuator
    from seagen.codegen.controller import shipped_config
    from seagen.control.experiment import contact_deg, targets_n
    from seagen.control.gentwin import StepTwin
    from seagen.defaults import model_label
    from seagen.plant import PlantConfig

    if (ticks is not None and ticks < 1) or not 1 <= actuators <= MAX_ACTUATORS:
        raise UserError(f"--ticks must be >= 1 and --actuators 1..{MAX_ACTUATORS} (got {ticks}, {actuators})")
    root = Path(folder)
    v = Verdict("", str(root), command="pil")
    files, ex, man = _export(root, model, prefix, v, allow_pickle, actuator)
    if not man.data["options"].get("controller"):
        raise UserError(
            f"{man.path}: exported without --controller (re-export with seagen export --controller)"
        )
    v.prefix = ex.prefix
    plant_cfg = PlantConfig(actuator=export_actuator(ex.loaded, actuator, model))  # the export's
    ticks = ticks or default_ticks(plant_cfg.actuator)
    cal_qm, cal, shared = None, None, False
    if cal_model is not None:
        cal_files, cal_ex, _ = _export(root, cal_model, None, v, allow_pickle, actuator)
        export_actuator(cal_ex.loaded, plant_cfg.actuator, model_label(cal_model))  # another design's: exit 2
        cal_qm, cal = cal_ex.qmodel, cal_ex.prefix
        files = {**files, **cal_files}
        shared = cal_ex.act is not None and ex.act is not None and cal_ex.act.cid == ex.act.cid
    board = PilController(files, ex.prefix, core, cal, shared=shared)  # one pipeline for one actuator
    res = PilResult(v, core, board.board.machine, actuators)
    cfg = shipped_config(ex.qmodel, ex.act)  # the configuration export --controller renders
    angles = np.array(contact_deg(plant_cfg.actuator, actuators))
    try:
        for i, target in enumerate(targets_n(plant_cfg.actuator)):
            twin_cfg = replace(cfg, predictor=StepTwin(ex.prefix, ex.qmodel, ex.act))
            problem, done = closed_loop(
                board, twin_cfg, cal_qm, angles, target, ticks, seed=i, plant_cfg=plant_cfg
            )
            what = "commands, desired, comp, pot_avg, fault" + (f" and {cal} force estimates" if cal else "")
            v.add(
                f"{target:g} N closed loop on {board.board.machine}: {what} == twins",
                problem,
                f"{done} ticks x {actuators} actuators bit-identical",
            )
        res.instructions = board.instructions
    finally:
        board.close()
    return res
