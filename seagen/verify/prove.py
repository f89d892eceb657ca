"""`seagen verify --prove`: Frama-C Eva proves an export's C free of run-time errors on its stated domain."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from seagen.codegen.manifest import Manifest
from seagen.errors import UserError
from seagen.verify.drift import manifests_in
from seagen.verify.result import Verdict

FRAMA_C = "frama-c"
TICKS = 24  # ticks from reset: two pot-average blocks (10 at 100 Hz), every predictor phase, and more
TIMEOUT_S = 600

# The data model of the core the C runs on: LP64 for the portable host build, ILP32 for the Cortex-M cores
# (int and long 32-bit, long long 64-bit, as arm-none-eabi-gcc's AAPCS).
MACHDEP = {"portable": "x86_64", "cortex-m4": "gcc_x86_32", "cortex-m0plus": "gcc_x86_32"}

# The macros arm-none-eabi-gcc predefines for the core that select kernel code in sea_dsp.h and
# sea_fixed_ctrl.c (-mcpu=cortex-m4 / cortex-m0plus): the C that target compiles is the C analysed.
TARGET_MACROS = {
    "portable": (),
    "cortex-m4": (
        "__ARM_ARCH_7EM__",
        "__ARM_FEATURE_SIMD32",
        "__ARM_FEATURE_SAT",
        "__ARM_FEATURE_DSP",
        "__ARM_FEATURE_IDIV",
    ),
    "cortex-m0plus": ("__ARM_ARCH_6M__",),
}

# Eva's settings, recorded in every report: precision level 2, loops of up to 64 iterations unrolled (the
# kernels' neuron and input loops), the harness's tick loop unrolled by its annotation; the default alarms
# (signed overflow, invalid memory access, uninitialised read, division by zero, invalid shift, pointer
# comparison) are all kept. The same on every target: the Cortex-M4 kernels' packed int16 pairs are, for
# Frama-C only, the struct of their two halves (sea_int16x2 of sea_dsp.h under __FRAMAC__), so the interval
# domain keeps each half's range with no bitwise domain or inlining (docs/prove.md).
EVA_OPTIONS = ("-eva", "-eva-precision", "2", "-eva-auto-loop-unroll", "64")

_ALARM = re.compile(r"^\[eva:alarm\] ([^:\s]+):(\d+): Warning:\s*(.*)$")


@dataclass(frozen=True)
class Alarm:
    """One Eva alarm: where, and the property it could not prove."""

    file: str
    line: int
    prop: str

    def text(self) -> str:
        """file:line: property."""
        return f"{self.file}:{self.line}: {self.prop}"


def frama_c_version(exe: str = FRAMA_C) -> str | None:
    """`frama-c -version` (e.g. '25.0-beta (Manganese)'), or None when it is not installed."""
    if shutil.which(exe) is None:
        return None
    out = subprocess.run([exe, "-version"], capture_output=True, text=True, timeout=60)
    return out.stdout.strip() or None


def parse_alarms(log: str) -> list[Alarm]:
    """Every `[eva:alarm]` of a Frama-C log (run-time errors and callee preconditions not proven), each with
    its property on one line; duplicates (the same property at the same line) once."""
    out: list[Alarm] = []
    lines = log.splitlines()
    for k, line in enumerate(lines):
        m = _ALARM.match(line)
        if not m:
            continue
        body = [m.group(3)]
        for nxt in lines[k + 1 :]:
            if nxt.startswith("["):
                break
            body.append(nxt.strip())
        prop = " ".join(s for s in body if s)
        if "assert" in prop:  # the asserted property, without Eva's note on its temporaries
            prop = prop[: prop.index(";") + 1] if ";" in prop else prop
        a = Alarm(Path(m.group(1)).name, int(m.group(2)), prop)
        if a not in out:
            out.append(a)
    return out


def harness_files(man: Manifest, root: Path, ticks: int = TICKS) -> dict[str, str]:
    """The Eva harness for the export `man` in `root` (one entry point per public function), and for a
    Cortex-M4 export the ACLE intrinsics' contracts (arm_acle.h)."""
    from seagen.codegen.render import environment

    p = man.prefix
    head = (root / f"{p}.h").read_text(errors="replace")
    step = re.search(rf"\bint16_t {re.escape(p)}_step\(([^)]*)\);", head)
    externals = [a for a in step.group(1).split(",")[3:]] if step else []
    controller = bool(man.data["options"].get("controller"))
    ctl_head = root / f"{p}_controller.h"
    shared = controller and ctl_head.is_file() and f"{p}_controller_init_shared(" in ctl_head.read_text()
    env = environment()
    ctx = {
        "P": p,
        "PU": p.upper(),
        "step": step is not None,
        "externals": externals,
        "controller": controller,
        "shared": shared,
        "ticks": ticks,
    }
    out = {f"{p}_eva_harness.c": env.get_template("eva_harness.c.j2").render(ctx)}
    if man.data["options"].get("target") == "cortex-m4":
        out["arm_acle.h"] = env.get_template("eva_arm_acle.h.j2").render({})
    return out


def entries(man: Manifest, harness: str) -> list[tuple[str, str]]:
    """(harness entry point, the function it proves) for each public function the harness drives."""
    p = man.prefix
    out = [("prove_infer", f"{p}_infer")]
    if "void prove_step(" in harness:
        out.append(("prove_step", f"{p}_step ({TICKS} ticks from {p}_reset)"))
    if "void prove_controller(" in harness:
        out.append(("prove_controller", f"{p}_controller_tick ({TICKS} ticks from {p}_controller_init)"))
    if "void prove_controller_shared(" in harness:
        what = f"{p}_controller_tick on a shared pipeline ({TICKS} ticks from {p}_controller_init_shared)"
        out.append(("prove_controller_shared", what))
    return out


def command(target: str, sources: list[str], entry: str) -> list[str]:
    """The frama-c command line seagen runs for one entry point of an export for `target`."""
    cpp = ["-I."] + [f"-D{m}" for m in TARGET_MACROS[target]]
    opts = list(EVA_OPTIONS)
    return [FRAMA_C, *opts, "-machdep", MACHDEP[target], f"-cpp-extra-args={' '.join(cpp)}"] + [
        *sources,
        "-main",
        entry,
    ]


def run_entry(work: Path, target: str, sources: list[str], entry: str) -> tuple[list[Alarm], str]:
    """Eva on one entry point in `work`: its alarms, and '' or the reason it did not complete."""
    try:
        out = subprocess.run(
            command(target, sources, entry),
            cwd=work,
            env={**os.environ, "PWD": str(work)},  # frama-c resolves relative file names against $PWD
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        return [], f"frama-c did not finish in {TIMEOUT_S} s"
    log = out.stdout + out.stderr
    if out.returncode != 0:
        lines = log.splitlines()
        k = next((i for i, ln in enumerate(lines) if "error" in ln.lower()), None)
        err = " ".join(s.strip() for s in lines[k : k + 2]) if k is not None else log.strip()[-200:]
        return [], f"frama-c failed (exit {out.returncode}): {err}"
    alarms = parse_alarms(log)
    if not alarms and "NON TERMINATING FUNCTION" in log:
        return [], "the analysis found no path through the function (an invalid property stopped every path)"
    if not alarms and (open_props := unproven(log)):
        return [], f"Eva's summary leaves properties unproven: {open_props}"
    return alarms, ""


_STATUS = re.compile(
    r"^\s*(Assertions|Preconditions|Postconditions)\s+\d+ valid\s+(\d+) unknown\s+(\d+) invalid", re.M
)


def unproven(log: str) -> str:
    """The summary's unknown or invalid assertions, preconditions and postconditions ('' when none): a
    second reading of the same verdict, so that a status Eva reports without an alarm line is not missed."""
    out = []
    for m in _STATUS.finditer(log):
        if int(m.group(2)) or int(m.group(3)):
            out.append(f"{m.group(1).lower()} {m.group(2)} unknown, {m.group(3)} invalid")
    return "; ".join(out)


def settings_line(target: str, version: str) -> str:
    """The tool, its version and the settings of a run, for the report."""
    macros = " ".join(f"-D{m}" for m in TARGET_MACROS[target])
    opts = " ".join(EVA_OPTIONS)
    return f"Frama-C {version}, {opts} -machdep {MACHDEP[target]}" + (f", {macros}" if macros else "")


def check_prove(v: Verdict, root: Path, man: Manifest) -> None:
    """Add one check per public function of the export in `root`: Eva over its contract's domain, passed
    with 0 alarms (every callee's precondition proven included); each alarm named by file:line and property.
    Frama-C missing: UserError (exit 2)."""
    version = frama_c_version()
    if version is None:
        raise UserError("frama-c not found: --prove needs Frama-C Eva (Debian: apt-get install frama-c-base)")
    target = man.data["options"].get("target", "portable")
    if target not in MACHDEP:
        raise UserError(f"{man.path}: target {target!r} is not one --prove knows ({', '.join(MACHDEP)})")
    names = [n for n in man.files if n.endswith((".c", ".h")) and "/" not in n]
    missing = [n for n in names if not (root / n).is_file()]
    if missing:  # the drift checks fail on it; the proof is not run on an incomplete export
        why = f"not run: {missing[0]} is missing"
        v.skip(f"{man.prefix}: Frama-C Eva, 0 alarms over its contracts' domain", why)
        return
    harness = harness_files(man, root)
    info = settings_line(target, version)
    files = {n: (root / n).read_text(errors="replace") for n in names} | harness
    hname = f"{man.prefix}_eva_harness.c"
    todo = entries(man, harness[hname])
    results = prove_sources(files, target, [e for e, _what in todo])
    for entry, what in todo:
        alarms, failed = results[entry]
        name = f"{what}: Frama-C Eva, 0 alarms over its contract's domain"
        if failed:
            v.add(name, failed, kind="prove")
        elif alarms:
            v.add(name, f"{len(alarms)} alarm(s): " + "; ".join(a.text() for a in alarms), kind="prove")
        else:
            v.add(name, None, info, kind="prove")


def prove_sources(
    files: dict[str, str], target: str, entry_points: list[str]
) -> dict[str, tuple[list[Alarm], str]]:
    """Eva on C sources given by name (every .c analysed together, the .h beside them) for `target`, once
    per entry point: its alarms and '' or why it did not complete."""
    with tempfile.TemporaryDirectory(prefix="seagen-prove-") as tmp:
        work = Path(tmp)
        for n, text in files.items():
            (work / n).write_text(text)
        sources = sorted(n for n in files if n.endswith(".c"))
        return {e: run_entry(work, target, sources, e) for e in entry_points}


def prove_folder(folder: str | Path, prefix: str | None = None) -> Verdict:
    """Only the proof (no model needed): the export of `folder` named `prefix` (the only one when None)."""
    root = Path(folder)
    if not root.is_dir():
        raise UserError(f"{root}: not a folder")
    found = [m for m in manifests_in(root) if prefix is None or m.prefix == prefix]
    if len(found) != 1:
        what = "no export" if not found else "several exports (name one with --prefix)"
        raise UserError(f"{root}: {what}{f' named {prefix}' if prefix else ''}")
    man = found[0]
    v = Verdict(man.prefix, str(root), command="verify --prove")
    check_prove(v, root, man)
    return v
