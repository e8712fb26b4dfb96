"""From one line of text to a `Block`: the grammar (gcode.lark) and its fast path.

`parse_line_full` always runs the lark LALR parser. `parse_line` gives the same
result faster: most lines of real programs are "simple" — letters and plain numbers
only. Such a line is split by one regex into its *shape* (the text with the numbers
after every letter but G and M removed, e.g. "G1 X Y Z F") and the numbers. Each
distinct shape is parsed ONCE by the full grammar, with "0" in every slot, giving a
word template; the line's own numbers then fill the slots (a slot number is a plain
signed decimal, which the grammar reads as exactly `float(text)`). Lines whose shape
has anything else (comments, brackets, parameters, blanks between a letter and its
number) take the full grammar. tests/test_ipr_props.py checks the two agree.
"""
from __future__ import annotations

import math
import re
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

from lark import Lark, Token, Transformer, UnexpectedCharacters, UnexpectedInput, UnexpectedToken


class Block(NamedTuple):
    """The words of one line, before any evaluation.

    words: (LETTER, value) in text order; value is a float, or an expression tree
        (see ipr.expressions) where the line uses brackets, parameters or functions.
    assigns: (parameter, value) for each `#n=...`; parameter is an int, a lower-case
        name without blanks, or an expression tree for `#[...]`/`##n`.
    messages: the text of each (MSG, ...) comment. Other comments are dropped.
    delete: the line starts with "/" (block delete). percent: the line is "%".
    """

    words: tuple = ()
    assigns: tuple = ()
    messages: tuple = ()
    delete: bool = False
    percent: bool = False


class LineSyntaxError(Exception):
    """A line the grammar rejects; `col` is 1-based."""

    def __init__(self, col: int, message: str):
        super().__init__(message)
        self.col = col
        self.message = message


MAX_DIGITS = 30   # longer numbers take the full grammar, which rejects non-finite ones


class _NumberTooLarge(Exception):
    def __init__(self, token: Token):
        self.token = token


def _to_float(token: Token) -> float:
    value = float(token.replace(" ", "").replace("\t", ""))
    if not math.isfinite(value):
        raise _NumberTooLarge(token)
    return value


class _ToBlock(Transformer):
    """Builds Block and, in parallel, the 1-based column of every word."""

    def number(self, items):
        return _to_float(items[0])

    def neg(self, items):
        v = items[-1]
        return -v if isinstance(v, float) else ("neg", v)

    def value(self, items):
        return items[-1]

    def func(self, items):
        return (items[0].lower(), items[1])

    def atan(self, items):
        return ("atan", items[1], items[2])

    def binary(self, items):
        a, op, b = items
        return (op.lower(), a, b)

    def param_number(self, items):
        n = _to_float(items[-1])
        return ("#", int(n) if n.is_integer() else n)

    def param_name(self, items):
        return ("#", re.sub(r"[ \t]", "", items[-1][1:-1]).lower())

    def param_indirect(self, items):
        return ("#", items[-1])

    def param_expr(self, items):
        return ("#", items[-1])

    def word(self, items):
        letter = items[0]
        return ("word", letter.upper(), items[1], letter.column)

    def line_number(self, items):
        letter = items[0]
        return ("word", "N", _to_float(items[1]), letter.column)

    def assignment(self, items):
        target, value = items[0], items[-1]
        key = target[1]
        return ("assign", key, value, None)

    def message(self, items):
        text = items[0][1:-1]
        return ("msg", text.split(",", 1)[1].strip(), None, items[0].column)

    def block_delete(self, items):
        return ("delete", None, None, None)

    def percent_line(self, items):
        return Block(percent=True), ()

    def block_line(self, items):
        words, cols, assigns, msgs, delete = [], [], [], [], False
        for it in items:
            if isinstance(it, Token):
                continue  # plain comment
            kind = it[0]
            if kind == "word":
                words.append((it[1], it[2]))
                cols.append(it[3])
            elif kind == "assign":
                assigns.append((it[1], it[2]))
            elif kind == "msg":
                msgs.append(it[1])
            else:
                delete = True
        return Block(tuple(words), tuple(assigns), tuple(msgs), delete), tuple(cols)


_GRAMMAR = (Path(__file__).with_name("gcode.lark")).read_text()
_PARSER = Lark(_GRAMMAR, parser="lalr", lexer="contextual", transformer=_ToBlock(),
               propagate_positions=False, maybe_placeholders=False)


def parse_line_columns(text: str) -> tuple[Block, tuple[int, ...]]:
    """Full grammar: the Block and the 1-based column of each of its words."""
    try:
        return _PARSER.parse(text.rstrip("\r\n"))
    except UnexpectedCharacters as e:
        raise LineSyntaxError(e.column, f"unexpected character {text[e.pos_in_stream]!r}") from None
    except UnexpectedToken as e:
        tok = e.token
        if tok.type == "$END":
            raise LineSyntaxError(len(text.rstrip("\r\n")) + 1, "line ends in the middle of a word") from None
        raise LineSyntaxError(tok.column, f"unexpected {str(tok)!r}") from None
    except UnexpectedInput as e:
        raise LineSyntaxError(getattr(e, "column", 1) or 1, "syntax error") from None
    except _NumberTooLarge as e:  # raised by the transformer, which runs inside the parse
        raise LineSyntaxError(e.token.column, f"number {str(e.token)[:20]}... is too large") from None


def parse_line_full(text: str) -> Block:
    """Parse one line with the full lark grammar."""
    return parse_line_columns(text)[0]


# Numbers directly after a letter other than G/M become slots; G and M numbers stay in
# the shape because they select the codes.
_D = MAX_DIGITS
_SLOT = re.compile(rf"(?<=[A-FH-LN-Za-fh-ln-z])([-+]?(?:[0-9]{{1,{_D}}}(?:\.[0-9]{{0,{_D}}})?|\.[0-9]{{1,{_D}}}))(?![0-9])")
_SIMPLE_SHAPE = re.compile(r"[ \t]*(?:/[ \t]*)?(?:(?:[GMgm](?:[0-9]+\.?[0-9]*|\.[0-9]+)|[A-FH-LN-Za-fh-ln-z]\x00)[ \t]*)*\r?\n?")
_SHAPE_CACHE_MAX = 4096


class Template(NamedTuple):
    """A shape's words: `fixed` values for G/M, None where a slot number goes."""

    letters: tuple[str, ...]
    fixed: tuple[float | None, ...]
    slots: tuple[int, ...]          # word index of each slot, in text order
    delete: bool
    key: str


@lru_cache(maxsize=_SHAPE_CACHE_MAX)
def template_for(shape: str) -> Template | None:
    """The word template of a simple shape (parsed once by the full grammar), else None."""
    if _SIMPLE_SHAPE.fullmatch(shape) is None:
        return None
    parts = shape.split("\x00")
    try:
        block = parse_line_full("0".join(parts))
    except LineSyntaxError:
        return None   # the full grammar will report it, at the right column
    letters = tuple(w[0] for w in block.words)
    slots = tuple(i for i, w in enumerate(block.words) if w[0] not in "GM")
    if len(slots) != len(parts) - 1:
        return None
    fixed = tuple(None if i in slots else w[1] for i, w in enumerate(block.words))
    return Template(letters, fixed, slots, block.delete, shape)


def split_parts(text: str) -> list[str]:
    """[text, number, text, number, ..., text]: the shape is "\x00".join(parts[0::2])."""
    return _SLOT.split(text)


def split_line(text: str) -> tuple[Template | None, list[str]]:
    """The line's template (None: not simple) and its slot numbers as text."""
    if "\x00" in text:   # the slot marker itself: only the full grammar is unambiguous
        return None, []
    parts = _SLOT.split(text)
    return template_for("\x00".join(parts[0::2])), parts[1::2]


def parse_line(text: str) -> Block:
    """Same result as parse_line_full(text), through the shape cache where it applies."""
    tpl, nums = split_line(text)
    if tpl is None:
        return parse_line_full(text)
    values = list(tpl.fixed)
    for i, s in zip(tpl.slots, nums):
        values[i] = float(s)
    return Block(tuple(zip(tpl.letters, values)), (), (), tpl.delete)
