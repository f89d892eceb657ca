"""MISRA C:2012 check of exported C with cppcheck's addon: a finding outside seagen's deviation record fails.

The suppression list comes from seagen's own record (seagen/verify/misra_record.py, docs/misra.md), located
in the checked files by each deviation's code pattern; suppressions written in the checked files are never
honoured (no --inline-suppr) and a `cppcheck-suppress` comment is itself a finding."""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from seagen.verify.misra_record import RECORD, Deviation
from seagen.verify.result import Verdict

VERSION = "2.10"  # the cppcheck whose addon the record was made with (Debian 12's)
FLAGS = (
    "--enable=all",
    "--std=c99",
    "--addon=misra",
    "--xml",
    "-q",
    "--suppress=missingIncludeSystem",
    "--suppress=unmatchedSuppression",
)
# The compiler's predefined macros of each target (one configuration each); portable: every configuration.
DEFINES = {
    "portable": (),
    "cortex-m4": (
        "__GNUC__",
        "__ARM_ARCH_7EM__",
        "__ARM_FEATURE_SIMD32",
        "__ARM_FEATURE_SAT",
        "__ARM_FEATURE_IDIV",
    ),
    "cortex-m0plus": ("__GNUC__", "__ARM_ARCH_6M__"),
}
CALLER = "seagen_misra_caller.c"
SUPPRESS_COMMENT = re.compile(r"cppcheck-suppress|misra-suppress", re.IGNORECASE)


@dataclass(frozen=True)
class Finding:
    """One cppcheck message: rule (e.g. 10.4, or a cppcheck id such as unusedFunction), file, line."""

    rule: str
    file: str
    line: int
    text: str = ""

    def line_text(self) -> str:
        """file:line: rule message."""
        return f"{self.file}:{self.line}: {self.rule} {self.text}".rstrip()


def cppcheck_version(exe: str = "cppcheck") -> str | None:
    """The installed cppcheck's version ('2.10'), or None when it is missing."""
    path = shutil.which(exe)
    if path is None:
        return None
    try:
        out = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    m = re.search(r"(\d+\.\d+(?:\.\d+)?)", out)
    return m.group(1) if m else None


def skip_reason(exe: str = "cppcheck") -> str | None:
    """Why the check cannot run here (no cppcheck, or another version than the record's), or None."""
    got = cppcheck_version(exe)
    if got is None:
        return f"{exe} not found (the MISRA check needs cppcheck {VERSION}: apt-get install cppcheck)"
    if got != VERSION:
        return f"cppcheck {got} installed; the deviation record was made with cppcheck {VERSION}"
    if not _addon_present(exe):
        return f"cppcheck {got} has no misra addon"
    return None


def _addon_present(exe: str) -> bool:
    """True when cppcheck's misra.py addon is installed next to it."""
    path = shutil.which(exe)
    if path is None:
        return False
    roots = [
        Path(path).resolve().parent,
        Path("/usr/lib/x86_64-linux-gnu/cppcheck"),
        Path("/usr/share/cppcheck"),
    ]
    roots += list(Path("/usr/lib").glob("*/cppcheck"))
    return any((r / "addons" / "misra.py").is_file() for r in roots)


def cppcheck_id(rule: str) -> str:
    """The cppcheck message id of a record's rule: 10.4 -> misra-c2012-10.4; other ids as they are."""
    return f"misra-c2012-{rule}" if re.fullmatch(r"\d+\.\d+", rule) else rule


def suppressions(files: dict[str, str], record: tuple[Deviation, ...] = RECORD) -> list[str]:
    """cppcheck suppressions (id:file:line) for each line of `files` that a deviation of the record covers."""
    out = []
    for dev in record:
        pattern = re.compile(dev.match)
        for name in sorted(files):
            if not re.fullmatch(dev.files, name):
                continue
            for n, line in enumerate(files[name].splitlines(), 1):
                if pattern.search(line):
                    out.append(f"{cppcheck_id(dev.rule)}:{name}:{n}")
    return out


def comment_findings(files: dict[str, str]) -> list[Finding]:
    """Suppression comments in the checked files: never honoured, and reported as findings themselves."""
    out = []
    for name in sorted(files):
        for n, line in enumerate(files[name].splitlines(), 1):
            if SUPPRESS_COMMENT.search(line):
                out.append(
                    Finding(
                        "suppression-comment", name, n, "suppressions are taken from seagen's record only"
                    )
                )
    return out


def _shared_calls(p: str, text: str, ext: str) -> list[str]:
    """Caller lines for the shared-pipeline API of export `p` (NAME_step_features, NAME_predict_features_q16,
    NAME_ACT_KEY) where its header has it; they declare f_p, which NAME_controller_init_shared takes."""
    if f"int16_t {p}_step_features(const sea_features_out *f" not in text:
        return []
    pu = p.upper()
    out = [
        f"        static sea_features_out f_{p};",
        f"        sea_features_step(&s_{p}, {pu}_ACT, 0, 0, &f_{p});",
        f"        acc += {p}_step_features(&f_{p}{ext});",
        f"        acc += ({pu}_ACT_KEY != 0u) ? 1 : 0;",
    ]
    if f"int32_t {p}_predict_features_q16(void *ctx," in text:
        out.append(f"        acc += {p}_predict_features_q16(&f_{p}, 0, 0, 0);")
    return out


def caller_source(files: dict[str, str], extra: tuple[str, ...] = ()) -> str:
    """A C file using the public API of every export among `files` (NAME.h with NAME_infer), so that the
    analysis sees it called: NAME_infer, NAME_reset/NAME_step/NAME_predict_q16, the shared-pipeline API,
    NAME_controller_init/_tick/_init_shared, the Q macros;
    `extra`: more lines (#include lines go to the top, statements into main)."""
    lines = [
        f"/* {CALLER} -- generated by seagen verify --misra: calls every export's API. */",
        "#include <stdint.h>",
    ]
    lines += [e for e in extra if e.startswith("#")]
    body = ["    int32_t acc = 0;", *("    " + e for e in extra if not e.startswith("#"))]
    for name in sorted(files):
        text = files[name]
        m = re.search(r"void (\w+)_infer\(const int16_t in\[", text)
        if not name.endswith(".h") or m is None or m.group(1) + ".h" != name:
            continue
        p = m.group(1)
        pu = p.upper()
        lines.append(f'#include "{name}"')
        body += [
            "    {",
            f"        int16_t in_{p}[{pu}_N_IN] = {{0}};",
            f"        int16_t out_{p}[{pu}_N_OUT] = {{0}};",
            f"        {p}_infer(in_{p}, out_{p});",
            f"        acc += (int32_t)out_{p}[0] + {pu}_OUT_Q;",
        ]
        for q in re.findall(rf"#define ({pu}_IN_Q_\w+) ", text):
            body.append(f"        acc += {q};")
        step = re.search(rf"int16_t {p}_step\({p}_state_t \*s, int32_t enc, int32_t pot([^)]*)\);", text)
        if step:
            ext = "".join(", 0" for _ in re.findall(r"int16_t \w+", step.group(1)))
            body += [
                f"        static {p}_state_t s_{p};",
                f"        {p}_reset(&s_{p});",
                f"        acc += {p}_step(&s_{p}, 0, 0{ext});",
            ]
            if f"int32_t {p}_predict_q16(void *ctx," in text:
                body.append(f"        acc += {p}_predict_q16(&s_{p}, 0, 0, 0);")
            body += _shared_calls(p, text, ext)
        if f"{p}_controller.h" in files:
            lines.append(f'#include "{p}_controller.h"')
            body += [
                f"        static {p}_controller_t c_{p};",
                f"        {p}_controller_init(&c_{p}, 0, 0);",
                f"        acc += {p}_controller_tick(&c_{p}, 0, 0, 0);",
            ]
            if f"{p}_controller_init_shared(" in files[f"{p}_controller.h"]:
                body.append(f"        {p}_controller_init_shared(&c_{p}, 0, 0, &f_{p});")
        body.append("    }")
    lines += ["", "int main(void)", "{", *body, "    return (int)acc;", "}", ""]
    return "\n".join(lines)


def run_cppcheck(
    files: dict[str, str],
    target: str = "portable",
    record: tuple[Deviation, ...] = RECORD,
    exe: str = "cppcheck",
    calls: tuple[str, ...] = (),
) -> list[Finding]:
    """Every finding of cppcheck's MISRA addon (and of --enable=all) on `files` (name -> text, one folder)
    analysed together with a generated caller (plus `calls`, see caller_source), outside the record;
    suppression comments are findings."""
    if target not in DEFINES:
        raise ValueError(f"unknown target {target!r}")
    all_files = {**files, CALLER: caller_source(files, calls)}

    found = comment_findings(files)
    with tempfile.TemporaryDirectory(prefix="seagen-misra.") as tmp:
        root = Path(tmp)
        src = root / "src"
        src.mkdir()
        for name, text in all_files.items():
            (src / name).write_text(text)
        supp = root / "suppressions.txt"
        supp.write_text("\n".join(suppressions(all_files, record)) + "\n")
        cmd = [exe, *FLAGS, f"--suppressions-list={supp}", *(f"-D{d}" for d in DEFINES[target])]
        cmd += sorted(n for n in all_files if n.endswith(".c"))
        proc = subprocess.run(cmd, cwd=src, capture_output=True, text=True, timeout=1800)
        found += [f for f in _parse(proc.stderr) if f.file != CALLER]
    return sorted(set(found), key=lambda f: (f.file, f.line, f.rule))


def _parse(xml_text: str) -> list[Finding]:
    """Findings from cppcheck's --xml report (the message's first location)."""
    start = xml_text.find("<?xml")
    if start < 0:
        raise RuntimeError(f"cppcheck wrote no XML report: {xml_text.strip()[:300]}")
    root = ET.fromstring(xml_text[start:])
    out = []
    for err in root.iter("error"):
        ident = err.get("id", "")
        loc = err.find("location")
        file = Path(loc.get("file", "")).name if loc is not None else ""
        line = int(loc.get("line", "0")) if loc is not None else 0
        rule = ident.removeprefix("misra-c2012-")
        out.append(Finding(rule, file, line, "" if ident.startswith("misra") else err.get("msg", "")))
    return out


def check_folder(v: Verdict, folder: Path, target: str) -> None:
    """`seagen verify --misra`: every export's C in `folder` (with a generated caller of their API) under
    cppcheck's MISRA addon, added to the verdict; skipped (with the reason) without cppcheck VERSION."""
    name = f"MISRA C:2012 (cppcheck {VERSION} misra addon): 0 findings outside seagen's deviation record"
    if why := skip_reason():
        v.skip(name, why, kind="misra")
        return
    files = {
        p.name: p.read_text(errors="replace")
        for p in sorted(folder.iterdir())
        if p.suffix in (".c", ".h")
        and p.is_file()
        and not p.name.endswith(("_driver.c", "_driver.h", "_bench.c"))
    }
    try:
        found = run_cppcheck(files, target if target in DEFINES else "portable")
    except (OSError, RuntimeError, subprocess.SubprocessError, ET.ParseError) as e:
        v.add(name, f"cppcheck did not complete: {e}", kind="misra")
        return
    head = "; ".join(f.line_text() for f in found[:5])

    v.add(name, f"{len(found)} finding(s): {head}" if found else None, f"{len(files)} files", kind="misra")
