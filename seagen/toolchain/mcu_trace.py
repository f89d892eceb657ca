"""Executed-instruction traces on the emulated Cortex-M: cycle estimate, ISA check and measured stack depth.

unicorn gives addresses, not instructions; the mnemonics come from `arm-none-eabi-objdump -d` of the linked
ELF. The cycle model (documented in README, `seagen bench`) follows the Cortex-M0+ and Cortex-M4 technical
reference manuals:

| class | Cortex-M0+ (single-cycle multiplier) | Cortex-M4 |
| --- | --- | --- |
| ALU, multiply (MULS; M4: MUL/MLA/SMLAD/SMULL/SMLAL/SMMLA/USAT...) | 1 | 1 |
| single load/store | 2 | 2, or 1 right after another load/store (pipelined) |
| LDM/STM/PUSH/POP of N registers | 1 + N (+2 when POP loads pc) | 1 + N (+2 when POP loads pc) |
| branch taken (B, Bcc, BX, BLX; POP pc above) | 2 | 1 + P, P = 2 |
| branch not taken | 1 | 1 |
| BL | 3 | 1 + P = 3 |
| SDIV/UDIV | - | 12 (worst case of 2-12) |
| instruction skipped inside an IT block (its condition false) | - | 1 (counted as executed) |
| VLDR / VSTR; VLDM/VSTM/VPUSH/VPOP of N registers | - | 2; 1 + N |
| VMLA/VMLS/VNMLA/VNMLS/VFMA/VFMS; VDIV, VSQRT | - | 3; 14 |
| other floating point (VADD, VMUL, VMOV, VCVT, VCMP, VMRS, ...) | - | 1 |

Flash wait states W (`flash_wait`, 0 by default: zero-wait memory, e.g. an M0+ at <= 24 MHz or an M4 with a
flash accelerator hitting) add W cycles to every data read from flash (constant tables: addresses below
0x20000000; RAM reads add none) and to every taken branch, BL and POP/BX/LDM loading pc (the refetch). A
core with one wait state and no cache (SAMD21 at 48 MHz: W = 1) pays at least that; the sequential
instruction fetches, hidden or not by a prefetch buffer, are not modelled (a lower bound). M4 branch-target
alignment effects are not modelled. unicorn does not report instructions skipped inside an IT block; the
trace counts them from the IT instruction's mask.
"""

from __future__ import annotations

import re
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

LINE = re.compile(r"^\s*([0-9a-f]+):\s+([0-9a-f]{4})(?: ([0-9a-f]{4}))?\s+(\S+)\s*(.*)$")
CONDS = ["eq", "ne", "cs", "cc", "hs", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le", "al"]
ARMV6M_MNEMONICS = """
adc adcs add adds adr and ands asr asrs b bic bics bkpt bl blx bx cmn cmp cpsid cpsie dmb dsb eor eors
isb ldm ldmia ldr ldrb ldrh ldrsb ldrsh lsl lsls lsr lsrs mov movs mrs msr mul muls mvn mvns neg negs
nop orr orrs pop push rev rev16 revsh ror rors rsb rsbs sbc sbcs sev stm stmia str strb strh sub subs
svc sxtb sxth tst udf uxtb uxth wfe wfi yield
"""
V6M = set(ARMV6M_MNEMONICS.split())
V6M_WIDE = {"bl", "dmb", "dsb", "isb", "mrs", "msr"}
V8M_ONLY = {"sg", "tt", "ttt", "tta", "ttat", "lda", "ldab", "ldah", "stl", "stlb", "stlh", "ldaex", "stlex"}


@dataclass(frozen=True)
class Insn:
    """One disassembled instruction: mnemonic (no .n/.w, no condition for branches), width, operands."""

    mnemonic: str
    size: int
    ops: str


def disassemble(elf: Path) -> dict[int, Insn]:
    """Address -> instruction of every instruction in the ELF's code sections."""
    out = subprocess.run(
        ["arm-none-eabi-objdump", "-d", str(elf)], capture_output=True, text=True, check=True
    )
    table = {}
    for line in out.stdout.splitlines():
        m = LINE.match(line)
        if m and not m.group(4).startswith("."):
            table[int(m.group(1), 16)] = Insn(
                m.group(4).split(".")[0], 4 if m.group(3) else 2, m.group(5).split(";")[0].strip()
            )
    return table


def _branch(mn: str) -> bool:
    return mn in ("b", "bx", "blx", "cbz", "cbnz") or (mn[:1] == "b" and mn[1:] in CONDS)


def reg_count(ops: str) -> int:
    """Registers in a {..} list (ranges r4-r7 counted)."""
    inner = ops[ops.find("{") + 1 : ops.find("}")]
    n = 0
    for part in filter(None, (p.strip() for p in inner.split(","))):
        a, _, b = part.partition("-")
        n += int(b[1:]) - int(a[1:]) + 1 if b and a[1:].isdigit() and b[1:].isdigit() else 1
    return n


FP_MULTI = {"vldm", "vldmia", "vldmdb", "vstm", "vstmia", "vstmdb", "vpush", "vpop"}
FP_MAC = {"vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms"}


def _fp_cycles(mn: str, ops: str) -> int:
    """Cycles of a Cortex-M4 floating-point instruction (Cortex-M4 TRM, FPU instruction timings)."""
    if mn in FP_MULTI:
        return 1 + reg_count(ops)
    if mn in ("vldr", "vstr"):
        return 2
    if mn in FP_MAC:
        return 3
    if mn in ("vdiv", "vsqrt"):
        return 14
    return 1


def it_block(mnemonic: str) -> int:
    """Instructions an IT instruction covers (it: 1, itt/ite: 2, ... up to 4); 0 for any other mnemonic."""
    if mnemonic[:2] != "it" or len(mnemonic) > 5 or any(c not in "te" for c in mnemonic[2:]):
        return 0
    return len(mnemonic) - 1


def refetches(insn: Insn, taken: bool) -> int:
    """1 when the instruction makes the core fetch from a new address (a taken branch, BL, a pc load)."""
    mn = insn.mnemonic
    if mn in ("bl", "blx") or (taken and _branch(mn)):
        return 1
    if mn in ("pop", "ldm", "ldmia"):
        return int("pc" in insn.ops[insn.ops.find("{") :])
    return int(mn in ("ldr", "mov", "add") and insn.ops.split(",")[0].strip() == "pc")


def cycles(cpu: str, insn: Insn, taken: bool, after_mem: bool) -> int:
    """Cycles of one executed instruction under the model in the module docstring (no wait states)."""
    mn, p = insn.mnemonic, 2
    if mn.startswith("v") and cpu == "cortex-m4":
        return _fp_cycles(mn, insn.ops)
    if mn in ("push", "pop", "ldm", "ldmia", "stm", "stmia", "stmdb", "ldmdb"):
        return 1 + reg_count(insn.ops) + (2 if "pc" in insn.ops else 0)
    if mn == "bl":
        return 3
    if _branch(mn):
        return (2 if cpu == "cortex-m0plus" else 1 + p) if taken else 1
    if mn.startswith(("ldr", "str")):
        if mn in ("ldrd", "strd"):
            return 3
        return 1 if (cpu == "cortex-m4" and after_mem) else 2
    if mn in ("sdiv", "udiv"):
        return 12
    return 1


def isa_violation(cpu: str, insn: Insn) -> str | None:
    """None if the instruction exists on `cpu`, else a short reason."""
    mn = insn.mnemonic
    if cpu == "cortex-m0plus":
        base = mn if mn in V6M else (mn[:-2] if mn[-2:] in CONDS and mn[:-2] == "b" else None)
        if base is None:
            return f"{mn} is not ARMv6-M"
        if insn.size == 4 and base not in V6M_WIDE:
            return f"32-bit {mn} is Thumb-2 (not ARMv6-M)"
        return None
    if mn.startswith("v") or mn in V8M_ONLY:
        return f"{mn} is not an integer ARMv7E-M instruction"
    return None


@dataclass
class Trace:
    """What one call executed: instruction count, estimated cycles, stack pointers, ISA problems."""

    @property
    def stack(self) -> int:
        """Bytes of stack the call used below its entry stack pointer."""
        return self.entry_sp - self.min_sp

    instructions: int = 0  # including instructions skipped inside an IT block
    cycles: int = 0  # including the flash wait states of the trace
    it_skipped: int = 0
    flash_reads: int = 0  # data reads from flash (each + flash_wait cycles)
    refetches: int = 0  # taken branches, BL, pc loads (each + flash_wait cycles)
    min_sp: int = 1 << 32
    entry_sp: int = 0
    violations: set[str] = field(default_factory=set)


def _it_addresses(code: dict[int, Insn], addr: int, n: int) -> list[int]:
    """The addresses of the n instructions after the IT instruction at addr."""
    out, a = [], addr + 2
    for _ in range(n):
        out.append(a)
        a += code[a].size if a in code else 2
    return out


def traced_call(
    machine, code: dict[int, Insn], symbol: str, *args, flash_wait: int = 0
) -> tuple[list, Trace]:
    """machine.call(symbol, *args) with a per-instruction hook filling a Trace (cycles, SP, ISA); with
    `flash_wait` W, every flash data read and every refetch costs W more cycles."""
    from unicorn import UC_HOOK_CODE, UC_HOOK_MEM_READ
    from unicorn import arm_const as A

    from seagen.toolchain.cortexm import RAM

    t = Trace()
    prev: list[tuple[int, int, Insn, bool] | None] = [None]  # the previous instruction, settled on the next
    pending_it: list[int] = []  # addresses still ahead in the current IT block

    def settle(next_addr: int) -> None:
        if (p := prev[0]) is not None:
            addr, size, insn, after_mem = p
            taken = next_addr != addr + size
            t.cycles += cycles(machine.cpu, insn, taken, after_mem)
            t.refetches += refetches(insn, taken)

    def skip_it(addr: int) -> None:
        """Count the IT-block instructions the core skipped before reaching addr."""
        skipped = pending_it.index(addr) if addr in pending_it else len(pending_it)
        t.it_skipped += skipped
        t.instructions += skipped
        t.cycles += skipped
        del pending_it[: skipped + 1]

    def reads(uc, access, address: int, size: int, value, _data) -> None:
        if address < RAM:
            t.flash_reads += 1

    def hook(uc, addr: int, size: int, _data) -> None:
        settle(addr)
        if pending_it:
            skip_it(addr)
        last = prev[0]
        insn = code.get(addr, Insn("?", size, ""))
        if (bad := isa_violation(machine.cpu, insn)) is not None:
            t.violations.add(bad)
        after_mem = last is not None and last[2].mnemonic.startswith(("ldr", "str"))
        prev[0] = (addr, size, insn, after_mem)
        if n_it := it_block(insn.mnemonic):
            pending_it[:] = _it_addresses(code, addr, n_it)
        if t.instructions == 0:
            t.entry_sp = uc.reg_read(A.UC_ARM_REG_SP)
        t.instructions += 1
        t.min_sp = min(t.min_sp, uc.reg_read(A.UC_ARM_REG_SP))

    handles = [machine.uc.hook_add(UC_HOOK_CODE, hook), machine.uc.hook_add(UC_HOOK_MEM_READ, reads)]
    try:
        back, _ = machine.call(symbol, *args)
    finally:
        for h in handles:
            machine.uc.hook_del(h)
        machine.uc.ctl_flush_tb()
    settle(machine.halt)
    if pending_it:
        skip_it(machine.halt)
    t.cycles += flash_wait * (t.flash_reads + t.refetches)
    return back, t
