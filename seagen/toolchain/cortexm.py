"""Cross-compile generated C for a Cortex-M core (arm-none-eabi-gcc) and run it, bit for bit, in unicorn.

The firmware image is the model's own files plus the batch driver every target uses (templates/driver.c.j2);
it is linked at flash 0x0 and called directly, with no start-up code: the loader does its one job, copying
.data (the M0+ kernel's weight tables) to RAM at 0x20000000; no .bss (the generated C has no other static
data). Arguments in r0-r3 and on the stack, inputs and outputs in RAM after .data, the return
address a halt loop after the image. Instructions are counted per executed instruction (UC_HOOK_CODE) of one
NAME_infer call, its return included.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from seagen.errors import UserError
from seagen.ir import QModel
from seagen.toolchain.host import CACHE, STRICT_CFLAGS, _key, compile_objects
from seagen.toolchain.target import Target, driver_sources, entry_points

GCC = "arm-none-eabi-gcc"
TOOLS = (GCC, "arm-none-eabi-objcopy", "arm-none-eabi-size", "arm-none-eabi-nm")
CPUS = ("cortex-m4", "cortex-m0plus")
FREESTANDING = ("-ffreestanding", "-nostdlib", "-ffunction-sections", "-fdata-sections")
FLASH, RAM = 0x00000000, 0x20000000
STACK_BYTES = 64 * 1024
LINKER_SCRIPT = """\
MEMORY
{
    FLASH (rx) : ORIGIN = 0x00000000, LENGTH = 1M
    RAM (rwx) : ORIGIN = 0x20000000, LENGTH = 256K
}
SECTIONS
{
    .text : { *(.text*) *(.rodata*) } > FLASH
    .ARM.exidx : { *(.ARM.exidx*) } > FLASH
    .data : { *(.data*) } > RAM AT > FLASH
    .bss : { *(.bss*) *(COMMON) } > RAM
}
"""


def toolchain_missing() -> str | None:
    """None if the Arm cross toolchain is on PATH, else a message saying how to install it."""
    missing = [t for t in TOOLS if shutil.which(t) is None]
    if not missing:
        return None
    return (
        f"{', '.join(missing)} not found: install the Arm cross compiler "
        "(Debian: apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi, or `make toolchain` as root)"
    )


def cpu_flags(cpu: str) -> tuple[str, ...]:
    """-mthumb -mcpu=... for one of CPUS."""
    if cpu not in CPUS:
        raise UserError(f"cpu must be one of {', '.join(CPUS)}, not {cpu!r}")
    return ("-mthumb", f"-mcpu={cpu}")


@dataclass(frozen=True)
class Image:
    """A linked firmware image: flat binary at FLASH, symbol addresses, and per-object section sizes."""

    binary: bytes
    symbols: dict[str, int]
    objects: dict[str, dict[str, int]]  # source file -> {section: bytes}
    image_sections: dict[str, int]
    data: bytes = b""  # .data, copied to RAM (its address) as start-up code would

    def flash_bytes(self, files: list[str] | None = None) -> int:
        """.text + .rodata + .data of the objects of `files` (all by default), per arm-none-eabi-size."""
        names = self.objects if files is None else files
        return sum(
            size
            for f in names
            for sec, size in self.objects[f].items()
            if sec.startswith((".text", ".rodata", ".data"))
        )


def _run(cmd: list[str], what: str) -> str:
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise UserError(f"{what} failed:\n{' '.join(cmd)}\n{res.stderr}")
    return res.stdout


def _sections(path: Path) -> dict[str, int]:
    """{section: size} of an object or ELF file (arm-none-eabi-size -A)."""
    out: dict[str, int] = {}
    for line in _run(["arm-none-eabi-size", "-A", str(path)], "size").splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            out[parts[0]] = out.get(parts[0], 0) + int(parts[1])
    return out


def _symbols(elf: Path) -> dict[str, int]:
    """Global and local function/data symbols of the ELF with their addresses."""
    out = {}
    for line in _run(["arm-none-eabi-nm", str(elf)], "nm").splitlines():
        parts = line.split()
        if len(parts) == 3:
            out[parts[2]] = int(parts[0], 16)
    return out


def _compile_link(
    work: Path, sources: dict[str, str], flags: tuple[str, ...], roots: tuple[str, ...]
) -> Path:
    """Compile every .c with the strict flags for the target and link them (+ libgcc) into work/fw.elf."""
    ordered = dict(sorted(sources.items()))
    objs = compile_objects(ordered, work, (*flags, *FREESTANDING), cc=GCC, pic=False)
    (work / "link.ld").write_text(LINKER_SCRIPT)
    return link(work, objs, flags, roots)


def link(
    work: Path,
    objs: list[Path],
    flags: tuple[str, ...],
    roots: tuple[str, ...],
    name: str = "fw",
    libs: tuple[str, ...] = ("-lgcc",),
) -> Path:
    """Link objs with work/link.ld and --gc-sections keeping the functions `roots` (+ libs): NAME.elf."""
    elf = work / f"{name}.elf"
    undef = [f"-Wl,--undefined={r}" for r in roots]
    cmd = [GCC, *flags, "-nostdlib", "-T", str(work / "link.ld"), "-Wl,--gc-sections", *undef]
    _run([*cmd, *map(str, objs), *libs, "-o", str(elf)], f"linking the Cortex-M image {name}")
    return elf


def flat_section(elf: Path, section: str = ".text") -> bytes:
    """One section of a linked image as flat bytes (objcopy -O binary)."""
    out = elf.with_name(f"{elf.stem}{section.replace('.', '_')}.bin")
    _run(["arm-none-eabi-objcopy", "-O", "binary", "-j", section, str(elf), str(out)], "objcopy")
    return out.read_bytes()


def no_startup_sections(elf: Path) -> dict[str, int]:
    """The image's section sizes; an image with .bss is refused (.data is copied to RAM by the loader)."""
    sections = _sections(elf)
    if sections.get(".bss", 0):
        raise UserError(f"{elf.name} has .bss ({sections}): the emulator runs no start-up code")
    return sections


def data_section(elf: Path, sections: dict[str, int]) -> bytes:
    """The initial contents of .data (empty without one), which the loader copies to RAM at 0x20000000."""
    return flat_section(elf, ".data") if sections.get(".data", 0) else b""


def _describe(work: Path, elf: Path, sources: dict[str, str]) -> dict:
    """The cached description of a linked image (symbols and sizes); refuses images needing start-up code."""
    image_sections = no_startup_sections(elf)
    (work / "fw.bin").write_bytes(flat_section(elf))
    (work / "data.bin").write_bytes(data_section(elf, image_sections))
    objects = {f: _sections(work / (Path(f).stem + ".o")) for f in sorted(sources) if f.endswith(".c")}
    return {"symbols": _symbols(elf), "objects": objects, "image_sections": image_sections}


def build_image(
    sources: dict[str, str], cpu: str, roots: tuple[str, ...], extra: tuple[str, ...] = (), name: str = "fw"
) -> Image:
    """Cross-compile and link `sources` for `cpu` keeping the functions `roots`; cached by content hash."""
    if msg := toolchain_missing():
        raise UserError(msg)
    flags = (*cpu_flags(cpu), *extra)
    key = _key(sorted(sources.items()), flags, roots, STRICT_CFLAGS, FREESTANDING, LINKER_SCRIPT)
    out = CACHE / f"cortexm_{name}_{key}"
    if not (out / "image.json").exists():
        CACHE.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(dir=CACHE, prefix=".cortexm."))
        desc = _describe(work, _compile_link(work, sources, flags, roots), sources)
        (work / "image.json").write_text(json.dumps(desc))
        try:
            os.replace(work, out)
        except OSError:  # built concurrently by another process: keep theirs
            shutil.rmtree(work, ignore_errors=True)
    desc = json.loads((out / "image.json").read_text())
    data = (out / "data.bin").read_bytes() if (out / "data.bin").exists() else b""  # cached before .data
    sections = desc["image_sections"]
    return Image((out / "fw.bin").read_bytes(), desc["symbols"], desc["objects"], sections, data)


PAGE_BITS = 12  # unicorn maps memory in 4 KiB pages


def _page(n: int) -> int:
    """n bytes rounded up to whole emulator pages (at least one)."""
    page = 1 << PAGE_BITS
    return max(page, (n + page - 1) & ~(page - 1))


class Machine:
    """One emulated Cortex-M core (unicorn) with an image in flash; calls its functions on RAM buffers."""

    def __init__(self, image: Image, cpu: str) -> None:
        try:
            from unicorn import (
                UC_ARCH_ARM,
                UC_MODE_THUMB,
                UC_PROT_ALL,
                UC_PROT_EXEC,
                UC_PROT_READ,
                Uc,
            )
            from unicorn import arm_const as A
        except ImportError as e:
            raise UserError("the Cortex-M emulator needs unicorn 2: pip install 'unicorn>=2'") from e

        self.image, self.cpu = image, cpu
        # UC_MODE_MCLASS would make unicorn 2.1 ignore the model and emulate a Cortex-M33; plain Thumb mode
        # with the model set gives the real core (the M0 faults on Thumb-2). unicorn has no M0+: the M0 has
        # the same ARMv6-M instruction set.
        self.uc = Uc(UC_ARCH_ARM, UC_MODE_THUMB)
        self.uc.ctl_set_cpu_model(A.UC_CPU_ARM_CORTEX_M4 if cpu == "cortex-m4" else A.UC_CPU_ARM_CORTEX_M0)
        self.halt = (len(image.binary) + 3) & ~3
        self.uc.mem_map(FLASH, _page(self.halt + 4), UC_PROT_READ | UC_PROT_EXEC)
        pad = b"\x00" * (self.halt - len(image.binary))
        self.uc.mem_write(FLASH, image.binary + pad + b"\xfe\xe7\xfe\xe7")  # b . (halt loop)
        self.ram = 0
        self._prot_all = UC_PROT_ALL
        self._grow(256 * 1024)

    def _grow(self, need: int) -> None:
        """Map at least `need` bytes of RAM at 0x20000000 (re-mapped larger on demand)."""
        if need <= self.ram:
            return
        if self.ram:
            self.uc.mem_unmap(RAM, self.ram)
        self.ram = _page(need)
        self.uc.mem_map(RAM, self.ram, self._prot_all)
        self.uc.mem_write(RAM, self.image.data)

    def _layout(self, args: tuple[int | np.ndarray, ...]) -> tuple[list[int], list[tuple[int, np.ndarray]]]:
        """Copy array arguments into RAM; return the argument words and (address, array) of each buffer."""
        sizes = [a.nbytes if isinstance(a, np.ndarray) else 0 for a in args]
        first = (len(self.image.data) + 7) & ~7  # the arguments follow .data
        self._grow(first + sum((s + 7) & ~7 for s in sizes) + STACK_BYTES)
        words, bufs, at = [], [], RAM + first
        for a in args:
            if isinstance(a, np.ndarray):
                a = np.ascontiguousarray(a)
                self.uc.mem_write(at, a.tobytes())
                words.append(at)
                bufs.append((at, a))
                at += (a.nbytes + 7) & ~7
            else:
                words.append(int(a) & 0xFFFFFFFF)
        return words, bufs

    def _set_args(self, words: list[int]) -> None:
        """AAPCS: r0-r3, the rest on the stack; lr = the halt loop."""
        from unicorn import arm_const as A

        sp = (RAM + self.ram - 4 * max(0, len(words) - 4)) & ~7
        for i, w in enumerate(words[4:]):
            self.uc.mem_write(sp + 4 * i, int(w).to_bytes(4, "little"))
        regs = (A.UC_ARM_REG_R0, A.UC_ARM_REG_R1, A.UC_ARM_REG_R2, A.UC_ARM_REG_R3)
        for reg, w in zip(regs, words, strict=False):
            self.uc.reg_write(reg, w)
        self.uc.reg_write(A.UC_ARM_REG_SP, sp)
        self.uc.reg_write(A.UC_ARM_REG_LR, self.halt | 1)

    def _hook(self) -> tuple[list[int], int]:
        """Install a per-instruction counter (UC_HOOK_CODE, as the DESIGN.md section 5 numbers)."""
        from unicorn import UC_HOOK_CODE

        def tick(uc: object, addr: int, size: int, c: list[int]) -> None:
            c[0] += 1

        count = [0]
        return count, self.uc.hook_add(UC_HOOK_CODE, tick, count)

    def call(self, symbol: str, *args: int | np.ndarray, count: bool = False) -> tuple[list[np.ndarray], int]:
        """Call `symbol(args)` (arrays by pointer); return the arrays read back and the instruction count."""
        from unicorn import arm_const as A

        entry = self.image.symbols[symbol]
        words, bufs = self._layout(args)
        self._set_args(words)
        counter, hook = self._hook() if count else ([0], None)
        # code translated before a hook was added would not call it
        self.uc.ctl_flush_tb()  # type: ignore[attr-defined]
        try:
            self.uc.emu_start(entry | 1, self.halt, timeout=600_000_000)
        finally:
            if hook is not None:
                self.uc.hook_del(hook)
                self.uc.ctl_flush_tb()  # type: ignore[attr-defined]
        pc = self.uc.reg_read(A.UC_ARM_REG_PC)
        if pc != self.halt:
            raise RuntimeError(f"{symbol} on {self.cpu} stopped at {pc:#x}, not at the return address")
        back = [np.frombuffer(self.uc.mem_read(at, a.nbytes), a.dtype).reshape(a.shape) for at, a in bufs]
        return back, counter[0]


class CortexM(Target):
    """A generated model cross-compiled for a Cortex-M core and run on the emulator."""

    def __init__(self, files: dict[str, str], prefix: str, qm: QModel, cpu: str = "cortex-m4") -> None:
        super().__init__(prefix, qm)
        self.cpu = cpu
        self.model_files = sorted(files)
        sources = {**files, **driver_sources(prefix, qm)}
        roots = (f"{prefix}_infer", *entry_points(prefix, qm))
        self.image = build_image(sources, cpu, roots, name=prefix)
        self.machine = Machine(self.image, cpu)

    @property
    def flash_bytes(self) -> int:
        """.text + .rodata of the model's objects (NAME.c and the runtime it uses; not the driver)."""
        return self.image.flash_bytes([f for f in self.model_files if f.endswith(".c")])

    def _call(self, fn: str, *args: int | np.ndarray) -> list[np.ndarray]:
        """NAME_{fn} on the emulated core; arrays are copied into RAM and read back."""
        return self.machine.call(f"{self.prefix}_{fn}", *args)[0]

    def instructions(self, x: np.ndarray) -> np.ndarray:
        """Executed instructions of each NAME_infer(row, out) call over the rows of x (return included)."""
        x = np.ascontiguousarray(np.atleast_2d(x), dtype=np.int16)
        infer, out = f"{self.prefix}_infer", np.zeros(1, np.int16)
        return np.array([self.machine.call(infer, row, out, count=True)[1] for row in x])
