"""The manual: the MkDocs site builds with --strict (no broken link or anchor, every page in the nav), its
command reference covers every sub-command and option the parsers have, and README.md stays a landing
page."""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

from seagen.cli import build_parser
from seagen.cli.reference import render

ROOT = Path(__file__).resolve().parents[1]


def commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """prog -> parser for every sub-command at any depth (walked here, not by the generator)."""
    out: dict[str, argparse.ArgumentParser] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out[sub.prog] = sub
                out.update(commands(sub))
    return out


def sections(markdown: str) -> dict[str, str]:
    """`## `prog`` heading -> that section's text."""
    parts = re.split(r"^## `([^`]+)`\n", markdown, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


def test_site_builds_strict(tmp_path):
    """`mkdocs build --strict` succeeds (broken links and anchors, pages missing from the nav fail it), and
    the hook serves the command reference as a page."""
    res = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml")]
        + ["--site-dir", str(tmp_path / "site")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    cli = (tmp_path / "site" / "cli" / "index.html").read_text()
    assert "seagen data generate" in cli and "seagen discrepancy" in cli
    assert not (ROOT / "docs" / "cli.md").exists(), "cli.md is generated at build time, not kept in docs/"


def test_cli_reference_has_every_command_and_option():
    """Every sub-command (data generate, ... included) has its section, with the usage argparse prints and
    each of its option strings and positionals, so the reference cannot drift from --help."""
    parser = build_parser()
    found = sections(render(parser))
    subs = commands(parser)
    assert {"seagen data generate", "seagen export", "seagen verify", "seagen demo"} <= set(subs)
    assert set(found) == set(subs)
    for prog, sub in subs.items():
        text = found[prog]
        assert " ".join(sub.format_usage().split()) in text, prog
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
                continue
            names = action.option_strings or [action.metavar or action.dest]
            for name in names:
                assert f"`{name}`" in text, (prog, name)


def test_cli_reference_lists_nested_commands_and_escapes_help():
    """A group's section names its sub-commands; help text cannot break a table row."""
    sub = argparse.ArgumentParser(prog="x")
    group = sub.add_subparsers(dest="c").add_parser("g", help="a group")
    inner = group.add_subparsers(dest="a")
    inner.add_parser("run", help="runs").add_argument("--n", help="a | b *c* <d> `e` [f]")
    text = render(sub)
    assert "Sub-commands: `run`." in text
    row = next(ln for ln in text.splitlines() if ln.startswith("| `--n`"))
    assert row.count(" | ") == 3 and r"a \| b \*c\* \<d> \`e\` \[f]" in row


def test_readme_is_a_landing_page():
    """README.md: at most 200 lines, and every relative link in it names a file of the repository."""
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text)
    assert any(ln.startswith("docs/") for ln in links)
    missing = [ln for ln in links if "://" not in ln and not (ROOT / ln).exists()]
    assert not missing, missing
