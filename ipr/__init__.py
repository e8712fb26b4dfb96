"""IPR: the interpreter. G-code text in, motion entities (ipr.entities) out.

    from ipr import parse_text, parse_file, iter_entities, Setup
    program = parse_file("part.nc", setup=Setup(work_offsets_mm={"G54": (100, 50, 0)}))
    for entity in iter_entities(open("big.nc"), "big.nc"):   # streaming, bounded memory
        ...
    text = ProgramText.read("part.nc")         # read once, interpreted as often as needed
    for batch in text.interpret(setup):          # lists of entities; GCodeError at the end
        ...

Lines are split at "\n" only ("\r" is a blank). Errors raise ipr.entities.GCodeError,
whose `diagnostics` print as `file:line:col: error[CODE]: message` (codes: ipr/errors.py,
docs/gcode-errors.md; corner cases of the dialect: docs/gcode-notes.md).

Modules: gcode.lark + syntax.py (grammar), shapes.py (fast path: line shapes parsed once),
block.py (modal-group checks), interpreter.py (lines -> blocks, atomic commit), execute.py
(a block's effects), plain.py (plain G0..G3 fast path), plain_runs.py (numba: long stretches of
plain G0/G1 lines read and run at once), memo.py (lines of a loop read once, their expressions
compiled), arcs.py, nurbs_blocks.py +
nurbs_groups.py (NURBS block forms), expressions.py, modal.py (state, Setup), errors.py;
control flow: program_counter.py + oword.py over source.py (a file's lines); interpretation.py
(a whole program run in batches, and ProgramText: a program kept to be interpreted again).

Syntax, one line at a time: `parse_line_full(text)` always runs the lark grammar
(ipr/gcode.lark); `parse_line(text)` returns the same thing through the fast path
(ipr/shapes.py). Both return an `ipr.syntax.Block`, a NamedTuple:

    Block(words=(("G", 1.0), ("X", 12.5), ("Z", ("*", ("#", 3), 10.0))),
          assigns=((1, 0.5),),          # #1=.5 ; names are lower-case, no blanks
          messages=("INSERT TOOL",),    # (MSG, INSERT TOOL)
          delete=False,                 # the line starts with "/"
          percent=False)                # the line is "%"

A word's value is a float, or an expression tree where the line has brackets,
parameters or functions (format: ipr/expressions.py). Both raise
ipr.syntax.LineSyntaxError (with `col`) on a line the grammar rejects.
"""
from __future__ import annotations

import gc
from collections.abc import Iterable, Iterator

from ipr.entities import Entity, GCodeError, Program
from ipr.interpretation import Interpretation, ProgramText
from ipr.modal import Setup
from ipr.shapes import parse_line
from ipr.source import read_text
from ipr.syntax import Block, LineSyntaxError, parse_line_full

__all__ = ["parse_text", "parse_file", "iter_entities", "Setup", "parse_line", "parse_line_full",
           "Block", "LineSyntaxError", "GCodeError", "Program", "Interpretation", "ProgramText"]


def _run(lines: Iterable[str], file: str, setup: Setup | None, all_errors: bool) -> Program:
    run = Interpretation(lines, file, setup, all_errors)
    entities: list[Entity] = []
    # The entity list only grows and holds no cycles: the cyclic collector would rescan
    # it again and again (half the run time on a 200,000-line program).
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        for batch in run:
            entities += batch
    finally:
        if gc_was_enabled:
            gc.enable()
    return Program(file, entities, run.warnings, run.program_number)


def parse_text(text: str, file: str = "<string>", *, setup: Setup | None = None,
               all_errors: bool = False) -> Program:
    """Interpret a whole program; raises GCodeError with the first error (or all of them)."""
    return _run(text.split("\n"), file, setup, all_errors)


def parse_file(path, *, setup: Setup | None = None, all_errors: bool = False) -> Program:
    """parse_text of the file's UTF-8 text (undecodable bytes replaced; a BOM is no text).
    The whole Program is returned at once, so the file is read at once; iter_entities streams."""
    return parse_text(read_text(path), str(path), setup=setup, all_errors=all_errors)


def iter_entities(lines: Iterable[str], file: str = "<string>", *,
                  setup: Setup | None = None) -> Iterator[Entity]:
    """Entities as the lines are read; raises GCodeError at the first error."""
    for batch in Interpretation(lines, file, setup):
        yield from batch
