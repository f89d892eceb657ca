"""render(qmodel, prefix) -> {filename: text}: the context is computed here, the layout is in templates/."""

from __future__ import annotations

import hashlib
from importlib import resources
from typing import Any

import jinja2
import numpy as np

from seagen import __version__
from seagen.cnames import assert_valid_prefix, check_input_macros, input_macro
from seagen.codegen.cfmt import c_array, c_comment, c_ident, c_int
from seagen.codegen.domain import domain_macros
from seagen.codegen.quant_summary import buffer_width, summary_lines
from seagen.codegen.targets import kernel_context
from seagen.ir import QMLP, QSF, QLayer, QModel
from seagen.runtime import features as F
from seagen.runtime.activations import SMOOTH
from seagen.runtime.actq import ActQ, act_q_of

RUNTIME = ("sea_fixed.h", "sea_fixed.c", "sea_nn.h", "sea_nn.c", "sea_features.h", "sea_features.c")


def environment() -> jinja2.Environment:
    """Jinja with StrictUndefined, trim_blocks, lstrip_blocks and the C formatting filters."""
    env = jinja2.Environment(
        loader=jinja2.FunctionLoader(lambda name: (resources.files("seagen.templates") / name).read_text()),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters["c_array"] = c_array
    env.filters["c_int"] = c_int
    env.filters["c_comment"] = c_comment  # user text in a comment (units, the output name)
    env.filters["c_ident"] = c_ident  # user names in identifiers and comments
    return env


def model_hash(qm: QModel) -> str:
    """sha256 of the quantized program (every integer and format), stable across runs."""
    h = hashlib.sha256()
    h.update(repr([(i.signal.name, i.frac, i.lo_q, i.hi_q) for i in qm.inputs]).encode())
    layers, horner = (qm.layers, ()) if isinstance(qm, QMLP) else ((), qm.horner)
    for q in layers:
        h.update(q.w_q.astype(np.int64).tobytes() + q.b_q.astype(np.int64).tobytes())
        h.update(repr((q.shift, q.acc_bits, q.activation, q.act_params)).encode())
    h.update(repr([(o.dst, o.var, o.src, o.add_reg, o.coef_q, o.align, o.shift) for o in horner]).encode())
    out_shift = qm.out_shift if isinstance(qm, QSF) else 0
    h.update(repr((qm.out_frac, out_shift, qm.output.name)).encode())
    return h.hexdigest()[:16]


def _activation(q: QLayer, table: dict[str, Any] | None, slopes: str = "") -> dict[str, Any] | None:
    """The sea_nn activation call of a layer: function and the arguments after (y, n); None if linear."""
    if q.activation == "relu":
        return {"fn": "sea_relu_s16", "args": []}
    if q.activation == "leaky_relu":
        return {"fn": "sea_leaky_s16", "args": [q.act_params[0]]}
    if q.activation == "hardtanh":
        return {"fn": "sea_hardtanh_s16", "args": [q.act_params[0], q.act_params[1]]}
    if q.activation in SMOOTH and table is not None:
        args = [table["name"], table["len"], table["in_shift"], table["offset"], q.act_params[0]]
        return {"fn": "sea_smooth_s16", "args": args}
    if q.activation in ("hardsigmoid", "hardswish"):
        fn = "sea_hsig_s16" if q.activation == "hardsigmoid" else "sea_hswish_s16"
        return {"fn": fn, "args": [c_int(q.act_params[0]), c_int(q.act_params[1], 64)]}
    if q.activation == "prelu":
        return {"fn": "sea_prelu_s16", "args": [slopes]}
    if table is not None:
        return {
            "fn": "sea_table_s16",
            "args": [table["name"], table["len"], table["in_shift"], table["offset"]],
        }
    return None


def _layers(qm: QMLP, prefix: str) -> list[dict[str, Any]]:
    """Per layer: its tables, the dense kernel, buffers and the activation call."""
    tables = {t.name: t for t in qm.tables}
    out = []
    for k, q in enumerate(qm.layers):
        t = tables.get(f"l{k}_{q.activation}")
        table = None
        if t is not None:
            # the smooth ones' tables end in _tab (tanh/sigmoid keep theirs): the MISRA record's 8.9 pattern
            tab = "_tab" if q.activation in SMOOTH else ""
            table = {"name": f"{prefix}_{t.name}{tab}", "data": t.values, "len": len(t.values)}
            table |= {"in_shift": t.in_shift, "offset": t.offset}
        out.append(
            {
                "k": k,
                "n_in": q.w_q.shape[1],
                "n_out": q.w_q.shape[0],
                "w": q.w_q,
                "b": q.b_q,
                "wbits": qm.weight_bits,
                "abits": q.acc_bits,
                "dense": f"sea_dense_w{qm.weight_bits}_a{q.acc_bits}",
                "shift": q.shift,
                "act_name": q.activation,
                "act": _activation(q, table, f"{prefix}_l{k}_prelu_tab"),
                "slopes": {"name": f"{prefix}_l{k}_prelu_tab", "data": q.act_params}
                if q.activation == "prelu"
                else None,
                "src": f"buf{k % 2}",
                "dst": f"buf{(k + 1) % 2}",
                "table": table,
            }
        )
    return out


def _horner(qm: QSF) -> list[dict[str, Any]]:
    """Per Horner step: a coefficient load, or sea_horner_s32 with a register or a constant addend."""
    return [
        {
            "load": op.var < 0,
            "dst": op.dst,
            "var": op.var,
            "src": op.src,
            "add_reg": op.add_reg if op.add_reg >= 0 else None,
            "coef": op.coef_q,
            "align": op.align,
            "shift": op.shift,
        }
        for op in qm.horner
    ]


def _features(qm: QModel) -> list[dict[str, Any]]:
    """Per input: the NAME_step argument it is (externals), or the sea_features_value it converts (kind and
    base signal as sea_features.h constant names, the formats)."""
    return [
        {
            "name": q.signal.name,
            "arg": f"{q.signal.name}_q" if src.kind == F.EXTERNAL else None,
            "kind": F.KIND_C[src.kind],
            "index": F.BASE_C[src.index] if src.kind in F.BASE_C_KINDS else src.index,
            "from_frac": src.from_frac,
            "to_frac": q.frac,
        }
        for q, src in zip(qm.inputs, F.sources(qm), strict=True)
    ]


def _kind_context(qm: QModel, prefix: str) -> dict[str, Any]:
    """The per-kind part of the context: MLP layers and buffers, or the SF Horner program."""
    if isinstance(qm, QMLP):
        layers = _layers(qm, prefix)
        return {
            "kind_template": "model_mlp.c.j2",
            "layers": layers,
            "width": buffer_width(qm),
            "out_buf": layers[-1]["dst"],
        }
    return {
        "kind_template": "model_sf.c.j2",
        "horner": _horner(qm),
        "n_regs": qm.n_regs,
        "out_reg": qm.horner[-1].dst,
        "out_shift": qm.out_shift,
    }


def context(qm: QModel, prefix: str, act: ActQ | None = None) -> dict[str, Any]:
    """Everything the templates print, decided here (`act`: the actuator, the paper's when None)."""
    pipeline = F.has_pipeline(qm)
    prefix = assert_valid_prefix(prefix)
    a = act or act_q_of()
    check_input_macros(prefix, [q.signal.name for q in qm.inputs])
    return {
        "P": prefix,
        "PU": prefix.upper(),
        "version": __version__,
        "hash": model_hash(qm),
        "n_in": len(qm.inputs),
        "inputs": qm.inputs,
        "in_macros": [input_macro(prefix, c_ident(q.signal.name)) for q in qm.inputs],
        "output": qm.output,
        "out_frac": qm.out_frac,
        "summary": summary_lines(qm),
        "pipeline": pipeline,
        "features": _features(qm) if pipeline else [],
        "externals": F.external_inputs(qm),
        "act": a.cid,
        "act_key": a.key,
        # the proven domain: header macros, ACSL contracts and the Eva harness (docs/prove.md)
        "domain": domain_macros(prefix.upper(), a.pot_max, F.is_predictor(qm)),
        "predictor": {"force_input": "force_n"} if F.is_predictor(qm) else None,
        **_kind_context(qm, prefix),
    }


def render(qm: QModel, prefix: str, target: str = "portable", act: ActQ | None = None) -> dict[str, str]:
    """{NAME.h, NAME.c} and the actuator's sea_act_<id>.{h,c} (when the feature pipeline is used) rendered
    from templates/ (the runtime files are added by the exporter); a target other than portable replaces
    the weight tables and NAME_infer by its kernel (codegen/targets.py); `act`: the actuator whose sea_act
    the feature pipeline reads (the paper's if None)."""
    from seagen.codegen.actfile import act_files

    env = environment()
    a = act or act_q_of()
    ctx = context(qm, prefix, a)
    kctx = kernel_context(qm, target)
    ctx["kernel"] = env.get_template(kctx["template"]).render({**ctx, **kctx}) if kctx else None
    ctx["own_clamp"] = kctx.get("own_clamp", False)  # the kernel defines the input box tables itself
    return {
        f"{prefix}.h": env.get_template("model.h.j2").render(ctx),
        f"{prefix}.c": env.get_template("model.c.j2").render(ctx),
        **(act_files(a) if ctx["pipeline"] else {}),
    }
