"""Per-line bookkeeping of a stream: what was sent and what grbl answered.

grbl answers every line it receives with exactly one `ok` or `error:N`, in order, so
the answers are matched to the oldest unanswered line (character counting). The
ledger refuses anything that would break that: a line sent twice in one session,
an answer with no line waiting for it. A session covers the lines from where it
started up to `resume_from`, the first line the next session must send; `check`
proves every covered line was sent exactly once and, unless the connection was
lost before its answer came, answered `ok`.
"""
from __future__ import annotations

from array import array
from collections import deque
from dataclasses import dataclass

UNSENT, SENT, OK, ERROR, DISCARDED = 0, 1, 2, 3, 4
STATE_NAMES = ("unsent", "sent", "ok", "error", "discarded")


class LedgerError(RuntimeError):
    """The stream's bookkeeping would lose or duplicate a line."""


@dataclass(slots=True)
class Fault:
    kind: str  # "error", "alarm", "stopped" (asked for), "disconnected", "stalled"
    message: str
    seq: int  # the stream line concerned (0 when none)
    source_line: int


class Ledger:
    """Sent/answered state of stream lines `first`.. (1-based seq numbers)."""

    def __init__(self, first: int = 1, journal=None):
        self.first = first
        self.journal = journal  # machine.grbl.journal.Journal: every event also goes to disk
        self._state = array("B")
        self._sends = array("B")
        self._waiting: deque[tuple[int, int]] = deque()  # (seq, bytes) sent, not yet answered
        self.resume_from: int | None = None
        self.connection_lost = False

    def _grow(self, seq: int) -> int:
        i = seq - self.first
        if i < 0:
            raise LedgerError(f"line {seq} precedes this session's first line {self.first}")
        while len(self._state) <= i:
            self._state.append(UNSENT)
            self._sends.append(0)
        return i

    def sent(self, seq: int, n_bytes: int) -> None:
        if seq:  # seq 0: the resume preamble's own lines, answered but not in the ledger
            i = self._grow(seq)
            if self._sends[i]:
                raise LedgerError(f"line {seq} would be sent a second time")
            if i and self._state[i - 1] == UNSENT:
                raise LedgerError(f"line {seq} sent before line {seq - 1}")
            self._sends[i] = 1
            self._state[i] = SENT
            if self.journal:
                self.journal.event(f"S {seq}")
        self._waiting.append((seq, n_bytes))

    def answered(self, ok: bool, code: int = 0) -> tuple[int, int]:
        """Match an ok/error to the oldest waiting line; returns (seq, its bytes)."""
        if not self._waiting:
            raise LedgerError(f"grbl answered {'ok' if ok else f'error:{code}'} with no line waiting")
        seq, n = self._waiting.popleft()
        if seq:
            self._state[seq - self.first] = OK if ok else ERROR
            if self.journal:
                self.journal.event(f"A {seq} {'ok' if ok else f'E{code}'}")
        return seq, n

    def discard_waiting(self) -> list[int]:
        """A soft reset emptied grbl's receive buffer: the waiting lines will never be answered."""
        gone = []
        while self._waiting:
            seq, _ = self._waiting.popleft()
            if seq:
                self._state[seq - self.first] = DISCARDED
                gone.append(seq)
                if self.journal:
                    self.journal.event(f"D {seq}")
        return gone

    @property
    def waiting(self) -> int:
        return len(self._waiting)

    @property
    def waiting_bytes(self) -> int:
        return sum(n for _, n in self._waiting)

    def state(self, seq: int) -> str:
        i = seq - self.first
        return STATE_NAMES[self._state[i]] if 0 <= i < len(self._state) else "unsent"

    def sends(self, seq: int) -> int:
        i = seq - self.first
        return self._sends[i] if 0 <= i < len(self._sends) else 0

    @property
    def last_sent(self) -> int:
        return self.first + len(self._state) - 1

    @property
    def last_acknowledged(self) -> int:
        """The last line of the unbroken run of `ok`s from the session's first line (first-1 if none)."""
        seq = self.first
        while seq - self.first < len(self._state) and self._state[seq - self.first] == OK:
            seq += 1
        return seq - 1

    def check(self) -> None:
        """Every line before `resume_from` sent exactly once and answered ok (or, after a
        lost connection, still waiting); every line at most once."""
        if any(s > 1 for s in self._sends):
            raise LedgerError("a line was sent more than once")
        if self.resume_from is None:
            raise LedgerError("the session has no resume point")
        waiting = {seq for seq, _ in self._waiting}
        for seq in range(self.first, self.resume_from):
            st = self._state[seq - self.first] if seq - self.first < len(self._state) else UNSENT
            if st == OK or (st == SENT and self.connection_lost and seq in waiting):
                continue
            raise LedgerError(f"line {seq} is before the resume point {self.resume_from} but is "
                              f"{STATE_NAMES[st]}")
