"""The processor-in-the-loop firmware of an export: the fw/ sources, the export's C and pil_model.h, linked
for one QEMU board (start-up with .data/.bss, the board's UART driver, the frame loop of fw/pil_main.c); built
by seagen's own compile line, or by CMake from the export folder as a package (cmake_firmware)."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from seagen.cnames import assert_valid_prefix
from seagen.codegen.runtime import runtime_sources
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


def model_header(ctl: str, cal: str | None, n_max: int, onboard: bool = True, shared: bool = True) -> str:
    """pil_model.h: which controller (NAME_controller of an export) and calibration model the loop runs;
    `onboard` False leaves the controller without its predictor (the setpoint comes over the link); `shared`
    (with a calibration model of the same actuator) runs one feature pipeline per actuator for both models
    (NAME_step_features, NAME_controller_init_shared), else each model its own."""
    ctl = assert_valid_prefix(ctl)
    shared = shared and cal is not None
    init = (
        f"{ctl}_controller_init_shared((a), (e), (p), (f))"
        if shared
        else f"{ctl}_controller_init((a), (e), (p))"
    )
    lines = [
        "/* pil_model.h -- written by seagen pil: the models of this firmware. */",
        "#ifndef PIL_MODEL_H",
        "#define PIL_MODEL_H",
        '#include "sea_control_extra.h"',
        f'#include "{ctl}_controller.h"',
        f"#define PIL_N_MAX {int(n_max)}u",
        f"typedef {ctl}_controller_t pil_ctl_t;",
        f"#define PIL_CTL_INIT(a, e, p, f) {init}"
        if onboard
        else f"#define PIL_CTL_INIT(a, e, p, f) ({init}, {NO_PREDICTOR})",
        f"#define PIL_CTL_TICK(a, e, p, f) {ctl}_controller_tick((a), (e), (p), (f))",
        "#define PIL_CTL_STATE(a) (&(a)->state)",
        "#define PIL_CTL_STATE_RW(a) (&(a)->state)",
    ]
    lines.append(f"#define PIL_SHARED {int(shared)}")
    if cal is None:
        lines.append("#define PIL_HAS_CAL 0")
    else:
        cal = assert_valid_prefix(cal)
        step = (
            f"(sea_features_step((s), {cal.upper()}_ACT, (e), (p), (f)), {cal}_step_features(f))"
            if shared
            else f"{cal}_step((s), (e), (p))"
        )
        lines += [
            f'#include "{cal}.h"',
            "#define PIL_HAS_CAL 1",
            f"typedef {cal}_state_t pil_cal_t;",
            f"#define PIL_CAL_RESET(s) {cal}_reset(s)",
            f"#define PIL_CAL_STEP(s, f, e, p) {step}",
        ]
        if shared:
            lines += [
                f"#if {cal.upper()}_ACT_KEY != {ctl.upper()}_ACT_KEY",
                f'#error "{cal} and {ctl} were exported for different actuators"',
                "#endif",
            ]
    return "\n".join([*lines, "#endif /* PIL_MODEL_H */", ""])


def fw_sources(b: Board) -> dict[str, str]:
    """The firmware's own C (start-up, frame loop, the board's UART driver) and the runtime's
    sea_control_extra (the setpoint over the link), which an export does not ship."""
    own = {f: (FW / f).read_text() for f in (*COMMON, b.driver)}
    return {**runtime_sources("sea_control_extra.h", "sea_control_extra.c"), **own}


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


def cmake_project(folder: Path, package: str, b: Board) -> str:
    """The firmware's CMakeLists.txt: the export folder added as a package and linked as seagen::PACKAGE
    (three lines), with the fw/ sources and the board's memory map."""
    own = " ".join(sorted(n for n in fw_sources(b) if n.endswith(".c")))
    return "\n".join(
        [
            "cmake_minimum_required(VERSION 3.13)",
            "project(pil C)",
            f'add_subdirectory("{folder.resolve().as_posix()}" seagen)',
            f"add_executable(pil {own})",
            f"target_link_libraries(pil PRIVATE seagen::{package} gcc)",
            "target_include_directories(pil PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})",
            f"target_compile_definitions(pil PRIVATE PIL_UART_IRQ={b.uart_irq})",
            "target_link_options(pil PRIVATE -nostdlib -T${CMAKE_CURRENT_SOURCE_DIR}/pil.ld)",
            "",
        ]
    )


def cmake_firmware(folder: Path, model_h: str, core: str, package: str) -> Path:
    """The firmware for the board of `core` built by CMake from an export folder: the project of
    cmake_project cross-built with the folder's own toolchain file (arm-none-eabi.cmake, SEAGEN_CPU) at
    seagen's strict flags; the ELF (cached by the folder's files and the project)."""
    if msg := cm.toolchain_missing():
        raise UserError(msg)
    cmake = shutil.which("cmake")
    if cmake is None:
        raise UserError("cmake not found (Debian: apt-get install cmake)")
    b = board(core)
    script = (FW / "pil.ld").read_text().replace("@FLASH_LEN@", str(b.flash)).replace("@RAM_LEN@", str(b.ram))
    project = {**fw_sources(b), "pil_model.h": model_h, "pil.ld": script}
    project["CMakeLists.txt"] = cmake_project(folder, package, b)
    exported = sorted(
        (p.relative_to(folder).as_posix(), p.read_bytes()) for p in folder.rglob("*") if p.is_file()
    )
    out = CACHE / f"pil_cmake_{b.machine}_{_key(sorted(project.items()), exported, STRICT_CFLAGS)}.elf"
    if out.exists():
        return out
    CACHE.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(dir=CACHE, prefix=".pilcmake."))
    try:
        for name, text in project.items():
            (work / name).write_text(text)
        flags = " ".join(f for f in (*STRICT_CFLAGS, "-ffreestanding") if not f.startswith("-std"))
        gen = ["-G", "Ninja"] if shutil.which("ninja") else []
        cfg = [cmake, "-S", str(work), "-B", str(work / "build"), *gen, f"-DCMAKE_C_FLAGS={flags}"]
        cfg += [f"-DCMAKE_TOOLCHAIN_FILE={folder.resolve() / 'arm-none-eabi.cmake'}", f"-DSEAGEN_CPU={b.cpu}"]
        for cmd in (cfg, [cmake, "--build", str(work / "build")]):
            res = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
            if res.returncode != 0:
                raise UserError(
                    f"{folder}: the CMake firmware build failed: {(res.stdout + res.stderr)[-2000:]}"
                )
        os.replace(work / "build" / "pil", out)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return out
