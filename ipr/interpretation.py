"""Running the interpreter over a whole program: its entities batch by batch, as often as needed.

An `Interpretation` drives the program counter (ipr.program_counter) over a program's lines
and hands out its entities a list (a batch, of about BATCH entities) at a time. Nothing
is kept between batches, so a program of any length, or a loop of any count, is interpreted
in memory bounded by the program's source text. When the batches run out, `warnings` and
`program_number` are final, and every error found (the first one, unless `all_errors`) is
raised as one GCodeError.

A `ProgramText` is a program's text and the texts of the subroutine files it calls, each
read once: every interpretation of it reads the same characters, so a check before motion
and the run after it interpret the same program even if a file changes on disk meanwhile.
Its lines are split a chunk at a time: a list of the 2,000,000 lines of a large CAM program
would cost several times the text itself.
"""
from __future__ import annotations

import gc
from collections.abc import Iterable, Iterator
from pathlib import Path

from ipr.entities import Entity, GCodeError
from ipr.interpreter import Interpreter
from ipr.modal import Setup
from ipr.program_counter import Executor
from ipr.source import Source, read_text

_CHUNK_CHARS = 1 << 20
BATCH = 4096   # entities gathered before a batch is handed out (a stretch of lines may make more)


def text_lines(text: str) -> Iterator[str]:
    """text.split("\\n"), a chunk of about _CHUNK_CHARS characters at a time."""
    start = 0
    while True:
        end = text.find("\n", start + _CHUNK_CHARS)
        if end < 0:
            yield from text[start:].split("\n")
            return
        yield from text[start:end].split("\n")
        start = end + 1


class Interpretation:
    """One run of the interpreter over `lines`; iterate it for the batches of entities.
    `texts` (path -> text) holds the subroutine files read so far, shared with other runs."""

    def __init__(self, lines: Iterable[str], file: str = "<string>", setup: Setup | None = None,
                 all_errors: bool = False, texts: dict[Path, str] | None = None):
        self.interp = Interpreter(file, setup, all_errors)
        self.executor = Executor(self.interp, Source(file, lines), texts)

    @property
    def warnings(self):
        return self.interp.warnings

    @property
    def program_number(self) -> int | None:
        return self.interp.state.program_number

    @property
    def last_line(self) -> int:
        """The last line of the main program read so far."""
        return self.executor.last_line

    def __iter__(self) -> Iterator[list[Entity]]:
        interp, executor = self.interp, self.executor
        more = True
        while more:
            more = self._steps()
            if not more:
                interp.finish(executor.last_line)
            if interp.out:
                batch, interp.out = interp.out, []
                yield batch
        if interp.diagnostics:
            raise GCodeError(interp.diagnostics)

    def _steps(self) -> bool:
        """Steps of the program counter until a batch of BATCH entities is made or the program
        ends (False). A loop makes its entities one iteration (one step) at a time; gathered, a
        consumer's per-batch work (vectorised checks) is paid once per batch, not per iteration.
        The cyclic garbage collector is held meanwhile: a stretch of lines makes tens of
        thousands of objects and no reference cycle, and the collector would scan them (and
        every object of the process) a hundred times over; it runs between batches instead
        (about 20 % of the time of a large CAM program)."""
        gc_was_enabled = gc.isenabled()
        gc.disable()
        try:
            interp, step = self.interp, self.executor.step
            while step():
                if len(interp.out) >= BATCH:
                    return True
            return False
        finally:
            if gc_was_enabled:
                gc.enable()


class ProgramText:
    """A program's text, interpreted as often as needed with the same result."""

    def __init__(self, file: str, text: str):
        self.file = file
        self.text = text.removeprefix("\ufeff")
        self.texts: dict[Path, str] = {}   # subroutine files, read at their first call

    @classmethod
    def read(cls, path) -> ProgramText:
        """Raises OSError when the file cannot be read."""
        return cls(str(path), read_text(path))

    def interpret(self, setup: Setup | None = None, all_errors: bool = False) -> Interpretation:
        return Interpretation(text_lines(self.text), self.file, setup, all_errors, self.texts)
