"""The command-line reference (Markdown) rendered from the argparse parsers `seagen --help` prints."""

from __future__ import annotations

import argparse
from collections.abc import Iterator

from seagen.cli import build_parser

INTRO = (
    "# Command reference\n\n"
    "Generated from seagen's argument parsers when the manual is built, so it says what `seagen COMMAND "
    "--help` says. Exit codes, stopping and concurrent writes: [The command line](command-line.md).\n"
)


def subcommands(parser: argparse.ArgumentParser) -> Iterator[tuple[str, str, argparse.ArgumentParser]]:
    """(full command, its one-line help, its parser) for every sub-command at any depth, in parser order."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield sub.prog, helps.get(name, ""), sub
                yield from subcommands(sub)


def options(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    """The arguments a parser documents: positionals and options, without -h and nested sub-commands."""
    return [
        a
        for a in parser._actions
        if a.help != argparse.SUPPRESS
        and not isinstance(a, argparse._HelpAction | argparse._SubParsersAction)
    ]


def cell(text: str) -> str:
    """Text made safe for one Markdown table cell (one line; no emphasis, link, HTML or column break)."""
    out = " ".join(text.split())
    for ch in "\\`*_[<|":
        out = out.replace(ch, "\\" + ch)
    return out


def argument(action: argparse.Action) -> str:
    """What an option takes (its metavar or choices; nothing for a flag), or a positional's name."""
    if not action.option_strings:
        return str(action.metavar or action.dest)
    if action.nargs == 0:
        return ""
    if action.metavar is not None:
        return str(action.metavar)
    if action.choices is not None:
        return choices(action)
    return action.dest.upper()


def choices(action: argparse.Action) -> str:
    """An argument's choices as argparse prints them, {a,b,c} (empty when it has none)."""
    return "{" + ",".join(map(str, action.choices)) + "}" if action.choices is not None else ""


def default(action: argparse.Action) -> str:
    """'required', the default an option takes a value with, or nothing (flags, None)."""
    if action.required:
        return "required"
    if action.nargs == 0 or action.default is None or action.default is argparse.SUPPRESS:
        return ""
    return f"default `{action.default}`"


def row(action: argparse.Action) -> str:
    """One table row: the option strings (or the positional's name), its value, required/default, help."""
    names = ", ".join(f"`{o}`" for o in action.option_strings) or f"`{argument(action)}`"
    value = argument(action) if action.option_strings else choices(action)
    shown = f"`{value}`" if value else ""
    return f"| {names} | {shown} | {default(action)} | {cell(action.help or '')} |"


def section(prog: str, help: str, parser: argparse.ArgumentParser) -> str:
    """One command's section: heading, one-line help, usage and its table of arguments."""
    usage = " ".join(parser.format_usage().split())
    lines = [f"## `{prog}`", "", cell(help), "", "```text", usage, "```", ""]
    names = [n for a in parser._actions if isinstance(a, argparse._SubParsersAction) for n in a.choices]
    if names:
        lines += ["Sub-commands: " + ", ".join(f"`{n}`" for n in names) + ".", ""]
    args = options(parser)
    if args:
        lines += ["| argument | value | required / default | what it does |", "| --- | --- | --- | --- |"]
        lines += [row(a) for a in args]
    return "\n".join(lines).rstrip("\n") + "\n"


def render(parser: argparse.ArgumentParser | None = None) -> str:
    """The whole reference: the top-level usage, then a section per sub-command (sub-sub-commands too)."""
    parser = parser or build_parser()
    top = " ".join(parser.format_usage().split())
    parts = [INTRO, f"```text\n{top}\n```\n"]
    parts += [section(prog, help, sub) for prog, help, sub in subcommands(parser)]
    return "\n".join(parts)


if __name__ == "__main__":
    print(render(), end="")
