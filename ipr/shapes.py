"""The fast path from a line to its Block: each line *shape* is parsed once by the grammar.

A shape is the line with some of its numbers cut out (the *slots*); the grammar parses
the shape once, with "0" in every slot, and the line's own numbers then fill the slots.
This gives exactly what ipr.syntax.parse_line_full gives on the line, because:

- a slot is a plain decimal (at most 30 digits each side of the point) that the regex
  takes whole (no digit follows it), which the grammar reads as `float(text)`; a word
  slot's sign is the unary minus/plus the grammar would fold into the number;
- the template is accepted only if every "0" became exactly one NUMBER token at the
  slot's position (blanks after it aside): then the tokens around it are the same as
  around the line's own number, and lark's parse is the same with the value swapped.
  A slot inside a comment, a parameter name, a number with blanks or two points, a G or
  M code's value, ... breaks this and the line takes the full grammar.

Level 1 ("simple" lines: words with plain numbers, the bulk of CAM output) cuts only the
numbers directly after letters other than G and M, so the shape keeps the codes
("G1 X Y Z F") and the interpreter can check the block once per shape. Level 2 also
cuts the numbers inside expressions and assignments ("Y[#2*-56.12]"), so that
parametric programs (LinuxCNC's 3D_Chips.ngc) skip lark too; their blocks are then
evaluated and checked as usual. tests/test_ipr_props.py compares this with the grammar.
"""
from __future__ import annotations

import re
from functools import lru_cache
from typing import NamedTuple

from ipr.syntax import Block, LineSyntaxError, Slot, parse_line_full, parse_template

MAX_DIGITS = 30   # longer numbers take the full grammar, which rejects non-finite ones
_SHAPE_CACHE = 4096
_D = MAX_DIGITS
_NUM = rf"(?:[0-9]{{1,{_D}}}(?:\.[0-9]{{0,{_D}}})?|\.[0-9]{{1,{_D}}})"
# Not after G or M: codes stay in the shape. A line number takes no sign in the grammar, so a
# sign after N stays in the shape too (and sends "N-0" to the full grammar, which rejects it).
_WORD_NUMBER = rf"(?:(?<=[A-FH-LO-Za-fh-lo-z])[-+]?|(?<=[Nn])){_NUM}"
_WORD_SLOT = re.compile(rf"({_WORD_NUMBER})(?![0-9])")
_ANY_SLOT = re.compile(rf"({_WORD_NUMBER}|(?<=[\[*/+\-= \t]){_NUM})(?![0-9])")
_SIMPLE_SHAPE = re.compile(r"[ \t]*(?:/[ \t]*)?(?:(?:[GMgm](?:[0-9]+\.?[0-9]*|\.[0-9]+)|"
                           r"[A-FH-LN-Za-fh-ln-z]\x00)[ \t]*)*\r?\n?")
MARK = "\x00"   # a slot in a shape; a line containing it takes the full grammar


class Template(NamedTuple):
    """A simple shape's words: `fixed` values for G/M, None where a slot number goes."""

    letters: tuple[str, ...]
    fixed: tuple[float | None, ...]
    slots: tuple[int, ...]          # word index of each slot, in text order
    delete: bool
    key: str


def _template_block(shape: str) -> Block | None:
    """The shape parsed with "0" in its slots, if every slot is one NUMBER token."""
    pieces = shape.split(MARK)
    starts, pos = [], 0
    for piece in pieces[:-1]:
        pos += len(piece)
        starts.append(pos)
        pos += 1
    try:
        block = parse_template("0".join(pieces), starts)
    except LineSyntaxError:
        return None   # the full grammar will report it, at the right column
    found: list[int] = []
    _collect_slots(block, found)
    if sorted(found) != list(range(len(starts))):
        return None
    return block


def _collect_slots(node, found: list[int]) -> None:
    if isinstance(node, Slot):
        found.append(node.index)
    elif isinstance(node, tuple):
        for item in node:
            _collect_slots(item, found)


@lru_cache(maxsize=_SHAPE_CACHE)
def template_for(shape: str) -> Template | None:
    """Level 1: the word template of a simple shape, else None."""
    if _SIMPLE_SHAPE.fullmatch(shape) is None:
        return None
    block = _template_block(shape)
    if block is None:
        return None
    letters = tuple(w[0] for w in block.words)
    slots = tuple(i for i, w in enumerate(block.words) if isinstance(w[1], Slot))
    fixed = tuple(None if isinstance(w[1], Slot) else w[1] for w in block.words)
    return Template(letters, fixed, slots, block.delete, shape)


# Level 1: split_parts(text) -> [text, number, text, ..., text]; the shape is
# MARK.join(parts[0::2]). The bound method itself: it runs once per line.
split_parts = _WORD_SLOT.split


def _source(node) -> str:
    """Python source building `node` with each Slot read from the parts list `p`."""
    if isinstance(node, Slot):
        return f"{'-' if node.negative else ''}float(p[{2 * node.index + 1}])"
    if isinstance(node, tuple):
        return "(" + "".join(_source(item) + ", " for item in node) + ")"
    return repr(node)


@lru_cache(maxsize=_SHAPE_CACHE)
def _filler(shape: str):
    """Level 2: a function from a line's parts to its Block, or None."""
    block = _template_block(shape)
    if block is None or any(letter in "GM" and not isinstance(v, float) for letter, v in block.words):
        return None
    source = (f"lambda p: Block({_source(block.words)}, {_source(block.assigns)}, "
              f"{block.messages!r}, {block.delete!r}, {block.percent!r})")
    return eval(source, {"Block": Block, "float": float})


def expression_block(text: str) -> Block | None:
    """Level 2 for a line that is not simple: its Block, or None (take the full grammar)."""
    if MARK in text:
        return None
    parts = _ANY_SLOT.split(text)
    fill = _filler(MARK.join(parts[0::2]))
    return None if fill is None else fill(parts)


def parse_line(text: str) -> Block:
    """Same result as parse_line_full(text), through the shape caches where they apply."""
    if MARK not in text:
        parts = split_parts(text)
        tpl = template_for(MARK.join(parts[0::2]))
        if tpl is not None:
            values = list(tpl.fixed)
            for i, s in zip(tpl.slots, parts[1::2]):
                values[i] = float(s)
            return Block(tuple(zip(tpl.letters, values)), (), (), tpl.delete)
    block = expression_block(text)
    return parse_line_full(text) if block is None else block
