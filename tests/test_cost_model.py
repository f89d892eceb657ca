"""The Cortex-M cost model of toolchain/mcu_trace.py prices what a real chip charges: instructions skipped
inside an IT block, flash wait states on flash reads and refetches (not RAM reads), the M4's FPU timings."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from seagen.toolchain import cortexm as cm
from seagen.toolchain.host import compile_objects
from seagen.toolchain.mcu_trace import Insn, cycles, disassemble, it_block, traced_call

pytest.importorskip("unicorn", reason="unicorn (the Cortex-M emulator) is not installed: pip install unicorn")

SRC = """\
#include <stdint.h>
static const int16_t table[8] = {3, -1, 4, -1, 5, -9, 2, 6};
int32_t pick(int32_t a, int32_t b);
int32_t pick(int32_t a, int32_t b)
{
    int32_t s = 0;
    for (int32_t i = 0; i < 8; ++i) { s += (a > i) ? b : -b; }
    return s;
}
int32_t flash_sum(int32_t n);
int32_t flash_sum(int32_t n)
{
    int32_t s = 0;
    for (int32_t i = 0; i < n; ++i) { s += table[i & 7]; }
    return s;
}
int32_t ram_sum(const int16_t *x);
int32_t ram_sum(const int16_t *x)
{
    int32_t s = 0;
    for (int32_t i = 0; i < 8; ++i) { s += x[i]; }
    return s;
}
"""


@pytest.fixture(scope="module")
def m4():
    """The three probes linked for the Cortex-M4: (machine, disassembly)."""
    if msg := cm.toolchain_missing():
        pytest.skip(msg)
    from seagen.bench.run import _machine

    work = Path(tempfile.mkdtemp(prefix="seagen-cost."))
    try:
        flags = cm.cpu_flags("cortex-m4")
        objs = compile_objects({"probe.c": SRC}, work, (*flags, *cm.FREESTANDING), cc=cm.GCC, pic=False)
        (work / "link.ld").write_text(cm.LINKER_SCRIPT)
        elf = cm.link(work, objs, flags, ("pick", "flash_sum", "ram_sum"), "probe")
        yield _machine(elf, "cortex-m4"), disassemble(elf)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def test_it_skipped_instructions_are_counted(m4):
    """Each instruction of an IT block whose condition fails is counted (unicorn's hook skips it)."""
    machine, code = m4
    if not any(it_block(i.mnemonic) for i in code.values()):
        pytest.skip("gcc emitted no IT block for the probe")
    _, plain = machine.call("pick", 4, 3, count=True)
    _, t = traced_call(machine, code, "pick", 4, 3)
    assert t.it_skipped > 0 and t.instructions == plain + t.it_skipped


def test_flash_wait_prices_flash_reads_and_refetches_only(m4):
    """W wait states add W x (flash data reads + refetches); a table in RAM adds no flash reads."""
    machine, code = m4
    _, t0 = traced_call(machine, code, "flash_sum", 8)
    _, t1 = traced_call(machine, code, "flash_sum", 8, flash_wait=1)
    _, t2 = traced_call(machine, code, "flash_sum", 8, flash_wait=2)
    assert t0.flash_reads == 8 and t0.refetches >= 7
    assert t1.cycles - t0.cycles == t0.flash_reads + t0.refetches == t2.cycles - t1.cycles
    _, r = traced_call(machine, code, "ram_sum", np.arange(8, dtype=np.int16), flash_wait=1)
    assert r.flash_reads == 0


@pytest.mark.parametrize(
    "insn, want",
    [
        (Insn("vldr", 4, "s0, [r0]"), 2),
        (Insn("vstr", 4, "s0, [r0]"), 2),
        (Insn("vmla", 4, "s0, s1, s2"), 3),
        (Insn("vfma", 4, "s0, s1, s2"), 3),
        (Insn("vdiv", 4, "s0, s1, s2"), 14),
        (Insn("vpush", 4, "{s16-s19}"), 5),
        (Insn("vadd", 4, "s0, s1, s2"), 1),
    ],
)
def test_m4_fpu_timings(insn, want):
    """The float peers' FPU instructions cost what the Cortex-M4 manual says."""
    assert cycles("cortex-m4", insn, False, False) == want
