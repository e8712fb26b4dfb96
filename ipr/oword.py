"""O-word lines (LinuxCNC's "O Codes" chapter): `o<name> call [1] [2]`, `o100 while [#1 LT 3]`, ...

`parse_oword(text)` reads one line into an `OWord` (label, keyword, argument expression trees,
the column of each), or returns None when the line is not an O-word control line (a plain
G-code line, or a bare Fanuc program number `O100`, which the ordinary grammar reads).
`is_oword_line(text)` is the cheap test used when scanning ahead for a label.

Labels: `o100` -> "100", `o<Probe X>` -> "probex" (case and blanks do not count, as in LinuxCNC).
Arguments are bracketed expressions, parsed by the ordinary grammar (ipr.syntax), so they
follow the same operators, functions and depth limit as expressions in words.
"""
from __future__ import annotations

import re
from typing import NamedTuple

from ipr.errors import BlockError
from ipr.syntax import LineSyntaxError, parse_line_columns

KEYWORDS = ("sub", "endsub", "return", "call", "if", "elseif", "else", "endif", "while", "endwhile",
            "do", "break", "continue", "repeat", "endrepeat")
_HEAD = re.compile(r"[ \t]*(?:/[ \t]*)?(?:[nN][ \t]*[0-9][0-9 \t.]*)?[oO][ \t]*(<[^>\n]*>|[0-9][0-9 \t]*)[ \t]*"
                   r"([a-zA-Z]*)")
_PREFIX = re.compile(r"[ \t]*(?:/[ \t]*)?(?:[nN][ \t]*[0-9][0-9 \t.]*)?[oO][ \t]*[<0-9]")
# how many bracketed arguments each keyword takes: (at least, at most)
_ARITY = {"sub": (0, 0), "endsub": (0, 1), "return": (0, 1), "call": (0, 30), "if": (1, 1),
          "elseif": (1, 1), "else": (0, 0), "endif": (0, 0), "while": (1, 1), "endwhile": (0, 0),
          "do": (0, 0), "break": (0, 0), "continue": (0, 0), "repeat": (1, 1), "endrepeat": (0, 0)}


class OWord(NamedTuple):
    label: str
    keyword: str
    args: tuple          # expression trees (or floats), one per bracketed argument
    arg_cols: tuple      # 1-based column of each argument's "["
    delete: bool         # the line starts with "/"


def label_of(text: str) -> str:
    """'<Probe X>' -> 'probex', '0100' -> '100'."""
    if text.startswith("<"):
        return re.sub(r"[ \t]", "", text[1:-1]).lower()
    return str(int(re.sub(r"[ \t]", "", text)))


def is_oword_line(text: str) -> bool:
    return _PREFIX.match(text) is not None


def parse_oword(text: str) -> OWord | None:
    """The O-word of a control line; None if the line has no O-word keyword.
    Raises BlockError (E-SYNTAX, E-EXPR-TOO-DEEP, E-OWORD) with the column."""
    m = _HEAD.match(text)
    if m is None or not m.group(2):
        return None
    keyword = m.group(2).lower()
    if keyword not in _ARITY:
        raise BlockError("E-OWORD", f"unknown O-word keyword {m.group(2)!r}", col=m.start(2) + 1)
    args, cols = _arguments(text, m.end())
    low, high = _ARITY[keyword]
    if not low <= len(args) <= high:
        want = f"{low}" if low == high else f"{low} to {high}"
        raise BlockError("E-OWORD", f"O-word {keyword} takes {want} bracketed argument(s), "
                         f"not {len(args)}", col=m.start(2) + 1)
    return OWord(label_of(m.group(1)), keyword, tuple(args), tuple(cols), text.lstrip().startswith("/"))


def _arguments(text: str, pos: int) -> tuple[list, list]:
    """The bracketed expressions after the keyword; comments may follow."""
    args, cols = [], []
    n = len(text)
    while pos < n:
        c = text[pos]
        if c in " \t\r\n":
            pos += 1
        elif c == "[":
            end = _closing(text, pos)
            args.append(_expression(text[pos:end + 1], pos + 1))
            cols.append(pos + 1)
            pos = end + 1
        elif c == "(":
            close = text.find(")", pos)
            if close < 0:
                raise BlockError("E-SYNTAX", "comment without its closing ')'", col=pos + 1)
            pos = close + 1
        elif c == ";":
            break
        else:
            raise BlockError("E-SYNTAX", f"unexpected {c!r} in an O-word line", col=pos + 1)
    return args, cols


def _closing(text: str, start: int) -> int:
    depth = 0
    for i in range(start, len(text)):
        if text[i] == "[":
            depth += 1
        elif text[i] == "]":
            depth -= 1
            if depth == 0:
                return i
    raise BlockError("E-SYNTAX", "'[' without its closing ']'", col=start + 1)


def _expression(bracketed: str, col: int):
    """The tree of one `[...]`, parsed as the value of an X word; columns mapped back."""
    try:
        block, _ = parse_line_columns("X" + bracketed)
    except LineSyntaxError as e:
        raise BlockError(e.code, e.message, col=max(e.col - 2, 0) + col) from None
    return block.words[0][1]
