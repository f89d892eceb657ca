"""The C token stream of a source file: what a compiler sees, with whitespace, comments and line ends
(CRLF or LF) left out, so reformatting can be told from an edit."""

from __future__ import annotations

import re

_STRIP = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'', re.S)
_TOKEN = re.compile(
    r'"(?:\\.|[^"\\])*"|\'(?:\\.|[^\'\\])*\''  # string and character literals
    r"|\.?\d(?:[eEpP][+-]|[\w.])*"  # preprocessing numbers
    r"|[A-Za-z_]\w*"  # identifiers and keywords
    r"|<<=|>>=|\.\.\.|->|\+\+|--|<<|>>|<=|>=|==|!=|&&|\|\||[-+*/%&|^]=|##"
    r"|\S"
)


def tokens(text: str) -> list[str]:
    """The tokens of C source `text`; a preprocessor line ends with a '<eol>' token (its extent matters)."""
    text = text.replace("\r\n", "\n").replace("\r", "\n").replace("\\\n", "")
    text = _STRIP.sub(lambda m: " " if m.group(0)[0] == "/" else m.group(0), text)
    out: list[str] = []
    for line in text.split("\n"):
        toks = _TOKEN.findall(line)
        out.extend(toks)
        if toks and toks[0] == "#":
            out.append("<eol>")
    return out


def same_tokens(a: str, b: str) -> bool:
    """True when two C sources differ only in whitespace, comments or line ends."""
    return tokens(a) == tokens(b)
