"""What each activation costs on the emulated cores: the default calibration MLP (9-16-32-1) with its hidden
ReLUs swapped for each activation, exported with each target kernel, run by unicorn.

`python -m seagen.bench.act_cost [-n N] [--json]`: per activation and core (cortex-m4 kernel on the M4,
cortex-m0plus kernel on the M0+ model), executed instructions of NAME_infer (mean, min and max over N inputs
drawn across the calibrated box; unicorn's deterministic count), the activation tables' bytes and
max |integer - float| (the same network in float64) against the proven bound on those inputs.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

import numpy as np

from seagen.defaults import GENERATED
from seagen.ir import FloatMLP
from seagen.runtime.activations import HARDSWISH, SELU

ACTS: dict[str, tuple[float, ...]] = {
    "relu": (),
    "tanh": (),
    "elu": (1.0,),
    "selu": SELU,
    "softplus": (1.0, 20.0),
    "gelu": (),
    "gelu_tanh": (),
    "mish": (),
    "silu": (),
    "hardsigmoid": (1.0 / 6.0, 0.5),
    "hardswish": HARDSWISH,
    "prelu": (0.25,),
}
TARGETS = ("cortex-m4", "cortex-m0plus")


def swapped(fm: FloatMLP, act: str) -> FloatMLP:
    """fm with every hidden activation replaced by `act` (PReLU: its slope on every channel)."""
    layers = []
    for lay in fm.layers[:-1]:
        p = ACTS[act] * lay.weight.shape[0] if act == "prelu" else ACTS[act]
        layers.append(dataclasses.replace(lay, activation=act, params=p))
    return dataclasses.replace(fm, layers=(*layers, fm.layers[-1]))


def rows(n: int = 50) -> list[dict]:
    """One row per activation and core."""
    from seagen.codegen.render import RUNTIME, render
    from seagen.codegen.runtime import runtime_sources
    from seagen.codegen.targets import RUNTIME as EXTRA
    from seagen.export import prepare
    from seagen.quant.mlp import quantize_mlp
    from seagen.reference import float_ref, numpy_ref
    from seagen.toolchain.cortexm import CortexM
    from seagen.toolchain.equivalence import random_inputs

    base = prepare(str(GENERATED / "models" / "mlp_calibration.pt"), prefix="cal_mlp").float_model
    assert isinstance(base, FloatMLP)
    out = []
    for act in ACTS:
        fm = swapped(base, act)
        qm = quantize_mlp(fm)
        x = numpy_ref.clamp_inputs(qm, random_inputs(qm, n, 1))  # in the box (the C clamps to it)
        want = numpy_ref.infer(qm, x)
        real = float_ref.predict(fm, x * np.array([2.0**-i.frac for i in qm.inputs]))
        err = float(np.max(np.abs(want * 2.0**-qm.out_frac - real)))
        for target in TARGETS:
            files = {**render(qm, "cost", target), **runtime_sources(*RUNTIME, *EXTRA[target])}
            mcu = CortexM(files, "cost", qm, target)
            if not np.array_equal(mcu.infer(x), want):
                raise AssertionError(f"{act} on {target}: the emulated core disagrees with numpy")
            counts = mcu.instructions(x)
            out.append(
                {
                    "act": act,
                    "cpu": target,
                    "instr": float(counts.mean()),
                    "instr_min": int(counts.min()),
                    "instr_max": int(counts.max()),
                    "table_bytes": sum(2 * len(t.values) for t in qm.tables),
                    "max_err": err,
                    "bound": qm.error_bound,
                }
            )
    return out


def table(rs: list[dict]) -> str:
    """Markdown: one line per activation, both cores."""
    lines = [
        "| activation | M4 instr (min-max) | M0+ instr (min-max) | tables B | max err / bound (N) |",
        "| --- | --: | --: | --: | --: |",
    ]
    by = {(r["act"], r["cpu"]): r for r in rs}
    for act in ACTS:
        m4, m0 = by[(act, "cortex-m4")], by[(act, "cortex-m0plus")]
        cell = [f"{r['instr']:.0f} ({r['instr_min']}-{r['instr_max']})" for r in (m4, m0)]
        err = f"{m4['max_err']:.4f} / {m4['bound']:.4f}"
        lines.append(f"| {act} | {cell[0]} | {cell[1]} | {m4['table_bytes']} | {err} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the table (or JSON); exit 2 without the emulator or the cross-compiler."""
    from seagen.toolchain.cortexm import toolchain_missing

    ap = argparse.ArgumentParser(prog="python -m seagen.bench.act_cost", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print the rows as JSON")
    ap.add_argument("-n", type=int, default=50, help="inputs per activation (default 50)")
    args = ap.parse_args(argv)
    if msg := toolchain_missing():
        print(f"error: {msg}", file=sys.stderr)
        return 2
    rs = rows(args.n)
    print(json.dumps(rs, indent=2) if args.json else table(rs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
