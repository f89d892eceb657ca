"""The exported controller (NAME_controller.c on disk) ticked on the host against the controller twin."""

from __future__ import annotations

import numpy as np

from seagen.verify.result import Verdict


def sequence(qm, n: int = 800, seed: int = 3, act=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raw enc/pot random walks (inside the pot range of the export's actuator `act`, the paper's when None;
    encoder steps within half its encoder-jump bound, so the ticks run the controller, not only its fault
    latch) and a desired force (Q16 N) stepping through the calibrated force range."""
    from seagen.runtime.actq import act_q_of
    from seagen.runtime.control import WALK_STEPS, sensor_walk

    a = act or act_q_of()
    force_n = next((i.signal.lo, i.signal.hi) for i in qm.inputs if i.signal.name == "force_n")
    steps = (max(1, min(WALK_STEPS[0], a.enc_jump_max // 2)), WALK_STEPS[1])
    return sensor_walk(seed, n, steps=steps, force_n=force_n, pot_max=a.pot_max)


def disk_ticks(files: dict[str, str], p: str, enc, pot, force) -> np.ndarray:
    """NAME_controller_init at the first sample, then NAME_controller_tick per sample (the files on disk)."""
    from seagen.toolchain.host import build

    cdef = (  # the actuator struct stays opaque: cffi takes its size from NAME_controller.h
        f"typedef struct {{ ...; }} {p}_controller_t;\n"
        f"void {p}_controller_init({p}_controller_t *a, int32_t enc, int32_t pot);\n"
        f"int32_t {p}_controller_tick({p}_controller_t *a, int32_t enc, int32_t pot, int32_t force_q16);\n"
    )
    mod = build(cdef, files, name=f"{p}_controller")
    a = mod.ffi.new(f"{p}_controller_t *")
    getattr(mod.lib, f"{p}_controller_init")(a, int(enc[0]), int(pot[0]))
    tick = getattr(mod.lib, f"{p}_controller_tick")
    return np.array([tick(a, int(e), int(q), int(f)) for e, q, f in zip(enc, pot, force, strict=True)])


def twin_ticks(qm, prefix: str, enc, pot, force, act=None) -> np.ndarray:
    """The Python controller twin with the shipped configuration and the per-tick predictor twin, for the
    export's actuator `act` (the paper's when None)."""
    from seagen.codegen.controller import shipped_config
    from seagen.control.gentwin import StepTwin
    from seagen.runtime.control import ControlConfig, control_run

    cfg = shipped_config(qm, act)
    twin = StepTwin(prefix, qm, act)
    return control_run(ControlConfig(**{**cfg.__dict__, "predictor": twin}), enc, pot, force)


def check_controller(v: Verdict, files: dict[str, str], prefix: str, qm, act=None) -> None:
    """Record whether the exported controller's ticks equal the twin's on one synthetic sequence."""
    enc, pot, force = sequence(qm, act=act)
    got = disk_ticks(files, prefix, enc, pot, force)
    want = twin_ticks(qm, prefix, enc, pot, force, act)
    bad = np.flatnonzero(got != want)
    problem = None
    if bad.size:
        k = int(bad[0])
        problem = (
            f"tick {k} (enc {enc[k]}, pot {pot[k]}, force_q16 {force[k]}): C {got[k]} vs twin {want[k]} mV"
        )
    v.add(tick_name(prefix), problem, info=f"{len(enc)} ticks")


def tick_name(prefix: str) -> str:
    """The stable name of the controller check."""
    return f"{prefix}_controller_tick over the synthetic sequence (host) == controller twin"
