"""The portable C on an 8-bit AVR (ATmega328P, an Arduino Uno's part; int is 16 bits there): built with
Debian's avr-gcc and avr-libc at the strict flags, run under simavr on recorded input vectors, and every
output equal to the integer reference bit for bit; flash and RAM from avr-size, cycles per NAME_infer from
the part's own 16-bit timer."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from seagen.defaults import GENERATED
from seagen.export import prepare
from seagen.reference import numpy_ref
from seagen.toolchain.equivalence import edge_inputs, random_inputs

MCU = "atmega328p"
F_CPU = 16_000_000
UNO_RAM = 2048
# the strict flags of seagen's own builds (no -O: -Os, as firmware for a small part is built)
AVR_FLAGS = ("-std=c99", "-Os", "-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Werror")
TOOLS = ("avr-gcc", "avr-size", "simavr")
MISSING = [t for t in TOOLS if shutil.which(t) is None]
pytestmark = pytest.mark.skipif(
    bool(MISSING), reason=f"{', '.join(MISSING)} not found (make installs Debian's gcc-avr avr-libc simavr)"
)
MODELS = {
    "cal_sf": "sf_calibration",
    "ctl_sf": "sf_control",
    "cal_mlp": "mlp_calibration",
    "ctl_mlp": "mlp_control",
}
FAST = ("cal_sf",)  # ~1 s; the others in the slow suite (both controller tests run in make test)


# The harnesses' Timer1 overflow count and their decimal print over UART0 (one definition for both).
UART = """ISR(TIMER1_OVF_vect) { overflows++; }

static void put(char c)
{
    while ((UCSR0A & (1u << UDRE0)) == 0u) {
    }
    UDR0 = (uint8_t)c;
}

static void put_int(int32_t v)
{
    char buf[12];
    uint8_t n = 0u;
    uint32_t u = (v < 0) ? (uint32_t)0 - (uint32_t)v : (uint32_t)v;
    if (v < 0) {
        put('-');
    }
    do {
        buf[n++] = (char)('0' + (char)(u % 10u));
        u /= 10u;
    } while (u != 0u);
    while (n > 0u) {
        put(buf[--n]);
    }
    put(' ');
}
"""


def harness(prefix: str, n_in: int, n_out: int, rows: np.ndarray) -> str:
    """main.c: NAME_infer on each row (kept in program memory), its outputs and the cycles it took (Timer1
    at the CPU clock, overflows counted; the call and the timer's reads included) printed over the UART, one
    row a line; then sleep with interrupts off, which ends simavr."""
    table = ",\n".join("    {" + ", ".join(str(int(v)) for v in row) + "}" for row in rows)
    return f"""#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h>
#include <stdint.h>
#include "{prefix}.h"

static const int16_t rows[{len(rows)}][{n_in}] PROGMEM = {{
{table}
}};
static volatile uint16_t overflows;

{UART}
int main(void)
{{
    uint16_t i;
    uint8_t j;
    UCSR0B = (uint8_t)(1u << TXEN0);
    TIMSK1 = (uint8_t)(1u << TOIE1);
    sei();
    for (i = 0u; i < {len(rows)}u; i++) {{
        int16_t x[{n_in}];
        int16_t y[{n_out}];
        uint32_t cycles;
        for (j = 0u; j < {n_in}u; j++) {{
            x[j] = (int16_t)pgm_read_word(&rows[i][j]);
        }}
        overflows = 0u;
        TCNT1 = 0u;
        TCCR1B = (uint8_t)(1u << CS10);
        {prefix}_infer(x, y);
        cycles = TCNT1; /* read while it runs: simavr reads a stopped timer as 0 */
        TCCR1B = 0u;
        cycles |= (uint32_t)overflows << 16;
        for (j = 0u; j < {n_out}u; j++) {{
            put_int(y[j]);
        }}
        put_int((int32_t)cycles);
        put('\\n');
    }}
    cli();
    sleep_cpu();
    return 0;
}}
"""


def _build(work: Path, files: dict[str, str], main_c: str) -> Path:
    """The export's C and main.c compiled and linked for the ATmega328P at the strict flags (-Werror)."""
    src = work / "src"
    src.mkdir(parents=True)
    for name, text in {**files, "main.c": main_c}.items():
        (src / name).write_text(text)
    sources = sorted(str(src / n) for n in (*files, "main.c") if n.endswith(".c"))
    elf = work / "fw.elf"
    cmd = ["avr-gcc", f"-mmcu={MCU}", f"-DF_CPU={F_CPU}UL", *AVR_FLAGS, "-ffunction-sections"]
    cmd += ["-fdata-sections", "-Wl,--gc-sections", "-I", str(src), *sources, "-o", str(elf)]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-4000:]
    return elf


def avr_size(elf: Path) -> tuple[int, int]:
    """(flash, RAM) of an image in bytes: .text + .data, .data + .bss (avr-size's Berkeley columns)."""
    out = subprocess.run(["avr-size", str(elf)], capture_output=True, text=True, check=True).stdout
    text, data, bss = (int(v) for v in out.splitlines()[1].split()[:3])
    return text + data, data + bss


def run_simavr(elf: Path) -> list[list[int]]:
    """The integers each line the firmware printed over the UART (simavr echoes UART0 on stderr)."""
    res = subprocess.run(
        ["simavr", "-m", MCU, "-f", str(F_CPU), str(elf)], capture_output=True, text=True, timeout=120
    )
    text = re.sub(r"\x1b\[[0-9;]*m", "", res.stderr)
    lines = [ln.strip().rstrip(".").strip() for ln in text.splitlines()]
    return [[int(v) for v in ln.split()] for ln in lines if re.fullmatch(r"-?\d+( -?\d+)*", ln)]


def _rows(qm) -> np.ndarray:
    """Recorded input rows: random in and around the calibrated box and across int16, and the edges."""
    return np.vstack([random_inputs(qm, 24, seed=5), edge_inputs(len(qm.inputs))]).astype(np.int64)


@pytest.mark.parametrize(
    "prefix", [pytest.param(p, marks=() if p in FAST else pytest.mark.slow) for p in sorted(MODELS)]
)
def test_portable_c_on_avr_equals_the_reference(prefix, tmp_path):
    """NAME_infer built for the ATmega328P (16-bit int) under simavr == numpy_ref on every recorded row,
    warning-free at -Wall -Wextra -Wpedantic -Wconversion -Werror; its image fits the Uno's flash, and the
    RAM it needs (const tables included: avr-gcc keeps them in RAM) is printed with the cycles."""
    ex = prepare(str(GENERATED / "models" / f"{MODELS[prefix]}.pt"), prefix=prefix)
    qm = ex.qmodel
    rows = _rows(qm)
    n_out = int(numpy_ref.infer(qm, rows[:1]).reshape(1, -1).shape[1])
    elf = _build(tmp_path, ex.files, harness(prefix, len(qm.inputs), n_out, rows))
    got = run_simavr(elf)
    assert len(got) == len(rows), got[:3]
    outs = np.array([g[:n_out] for g in got], dtype=np.int64)
    np.testing.assert_array_equal(outs, numpy_ref.infer(qm, rows).reshape(len(rows), -1))
    flash, ram = avr_size(elf)
    cycles = [g[n_out] for g in got]
    print(f"{prefix}: flash {flash} B, RAM {ram} B, {min(cycles)}-{max(cycles)} cycles per {prefix}_infer")
    assert flash <= 32 * 1024 - 512  # the Uno's flash less its boot loader


def controller_harness(prefix: str, enc: np.ndarray, pot: np.ndarray, force: np.ndarray) -> str:
    """main.c: NAME_controller_init on the first sample, then NAME_controller_tick on every recorded
    (enc, pot, desired force) sample (kept in program memory); each command (mV) and the tick's cycles
    printed over the UART, one tick a line."""
    table = ",\n".join(
        f"    {{{int(e)}, {int(p)}, {int(f)}}}" for e, p, f in zip(enc, pot, force, strict=True)
    )
    return f"""#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h>
#include <stdint.h>
#include "{prefix}_controller.h"

static const int32_t samples[{len(enc)}][3] PROGMEM = {{
{table}
}};
static volatile uint16_t overflows;
static {prefix}_controller_t ctl;

{UART}
static int32_t sample(uint16_t i, uint8_t j)
{{
    return (int32_t)pgm_read_dword(&samples[i][j]);
}}

int main(void)
{{
    uint16_t i;
    UCSR0B = (uint8_t)(1u << TXEN0);
    TIMSK1 = (uint8_t)(1u << TOIE1);
    sei();
    {prefix}_controller_init(&ctl, sample(0u, 0u), sample(0u, 1u));
    for (i = 0u; i < {len(enc)}u; i++) {{
        const int32_t e = sample(i, 0u);
        const int32_t p = sample(i, 1u);
        const int32_t f = sample(i, 2u);
        int32_t out;
        uint32_t cycles;
        overflows = 0u;
        TCNT1 = 0u;
        TCCR1B = (uint8_t)(1u << CS10);
        out = {prefix}_controller_tick(&ctl, e, p, f);
        cycles = TCNT1;
        TCCR1B = 0u;
        cycles |= (uint32_t)overflows << 16;
        put_int(out);
        put_int((int32_t)cycles);
        put('\\n');
    }}
    cli();
    sleep_cpu();
    return 0;
}}
"""


# ctl_mlp's controller fits the Uno since the tables are read from program memory (SEA_ROM, sea_fixed.h)
@pytest.mark.parametrize("prefix", ["ctl_sf", "ctl_mlp"])
def test_controller_ticks_on_avr_equal_the_twins(prefix, tmp_path):
    """NAME_controller (the --controller export: sea_control, sea_pid, the model as its predictor) on the
    ATmega328P under simavr, fed a recorded sensor walk and desired forces: every tick's command equals the
    Python twins' (controller twin + the predictor's per-tick twin)."""
    from seagen.codegen.controller import shipped_config
    from seagen.control.gentwin import StepTwin
    from seagen.runtime.control import ControlConfig, control_run, q16, sensor_walk

    ex = prepare(str(GENERATED / "models" / f"{MODELS[prefix]}.pt"), prefix=prefix, controller=True)
    enc, pot, force = sensor_walk(7, 300, steps=(60, 30))
    force[-30:] = q16(25.0)  # a force-range fault latches: the command goes to 0
    elf = _build(tmp_path, ex.files, controller_harness(prefix, enc, pot, force))
    got = run_simavr(elf)
    assert len(got) == len(enc), got[:3]
    cfg = ControlConfig(**{**shipped_config(ex.qmodel).__dict__, "predictor": StepTwin(prefix, ex.qmodel)})
    want = control_run(cfg, enc, pot, force)
    out = np.array([g[0] for g in got], dtype=np.int64)
    bad = np.flatnonzero(out != want)
    assert bad.size == 0, f"first mismatch at tick {bad[0]}: {out[bad[0]]} vs {want[bad[0]]}"
    assert np.abs(out).max() > 0 and (out[-10:] == 0).all()
    flash, ram = avr_size(elf)
    cycles = [g[1] for g in got]
    print(f"{prefix}_controller: flash {flash} B, RAM {ram} B, {min(cycles)}-{max(cycles)} cycles per tick")
    assert ram <= UNO_RAM - 256  # the static RAM leaves the stack at least 256 B of the Uno's 2 KB


def _table_mlp(weight_bits: int):
    """A small MLP with each table kind the AVR reads from program memory: int8 or int16 weights, int32
    biases, a tanh table, a GELU table (2,049 int16 entries each: 8 KB that an Uno's RAM could not hold) and
    PReLU slopes. (int64 biases: cal_mlp's last layer, test_portable_c_on_avr_equals_the_reference.)"""
    from seagen.ir import FloatLayer, FloatMLP, Signal
    from seagen.quant.mlp import quantize_mlp

    rng = np.random.default_rng(11)
    inputs = tuple(Signal(f"x{i}", "1", -100.0 * (i + 1), 80.0 * (i + 1)) for i in range(3))
    layers = (
        FloatLayer(rng.normal(0, 0.02, (6, 3)), rng.normal(0, 0.5, 6), "tanh"),
        FloatLayer(rng.normal(0, 1.0, (5, 6)), rng.normal(0, 0.5, 5), "gelu"),
        FloatLayer(
            rng.normal(0, 1.0, (16, 5)), rng.normal(0, 0.5, 16), "prelu", params=tuple(rng.uniform(-1, 1, 16))
        ),
        FloatLayer(rng.normal(0, 10.0, (1, 16)), rng.normal(0, 5.0, 1)),
    )
    return quantize_mlp(FloatMLP(inputs, Signal("y", "1", -1e6, 1e6), layers), weight_bits)


@pytest.mark.parametrize("weight_bits", [8, 16])
def test_every_table_kind_from_program_memory(weight_bits, tmp_path):
    """The portable kernels' reads of SEA_ROM tables on the AVR (pgm_read_byte/word/dword): an MLP with each
    table kind equals numpy_ref bit for bit under simavr, and its static RAM is the harness's alone."""
    from seagen.codegen.render import RUNTIME, render
    from seagen.codegen.runtime import runtime_sources

    qm = _table_mlp(weight_bits)
    files = {**render(qm, "tbl", "portable"), **runtime_sources(*RUNTIME)}
    text = files["tbl.c"]
    assert "sea_table_s16" in text and "sea_smooth_s16" in text and "sea_prelu_s16" in text
    assert f"static const int{weight_bits}_t tbl_w0" in text
    assert text.count("] SEA_ROM = {") == text.count("static const int") - 2  # all but in_lo / in_hi
    rows = _rows(qm)
    elf = _build(tmp_path, files, harness("tbl", len(qm.inputs), 1, rows))
    got = run_simavr(elf)
    assert len(got) == len(rows), got[:3]
    outs = np.array([g[:1] for g in got], dtype=np.int64)
    np.testing.assert_array_equal(outs, numpy_ref.infer(qm, rows).reshape(len(rows), -1))
    flash, ram = avr_size(elf)
    print(f"tbl (int{weight_bits} weights, tanh, GELU, PReLU): flash {flash} B, RAM {ram} B")
    assert ram < 64  # the tables (over 8 KB) stay in flash
