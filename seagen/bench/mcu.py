"""Instructions per inference and flash of the default models on emulated Cortex-M4 and M0+ cores.

`python -m seagen.bench.mcu [--json]`. For each model in generated/models: the generated fixed-point C
(NAME_infer, unicorn UC_HOOK_CODE counts, mean over inputs drawn across the calibrated box), and, on the same
emulator, a plain float C loop of the same float network (M4: -mfloat-abi=hard -mfpu=fpv4-sp-d16; M0+: soft
float through libgcc). Nothing here is optimised: it measures what the generator emits today.

Flash: "flash B" is .text + .rodata of the model's objects (NAME.o with its NAME_step pipeline and the
1 KB linkage table, plus sea_fixed.o and sea_nn.o); "image B" is the .text of an image linked with
--gc-sections from NAME_infer (or float_infer) alone, libgcc helpers included: what inference needs.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from seagen.defaults import DEFAULT_PREFIX, GENERATED
from seagen.ir import FloatMLP, FloatSF
from seagen.toolchain.cortexm import CPUS, CortexM, Machine, build_image, toolchain_missing

MODELS = GENERATED / "models"
PREFIX = DEFAULT_PREFIX
FLOAT_FLAGS = {"cortex-m4": ("-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"), "cortex-m0plus": ("-mfloat-abi=soft",)}
ACT = {"relu": "{v} > 0.0f ? {v} : 0.0f", "linear": "{v}"}


def _f(v: float) -> str:
    """A C float literal that round-trips float32."""
    s = f"{float(np.float32(v)):.9g}"
    return (s if any(c in s for c in ".e") else s + ".0") + "f"


def _float_mlp_body(fm: FloatMLP) -> tuple[list[str], list[str]]:
    """Const weight tables and the statements of a plain float loop over the layers."""
    tables, body, src = [], ["    int i, j;"], "in"
    for k, layer in enumerate(fm.layers):
        if layer.activation not in ACT:
            raise NotImplementedError(f"float benchmark: activation {layer.activation}")
        n_out, n_in = layer.weight.shape
        tables.append(
            f"static const float w{k}[{n_out * n_in}] = {{ {', '.join(map(_f, layer.weight.ravel()))} }};"
        )
        tables.append(f"static const float b{k}[{n_out}] = {{ {', '.join(map(_f, layer.bias))} }};")
        dst = "out" if k == len(fm.layers) - 1 else f"h{k}"
        if dst != "out":
            body.insert(0, f"    float h{k}[{n_out}];")
        body += [
            f"    for (i = 0; i < {n_out}; ++i) {{",
            f"        float acc = b{k}[i];",
            f"        for (j = 0; j < {n_in}; ++j) {{",
            f"            acc += w{k}[i * {n_in} + j] * {src}[j];",
            "        }",
            f"        {dst}[i] = {ACT[layer.activation].format(v='acc')};",
            "    }",
        ]
        src = dst
    return tables, body


def _float_sf_body(fm: FloatSF) -> tuple[list[str], list[str]]:
    """Straight-line 2-D Horner of the float polynomial: a polynomial in a whose coefficients are in b."""
    deg_a = max(p[0] for p in fm.powers)
    terms = dict(zip(fm.powers, fm.coef, strict=True))
    body = ["    const float a = in[0], b = in[1];", "    float r = 0.0f, c;"]
    for pa in range(deg_a, -1, -1):
        deg_b = max((p[1] for p in fm.powers if p[0] == pa), default=0)
        body.append(f"    c = {_f(terms.get((pa, deg_b), 0.0))};")
        body += [f"    c = c * b + {_f(terms.get((pa, pb), 0.0))};" for pb in range(deg_b - 1, -1, -1)]
        body.append("    r = r * a + c;")
    return [], [*body, "    out[0] = r;"]


def float_source(fm: FloatMLP | FloatSF) -> str:
    """C99 float twin of the float model: float_infer(in, out) on physical-unit inputs."""
    tables, body = _float_mlp_body(fm) if isinstance(fm, FloatMLP) else _float_sf_body(fm)
    return "\n".join(
        [
            "#include <stdint.h>",
            "void float_infer(const float *in, float *out);",
            *tables,
            "void float_infer(const float *in, float *out)",
            "{",
            *body,
            "}",
            "",
        ]
    )


def macs(fm: FloatMLP | FloatSF) -> int | None:
    """Multiply-accumulates of one MLP inference (sum of n_in * n_out over layers); None for a surface fit."""
    if isinstance(fm, FloatMLP):
        return sum(int(np.prod(layer.weight.shape)) for layer in fm.layers)
    return None


def _inputs(qm, n: int, seed: int = 0) -> np.ndarray:
    """Int16 inputs drawn uniformly across the calibrated box (the operating range)."""
    rng = np.random.default_rng(seed)
    lo = np.array([i.lo_q for i in qm.inputs])
    hi = np.array([i.hi_q for i in qm.inputs])
    return rng.integers(lo, hi + 1, (n, len(lo)))


def float_run(fm: FloatMLP | FloatSF, cpu: str, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The float twin on the emulated core: outputs, instructions per call, linked .text (with libgcc)."""
    image = build_image({"float_net.c": float_source(fm)}, cpu, ("float_infer",), FLOAT_FLAGS[cpu], "float")
    m, out = Machine(image, cpu), np.zeros(1, np.float32)
    ys, counts = [], []
    for row in np.asarray(x, dtype=np.float32):
        (_, y), n = m.call("float_infer", row, out, count=True)
        ys.append(float(y[0]))
        counts.append(n)
    return np.array(ys), np.array(counts), image.image_sections[".text"]


def bench_model(name: str, n: int = 50) -> list[dict]:
    """Fixed-point and float instruction counts and flash of one default model on both cores."""
    from seagen.export import prepare
    from seagen.reference import float_ref

    ex = prepare(str(MODELS / f"{name}.pt"), prefix=PREFIX[name])
    qm, fm = ex.qmodel, ex.float_model
    xq = _inputs(qm, n)
    xf = xq * np.array([2.0**-i.frac for i in qm.inputs])
    want = float_ref.predict(fm, xf)
    rows = []
    for cpu in CPUS:
        mcu = CortexM(ex.files, ex.prefix, qm, cpu)
        counts = mcu.instructions(xq)
        yf, fcounts, fimage = float_run(fm, cpu, xf)
        err = float(np.max(np.abs(yf - want)) / max(float(np.max(np.abs(want))), 1e-12))
        if err > 1e-4:
            raise AssertionError(f"the float twin of {ex.prefix} on {cpu} is off by {err:.2e} (relative)")
        infer_only = build_image(ex.files, cpu, (f"{ex.prefix}_infer",), name=f"{ex.prefix}_infer")
        rows.append(
            {
                "model": ex.prefix,
                "cpu": cpu,
                "macs": macs(fm),
                "instr": float(counts.mean()),
                "instr_min": int(counts.min()),
                "instr_max": int(counts.max()),
                "flash_bytes": mcu.flash_bytes,
                "flash_by_object": {f: mcu.image.flash_bytes([f]) for f in mcu.image.objects},
                "infer_image_bytes": infer_only.image_sections[".text"],
                "float_instr": float(fcounts.mean()),
                "float_image_bytes": fimage,
                "float_max_rel_err": err,
            }
        )
    return rows


def _per_mac(instr: float, m: int | None) -> str:
    return f"{instr / m:6.1f}" if m else "     -"


def table(rows: list[dict]) -> str:
    """A plain-text table of the benchmark rows."""
    head = (
        f"{'model':8} {'cpu':14} {'MACs':>5} {'instr':>8} {'/MAC':>6} {'flash B':>8} {'image B':>8} "
        f"{'float instr':>11} {'/MAC':>6} {'image B':>8} {'float/fixed':>11}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        fixed = f"{r['instr']:8.0f} {_per_mac(r['instr'], r['macs'])} {r['flash_bytes']:8d}"
        fixed += f" {r['infer_image_bytes']:8d}"
        flt = f"{r['float_instr']:11.0f} {_per_mac(r['float_instr'], r['macs'])} {r['float_image_bytes']:8d}"
        ratio = r["float_instr"] / r["instr"]
        lines.append(f"{r['model']:8} {r['cpu']:14} {r['macs'] or '-':>5} {fixed} {flt} {ratio:11.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark over the default models; print a table or JSON."""
    ap = argparse.ArgumentParser(prog="python -m seagen.bench.mcu", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print the rows as JSON")
    ap.add_argument("-n", type=int, default=50, help="inputs per model (default 50)")
    args = ap.parse_args(argv)
    if msg := toolchain_missing():
        print(f"error: {msg}", file=sys.stderr)
        return 2
    rows = [r for name in PREFIX for r in bench_model(name, args.n)]
    print(json.dumps(rows, indent=2) if args.json else table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
