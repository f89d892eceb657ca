"""`make bench`: seagen's kernels against emlearn's float MLP and a plain float loop, on Cortex-M4 and M0+.

`python -m seagen.bench.compare [--json] [--readme README.md]`. For the default calibration MLP and
SF: seagen's portable kernel and the kernel of each core's target, emlearn 0.23's float MLP (its "loadable"
C generated from the same float network, i.e. trained on the same data) and a plain float C loop (M4F:
hardware single precision; M0+: libgcc soft float). Per implementation and core: instructions and cycles
of one inference (mean over inputs drawn across the calibrated box), per MAC, flash (.text + .rodata + the
initial values of .data of an image linked from the entry point, helpers included), RAM (.data + .bss),
stack (measured), float helpers linked, and the max |error| against the float model (torch's float64 twin,
seagen.reference.float_ref).
The glove's load comes from the firmware example itself (seagen/bench/glove.py): examples/firmware built from
exports with each core's target kernels, its average 100 Hz tick of seven actuators on the emulated core.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from seagen.bench import glove as G
from seagen.bench import run as B
from seagen.bench.mcu import FLOAT_FLAGS, float_source, macs
from seagen.defaults import DEFAULT_PREFIX, default_model
from seagen.toolchain import cortexm as cm
from seagen.toolchain.elfinfo import library_helpers
from seagen.toolchain.host import compile_objects
from seagen.toolchain.mcu_trace import disassemble, traced_call

DATA_AT = 0x20020000  # .data/.bss of the float implementations (the arguments sit at 0x20000000)
LINKER = cm.LINKER_SCRIPT.replace(
    "RAM (rwx) : ORIGIN = 0x20000000, LENGTH = 256K", "RAM (rwx) : ORIGIN = 0x20020000, LENGTH = 64K"
)
TARGET_OF = {"cortex-m4": "cortex-m4", "cortex-m0plus": "cortex-m0plus"}
N = 60


def _emlearn_source(fm) -> dict[str, str]:
    """emlearn's loadable float MLP of the same float network, with a float_infer(in, out) entry point."""
    from emlearn.net import c_generate_net_loadable

    acts = ["identity" if L.activation == "linear" else L.activation for L in fm.layers]
    w = [np.asarray(L.weight, dtype=np.float32).T for L in fm.layers]
    b = [np.asarray(L.bias, dtype=np.float32) for L in fm.layers]
    n_in = w[0].shape[0]
    code = c_generate_net_loadable(acts, w, b, "eml")
    code += "\nvoid float_infer(const float *in, float *out);\n"
    code += f"void float_infer(const float *in, float *out) {{ out[0] = eml_regress1(in, {n_in}); }}\n"
    return {"eml_model.c": code}


def _image(sources: dict[str, str], cpu: str, flags: tuple[str, ...], root: str, strict: bool):
    """Compile (strict flags only for seagen's C), link from `root`; (machine, code map, elf, objs, work)."""
    import subprocess

    import emlearn

    work = Path(tempfile.mkdtemp(prefix="seagen-cmp."))
    all_flags = (*cm.cpu_flags(cpu), *flags)
    if strict:
        objs = compile_objects(sources, work, (*all_flags, *cm.FREESTANDING), cc=cm.GCC, pic=False)
    else:  # third-party C: its own warnings are not ours to fix
        objs = []
        (work / "src").mkdir()
        for name, text in sources.items():
            (work / "src" / name).write_text(text)
            obj = work / (Path(name).stem + ".o")
            cmd = [
                cm.GCC,
                "-std=gnu99",
                "-O2",
                *all_flags,
                "-ffunction-sections",
                "-fdata-sections",
                "-I",
                emlearn.includedir,
                "-c",
                str(work / "src" / name),
                "-o",
                str(obj),
            ]
            subprocess.run(cmd, check=True, capture_output=True)
            objs.append(obj)
    (work / "link.ld").write_text(LINKER)
    libs = ("-lgcc", "-lgcc") if strict else ("-lm", "-lc", "-lgcc", "-lgcc")
    elf = cm.link(work, objs, all_flags, (root,), libs=libs)
    sections = cm._sections(elf)
    machine = cm.Machine(cm.Image(cm.flat_section(elf), cm._symbols(elf), {}, sections), cpu)
    if sections.get(".data", 0):  # emlearn's tables: copied to RAM here, as start-up code would
        machine.uc.mem_write(DATA_AT, cm.flat_section(elf, ".data"))
    return machine, disassemble(elf), elf, objs, work


def _measure(
    name: str, cpu: str, sources, flags, root: str, rows: list, out_dtype, strict: bool
) -> tuple[dict, np.ndarray]:
    """Trace `root(row, out)` over the rows; the table row and the outputs."""
    machine, code, elf, objs, work = _image(sources, cpu, flags, root, strict)
    try:
        ys, traces = [], []
        for r in rows:
            back, t = traced_call(machine, code, root, r, np.zeros(1, out_dtype))
            ys.append(back[1][0])
            traces.append(t)
        sections = cm._sections(elf)
        helpers = library_helpers(elf, objs)
        row = {
            "impl": name,
            "cpu": cpu,
            "instr": float(np.mean([t.instructions for t in traces])),
            "cycles": float(np.mean([t.cycles for t in traces])),
            "flash": sections.get(".text", 0) + sections.get(".data", 0),  # .data's initial values
            "ram": sections.get(".data", 0) + sections.get(".bss", 0),
            "stack": max(t.stack for t in traces),
            "float_helpers": [h for h in helpers if B.FLOAT_HELPER.match(h)],
            "isa": sorted(set().union(*(t.violations for t in traces))),
        }
        return row, np.array(ys, dtype=float)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def bench_model(name: str) -> list[dict]:
    """Every implementation of one default model on both cores."""
    from seagen.bench.mcu import _inputs
    from seagen.export import prepare
    from seagen.reference import float_ref

    rows = []
    for cpu in cm.CPUS:
        impls = {}
        for target in ("portable", TARGET_OF[cpu]):
            ex = prepare(str(default_model(name)), prefix=DEFAULT_PREFIX[name], target=target)
            impls[f"seagen {target}"] = ("fixed", ex)
        qm, fm = ex.qmodel, ex.float_model
        xq = _inputs(qm, N, seed=1)
        xf = xq * np.array([2.0**-i.frac for i in qm.inputs])
        want = float_ref.predict(fm, xf)
        for label, (_, e) in impls.items():
            row, y = _measure(
                label, cpu, e.files, (), f"{e.prefix}_infer", list(xq.astype(np.int16)), np.int16, True
            )
            rows.append(
                {
                    **row,
                    "model": e.prefix,
                    "macs": macs(fm),
                    "max_err": float(np.max(np.abs(y * 2.0**-qm.out_frac - want))),
                }
            )
        floats = {"float loop": {"float_net.c": float_source(fm)}}
        if macs(fm):
            floats["emlearn 0.23 float MLP"] = _emlearn_source(fm)
        for label, src in floats.items():
            row, y = _measure(
                label,
                cpu,
                src,
                FLOAT_FLAGS[cpu],
                "float_infer",
                list(xf.astype(np.float32)),
                np.float32,
                label == "float loop",
            )
            rows.append(
                {**row, "model": ex.prefix, "macs": macs(fm), "max_err": float(np.max(np.abs(y - want)))}
            )
    return rows


CORE = {"cortex-m4": "M4F", "cortex-m0plus": "M0+"}


def table(rows: list[dict]) -> str:
    """The README table (Markdown)."""
    head = (
        "| model | implementation | core | instr | cycles | instr / MAC | flash B | RAM B | stack B "
        "| float helpers | max \\|err\\| vs float |"
    )
    lines = [head, "| " + " | ".join(["---"] * 11) + " |"]
    for r in rows:
        per = f"{r['instr'] / r['macs']:.1f}" if r["macs"] else "–"
        fh = f"{len(r['float_helpers'])} (`{r['float_helpers'][0]}`…)" if r["float_helpers"] else "none"
        bold = "**" if r["impl"].startswith("seagen cortex") else ""
        lines.append(
            f"| {r['model']} | {r['impl']} | {CORE[r['cpu']]} | {bold}{r['instr']:,.0f}{bold} "
            f"| {r['cycles']:,.0f} | {per} | {r['flash']:,} | {r['ram']:,} | {r['stack']} | {fh} "
            f"| {r['max_err']:.2g} |"
        )
    return "\n".join(lines)


def firmware_rows() -> list[B.Entry]:
    """`seagen bench` of the four default models exported for each core's target kernel."""
    from seagen.export import prepare, write

    rows = []
    for cpu in cm.CPUS:
        with tempfile.TemporaryDirectory() as d:
            for name, prefix in DEFAULT_PREFIX.items():
                write(prepare(str(default_model(name)), prefix=prefix, target=cpu), d)
            rows += B.bench_dir(Path(d), (cpu,))
    return rows


def goals(cmp: list[dict], fw: list[B.Entry], glove: list[G.GloveLoad]) -> str:
    """The issue-12 goals with what was measured (Markdown)."""
    c = {(r["impl"], r["model"], r["cpu"]): r for r in cmp}
    e = {(r.entry, r.cpu): r for r in fw}
    m4, m0 = "cortex-m4", "cortex-m0plus"

    def load(cal: str, ctl: str, wait: int = 0) -> float:
        return next(g.percent for g in glove if (g.cpu, g.cal, g.ctl, g.flash_wait) == (m0, cal, ctl, wait))

    waits = sorted({g.flash_wait for g in glove} - {0})

    items = [
        (
            "cal_mlp `_infer`, Cortex-M4 (instructions)",
            c[("seagen cortex-m4", "cal_mlp", m4)]["instr"],
            1300,
            1000,
        ),
        (
            "cal_mlp `_infer`, Cortex-M4 (cycles, IT-skipped instructions counted, 0 wait states)",
            c[("seagen cortex-m4", "cal_mlp", m4)]["cycles"],
            1500,
            None,
        ),
        ("cal_mlp `_infer`, Cortex-M0+", c[("seagen cortex-m0plus", "cal_mlp", m0)]["instr"], 4000, 2800),
        ("cal_sf `_infer`, Cortex-M4", c[("seagen cortex-m4", "cal_sf", m4)]["instr"], 60, 40),
        ("cal_sf `_infer`, Cortex-M0+", c[("seagen cortex-m0plus", "cal_sf", m0)]["instr"], 120, 90),
        (
            "cal_mlp `_infer` image with its tables, flash on M4 (bytes; 2.2 KB = 2,253 B)",
            c[("seagen cortex-m4", "cal_mlp", m4)]["flash"],
            2253,
            None,
        ),
        (
            "controller tick with the ctl_mlp predictor, M0+ (instructions)",
            e[("ctl_mlp_bench_tick", m0)].instr_mean,
            5000,
            2500,
        ),
        (
            "controller tick with the ctl_sf predictor, M0+",
            e[("ctl_sf_bench_tick", m0)].instr_mean,
            5000,
            2500,
        ),
        (
            "glove: firmware example, 7 × (features + cal_mlp + ctl_mlp tick) at 100 Hz, % of a 48 MHz M0+",
            load("cal_mlp", "ctl_mlp"),
            15,
            8,
        ),
        (
            "glove: firmware example, 7 × (features + cal_mlp + ctl_sf tick), %",
            load("cal_mlp", "ctl_sf"),
            15,
            8,
        ),
        (
            "glove: firmware example, 7 × (features + cal_sf + ctl_sf tick), %",
            load("cal_sf", "ctl_sf"),
            15,
            8,
        ),
    ] + [
        (
            f"glove: 7 × (features + cal_mlp + ctl_mlp tick) at {w} flash wait state(s) (SAMD21-class), %",
            load("cal_mlp", "ctl_mlp", w),
            15,
            None,
        )
        for w in waits
    ]
    lines = ["| measure | measured | goal | moonshot | |", "| --- | --- | --- | --- | --- |"]
    for what, got, goal, moon in items:
        verdict = "met" if got <= goal else f"missed by {got - goal:,.1f}"
        if moon is not None and got <= moon:
            verdict = "moonshot met"
        fmt = (lambda v: f"{v:.1f}") if goal < 100 else (lambda v: f"{v:,.0f}")
        lines.append(
            f"| {what} | {fmt(got)} | ≤ {fmt(goal)} | {'≤ ' + fmt(moon) if moon else ''} | {verdict} |"
        )
    return "\n".join(lines)


def write_readme(readme: Path, text: str) -> None:
    """Replace the block between the bench markers in the README (written to a temporary name, renamed)."""
    import os

    begin, end = "<!-- bench:begin (make bench) -->", "<!-- bench:end -->"
    src = readme.read_text()
    if begin not in src or end not in src:
        raise SystemExit(f"{readme}: no {begin} ... {end} block")
    out = src[: src.index(begin) + len(begin)] + "\n" + text + "\n" + src[src.index(end) :]
    tmp = readme.with_suffix(".md.tmp")
    tmp.write_text(out)
    os.replace(tmp, readme)


def main(argv: list[str] | None = None) -> int:
    """Run the comparison over the default calibration models; print (or write into the README) the table."""
    ap = argparse.ArgumentParser(prog="python -m seagen.bench.compare", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print the rows as JSON")
    ap.add_argument("--readme", metavar="FILE", help="write the table between the bench markers of FILE")
    ap.add_argument(
        "--flash-wait",
        type=int,
        default=0,
        metavar="N",
        help="also price the glove's tick at N flash wait states (1: a SAMD21-class M0+ at 48 MHz, no cache)",
    )
    args = ap.parse_args(argv)
    if msg := cm.toolchain_missing():
        print(f"error: {msg}", file=sys.stderr)
        return 2
    rows = [r for name in ("mlp_calibration", "sf_calibration") for r in bench_model(name)]
    fw = firmware_rows()
    waits = sorted({0, max(args.flash_wait, 0)})
    glove = [G.glove_load(*cfg, flash_wait=w) for w in waits for cfg in G.CONFIGS]
    text = (
        table(rows)
        + "\n\nThe glove's load: `examples/firmware` built from exports with the core's `--target`, mean of "
        + f"ticks {G.TRACED.start}-{G.TRACED.stop - 1} of its sensor sequence (`seagen/bench/glove.py`):\n\n"
        + G.table(glove)
        + "\n\nGoals (cycles from the model in `seagen/toolchain/mcu_trace.py`):\n\n"
        + goals(rows, fw, glove)
    )
    if args.readme:
        write_readme(Path(args.readme), text)
    print(
        json.dumps(
            {"compare": rows, "firmware": B.as_json(fw), "glove": [G.as_json(g) for g in glove]}, indent=2
        )
        if args.json
        else text
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
