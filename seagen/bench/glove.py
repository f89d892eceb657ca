"""The glove's load: the firmware example (examples/firmware, seven SEAs in one 100 Hz tick) built from
exports with a core's target kernels and run on the emulated core; average cycles of one tick.

The example's glove.c/.h are taken as they are (per actuator one feature pipeline, read by cal_mlp and by
the ctl_mlp controller's predictor); for another pair of
models (e.g. the SF control predictor) the prefixes cal_mlp / ctl_mlp in their text are replaced by the
other models' prefixes, nothing else. Sensor sequence: `sensors` (random walks of the raw counts, desired
forces stepping every 40 ticks), the same one tests/test_firmware_example.py checks against the Python twins.
Cycles: the model in seagen/toolchain/mcu_trace.py; the load is cycles per tick / (48 MHz / 100 Hz).
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from seagen.actuator import default_actuator
from seagen.defaults import DEFAULT_PREFIX, default_model
from seagen.toolchain import cortexm as cm
from seagen.toolchain.host import compile_objects
from seagen.toolchain.mcu_trace import disassemble, traced_call

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "firmware"
N_SEA, TICKS = 7, 120
CYCLES_PER_TICK = round(48_000_000 / default_actuator().loop_hz)  # a 48 MHz core at the paper's loop rate
MODEL_OF = {prefix: name for name, prefix in DEFAULT_PREFIX.items()}
TRACED = range(10, 40)  # 30 ticks after 10 of warm-up: three refreshes of the pot average


@dataclass
class GloveLoad:
    """One tick of the firmware example on one core: instructions and cycles (mean over the traced ticks)."""

    cpu: str
    target: str
    cal: str
    ctl: str
    ticks: int
    instr_mean: float
    cycles_mean: float
    cycles_max: int
    flash_wait: int = 0  # flash wait states priced into the cycles
    it_skipped: float = 0.0  # of instr_mean: instructions skipped inside IT blocks (M4)

    @property
    def percent(self) -> float:
        """Cycles of the mean tick as % of a 48 MHz core at 100 Hz."""
        return 100.0 * self.cycles_mean / CYCLES_PER_TICK


def sensors(seed: int, ticks: int = TICKS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(enc, pot, desired force Q16) per tick and actuator: random walks, forces stepping within range."""
    from seagen.runtime.control import pot_at, sensor_walk

    start = (300, pot_at(0.29296875))  # the pot at 1,200 counts of the paper's 12-bit ADC
    top = default_actuator().control.force_max_n  # desired forces from 5 to 75 % of it: 1 to 15 N
    return sensor_walk(seed, ticks, (N_SEA,), start=start, force_n=(0.05 * top, 0.75 * top), hold=40)


def glove_files(target: str = "portable", cal: str = "cal_mlp", ctl: str = "ctl_mlp") -> dict[str, str]:
    """What the example's README exports into one folder (with `--target target`), plus glove.c/.h."""
    from seagen.codegen.controller import controller_files
    from seagen.export import prepare

    c = prepare(str(default_model(MODEL_OF[cal])), prefix=cal, target=target)
    k = prepare(str(default_model(MODEL_OF[ctl])), prefix=ctl, target=target)
    files = {**c.files, **k.files, **controller_files(ctl, k.qmodel)}
    for f in EXAMPLE.glob("glove.[ch]"):
        files[f.name] = f.read_text().replace("cal_mlp", cal).replace("CAL_MLP", cal.upper())
        files[f.name] = files[f.name].replace("ctl_mlp", ctl).replace("CTL_MLP", ctl.upper())
    return files


def _run(
    machine, code, seed: int, traced: range, flash_wait: int = 0
) -> tuple[list[int], list[int], list[int]]:
    """glove_init, then ticks to the end of `traced`; instructions, cycles, IT-skipped of each traced tick."""
    enc, pot, force = sensors(seed)
    i32 = np.int32
    g = machine.call("glove_init", np.zeros(16384, np.uint8), enc[0].astype(i32), pot[0].astype(i32))[0][0]
    instr, cycles, skipped = [], [], []
    for k in range(traced.stop):
        out, est = np.zeros(N_SEA, np.int32), np.zeros(N_SEA, np.int16)
        args = (g, enc[k].astype(i32), pot[k].astype(i32), force[k].astype(i32), out, est)
        if k in traced:
            back, t = traced_call(machine, code, "glove_tick", *args, flash_wait=flash_wait)
            instr.append(t.instructions)
            cycles.append(t.cycles)
            skipped.append(t.it_skipped)
        else:
            back, _ = machine.call("glove_tick", *args)
        g = back[0]
    return instr, cycles, skipped


def glove_load(
    cpu: str,
    cal: str = "cal_mlp",
    ctl: str = "ctl_mlp",
    target: str | None = None,
    traced: range = TRACED,
    flash_wait: int = 0,
) -> GloveLoad:
    """Build the example with the core's target kernels (or `target`) and trace the ticks `traced`, cycles
    at `flash_wait` flash wait states."""
    from seagen.bench.run import _machine

    target = target or cpu
    work = Path(tempfile.mkdtemp(prefix="seagen-glove."))
    try:
        flags = cm.cpu_flags(cpu)
        objs = compile_objects(
            glove_files(target, cal, ctl), work, (*flags, *cm.FREESTANDING), cc=cm.GCC, pic=False
        )
        (work / "link.ld").write_text(cm.LINKER_SCRIPT)
        elf = cm.link(work, objs, flags, ("glove_init", "glove_tick"), "glove")
        instr, cycles, skipped = _run(_machine(elf, cpu), disassemble(elf), 7, traced, flash_wait)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return GloveLoad(
        cpu,
        target,
        cal,
        ctl,
        len(traced),
        float(np.mean(instr)),
        float(np.mean(cycles)),
        int(max(cycles)),
        flash_wait,
        float(np.mean(skipped)),
    )


# (core, calibration model, control predictor) measured by `make bench`
CONFIGS = (
    ("cortex-m0plus", "cal_mlp", "ctl_mlp"),
    ("cortex-m0plus", "cal_mlp", "ctl_sf"),
    ("cortex-m0plus", "cal_sf", "ctl_sf"),
    ("cortex-m4", "cal_mlp", "ctl_mlp"),
    ("cortex-m4", "cal_mlp", "ctl_sf"),
)
CORE = {"cortex-m4": "M4", "cortex-m0plus": "M0+"}


def as_json(r: GloveLoad) -> dict:
    """One row as a plain dict, with its load in %."""
    return {**asdict(r), "percent": r.percent}


def table(rows: list[GloveLoad]) -> str:
    """The README table of the glove's load (Markdown)."""
    lines = [
        "| core | models (`--target` = the core) | instr / tick (IT-skipped) | flash wait states "
        "| cycles / tick (max) | % of 48 MHz at 100 Hz |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        lines.append(
            f"| {CORE[r.cpu]} | 7 × (features + {r.cal} + {r.ctl} controller tick) | {r.instr_mean:,.0f} "
            f"({r.it_skipped:,.0f}) | {r.flash_wait} | {r.cycles_mean:,.0f} ({r.cycles_max:,}) "
            f"| {r.percent:.1f} % |"
        )
    return "\n".join(lines)
