"""The C controller (c_runtime/sea_pid.c, sea_control.c) built with cffi, and a batch wrapper for the loop."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

from seagen.codegen.runtime import cdef_of, runtime_sources
from seagen.runtime.control import ControlConfig, KinParams
from seagen.toolchain import host
from seagen.toolchain.actc import CAct

SOURCES = (
    "sea_fixed.h",
    "sea_fixed.c",
    "sea_fixed_ctrl.c",
    "sea_pid.h",
    "sea_pid.c",
    "sea_control.h",
    "sea_control.c",
    "sea_control_extra.h",
    "sea_control_extra.c",
)
NN_SOURCES = ("sea_nn.h", "sea_nn.c", "sea_features.h", "sea_features.c")
CDEF = (
    cdef_of(*runtime_sources("sea_fixed.h", "sea_pid.h", "sea_control.h", "sea_control_extra.h").values())
    + "\n"
)


def build_control(extra_cdef: str = "", extra_sources: dict[str, str] | None = None) -> ModuleType:
    """The controller runtime (plus optional extra C, e.g. a generated predictor) as a cffi module."""
    return host.build(
        CDEF + extra_cdef, {**runtime_sources(*SOURCES), **(extra_sources or {})}, name="control"
    )


def generated_cdef(prefix: str, root: Path) -> str:
    """cffi declarations of a generated control predictor (its header, after sea_features.h's)."""
    return cdef_of(*runtime_sources("sea_features.h").values(), (root / f"{prefix}.h").read_text())


def generated_sources(prefix: str, root: Path) -> dict[str, str]:
    """The exported {prefix}.c/.h and the actuator files (from the folder root) plus the sea_nn runtime they
    link against."""
    files = {f"{prefix}{ext}": (root / f"{prefix}{ext}").read_text() for ext in (".h", ".c")}
    acts = {p.name: p.read_text() for p in sorted(root.glob("sea_act_*.[ch]"))}
    return {**runtime_sources(*NN_SOURCES), **files, **acts}


def generated_ctx(prefix: str) -> Callable[[ModuleType], object]:
    """ctx factory: a fresh {prefix}_state_t, reset, for one actuator."""

    def make(mod: ModuleType) -> object:
        st = mod.ffi.new(f"{prefix}_state_t *")
        getattr(mod.lib, f"{prefix}_reset")(st)
        return st

    return make


class CController:
    """A batch of C controllers, one sea_control_state each; one shared config, or one per actuator when
    the predictor is stateful (`make_ctx`: a fresh ctx per actuator, made at the first reset and kept)."""

    def __init__(
        self,
        mod: ModuleType,
        c: ControlConfig,
        predictor: str | None,
        ctx: object = None,
        make_ctx: Callable[[ModuleType], object] | None = None,
    ) -> None:
        self.mod, self.ffi, self.lib = mod, mod.ffi, mod.lib
        self.c, self.predictor, self.make_ctx = c, predictor, make_ctx
        self.act = CAct(self.ffi, c.act)
        self.ctxs: list = [ctx]  # owned: the C config points into them
        self.cfgs = [] if make_ctx else [self._config(ctx)]
        self.states: list = []

    def _config(self, ctx: object) -> object:
        """One sea_control_config pointing at `ctx`."""
        ffi, c = self.ffi, self.c
        cfg = ffi.new("sea_control_config *")
        p = cfg.pid
        p.kp, p.ki, p.kd, p.d_alpha, p.margin, p.out_min, p.out_max = c.pid.as_tuple()
        cfg.act = self.act.ptr
        cfg.predictor = ffi.addressof(self.lib, self.predictor) if self.predictor else ffi.NULL
        cfg.predictor_ctx = ffi.cast("void *", ctx) if ctx is not None else ffi.NULL
        cfg.predict_every, cfg.pred_avg = c.predict_every, c.pred_avg
        cfg.force_min, cfg.force_max = c.force_min, c.force_max
        cfg.enc_jump_max, cfg.pot_stuck_ticks = c.enc_jump_max, c.pot_stuck_ticks
        return cfg

    def _cfg(self, i: int) -> object:
        return self.cfgs[i] if self.make_ctx else self.cfgs[0]

    def reset(self, enc: np.ndarray, pot: np.ndarray) -> None:
        """sea_control_reset for each actuator (a stateful predictor's ctx is kept across resets)."""
        if self.make_ctx and len(self.cfgs) != len(enc):
            self.ctxs = [self.make_ctx(self.mod) for _ in range(len(enc))]
            self.cfgs = [self._config(x) for x in self.ctxs]
        self.states = [self.ffi.new("sea_control_state *") for _ in range(len(enc))]
        for i, (st, e, p) in enumerate(zip(self.states, enc, pot, strict=True)):
            self.lib.sea_control_reset(self._cfg(i), st, int(e), int(p))

    def step(self, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
        """sea_control_step for each actuator; returns the commands (mV, int64)."""
        f = np.broadcast_to(force_q16, np.shape(enc))
        step, n = self.lib.sea_control_step, len(self.states)
        out = [step(self._cfg(i), self.states[i], int(enc[i]), int(pot[i]), int(f[i])) for i in range(n)]
        return np.array(out, dtype=np.int64)

    def set_desired(self, desired_q16: np.ndarray) -> None:
        """sea_control_set_desired for each actuator."""
        for st, d in zip(self.states, desired_q16, strict=True):
            self.lib.sea_control_set_desired(st, int(d))

    def field(self, name: str) -> np.ndarray:
        """One int field of every state (e.g. 'fault', 'desired', 'comp', 'pot_avg')."""
        return np.array([getattr(st, name) for st in self.states], dtype=np.int64)


def kin_ctx(mod: ModuleType, k: KinParams) -> object:
    """A sea_kin_params the C kinematic predictor reads through its ctx pointer."""
    ctx = mod.ffi.new("sea_kin_params *")
    ctx.friction_q16, ctx.inv_k_q16 = k.friction_q16, k.inv_k_q16
    return ctx
