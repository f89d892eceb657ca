"""The quantized ONNX graph: integer ops only (int64 inside, int16 in and out), run by onnxruntime.

onnxruntime's CPU kernels have no int16 MatMul/Clip/Max, so the graph casts to int64, computes there and
casts back after saturating. The rounding shift is Mod/Sub/Div (exact) plus the half-to-even correction;
BitShift is unsigned-only and Sign on int64 is avoided (DESIGN.md §4).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from seagen import __version__
from seagen.ir import QMLP, QSF, QLayer, QModel, QTable
from seagen.quant.activation import ADDED
from seagen.runtime import activations as A

OPSET = 17


class _Graph:
    """Tiny builder: unique names, int64 constants, node list."""

    def __init__(self) -> None:
        self.nodes: list[onnx.NodeProto] = []
        self.inits: list[onnx.TensorProto] = []
        self.n = 0

    def const(self, value: object, name: str = "c") -> str:
        """An int64 initializer; returns its name."""
        self.n += 1
        full = f"{name}_{self.n}"
        self.inits.append(numpy_helper.from_array(np.asarray(value, dtype=np.int64), full))
        return full

    def op(self, kind: str, *inputs: str, **attrs: Any) -> str:
        """A node with one output; returns the output's name."""
        self.n += 1
        out = f"{kind.lower()}_{self.n}"
        self.nodes.append(helper.make_node(kind, list(inputs), [out], **attrs))
        return out

    def rshift_rne(self, v: str, s: int) -> str:
        """round(v / 2^s) half to even, exact on int64."""
        if s <= 0:
            return v
        d = self.const(1 << s, "pow2")
        r = self.op("Mod", v, d, fmod=0)
        q = self.op("Div", self.op("Sub", v, r), d)
        half = self.const(1 << (s - 1), "half")
        odd = self.op("Equal", self.op("Mod", q, self.const(2, "two"), fmod=0), self.const(1, "one"))
        up = self.op("Or", self.op("Greater", r, half), self.op("And", self.op("Equal", r, half), odd))
        return self.op("Add", q, self.op("Cast", up, to=TensorProto.INT64))

    def rshift_floor(self, v: str, s: int) -> str:
        """floor(v / 2^s), exact on int64 (the floor steps of the surface-fit Horner program)."""
        if s <= 0:
            return v
        d = self.const(1 << s, "pow2")
        return self.op("Div", self.op("Sub", v, self.op("Mod", v, d, fmod=0)), d)

    def clip(self, v: str, lo: object, hi: object) -> str:
        """Saturate v to [lo, hi] (int64 Clip)."""
        return self.op("Clip", v, self.const(lo, "lo"), self.const(hi, "hi"))


def _layers(g: _Graph, qm: QMLP, x: str) -> str:
    tables = {t.name: t for t in qm.tables}
    for k, q in enumerate(qm.layers):
        acc = g.op("Add", g.op("MatMul", x, g.const(q.w_q.T, f"w{k}")), g.const(q.b_q, f"b{k}"))
        y = g.clip(g.rshift_rne(acc, q.shift), -(2**15), 2**15 - 1)
        if q.activation == "relu":
            y = g.op("Max", y, g.const(0, "zero"))
        elif q.activation == "leaky_relu":
            neg = g.rshift_rne(g.op("Mul", y, g.const(q.act_params[0], "alpha")), 15)
            y = g.op("Where", g.op("GreaterOrEqual", y, g.const(0, "zero")), y, neg)
        elif q.activation == "hardtanh":
            y = g.clip(y, q.act_params[0], q.act_params[1])
        elif q.activation in ADDED:
            y = _added(g, q, tables.get(f"l{k}_{q.activation}"), y)
        elif q.activation in ("tanh", "sigmoid"):
            t = tables[f"l{k}_{q.activation}"]
            idx = g.op("Add", g.rshift_rne(y, t.in_shift), g.const(t.offset, "off"))
            y = g.op("Gather", g.const(t.values, t.name), g.clip(idx, 0, len(t.values) - 1))
        x = y
    return g.op("Gather", x, g.const(0, "col"), axis=1)


def _added(g: _Graph, q: QLayer, t: QTable | None, y: str) -> str:
    """The smooth and piecewise-linear activations (seagen/runtime/activations.py), on int64."""
    i16 = (-(2**15), 2**15 - 1)
    if q.activation in A.SMOOTH:
        assert t is not None
        idx = g.clip(g.op("Add", g.rshift_rne(y, t.in_shift), g.const(t.offset, "off")), 0, len(t.values) - 1)
        pos = g.op("Mul", g.op("Max", y, g.const(0, "zero")), g.const(q.act_params[0], "slope"))
        return g.clip(
            g.op("Add", g.rshift_rne(pos, A.SLOPE_FRAC), g.op("Gather", g.const(t.values, t.name), idx)), *i16
        )
    if q.activation in ("hardsigmoid", "hardswish"):
        v = g.op("Add", g.op("Mul", y, g.const(q.act_params[0], "alpha")), g.const(q.act_params[1], "beta"))
        h = g.clip(g.rshift_rne(v, A.HSIG_FRAC - A.TABLE_OUT_FRAC), 0, 1 << A.TABLE_OUT_FRAC)
        return (
            h
            if q.activation == "hardsigmoid"
            else g.clip(g.rshift_rne(g.op("Mul", y, h), A.TABLE_OUT_FRAC), *i16)
        )
    neg = g.clip(g.rshift_rne(g.op("Mul", y, g.const(np.array(q.act_params), "alpha")), A.PRELU_FRAC), *i16)
    return g.op("Where", g.op("GreaterOrEqual", y, g.const(0, "zero")), y, neg)


def _sf(g: _Graph, qm: QSF, x: str) -> str:
    cols = [g.op("Gather", x, g.const(i, "col"), axis=1) for i in range(len(qm.inputs))]
    regs: dict[int, str] = {}
    for op in qm.horner:
        if op.var < 0:
            regs[op.dst] = g.op("Mul", g.op("Mul", cols[0], g.const(0, "zero")), g.const(op.coef_q, "k"))
            regs[op.dst] = g.op("Add", regs[op.dst], g.const(op.coef_q, "k"))
            continue
        add = regs[op.add_reg] if op.add_reg >= 0 else g.const(op.coef_q, "k")
        if op.align >= 0:
            add = g.op("Mul", add, g.const(1 << op.align, "al"))
        else:
            add = g.rshift_floor(add, -op.align)
        prod = g.rshift_floor(g.op("Mul", cols[op.var], regs[op.src]), op.shift)
        regs[op.dst] = g.clip(g.op("Add", prod, add), -(2**31), 2**31 - 1)
    return g.clip(g.rshift_rne(regs[qm.horner[-1].dst], qm.out_shift), -(2**15), 2**15 - 1)


def build_onnx(qm: QModel, name: str = "seagen_model") -> onnx.ModelProto:
    """The integer graph of `qm`: input x int16 [N, n_in] -> output y int16 [N], exactly NAME_infer."""
    g = _Graph()
    x = g.op("Cast", "x", to=TensorProto.INT64)
    lo = np.array([i.lo_q for i in qm.inputs])
    hi = np.array([i.hi_q for i in qm.inputs])
    x = g.op("Min", g.op("Max", x, g.const(lo, "in_lo")), g.const(hi, "in_hi"))
    y = _sf(g, qm, x) if isinstance(qm, QSF) else _layers(g, qm, x)
    g.nodes.append(helper.make_node("Cast", [y], ["y"], to=TensorProto.INT16))
    n_in = len(qm.inputs)
    graph = helper.make_graph(
        g.nodes,
        name,
        [helper.make_tensor_value_info("x", TensorProto.INT16, ["N", n_in])],
        [helper.make_tensor_value_info("y", TensorProto.INT16, ["N"])],
        g.inits,
    )
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name="seagen",
        producer_version=__version__,
    )
    model.ir_version = 8
    onnx.checker.check_model(model)
    return model


def session(model: onnx.ModelProto):
    """An onnxruntime CPU session with all graph optimizations on."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    return ort.InferenceSession(model.SerializeToString(), opts, providers=["CPUExecutionProvider"])


def infer(qm: QModel, x: np.ndarray, model: onnx.ModelProto | None = None) -> np.ndarray:
    """Run the graph on int16 features (N, n_in) -> (N,) int64."""
    sess = session(model if model is not None else build_onnx(qm))
    xin = np.clip(np.atleast_2d(np.asarray(x)), -(2**15), 2**15 - 1).astype(np.int16)
    return sess.run(None, {"x": xin})[0].astype(np.int64)
