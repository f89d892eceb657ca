"""Elementwise subgraphs that converters write for one activation, read as that activation: GELU as
0.5 x (1 + erf(x / sqrt 2)) (tf2onnx, jax2onnx, torch's legacy exporter) or its tanh form, SiLU as
x * sigmoid(x), Mish as x * tanh(softplus(x)), torch's Softplus(beta, threshold) as Where(beta x > t, x, ...).

A region is the set of elementwise nodes between one edge x and a node that takes x along two paths (the
place a chain stops). It is identified by what it computes: run on a grid of x by onnx's reference runtime
(as constant folding runs nodes: no code from the file) and compared with each candidate in float64; it is
read as the candidate that agrees within float32 rounding everywhere on the grid, else left as it is (and
refused by the chain reader, naming the node). The oracle (onnxruntime on the original) checks the result.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from seagen.frontends.graph import Node
from seagen.runtime.activations import act_float

FUSED_OP = "seagen.Activation"  # the op of a node that stands for a recognised region
ELEMENTWISE = {
    *("Mul", "Add", "Sub", "Div", "Erf", "Tanh", "Sigmoid", "Pow", "Exp", "Log", "Softplus", "Where"),
    *("Greater", "Less", "GreaterOrEqual", "LessOrEqual", "Sqrt", "Neg", "Abs", "Max", "Min", "Reciprocal"),
    *("Identity", "Cast", "HardSigmoid"),
}
MAX_NODES = 24
MAX_TAIL = 3  # single-input nodes after the region that may complete it (a final * 0.5)
GRID = np.concatenate([np.linspace(-12.0, 12.0, 4801), [-30.0, -20.0, 20.0, 30.0]])
TOL = 2e-6  # |region - candidate| <= TOL (1 + |candidate|): float32 rounding of a few ops, far below the
# gap between any two candidates (GELU's erf and tanh forms differ by up to 4.7e-4)


def _candidates(consts_in_region: list[float], f0: float) -> list[tuple[str, tuple[float, ...]]]:
    """The activations a region may be; Softplus's beta from f(0) = log 2 / beta, its threshold among the
    region's constants (or none)."""
    out: list[tuple[str, tuple[float, ...]]] = [("gelu", ()), ("gelu_tanh", ()), ("silu", ()), ("mish", ())]
    out.append(("hardswish", ()))
    if f0 > 0:
        beta = math.log(2.0) / f0
        for b in {beta, round(beta, 6)}:
            out += [("softplus", (b, t)) for t in {*consts_in_region, math.inf} if t > 0]
    return out


def _region(n: Node, producer: dict[str, Node], consts: set[str]) -> tuple[str, list[Node]] | None:
    """(x, the region's nodes) when n's computed inputs all come from one edge x through elementwise nodes."""
    computed = list(dict.fromkeys(i for i in n.inputs if i and i not in consts))
    # candidate x: edges on the way back from the first computed input, nearest first
    edge: str | None = computed[0]
    order: list[str] = []
    while edge is not None and len(order) <= MAX_NODES:
        order.append(edge)
        p = producer.get(edge)
        if p is None or p.op not in ELEMENTWISE:
            break
        ins = [i for i in p.inputs if i and i not in consts]
        edge = ins[0] if len(ins) == 1 else None
    for x in order:
        seen: dict[int, Node] = {}
        todo, ok = list(computed), True
        while todo and ok:
            e = todo.pop()
            if e == x or e in consts:
                continue
            p = producer.get(e)
            if p is None or p.op not in ELEMENTWISE or len(seen) > MAX_NODES:
                ok = False
                break
            if id(p) not in seen:
                seen[id(p)] = p
                todo += [i for i in p.inputs if i]
        if ok and seen:
            return x, list(seen.values())
    return None


def _evaluate(model: Any, nodes: list[Node], x: str, out: str, consts: dict) -> np.ndarray | None:
    """The region's output for x = GRID (float32), by onnx's reference runtime; None if it cannot run."""
    from onnx import TensorProto, helper, numpy_helper
    from onnx.reference import ReferenceEvaluator

    used = {i for n in nodes for i in n.inputs if i in consts}
    inits = [numpy_helper.from_array(np.asarray(consts[i]), i) for i in sorted(used)]
    raw = [n.raw for n in nodes]
    order = _topo(raw, x, used)
    g = helper.make_graph(
        order,
        "region",
        [helper.make_tensor_value_info(x, TensorProto.FLOAT, [len(GRID)])],
        [helper.make_tensor_value_info(out, 0, None)],
        inits,
    )
    m = helper.make_model(g, opset_imports=model.opset_import, ir_version=model.ir_version)
    try:
        (y,) = ReferenceEvaluator(m).run(None, {x: GRID.astype(np.float32)})
    except Exception:  # noqa: BLE001 - the reference runtime raises many types; the region is then kept
        return None
    y = np.asarray(y, dtype=float)
    return y if y.shape == GRID.shape else None


def _topo(raw: list[Any], x: str, known: set[str]) -> list[Any]:
    """The nodes in an order that computes each input before its use."""
    have, todo = {x, *known}, list(raw)
    out: list[Any] = []
    while todo:
        ready = [n for n in todo if all(i in have or not i for i in n.input)]
        if not ready:
            return out + todo
        for n in ready:
            out.append(n)
            have.update(n.output)
        todo = [n for n in todo if all(n is not r for r in ready)]
    return out


def identify(y: np.ndarray, region_consts: list[float]) -> tuple[str, tuple[float, ...]] | None:
    """The candidate the region computes (within TOL on the grid), or None."""
    if not np.all(np.isfinite(y)):
        return None
    f0 = float(y[np.argmin(np.abs(GRID))])
    for name, p in _candidates(region_consts, f0):
        want = act_float(name, p, GRID)
        if np.all(np.abs(y - want) <= TOL * (1.0 + np.abs(want))):
            return name, p
    return None


def _grow(model: Any, x: str, region: list[Node], n: Node, consts: dict, users: dict) -> tuple:
    """(the activation, its last node, the nodes before it) of the region ending at n, or of n followed by up
    to MAX_TAIL single-input elementwise nodes (the 0.5 * after x (1 + erf(x / sqrt 2))); (None, n, region)
    when none is a candidate."""
    tail, last = list(region), n
    for _ in range(MAX_TAIL + 1):
        vals = [
            float(np.asarray(consts[i]).reshape(-1)[0])
            for m in (*tail, last)
            for i in m.inputs
            if i in consts
        ]
        y = _evaluate(model, [*tail, last], x, last.outputs[0], consts)
        kind = identify(y, vals) if y is not None else None
        if kind is not None:
            return kind, last, tail
        nxt = users.get(last.outputs[0], [])
        if len(nxt) != 1 or nxt[0].op not in ELEMENTWISE:
            break
        if len({i for i in nxt[0].inputs if i and i not in consts}) != 1:
            break
        tail, last = [*tail, last], nxt[0]
    return None, n, region


def fuse_regions(model: Any, nodes: list[Node], consts: dict) -> list[Node]:
    """nodes with every recognised region replaced by one FUSED_OP node (attrs kind, params, form)."""
    changed = True
    while changed:
        changed = False
        producer = {o: n for n in nodes for o in n.outputs if o}
        users: dict[str, list[Node]] = {}
        for n in nodes:
            for i in n.inputs:
                users.setdefault(i, []).append(n)
        for n in nodes:
            if n.op not in ELEMENTWISE or len({i for i in n.inputs if i and i not in consts}) < 2:
                continue
            found = _region(n, producer, set(consts))
            if found is None:
                continue
            x, region = found
            members = {id(m) for m in region} | {id(n)}
            inner = [o for m in region for o in m.outputs]
            if any(id(u) not in members for o in inner for u in users.get(o, [])):
                continue  # a value inside the region is used outside it
            kind, last, body = _grow(model, x, region, n, consts, users)
            if kind is None:
                continue
            ops = "+".join(m.op for m in (*body, last))
            attrs = {"kind": kind[0], "params": kind[1], "form": ops}
            fused = Node(FUSED_OP, last.path, [x], list(last.outputs), attrs)
            gone = {id(m) for m in (*body, last)}
            nodes = [m for m in nodes if id(m) not in gone] + [fused]
            changed = True
            break
    return nodes
