"""The controller in the export: NAME_controller.{h,c} (tuned gains, limits, margin, the predictor wired in)
and the controller runtime, so firmware gets the whole force loop from one folder."""

from __future__ import annotations

from dataclasses import fields
from typing import Any

from seagen import __version__
from seagen.cnames import assert_valid_prefix
from seagen.codegen.render import environment, model_hash
from seagen.codegen.runtime import CONTROL_RUNTIME, runtime_sources
from seagen.errors import UserError
from seagen.ir import QMLP, QModel
from seagen.runtime.actq import ActQ
from seagen.runtime.control import MLP_PRED_AVG, ControlConfig
from seagen.runtime.features import is_predictor

FIELDS = ("predict_every", "pred_avg", "force_min", "force_max", "enc_jump_max", "pot_stuck_ticks")


def shipped_config(qm: QModel, act: ActQ | None = None) -> ControlConfig:
    """The configuration the closed-loop experiments use for this kind of predictor (Table II), for actuator
    `act` (the paper's when None: its defaults are ControlConfig's)."""
    kw: dict[str, Any] = {"pred_avg": MLP_PRED_AVG} if isinstance(qm, QMLP) else {}
    return ControlConfig(**kw) if act is None else ControlConfig.for_act(act, **kw)


def tick_config(c: ControlConfig) -> dict[str, int]:
    """The sea_control_config fields of `c` by name (seagen.toolchain.target.TICK_FIELDS), for Target.tick."""
    pid = {f"pid.{f.name}": int(getattr(c.pid, f.name)) for f in fields(c.pid)}
    return {**pid, **{f: int(getattr(c, f)) for f in FIELDS}}


def summary(c: ControlConfig) -> list[str]:
    """Lines describing the configuration, for the header comment."""
    p = c.pid
    return [
        f"PID kp {p.kp}, ki {p.ki}, kd {p.kd} (Q12), d_alpha {p.d_alpha} (Q16), margin {p.margin} (Q16 mm), "
        f"output {p.out_min}..{p.out_max} mV",
        f"predictor every {c.predict_every} tick(s), desired = mean of the last {c.pred_avg} prediction(s)",
        f"desired force {c.force_min}..{c.force_max} (Q16 N), encoder jump <= {c.enc_jump_max} counts/tick, "
        f"pot stuck after {c.pot_stuck_ticks} ticks",
    ]


def shares_pipeline(c: ControlConfig) -> bool:
    """Whether NAME_controller_init_shared is emitted: a predictor called every tick reads the same samples
    as the actuator's other models, so it can read their shared feature pipeline (bit for bit)."""
    return c.predict_every <= 1


def controller_files(
    prefix: str, qm: QModel, cfg: ControlConfig | None = None, act: ActQ | None = None
) -> dict[str, str]:
    """{NAME_controller.h, NAME_controller.c, sea_pid.*, sea_control.*} for a control predictor `qm`."""
    prefix = assert_valid_prefix(prefix)
    if not is_predictor(qm):
        raise UserError(
            f"--controller needs a control model (desired force -> compression_mm), not {qm.output.name}"
        )
    c = cfg or shipped_config(qm, act)
    ctx = {
        "P": prefix,
        "PU": prefix.upper(),
        "version": __version__,
        "hash": model_hash(qm),
        "summary": summary(c),
        "pid": c.pid.as_tuple(),
        "fields": [(f, int(getattr(c, f))) for f in FIELDS],
        "shared": shares_pipeline(c),
    }
    env = environment()
    out = {f"{prefix}_controller{x}": env.get_template(f"controller{x}.j2").render(ctx) for x in (".h", ".c")}
    return {**out, **runtime_sources(*CONTROL_RUNTIME)}
