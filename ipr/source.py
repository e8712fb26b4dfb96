"""The lines of one program file, random access by line number, read on demand.

The program counter (ipr.program_counter) jumps backwards (loops, calls) and scans forwards
(the `endwhile` of a `while`, a subroutine defined later in the file), so it reads lines
through a `Source`. A source fed from an iterator (ipr.iter_entities, streaming) reads it in
chunks and drops the lines already executed as long as no O-word line has been seen: a
straight-line program keeps streaming in bounded memory. From the first O-word line on every
line stays (a loop or call may come back to it); that memory grows with the program's size,
never with the number of blocks executed.

Scans are cached: the O-word of each line looked at, the line each construct jumps to, the
subroutine definitions (`o<name> sub`) and Fanuc program numbers (`O100`) met so far.
"""
from __future__ import annotations

from collections.abc import Iterable
from itertools import islice

from ipr.errors import BlockError
from ipr.oword import OWord, is_oword_line, label_of, parse_oword

_READ_LINES = 1024
_NO_OWORD = None


def read_text(path) -> str:
    """A program file's text: UTF-8 (undecodable bytes replaced), without a byte order mark."""
    with open(path, "rb") as f:
        return f.read().decode("utf-8", "replace").removeprefix("\ufeff")


class Source:
    """One file's lines; `file` names it in diagnostics and in the entities it produces."""

    def __init__(self, file: str, lines: Iterable[str]):
        self.file = file
        if isinstance(lines, list):
            self.lines, self._it = lines, None
        else:
            self.lines, self._it = [], iter(lines)
        self.base = 1              # the line number of lines[0]
        self.keep = False          # an O-word line was seen: no line is dropped any more
        self.owords: dict[int, OWord | None] = {}
        self.stretch_end: dict[int, int] = {}   # line -> the control line a run from it stops at
        self.jumps: dict[tuple, int] = {}
        self.subs: dict[str, int] = {}          # label -> line of its `sub`
        self.programs: dict[str, int] = {}      # Fanuc program number -> line of `O<n>`
        self.scanned = 0                        # definitions are indexed up to this line
        self.memo: dict = {}                    # line -> what reading it gave (ipr.interpreter), once kept
        self.compiled: dict = {}                # (line, argument) -> an O-word argument, compiled
        self._bom_checked = False

    # ---- lines ----------------------------------------------------------------------
    def _fill(self, last: int) -> None:
        """Read until line `last` is in memory (or the input ends)."""
        it = self._it
        while it is not None and self.base + len(self.lines) - 1 < last:
            more = list(islice(it, max(_READ_LINES, last - self.base - len(self.lines) + 1)))
            if not more:
                self._it = None
                break
            self.lines.extend(more)
        if not self._bom_checked and self.lines and self.base == 1:
            self.lines[0] = self.lines[0].removeprefix("\ufeff")
            self._bom_checked = True

    def text(self, n: int) -> str | None:
        """Line n's text, or None past the end."""
        self._fill(n)
        i = n - self.base
        return self.lines[i] if 0 <= i < len(self.lines) else None

    def chunk(self, n: int, count: int) -> list[str]:
        """Lines n .. n + count - 1 (fewer at the end of the input)."""
        self._fill(n + count - 1)
        i = n - self.base
        return self.lines[i:i + count]

    def trim(self, n: int) -> None:
        """Lines before n will not be read again (only while no O-word line has been seen)."""
        if not self.keep and n - self.base > _READ_LINES:
            del self.lines[:n - self.base]
            self.base = n

    # ---- O-words ----------------------------------------------------------------------
    def oword(self, n: int) -> OWord | None:
        """The O-word of line n (parsed once); None for any other line. Raises BlockError."""
        if n in self.owords:
            return self.owords[n]
        text = self.text(n)
        ow = parse_oword(text) if text is not None and is_oword_line(text) else None
        self.owords[n] = ow
        if ow is not None:
            self.keep = True
        return ow

    def find(self, n: int, label: str, keywords: tuple[str, ...]) -> int | None:
        """The first line after n holding an O-word `label` with one of `keywords`."""
        key = (n, keywords)
        if key in self.jumps:
            return self.jumps[key]
        m = n + 1
        while True:
            text = self.text(m)
            if text is None:
                return None
            if is_oword_line(text):
                try:
                    ow = self.oword(m)
                except BlockError:
                    ow = None   # reported if execution reaches it
                    self.owords[m] = None
                if ow is not None and ow.label == label and ow.keyword in keywords:
                    self.jumps[key] = m
                    return m
            m += 1

    def find_definition(self, label: str, fanuc: bool = False) -> int | None:
        """The line of `o<label> sub` (or of Fanuc `O<label>`), scanning the whole file once."""
        table = self.programs if fanuc else self.subs
        while label not in table:
            m = self.scanned + 1
            text = self.text(m)
            if text is None:
                return None
            self.scanned = m
            if is_oword_line(text):
                self._index(m, text)
        return table[label]

    def _index(self, m: int, text: str) -> None:
        try:
            ow = self.oword(m)
        except BlockError:
            return
        if ow is None:
            number = _program_number(text)
            if number is not None:
                self.programs.setdefault(number, m)
                self.keep = True
        elif ow.keyword == "sub":
            self.subs.setdefault(ow.label, m)


def _program_number(text: str) -> str | None:
    """'O100' (a Fanuc program number standing alone, comments allowed) -> '100'."""
    body = text.split("(", 1)[0].split(";", 1)[0].strip()
    if len(body) > 1 and body[0] in "oO":
        digits = body[1:].replace(" ", "").replace("\t", "")
        if digits.isdigit():
            return label_of(digits)
    return None
