"""The processor-in-the-loop firmware of an export: the fw/ sources, the export's C and pil_model.h, linked
for one QEMU board (start-up with .data/.bss, the board's UART driver, the frame loop of fw/pil_main.c)."""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from seagen.codegen.cfmt import assert_valid_prefix
from seagen.errors import UserError
from seagen.toolchain import cortexm as cm
from seagen.toolchain.host import CACHE, STRICT_CFLAGS, _key, compile_objects

FW = Path(__file__).resolve().parent / "fw"
COMMON = ("pil_board.h", "pil_common.c", "pil_main.c")
NO_PREDICTOR = "(a)->config.predictor = 0"


@dataclass(frozen=True)
class Board:
    """A QEMU machine for one core: its UART driver (fw/), the UART's interrupt, memory sizes, SysTick."""

    machine: str
    cpu: str
    driver: str
    uart_irq: int
    flash: int
    ram: int


BOARDS = {
    "cortex-m4": Board("mps2-an386", "cortex-m4", "pil_mps2.c", 0, 4 << 20, 256 << 10),
    "cortex-m0plus": Board("microbit", "cortex-m0plus", "pil_nrf51.c", 2, 256 << 10, 16 << 10),
}


def board(core: str) -> Board:
    """The board emulating `core` (one of BOARDS)."""
    if core not in BOARDS:
        raise UserError(f"--core must be one of {', '.join(BOARDS)}, not {core!r}")
    return BOARDS[core]


def model_header(ctl: str, cal: str | None, n_max: int, onboard: bool = True) -> str:
    """pil_model.h: which controller (NAME_controller of an export) and calibration model the loop runs;
    `onboard` False leaves the controller without its predictor (the setpoint comes over the link)."""
    ctl = assert_valid_prefix(ctl)
    lines = [
        "/* pil_model.h -- written by seagen pil: the models of this firmware. */",
        "#ifndef PIL_MODEL_H",
        "#define PIL_MODEL_H",
        '#include "sea_control.h"',
        f'#include "{ctl}_controller.h"',
        f"#define PIL_N_MAX {int(n_max)}u",
        f"typedef {ctl}_controller_t pil_ctl_t;",
        f"#define PIL_CTL_INIT(a, e, p) {ctl}_controller_init((a), (e), (p))"
        if onboard
        else f"#define PIL_CTL_INIT(a, e, p) ({ctl}_controller_init((a), (e), (p)), {NO_PREDICTOR})",
        f"#define PIL_CTL_TICK(a, e, p, f) {ctl}_controller_tick((a), (e), (p), (f))",
        "#define PIL_CTL_STATE(a) (&(a)->state)",
        "#define PIL_CTL_STATE_RW(a) (&(a)->state)",
    ]
    if cal is None:
        lines.append("#define PIL_HAS_CAL 0")
    else:
        cal = assert_valid_prefix(cal)
        lines += [
            f'#include "{cal}.h"',
            "#define PIL_HAS_CAL 1",
            f"typedef {cal}_state_t pil_cal_t;",
            f"#define PIL_CAL_RESET(s) {cal}_reset(s)",
            f"#define PIL_CAL_STEP(s, e, p) {cal}_step((s), (e), (p))",
        ]
    return "\n".join([*lines, "#endif /* PIL_MODEL_H */", ""])


def fw_sources(b: Board) -> dict[str, str]:
    """The firmware's own C (start-up, frame loop, the board's UART driver)."""
    return {f: (FW / f).read_text() for f in (*COMMON, b.driver)}


def build_firmware(files: dict[str, str], model_h: str, core: str) -> Path:
    """Compile the export's `files` with the firmware for the board of `core`; the ELF (cached by content)."""
    if msg := cm.toolchain_missing():
        raise UserError(msg)
    b = board(core)
    sources = {**files, **fw_sources(b), "pil_model.h": model_h}
    flags = (*cm.cpu_flags(b.cpu), f"-DPIL_UART_IRQ={b.uart_irq}")
    script = (FW / "pil.ld").read_text().replace("@FLASH_LEN@", str(b.flash)).replace("@RAM_LEN@", str(b.ram))
    out = CACHE / f"pil_{b.machine}_{_key(sorted(sources.items()), flags, script, STRICT_CFLAGS)}.elf"
    if out.exists():
        return out
    CACHE.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(dir=CACHE, prefix=".pil."))
    try:
        c_files = dict(sorted(sources.items()))
        objs = compile_objects(c_files, work, (*flags, *cm.FREESTANDING), cc=cm.GCC, pic=False)
        (work / "link.ld").write_text(script)
        elf = cm.link(work, objs, flags, (), "pil")
        os.replace(elf, out)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return out
