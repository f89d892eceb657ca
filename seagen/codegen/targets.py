"""Per-target MLP kernels: weight packing and template context for Cortex-M4 (SMLAD) and M0+ (offset uint16).

The integer semantics are the portable kernel's (QLayer: acc = b + W x, y = act(sat16(rshift_rne(acc, s))));
only the evaluation order of the exact integer sum and the representation of the tables change:
- cortex-m4: hidden layers two neurons per pass, the table holding per pass their b + 2^(s-1) - 1 (int32)
  then, input pair by input pair, both neurons' weights as int16 pairs (low half first), read in order by one
  pointer in runs of loads back to back; inputs and hidden outputs are int16 pairs; SMLAD (or SMLALD for a
  64-bit layer); the rounding (sea_rne_bit_*) adds bit s of the sum, so no tie test.
- cortex-m0plus: weights stored as uint16 w + 32768 for single `ldrh` loads (tables in RAM: .data, never
  written, so flash wait states do not price the reads), two neurons per pass, each
  accumulator starting from b + 2^(s-1) - 32768 * sum(x) in uint32 (modular) arithmetic; a single-output
  last layer is folded into the loop of the layer before it.
Every width decision below is proven here over the calibrated box (exact integers).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from seagen.codegen.cfmt import c_int
from seagen.errors import UserError
from seagen.ir import QMLP, QSF, QHorner, QLayer, QModel, QTable
from seagen.quant.interval import acc_interval
from seagen.runtime.activations import SMOOTH
from seagen.runtime.fixed import rshift_rne

TARGETS = ("portable", "cortex-m0plus", "cortex-m4")
TEMPLATES = {"cortex-m4": "mlp_cortex_m4.c.j2", "cortex-m0plus": "mlp_cortex_m0plus.c.j2"}
RUNTIME = {"portable": (), "cortex-m4": ("sea_dsp.h",), "cortex-m0plus": ("sea_dsp.h",)}
# Runtime files a target's export leaves out: the Cortex-M kernels call nothing of sea_nn.c (no dead code).
OMIT = {"portable": (), "cortex-m4": ("sea_nn.c",), "cortex-m0plus": ("sea_nn.c",)}

FUSED = ("relu", "linear")
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1


def check_target(target: str) -> str:
    """The target name, or a UserError listing the valid ones."""
    if target not in TARGETS:
        raise UserError(f"--target must be one of {', '.join(TARGETS)}, not {target!r}")
    return target


def _in_bounds(qm: QMLP) -> list[tuple[np.ndarray, np.ndarray]]:
    """Proven [lo, hi] of each layer's int16 inputs: the clamp box, then each layer's output interval."""
    out = [(np.array([i.lo_q for i in qm.inputs]), np.array([i.hi_q for i in qm.inputs]))]
    for q in qm.layers[:-1]:
        out.append((np.asarray(q.y_lo), np.asarray(q.y_hi)))
    return [(lo.astype(object), hi.astype(object)) for lo, hi in out]


def _half(shift: int) -> int:
    return 1 << (shift - 1) if shift > 0 else 0


def _check_layers(qm: QModel, target: str) -> None:
    """Target kernels: int16 outputs, a single model output, shifts >= 1 (ReLU and linear fused into the
    saturation, every other activation applied to each result by its sea_nn.h per-value form)."""
    if not isinstance(qm, QMLP):
        return
    for k, q in enumerate(qm.layers):
        if q.shift < 1:
            raise UserError(f"--target {target}: layer {k} has no rounding shift (use --target portable)")
    if qm.layers[-1].w_q.shape[0] != 1:
        raise UserError(f"--target {target}: the last layer must have one output")


def _elem(qm: QMLP, k: int) -> dict[str, Any] | None:
    """The sea_nn.h per-value call a layer's results go through (None for ReLU and linear, fused): its
    function, whether it reads the layer's table (tanh, sigmoid, the smooth ones) or per-channel slopes
    (PReLU: indexed by the neuron), the arguments after them and the data of that table."""
    q = qm.layers[k]
    t = next((t for t in qm.tables if t.name == f"l{k}_{q.activation}"), None)
    if q.activation in FUSED:
        return None
    # tables named _tab but tanh/sigmoid's (as the portable kernel names them: the MISRA record's 8.9 pattern)
    return {"suffix": "" if q.activation in ("tanh", "sigmoid") else "_tab", **_elem_call(q, k, t)}


def _elem_call(q: QLayer, k: int, t: QTable | None) -> dict[str, Any]:
    """_elem's function, table and arguments."""
    if q.activation in SMOOTH and t is not None:
        args = [str(len(t.values)), str(t.in_shift), c_int(t.offset), c_int(q.act_params[0])]
        return {
            "fn": "sea_smooth1",
            "table": [int(v) for v in t.values],
            "bits": 16,
            "index": False,
            "args": args,
        }
    if t is not None:  # tanh, sigmoid
        args = [str(len(t.values)), str(t.in_shift), c_int(t.offset)]
        return {
            "fn": "sea_table1",
            "table": [int(v) for v in t.values],
            "bits": 16,
            "index": False,
            "args": args,
        }
    if q.activation == "prelu":
        return {"fn": "sea_prelu1", "table": list(q.act_params), "bits": 32, "index": True, "args": []}
    if q.activation == "leaky_relu":
        return {"fn": "sea_prelu1", "table": None, "index": False, "args": [c_int(q.act_params[0])]}
    if q.activation == "hardtanh":
        return {
            "fn": "sea_hardtanh1",
            "table": None,
            "index": False,
            "args": [c_int(v) for v in q.act_params],
        }
    if q.activation in ("hardsigmoid", "hardswish"):
        fn = "sea_hsig1" if q.activation == "hardsigmoid" else "sea_hswish1"
        args = [c_int(q.act_params[0]), c_int(q.act_params[1], 64)]
        return {"fn": fn, "table": None, "index": False, "args": args}
    raise UserError(f"layer {k}: activation {q.activation} has no target kernel form")


def _proven16(mn: np.ndarray, mx: np.ndarray, shift: int) -> bool:
    """Every neuron's shifted accumulator lies in int16 over the box (saturation would never act)."""
    lo, hi = int(rshift_rne(int(min(mn)), shift)), int(rshift_rne(int(max(mx)), shift))
    return lo >= -(2**15) and hi <= 2**15 - 1


def _helpers(acc: int, act: str, proven: bool = False, usat: bool = True) -> dict[str, str]:
    """Names of the sea_dsp.h helpers (accumulator type, rounding shift, fused activation) for a layer.

    proven: the shifted accumulator is proven to lie in int16, so no upper saturation is needed (ReLU is then
    max(q, 0); on the M4 USAT does ReLU and saturation in one instruction anyway, usat=True keeps it)."""
    w = "s32" if acc == 32 else "s64"
    if act == "relu":
        sat = (
            f"sea_relu_proven_{w}"
            if proven and not usat
            else ("sea_relu_sat16" if w == "s32" else "sea_relu_sat16_s64")
        )
    else:
        sat = f"sea_proven16_{w}" if proven else f"sea_sat16_{w}"
    if acc == 32:
        return {"acc_t": "int32_t", "mac": "sea_smlad", "rne": "sea_rne_folded_s32", "sat": sat}
    return {"acc_t": "int64_t", "mac": "sea_smlald", "rne": "sea_rne_folded_s64", "sat": sat}


def _words(row: np.ndarray) -> list[int]:
    """int16 weights -> int32 words (low half first, an odd count padded with 0), as signed ints."""
    w = [int(v) for v in row] + ([0] if len(row) % 2 else [])
    return [
        int(np.int32(np.uint32(((w[i + 1] & 0xFFFF) << 16) | (w[i] & 0xFFFF)))) for i in range(0, len(w), 2)
    ]


def _groups(n_out: int, size: int) -> list[list[int]]:
    """Neuron indices in passes of `size` (the last pass may be smaller)."""
    return [list(range(j, min(j + size, n_out))) for j in range(0, n_out, size)]


def _pass_plan(g: int, n_words: int, acc: int, run: int) -> dict[str, Any]:
    """One M4 pass over g neurons: its table words in order, in runs of `run` loads back to back (the
    biases into the accumulators a0.., the weights into v0..), each run followed by the SMLADs it feeds."""
    items = [(f"a{n}", -1, n) for n in range(g)] if acc == 32 else []
    items += [("", i, n) for i in range(n_words) for n in range(g)]
    runs: list[dict[str, Any]] = []
    temps: set[str] = set()
    for start in range(0, len(items), run):
        chunk = items[start : start + run]
        names = [a or f"v{p}" for p, (a, _, _) in enumerate(chunk)]
        macs = [(n, i, names[p]) for p, (_, i, n) in enumerate(chunk) if i >= 0]
        temps.update(v for _, _, v in macs)
        runs.append({"at": start, "names": names, "macs": macs})
    return {"g": g, "runs": runs, "temps": sorted(temps)}


def m4_layers(qm: QMLP) -> list[dict[str, Any]]:
    """Cortex-M4 layer context: packed tables and the accumulator width proven with the folded half.

    A hidden layer runs `group` = 2 neurons per pass with its inputs in registers, its table holding per pass
    the biases (32-bit) then, input word by input word, that word of each neuron's weights: the pass reads the
    table in order, `run` loads back to back (the M4 pipelines a load behind a load: runs of 4 where the
    inputs leave four registers free, else 2). The last layer (one output) keeps b then its weights."""
    out = []
    for k, (q, (lo, hi)) in enumerate(zip(qm.layers, _in_bounds(qm), strict=True)):
        n_out, n_in = q.w_q.shape
        half = _half(q.shift)
        mn, mx, worst = acc_interval(q.w_q, q.b_q, lo, hi)
        acc = 32 if max(worst) + half <= INT32_MAX else 64
        last = k == len(qm.layers) - 1
        n_words = (n_in + 1) // 2
        unroll = 4 if n_words % 4 == 0 else (2 if n_words % 2 == 0 else 1)
        group = 1 if last else 2
        run = 4 if n_words <= 6 else 2  # registers: n_words inputs, 2 accumulators, 2 pointers, `run` loads
        bias = [int(b) + half - 1 for b in q.b_q]  # sea_rne_bit_* rounds u = acc + 2^(s-1) - 1
        rows = [_words(q.w_q[j]) for j in range(n_out)]
        table = []
        for g in _groups(n_out, group):
            table += [bias[j] for j in g] if acc == 32 else []
            table += [rows[j][i] for i in range(n_words) for j in g]
        out.append(
            {
                "k": k,
                "n_in": n_in,
                "n_out": n_out,
                "n_words": n_words,
                "group": group,
                "n_groups": n_out // group,
                "rest": n_out % group,
                "acc": acc,
                "shift": q.shift,
                "act": q.activation,
                "elem": _elem(qm, k),
                "table": table,
                "bias64": bias if acc == 64 else None,
                "last": last,
                "unroll": unroll,
                **_helpers(acc, q.activation, _proven16(mn, mx, q.shift)),
                "rne": f"sea_rne_bit_s{acc}",
                "pack": "sea_pack_nonneg16x2" if q.activation == "relu" else "sea_pack16x2",
                "plans": [_pass_plan(g, n_words, acc, run) for g in (group, n_out % group) if g and not last],
            }
        )
    return out


def _m0_acc(mn: np.ndarray, mx: np.ndarray, bias: list) -> int:
    """32 when every neuron's b + 2^(s-1) and final b + W x + 2^(s-1) are int32 (the uint32 sum is exact)."""
    fits = min(mn) >= INT32_MIN and max(mx) <= INT32_MAX
    return 32 if fits and min(bias) >= INT32_MIN and max(bias) <= INT32_MAX else 64


def m0plus_layers(qm: QMLP) -> list[dict[str, Any]]:
    """Cortex-M0+ layer context: offset-uint16 weights by neuron pairs, biases with the folded half."""
    out = []
    for k, (q, (lo, hi)) in enumerate(zip(qm.layers, _in_bounds(qm), strict=True)):
        n_out, n_in = q.w_q.shape
        half = _half(q.shift)
        mn, mx, _ = acc_interval(q.w_q, q.b_q + half, lo, hi)
        bias = [int(b) + half for b in q.b_q]
        acc = _m0_acc(mn, mx, bias)
        proven = _proven16(*acc_interval(q.w_q, q.b_q, lo, hi)[:2], q.shift)
        u = (q.w_q.astype(np.int64) + 32768).tolist()
        order = [j for p in range(0, n_out - 1, 2) for j in (p, p + 1)] + ([n_out - 1] if n_out % 2 else [])
        out.append(
            {
                "k": k,
                "n_in": n_in,
                "n_out": n_out,
                "n_pairs": n_out // 2,
                "odd": n_out % 2 == 1,
                "acc": acc,
                "shift": q.shift,
                "act": q.activation,
                "elem": _elem(qm, k),
                "u": [v for j in order for v in u[j]],
                "w": [int(v) for v in q.w_q.ravel()],
                "bias": bias,
                "fold": None,
                "folded": False,
                "last": k == len(qm.layers) - 1,
                **_helpers(acc, q.activation, proven, usat=False),
            }
        )
    if len(out) >= 2:
        out[-2]["fold"] = out[-1]
        out[-1]["folded"] = True
    return out


def _addend(op: QHorner) -> str:
    """C expression of a Horner step's addend: the constant, or a register aligned to the new format."""
    if op.add_reg < 0:
        return c_int(op.coef_q)
    if op.align > 0:
        return f"r{op.add_reg} * {1 << op.align}"
    return f"r{op.add_reg}" if op.align == 0 else f"(r{op.add_reg} >> {-op.align})"


def sf_steps(qm: QSF) -> dict[str, Any]:
    """Surface-fit kernel context: one C statement per Horner step, and the rounding of the output."""
    steps = []
    for op in qm.horner:
        if op.var < 0:
            steps.append({"dst": op.dst, "load": c_int(op.coef_q)})
        else:
            steps.append(
                {
                    "dst": op.dst,
                    "load": None,
                    "var": op.var,
                    "src": op.src,
                    "shift": op.shift,
                    "add": _addend(op),
                }
            )
    last = qm.horner[-1]
    # |r| < 2^30 + its proven error (QHorner planning), so r + 2^(s-1) cannot overflow int32 for s <= 30
    if not 0 <= qm.out_shift <= 30:
        raise UserError(f"surface fit: output shift {qm.out_shift} outside 0..30")
    return {
        "steps": steps,
        "n_regs": qm.n_regs,
        "final": last.dst,
        "out_shift": qm.out_shift,
        "out_half": _half(qm.out_shift),
        "template": "sf_horner.c.j2",
    }


def kernel_context(qm: QModel, target: str) -> dict[str, Any]:
    """Extra template context of a target kernel ({} for the portable one)."""
    check_target(target)
    if target == "portable":
        return {}
    if isinstance(qm, QSF):
        return {"target": target, **sf_steps(qm)}
    _check_layers(qm, target)
    if target == "cortex-m4":  # the input box as int16 pairs, for the pair clamp (sea_clamp16x2)
        lo, hi = (_words(np.array([getattr(i, f) for i in qm.inputs])) for f in ("lo_q", "hi_q"))
        clamp = {"own_clamp": True, "in_lo2": lo, "in_hi2": hi}
        return {"target": target, "tlayers": m4_layers(qm), "template": TEMPLATES[target], **clamp}
    return {"target": target, "tlayers": m0plus_layers(qm), "template": TEMPLATES[target]}
