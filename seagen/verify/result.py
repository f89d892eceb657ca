"""The outcome of a verification: named checks, rendered as text, JSON or JUnit XML."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field

# A parenthesised part holding a number ("(10000 rows)", "(12 of 140 inside the box)") is a count, not a name.
_COUNT = re.compile(r"\s*\((\d[^()]*)\)")


@dataclass
class Item:
    """One named check: passed, failed with a detail line (the first failing input and both outputs), or
    skipped (not run because an earlier check failed). `name` is stable across runs; counts go to `info`."""

    name: str
    ok: bool
    detail: str = ""
    kind: str = "numbers"  # "drift" (files, model, version, manifest) or "numbers"
    info: str = ""
    skipped: bool = False


def stable_name(name: str) -> tuple[str, str]:
    """The name without its counts, and the counts: 'x on test trials (2416 rows)' -> ('x on test
    trials', '2416 rows')."""
    counts = _COUNT.findall(name)
    return _COUNT.sub("", name).strip(), "; ".join(counts)


@dataclass
class Verdict:
    """Every check of one verification, in the order they ran; warnings and notes do not fail it. `error`:
    the bad-input message when verification could not run (exit 2)."""

    prefix: str
    folder: str
    items: list[Item] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    command: str = "verify"  # the seagen command that ran the checks (named in the text and JUnit)
    notes: list[str] = field(default_factory=list)
    error: str = ""

    @property
    def ok(self) -> bool:
        """True when every check that ran agreed and nothing stopped the verification."""
        return not self.error and all(i.ok for i in self.items)

    def add(
        self, name: str, problem: str | None, detail_ok: str = "", kind: str = "numbers", info: str = ""
    ) -> None:
        """Record a check: `problem` is None when it passed; counts in the name move to its info."""
        stable, counts = stable_name(name)
        self.items.append(Item(stable, problem is None, problem or detail_ok, kind, info or counts))

    def skip(self, name: str, why: str, kind: str = "numbers") -> None:
        """Record a check that was not run, and why."""
        self.items.append(Item(stable_name(name)[0], True, why, kind, skipped=True))

    def first_failure(self) -> Item | None:
        """The first failing check, if any."""
        return next((i for i in self.items if not i.ok), None)

    def text(self) -> str:
        """Console report: warnings, notes, one line per check, then the verdict."""
        lines = [f"warning: {w}" for w in self.warnings] + [f"note: {n}" for n in self.notes]
        for i in self.items:
            mark = "skip" if i.skipped else "ok  " if i.ok else "FAIL"
            head = i.name + (f" ({i.info})" if i.info else "")
            lines.append(f"  {mark} {head}" + (f": {i.detail}" if i.detail else ""))
        if self.error:
            lines.append(f"seagen {self.command}: {self.folder}: error: {self.error}")
            return "\n".join(lines)
        bad = sum(not i.ok for i in self.items)
        head = "agrees" if self.ok else f"DISAGREES ({bad} of {len(self.items)} checks failed)"
        lines.append(f"seagen {self.command}: {self.folder} ({self.prefix}) {head}")
        return "\n".join(lines)

    def to_json(self) -> str:
        """One JSON object: ok, prefix, folder, error, warnings, notes, checks."""
        doc = {"ok": self.ok, "prefix": self.prefix, "folder": self.folder, "error": self.error or None}
        doc |= {"warnings": self.warnings, "notes": self.notes, "checks": [asdict(i) for i in self.items]}
        return json.dumps(doc, indent=2)

    def junit(self) -> bytes:
        """JUnit XML: one test case per check (stable names), failures and skips marked; bad input is one
        errored test case carrying the message."""
        suite = ET.Element(
            "testsuite",
            name=f"seagen {self.command} {self.prefix}",
            tests=str(len(self.items) + bool(self.error)),
            failures=str(sum(not i.ok for i in self.items)),
            errors=str(int(bool(self.error))),
            skipped=str(sum(i.skipped for i in self.items)),
        )
        out = [f"warning: {w}" for w in self.warnings] + [f"note: {n}" for n in self.notes]
        if out:
            ET.SubElement(suite, "system-out").text = "\n".join(out)
        classname = f"seagen.{self.command}.{self.prefix}"
        for i in self.items:
            case = ET.SubElement(suite, "testcase", classname=classname, name=i.name)
            if i.skipped:
                ET.SubElement(case, "skipped", message=i.detail[:200])
            elif not i.ok:
                ET.SubElement(case, "failure", message=i.detail[:200]).text = i.detail
            elif i.info or i.detail:
                ET.SubElement(case, "system-out").text = "; ".join(s for s in (i.info, i.detail) if s)
        if self.error:
            case = ET.SubElement(suite, "testcase", classname=classname, name="verification runs")
            ET.SubElement(case, "error", message=self.error[:200]).text = self.error
        return ET.tostring(suite, encoding="utf-8", xml_declaration=True)
