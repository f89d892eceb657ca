"""The C controller (c_runtime/sea_pid.c, sea_control.c) built with cffi, and a batch wrapper for the loop."""

from __future__ import annotations

from types import ModuleType

import numpy as np

from seagen.build.host import build
from seagen.build.runtime import runtime_sources
from seagen.control.controller import ControlConfig, KinParams

SOURCES = ("sea_fixed.h", "sea_fixed.c", "sea_pid.h", "sea_pid.c", "sea_control.h", "sea_control.c")

PID_CDEF = """
typedef struct { int32_t kp; int32_t ki; int32_t kd; int32_t d_alpha; int32_t margin;
                 int16_t out_min; int16_t out_max; } sea_pid_params;
typedef struct { int32_t integ; int32_t d_filt; int32_t meas_prev; int16_t out; } sea_pid_state;
void sea_pid_reset(const sea_pid_params *p, sea_pid_state *s, int32_t meas, int16_t out);
int16_t sea_pid_step(const sea_pid_params *p, sea_pid_state *s, int32_t setpoint, int32_t meas);
int64_t sea_clamp_s64(int64_t v, int64_t lo, int64_t hi);
int32_t sea_div_rne_s32(int32_t num, int32_t den);
"""
CDEF = (
    PID_CDEF
    + """
typedef int32_t (*sea_predictor_fn)(void *ctx, int32_t enc, int32_t pot, int32_t force_q16);
typedef struct {
    sea_pid_params pid; const int32_t *link_table; sea_predictor_fn predictor; void *predictor_ctx;
    int32_t predict_every; int32_t force_min; int32_t force_max; int32_t enc_jump_max;
    int32_t pot_stuck_ticks;
} sea_control_config;
typedef struct {
    sea_pid_state pid; int32_t pot_buf[10]; int32_t pot_idx; int32_t pot_avg; int32_t pred_count;
    int32_t enc_prev; int32_t stuck_lo; int32_t stuck_hi; int32_t desired; int32_t comp; int32_t fault;
    int16_t out;
} sea_control_state;
void sea_control_reset(const sea_control_config *c, sea_control_state *s, int32_t enc, int32_t pot);
int16_t sea_control_step(const sea_control_config *c, sea_control_state *s, int32_t enc, int32_t pot,
                         int32_t force_q16);
void sea_control_set_desired(sea_control_state *s, int32_t desired_q16);
typedef struct { int32_t friction_q16; int32_t inv_k_q16; } sea_kin_params;
int32_t sea_predict_kinematic(void *ctx, int32_t enc, int32_t pot, int32_t force_q16);
"""
)


def build_control(extra_cdef: str = "", extra_sources: dict[str, str] | None = None) -> ModuleType:
    """The controller runtime (plus optional extra C, e.g. a generated predictor) as a cffi module."""
    return build(CDEF + extra_cdef, {**runtime_sources(*SOURCES), **(extra_sources or {})}, name="control")


class CController:
    """A batch of C controllers (one sea_control_state each) sharing one sea_control_config."""

    def __init__(self, mod: ModuleType, c: ControlConfig, predictor: str | None, ctx: object = None) -> None:
        ffi, lib = mod.ffi, mod.lib
        self.ffi, self.lib = ffi, lib
        self.table = ffi.new("int32_t[]", [int(x) for x in c.table])
        self.ctx = ctx
        self.cfg = ffi.new("sea_control_config *")
        p = self.cfg.pid
        p.kp, p.ki, p.kd, p.d_alpha, p.margin, p.out_min, p.out_max = c.pid.as_tuple()
        self.cfg.link_table = self.table
        self.cfg.predictor = ffi.addressof(lib, predictor) if predictor else ffi.NULL
        self.cfg.predictor_ctx = ffi.cast("void *", ctx) if ctx is not None else ffi.NULL
        self.cfg.predict_every = c.predict_every
        self.cfg.force_min, self.cfg.force_max = c.force_min, c.force_max
        self.cfg.enc_jump_max, self.cfg.pot_stuck_ticks = c.enc_jump_max, c.pot_stuck_ticks
        self.states: list = []

    def reset(self, enc: np.ndarray, pot: np.ndarray) -> None:
        """sea_control_reset for each actuator."""
        self.states = [self.ffi.new("sea_control_state *") for _ in range(len(enc))]
        for st, e, p in zip(self.states, enc, pot, strict=True):
            self.lib.sea_control_reset(self.cfg, st, int(e), int(p))

    def step(self, enc: np.ndarray, pot: np.ndarray, force_q16: np.ndarray) -> np.ndarray:
        """sea_control_step for each actuator; returns the commands (mV, int64)."""
        f = np.broadcast_to(force_q16, np.shape(enc))
        out = [
            self.lib.sea_control_step(self.cfg, st, int(e), int(p), int(x))
            for st, e, p, x in zip(self.states, enc, pot, f, strict=True)
        ]
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
