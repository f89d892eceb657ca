"""The outcome of a verification: named checks, rendered as text, JSON or JUnit XML."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, field


@dataclass
class Item:
    """One named check: passed or failed with a detail line (the first failing input and both outputs)."""

    name: str
    ok: bool
    detail: str = ""
    kind: str = "numbers"  # "drift" (files, model, version), "numbers", "misra" or "skipped" (not run)


@dataclass
class Verdict:
    """Every check of one verification, in the order they ran; warnings do not fail it."""

    prefix: str
    folder: str
    items: list[Item] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every check agreed."""
        return all(i.ok for i in self.items)

    def add(self, name: str, problem: str | None, detail_ok: str = "", kind: str = "numbers") -> None:
        """Record a check: `problem` is None when it passed."""
        self.items.append(Item(name, problem is None, problem or detail_ok, kind))

    def first_failure(self) -> Item | None:
        """The first failing check, if any."""
        return next((i for i in self.items if not i.ok), None)

    def text(self) -> str:
        """Console report: warnings, one line per check, then the verdict."""
        lines = [f"warning: {w}" for w in self.warnings]
        for i in self.items:
            mark = ("skip" if i.kind == "skipped" else "ok  ") if i.ok else "FAIL"

            lines.append(f"  {mark} {i.name}" + (f": {i.detail}" if i.detail else ""))
        bad = sum(not i.ok for i in self.items)
        head = "agrees" if self.ok else f"DISAGREES ({bad} of {len(self.items)} checks failed)"
        lines.append(f"seagen verify: {self.folder} ({self.prefix}) {head}")
        return "\n".join(lines)

    def to_json(self) -> str:
        """One JSON object: ok, prefix, folder, warnings, checks."""
        doc = {"ok": self.ok, "prefix": self.prefix, "folder": self.folder, "warnings": self.warnings}
        doc["checks"] = [asdict(i) for i in self.items]
        return json.dumps(doc, indent=2)

    def junit(self) -> bytes:
        """JUnit XML: one test case per check, failures carry the detail line."""
        suite = ET.Element(
            "testsuite",
            name=f"seagen verify {self.prefix}",
            tests=str(len(self.items)),
            failures=str(sum(not i.ok for i in self.items)),
            errors="0",
        )
        for w in self.warnings:
            ET.SubElement(suite, "system-out").text = f"warning: {w}"
        for i in self.items:
            case = ET.SubElement(suite, "testcase", classname=f"seagen.verify.{self.prefix}", name=i.name)
            if not i.ok:
                ET.SubElement(case, "failure", message=i.detail[:200]).text = i.detail
            elif i.kind == "skipped":
                ET.SubElement(case, "skipped", message=i.detail[:200])

        return ET.tostring(suite, encoding="utf-8", xml_declaration=True)
