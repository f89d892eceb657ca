"""`seagen bench DIR`: per entry point of an export, on emulated Cortex-M cores, what firmware pays for it.

For every model NAME in DIR (a header declaring NAME_infer) and each core: executed instructions of
NAME_infer (inputs drawn across the calibrated box), NAME_step (a synthetic raw enc/pot run after NAME_reset,
scaled to the export's actuator: seagen/bench/tick.py) and, for a control predictor (NAME_predict_q16), one
controller tick along the same run (sea_control_step with the predictor and the settings `seagen export
--controller` renders for that actuator, templates/bench_tick.c.j2); a cycle estimate (mcu_trace.py);
flash (.text + .rodata + the initial values of .data of an image linked from that entry point alone, library
helpers included) and RAM (.data + .bss); the stack: static worst case from -fstack-usage over the call
graph, and the deepest stack measured; every library helper linked (none may be float) and an ISA check of
each executed instruction.
"""

from __future__ import annotations

import re
import shutil
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from seagen.actuator import Actuator
from seagen.bench import tick as T
from seagen.errors import UserError
from seagen.toolchain import cortexm as cm
from seagen.toolchain.elfinfo import library_helpers, stack_usage, static_stack
from seagen.toolchain.host import compile_objects
from seagen.toolchain.mcu_trace import Trace, disassemble, traced_call

FLOAT_HELPER = re.compile(  # soft-float helpers of libgcc (AEABI and GCC names); integer helpers do not match
    r"^__(aeabi_([fd][a-z0-9]+|u?[il]2[fd])|(add|sub|mul|div|neg)[sdt]f3|(eq|ne|lt|le|gt|ge|un|cmp)[sdt]f2"
    r"|fix\w*|float\w*|extend\w*|trunc\w*)$"
)
CONTROL_FILES = (
    "sea_pid.h",
    "sea_pid.c",
    "sea_control.h",
    "sea_control.c",
    "sea_fixed_ctrl.c",
)
N_CALLS = 40


@dataclass
class Entry:
    """The measurements of one entry point on one core."""

    model: str
    cpu: str
    entry: str
    instr_mean: float
    instr_min: int
    instr_max: int
    cycles_mean: float
    flash: int
    ram: int
    stack_static: int | None
    stack_measured: int
    helpers: list[str]
    float_helpers: list[str]
    isa_violations: list[str]
    flash_wait: int = 0  # wait states priced into cycles_mean (seagen/toolchain/mcu_trace.py)
    it_skipped_mean: float = 0.0  # of instr_mean: skipped inside IT blocks (M4)


def find_models(d: Path) -> list[str]:
    """Prefixes NAME of the headers in d that declare NAME_infer."""
    names = []
    for h in sorted(d.glob("*.h")):
        if re.search(rf"\bvoid {re.escape(h.stem)}_infer\(", h.read_text()):
            names.append(h.stem)
    if not names:
        raise UserError(f"{d}: no exported model (no NAME.h declaring NAME_infer)")
    return names


def _box(c_text: str, prefix: str, header: str) -> tuple[np.ndarray, np.ndarray]:
    """The calibrated input box, read from NAME_in_lo / NAME_in_hi in NAME.c: int16 values, or int16 pairs
    packed low half first in int32 words (the Cortex-M4 kernel's pair clamp), NAME_N_IN of them."""
    n = re.search(rf"#define {prefix.upper()}_N_IN (\d+)", header)
    if n is None:
        raise UserError(f"{prefix}.h: no {prefix.upper()}_N_IN")
    out = []
    for side in ("lo", "hi"):
        m = re.search(rf"static const int(16|32)_t {prefix}_in_{side}\[\d+\] = \{{([^}}]*)\}}", c_text)
        if m is None:
            raise UserError(f"{prefix}.c: no {prefix}_in_{side} table")
        vals = [int(v) for v in m.group(2).split(",")]
        if m.group(1) == "32":
            vals = [((w >> k & 0xFFFF) ^ 0x8000) - 0x8000 for w in vals for k in (0, 16)]
        out.append(np.array(vals[: int(n.group(1))]))
    return out[0], out[1]


def _machine(elf: Path, cpu: str) -> cm.Machine:
    """An emulator loaded with the ELF's flat .text."""
    sections = cm.no_startup_sections(elf)
    image = cm.Image(cm.flat_section(elf), cm._symbols(elf), {}, sections, cm.data_section(elf, sections))
    return cm.Machine(image, cpu)


def _calls(prefix: str, entry: str, header: str, box: tuple[np.ndarray, np.ndarray], run: T.Run):
    """(symbol, args) of the set-up calls and of the measured calls of one entry point."""
    rng = np.random.default_rng(0)
    if entry == "infer":
        rows = rng.integers(box[0], box[1] + 1, (N_CALLS, len(box[0])))
        return [], [(f"{prefix}_infer", [r.astype(np.int16), np.zeros(1, np.int16)]) for r in rows]
    ep = zip(run.enc.tolist(), run.pot.tolist(), strict=True)
    if entry == "step":
        sig = re.search(rf"int16_t {prefix}_step\(([^)]*)\)", header)
        if sig is None:
            raise UserError(f"{prefix}.h declares no {prefix}_step")
        ext = [6000] * (len(sig.group(1).split(",")) - 3)  # a desired force ~6 N in the Q10 of a predictor
        setup: list[tuple[str, list]] = [(f"{prefix}_reset", ["state"])]
        return setup, [(f"{prefix}_step", ["state", e, p, *ext]) for e, p in ep]
    setup = [(f"{prefix}_bench_init", ["state", int(run.enc[0]), int(run.pot[0])])]
    return setup, [(f"{prefix}_bench_tick", ["state", e, p, run.force_q16]) for e, p in ep]


def _run(machine, code, setup, calls, flash_wait: int = 0, every: int = 1) -> list[Trace]:
    """Run the set-up calls, then the calls, tracing every `every`-th ('state': one RAM block throughout)."""
    state = np.zeros(1024, np.uint8)  # first argument everywhere: it stays at the same RAM address

    def args(a: list) -> list:
        return [state if isinstance(x, str) else x for x in a]

    for sym, a in setup:
        back, _ = machine.call(sym, *args(a))
        if a and isinstance(a[0], str):
            state = back[0].copy()
    traces = []
    for i, (sym, a) in enumerate(calls):
        if i % every:
            back, _ = machine.call(sym, *args(a))
        else:
            back, t = traced_call(machine, code, sym, *args(a), flash_wait=flash_wait)
            traces.append(t)
        if isinstance(a[0], str):
            state = back[0].copy()
    return traces


def _sources(d: Path, prefix: str, act: Actuator) -> tuple[dict[str, str], list[str]]:
    """The export's C files, plus the tick driver (act's controller) and sea_pid/sea_control if needed."""
    src = {p.name: p.read_text() for p in sorted(d.iterdir()) if p.suffix in (".c", ".h")}
    other = [
        f for f in src if f.endswith(".c") and f.startswith(tuple(find_models(d))) and f != f"{prefix}.c"
    ]
    for f in other:  # other models' files are not part of this model's image
        del src[f]
    entries = ["infer", *(["step"] if re.search(rf"\b{prefix}_step\(", src[f"{prefix}.h"]) else [])]
    if re.search(rf"\b{prefix}_predict_q16\(", src[f"{prefix}.h"]):
        from seagen.codegen.runtime import runtime_sources

        driver = T.tick_driver(prefix, T.controller_config(src[f"{prefix}.h"], prefix, act))
        src = {**runtime_sources(*CONTROL_FILES), **src, **driver}
        entries.append("tick")
    return src, entries


ROOTS = {
    "infer": ("{p}_infer",),
    "step": ("{p}_reset", "{p}_step"),
    "tick": ("{p}_bench_init", "{p}_bench_tick"),
}


def bench_model(
    d: Path, prefix: str, cpu: str, flash_wait: int = 0, actuator: Actuator | None = None
) -> list[Entry]:
    """Measure every entry point of model `prefix` in export folder d on `cpu`, on the design it was exported
    for (`actuator`: its description, the paper's when None; tick.export_actuator checks it)."""
    act = T.export_actuator(d, prefix, actuator)
    if msg := cm.toolchain_missing():
        raise UserError(msg)
    sources, entries = _sources(d, prefix, act)
    run = T.run_of(act, N_CALLS)
    flags = cm.cpu_flags(cpu)
    work = Path(tempfile.mkdtemp(prefix="seagen-bench."))
    try:
        objs = compile_objects(
            sources, work, (*flags, *cm.FREESTANDING, "-fstack-usage"), cc=cm.GCC, pic=False
        )
        (work / "link.ld").write_text(cm.LINKER_SCRIPT)
        roots = tuple(r.format(p=prefix) for e in entries for r in ROOTS[e])
        elf = cm.link(work, objs, flags, roots, "all")
        machine, code, usage = _machine(elf, cpu), disassemble(elf), stack_usage(work)
        box = _box(sources[f"{prefix}.c"], prefix, sources[f"{prefix}.h"])
        out = []
        for e in entries:
            measured = ROOTS[e][-1].format(p=prefix)
            keep = (ROOTS[e][0].format(p=prefix), measured) if e == "tick" else (measured,)
            alone = cm.link(work, objs, flags, keep, e)
            setup, calls = _calls(prefix, e, sources[f"{prefix}.h"], box, run)
            traces = _run(machine, code, setup, calls, flash_wait, 1 if e == "infer" else run.every)
            n = np.array([t.instructions for t in traces])
            sections = cm._sections(alone)
            helpers = library_helpers(alone, objs)
            out.append(
                Entry(
                    prefix,
                    cpu,
                    measured,
                    float(n.mean()),
                    int(n.min()),
                    int(n.max()),
                    float(np.mean([t.cycles for t in traces])),
                    sections.get(".text", 0) + sections.get(".data", 0),  # .data's initial values
                    sections.get(".data", 0) + sections.get(".bss", 0),
                    static_stack(alone, usage, measured),
                    max(t.stack for t in traces),
                    helpers,
                    [h for h in helpers if FLOAT_HELPER.match(h)],
                    sorted(set().union(*(t.violations for t in traces))),
                    flash_wait,
                    float(np.mean([t.it_skipped for t in traces])),
                )
            )
        return out
    finally:
        shutil.rmtree(work, ignore_errors=True)


def bench_dir(
    d: Path, cpus: tuple[str, ...], flash_wait: int = 0, actuator: Actuator | None = None
) -> list[Entry]:
    """Every model of the export folder on every named core, cycles at `flash_wait` wait states, on the
    design `actuator` the folder was exported for (the paper's when None)."""
    if not d.is_dir():
        raise UserError(f"{d}: not a directory")
    if not 0 <= flash_wait <= 15:
        raise UserError(f"--flash-wait must be 0..15 wait states, got {flash_wait}")
    models = find_models(d)
    for prefix in models:  # a folder for another design is refused before anything is built
        T.export_actuator(d, prefix, actuator)
    return [e for p in models for cpu in cpus for e in bench_model(d, p, cpu, flash_wait, actuator)]


def table(rows: list[Entry]) -> str:
    """A plain-text table of the measurements."""
    head = (
        f"{'entry point':24} {'core':14} {'instr':>7} {'min-max':>11} {'cycles':>7} {'flash B':>8} "
        f"{'RAM B':>6} {'stack B':>11} {'float helpers':>13} {'ISA':>4}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        stack = f"{r.stack_static if r.stack_static is not None else '?'}/{r.stack_measured}"
        lines.append(
            f"{r.entry:24} {r.cpu:14} {r.instr_mean:7.0f} {f'{r.instr_min}-{r.instr_max}':>11} "
            f"{r.cycles_mean:7.0f} {r.flash:8d} {r.ram:6d} {stack:>11} "
            f"{', '.join(r.float_helpers) or 'none':>13} {'ok' if not r.isa_violations else 'BAD':>4}"
        )
    lines.append("stack: static worst case (-fstack-usage over the call graph) / deepest measured")
    waits = sorted({r.flash_wait for r in rows})
    lines.append(
        f"cycles: at {', '.join(map(str, waits)) or 0} flash wait state(s) (paid by flash data reads and "
        "refetches after taken branches); instr counts those skipped inside IT blocks (M4)"
    )
    helpers = sorted({h for r in rows for h in r.helpers})
    lines.append(f"library helpers linked: {', '.join(helpers) or 'none'}")
    return "\n".join(lines)


def failures(rows: list[Entry]) -> list[str]:
    """What makes the bench fail: float helpers linked, instructions the named core lacks."""
    out = [
        f"{r.entry} on {r.cpu}: float helpers {', '.join(r.float_helpers)}" for r in rows if r.float_helpers
    ]
    out += [f"{r.entry} on {r.cpu}: {'; '.join(r.isa_violations)}" for r in rows if r.isa_violations]
    return out


def as_json(rows: list[Entry]) -> list[dict]:
    """The rows as plain dicts."""
    return [asdict(r) for r in rows]
