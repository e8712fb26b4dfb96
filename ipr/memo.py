"""The lines of a program that may run them again (loops, subroutines), read once.

ipr.interpreter keeps, per line of such a program (ipr.source.Source.memo), what reading it
gave: the plan and parts of a simple line's shape, or the Block of any other line. From the
line's second run on, its expressions are compiled (ipr.expressions.compile_expression) and,
where no G or M code is an expression, its checked signature is kept: a loop body costs its
arithmetic, not its parsing.
"""
from __future__ import annotations

from ipr.block import analyse
from ipr.expressions import compile_expression


class ReadLine:
    """What reading one line of a kept program gave (Interpreter.run's memo): its shape's plan
    and parts, or its Block and, once it runs a second time, its compiled expressions (and its
    checked signature where no G or M code is an expression)."""

    __slots__ = ("plan", "parts", "block", "words", "assigns", "spec")

    def __init__(self, plan, parts):
        self.plan, self.parts = plan, parts
        self.block = self.words = self.assigns = self.spec = None

    def compile(self, dialect: str) -> None:
        block = self.block
        self.words = tuple(None if v.__class__ is float else compile_expression(v) for _, v in block.words)
        self.assigns = tuple(compile_expression(v) for _, v in block.assigns)
        if all(v.__class__ is float for letter, v in block.words if letter in "GM"):
            sig = tuple((letter, v if letter in "GM" else None) for letter, v in block.words)
            self.spec = (sig, analyse(sig, dialect))
