"""render(qmodel, prefix) -> {filename: text}: the context is computed here, the layout is in templates/."""

from __future__ import annotations

import hashlib
from importlib import resources
from typing import Any

import jinja2
import numpy as np

from seagen import __version__
from seagen.codegen.cfmt import assert_valid_prefix, c_array, c_int
from seagen.codegen.summary import buffer_width, summary_lines
from seagen.codegen.targets import kernel_context
from seagen.ir import QModel
from seagen.quant.features import external_inputs, feature_plan
from seagen.quant.primitives import linkage_table_q16

RUNTIME = ("sea_fixed.h", "sea_fixed.c", "sea_nn.h", "sea_nn.c")


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
    return env


def model_hash(qm: QModel) -> str:
    """sha256 of the quantized program (every integer and format), stable across runs."""
    h = hashlib.sha256()
    h.update(repr([(i.signal.name, i.frac, i.lo_q, i.hi_q) for i in qm.inputs]).encode())
    for q in qm.layers:
        h.update(q.w_q.astype(np.int64).tobytes() + q.b_q.astype(np.int64).tobytes())
        h.update(repr((q.shift, q.acc_bits, q.activation, q.act_params)).encode())
    h.update(repr([(o.dst, o.var, o.src, o.add_reg, o.coef_q, o.align, o.shift) for o in qm.horner]).encode())
    h.update(repr((qm.out_frac, qm.out_shift, qm.output.name)).encode())
    return h.hexdigest()[:16]


def _layers(qm: QModel, prefix: str) -> list[dict[str, Any]]:
    tables = {t.name: t for t in qm.tables}
    out = []
    for k, q in enumerate(qm.layers):
        t = tables.get(f"l{k}_{q.activation}")
        out.append(
            {
                "k": k,
                "n_in": q.w_q.shape[1],
                "n_out": q.w_q.shape[0],
                "w": q.w_q,
                "b": q.b_q,
                "wbits": qm.weight_bits,
                "abits": q.acc_bits,
                "shift": q.shift,
                "act": q.activation,
                "params": q.act_params,
                "src": f"buf{k % 2}",
                "dst": f"buf{(k + 1) % 2}",
                "table": None
                if t is None
                else {
                    "name": f"{prefix}_{t.name}",
                    "values": t.values,
                    "in_shift": t.in_shift,
                    "offset": t.offset,
                },
            }
        )
    return out


def _features(qm: QModel) -> list[dict[str, Any]]:
    expr = {
        "base": "b[{i}]",
        "d": "d[{i}]",
        "dd": "dd[{i}]",
        "external": "ext[{i}]",
        "angle": "(int64_t)pot * SEA_POT_DEG_Q24 + SEA_POT_OFFSET_Q24",
    }
    return [
        {"expr": expr[s.kind].format(i=s.index), "from": s.from_frac, "to": s.to_frac, "kind": s.kind}
        for s in feature_plan(qm)
    ]


def _predictor(qm: QModel) -> dict[str, int] | None:
    """Glue for sea_control when the model maps desired force -> compression (Q16 in, Q16 out)."""
    names = [i.signal.name for i in qm.inputs]
    if qm.output.name != "compression_mm" or names.count("force_n") != 1 or qm.out_frac > 16:
        return None
    return {"force_frac": qm.inputs[names.index("force_n")].frac, "up": 16 - qm.out_frac}


def context(qm: QModel, prefix: str) -> dict[str, Any]:
    """Everything the templates print, decided here."""
    prefix = assert_valid_prefix(prefix)
    width = buffer_width(qm)
    features = _features(qm)
    return {
        "P": prefix,
        "PU": prefix.upper(),
        "version": __version__,
        "hash": model_hash(qm),
        "kind": qm.kind,
        "n_in": len(qm.inputs),
        "inputs": qm.inputs,
        "output": qm.output,
        "out_frac": qm.out_frac,
        "summary": summary_lines(qm),
        "layers": _layers(qm, prefix),
        "width": width,
        "horner": qm.horner,
        "n_regs": qm.n_regs,
        "out_shift": qm.out_shift,
        "features": features,
        "needs_diff": any(f["kind"] in ("d", "dd") for f in features),
        "externals": external_inputs(qm),
        "link": linkage_table_q16(),
        "predictor": _predictor(qm),
    }


def render(qm: QModel, prefix: str, target: str = "portable") -> dict[str, str]:
    """{NAME.h, NAME.c} rendered from templates/ (the runtime files are added by the exporter)."""
    env = environment()
    ctx = context(qm, prefix)
    # issue 12 hook: a target kernel (seagen/codegen/targets.py) replaces the layer tables and NAME_infer
    kctx = kernel_context(qm, target)
    ctx["kernel"] = env.get_template(kctx["template"]).render({**ctx, **kctx}) if kctx else None
    return {
        f"{prefix}.h": env.get_template("model.h.j2").render(ctx),
        f"{prefix}.c": env.get_template("model.c.j2").render(ctx),
    }
