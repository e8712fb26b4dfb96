"""From one line of text to a `Block`, by the grammar (gcode.lark) and lark's LALR parser.

`parse_line_full` runs the parser on a line; `parse_template` runs it on a line *shape*
(see ipr.shapes, the fast path, which calls the parser once per distinct shape).
"""
from __future__ import annotations

import hashlib
import math
import os
import re
from pathlib import Path
from typing import NamedTuple

from lark import Lark, Token, Transformer, UnexpectedCharacters, UnexpectedInput, UnexpectedToken


class Block(NamedTuple):
    """The words of one line, before any evaluation.

    words: (LETTER, value) in text order; value is a float, or an expression tree
        (see ipr.expressions) where the line uses brackets, parameters or functions.
    assigns: (parameter, value) for each `#n=...`; parameter is an int, a lower-case
        name without blanks, or an expression tree for `#[...]`/`##n`.
    messages: the text of each (MSG, ...) comment, and ("debug", text) for each (DEBUG, ...) or
        (PRINT, ...) comment, whose #-references are substituted when the block runs.
        Other comments are dropped.
    delete: the line starts with "/" (block delete). percent: the line is "%".
    """

    words: tuple = ()
    assigns: tuple = ()
    messages: tuple = ()
    delete: bool = False
    percent: bool = False


class LineSyntaxError(Exception):
    """A line the grammar rejects; `col` is 1-based; `code` the error code (E-SYNTAX, or
    E-EXPR-TOO-DEEP for an expression nested deeper than MAX_EXPR_DEPTH)."""

    def __init__(self, col: int, message: str, code: str = "E-SYNTAX"):
        super().__init__(message)
        self.col = col
        self.message = message
        self.code = code


# Expression trees deeper than this are refused: evaluation recurses once per level (rs274 refuses
# lines over 256 characters, which bounds its expressions at about 120 levels)
MAX_EXPR_DEPTH = 100


def expression_depth(node) -> int:
    """Levels of an expression tree (0 for a number), counted without recursion."""
    depth, stack = 0, [(node, 1)]
    while stack:
        n, d = stack.pop()
        if n.__class__ is tuple:
            depth = max(depth, d)
            stack.extend((child, d + 1) for child in n[1:])
    return depth


class _TooDeep(Exception):
    def __init__(self, column: int, depth: int):
        self.column = column
        self.depth = depth


MAX_DIGITS = 30   # longer numbers take the full grammar, which rejects non-finite ones


class _NumberTooLarge(Exception):
    def __init__(self, token: Token):
        self.token = token


def _to_float(token: Token) -> float:
    value = float(token.replace(" ", "").replace("\t", ""))
    if not math.isfinite(value):
        raise _NumberTooLarge(token)
    return value


class Slot(NamedTuple):
    """In a shape's template (ipr.shapes): the place of the shape's index-th number,
    negated when a unary minus stands before it."""

    index: int
    negative: bool = False


class _ToBlock(Transformer):
    """Builds Block and, in parallel, the 1-based column of every word."""

    def _number(self, token: Token):
        return _to_float(token)

    def number(self, items):
        return self._number(items[0])

    def neg(self, items):
        v = items[-1]
        if isinstance(v, float):
            return -v
        return Slot(v.index, not v.negative) if isinstance(v, Slot) else ("neg", v)

    def value(self, items):
        return items[-1]

    def func(self, items):
        return (items[0].lower(), items[1])

    def atan(self, items):
        return ("atan", items[1], items[2])

    def exists(self, items):
        return ("exists", items[-1][1])

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
        if items[1].__class__ is tuple:
            _check_depth(items[1], letter.column)
        return ("word", letter.upper(), items[1], letter.column)

    def line_number(self, items):
        letter = items[0]
        return ("word", "N", self._number(items[1]), letter.column)

    def assignment(self, items):
        target, value = items[0], items[-1]
        for tree in (target, value):
            if tree.__class__ is tuple:
                _check_depth(tree, 1)
        key = target[1]
        return ("assign", key, value, None)

    def message(self, items):
        kind, text = items[0][1:-1].split(",", 1)
        text = text.strip()
        if kind.strip().lower() != "msg":
            text = ("debug", text)
        return ("msg", text, None, items[0].column)

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


def _check_depth(tree, column: int) -> None:
    depth = expression_depth(tree)
    if depth > MAX_EXPR_DEPTH:
        raise _TooDeep(column, depth)


class _ToTemplate(_ToBlock):
    """_ToBlock for a shape's text: the NUMBER tokens that are exactly a "0" put in place of
    one of the shape's numbers (start positions in `slots`) become Slot markers."""

    slots: dict[int, int] = {}

    def _number(self, token: Token):
        index = self.slots.get(token.start_pos)
        if index is not None and token.replace(" ", "").replace("\t", "") == "0":
            return Slot(index)
        return _to_float(token)


_GRAMMAR = (Path(__file__).with_name("gcode.lark")).read_text()


def grammar_cache_file() -> str | bool:
    """Where lark keeps the parse tables it builds from the grammar, or False where no cache
    directory can be made (each process then builds them).

    Building them (the LALR analysis) costs ~40 ms of CPU per parser in every process that
    parses; loading them ~3 ms. The file is named by the grammar's hash, so checkouts with
    different grammars do not overwrite each other's; lark writes its own hash of the grammar,
    options, lark and Python versions into the file and rebuilds (and rewrites) on a mismatch
    or an unreadable file.
    """
    try:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "vcnc" / "grammar"
        base.mkdir(parents=True, exist_ok=True)
    except (OSError, RuntimeError):  # RuntimeError: no home directory
        return False
    return str(base / f"gcode-{hashlib.sha256(_GRAMMAR.encode()).hexdigest()[:16]}.lark-cache")


def build_parser(transformer: Transformer, cache: str | bool) -> Lark:
    """The grammar's LALR parser with `transformer` run inside it (no parse tree is built)."""
    return Lark(_GRAMMAR, parser="lalr", lexer="contextual", transformer=transformer,
                propagate_positions=False, maybe_placeholders=False, cache=cache)


_CACHE = grammar_cache_file()
_PARSER = build_parser(_ToBlock(), _CACHE)
_TEMPLATE_TRANSFORMER = _ToTemplate()
_TEMPLATE_PARSER = build_parser(_TEMPLATE_TRANSFORMER, _CACHE)


def parse_line_columns(text: str) -> tuple[Block, tuple[int, ...]]:
    """Full grammar: the Block and the 1-based column of each of its words."""
    return _parse(_PARSER, text)


def parse_template(text: str, slot_starts: list[int]) -> Block:
    """Full grammar on a shape's text with "0" at `slot_starts`: a Block holding Slot markers."""
    _TEMPLATE_TRANSFORMER.slots = {pos: i for i, pos in enumerate(slot_starts)}
    return _parse(_TEMPLATE_PARSER, text)[0]


def _bracket_depth(text: str) -> tuple[int, int]:
    """The deepest nesting of "[" in a line, and the column where it first passes MAX_EXPR_DEPTH."""
    depth = deepest = col = 0
    for i, c in enumerate(text):
        if c == "[":
            depth += 1
            deepest = max(deepest, depth)
            if depth == MAX_EXPR_DEPTH + 1 and not col:
                col = i + 1
        elif c == "]":
            depth -= 1
    return deepest, col


def _parse(parser: Lark, text: str) -> tuple[Block, tuple[int, ...]]:
    if text.count("[") > MAX_EXPR_DEPTH:
        depth, col = _bracket_depth(text)
        if depth > MAX_EXPR_DEPTH:
            raise LineSyntaxError(col, f"brackets nested {depth} deep (at most {MAX_EXPR_DEPTH})",
                                  "E-EXPR-TOO-DEEP")
    try:
        return parser.parse(text.rstrip("\r\n"))
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
    except _TooDeep as e:
        raise LineSyntaxError(e.column, f"expression nested {e.depth} levels deep (at most {MAX_EXPR_DEPTH})",
                              "E-EXPR-TOO-DEEP") from None


def parse_line_full(text: str) -> Block:
    """Parse one line with the full lark grammar."""
    return parse_line_columns(text)[0]
