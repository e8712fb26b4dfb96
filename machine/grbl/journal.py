"""The ledger on disk: every line sent and acknowledged, so a stream killed outright
(SIGKILL, power) still knows where it stood.

One text file, appended with O_APPEND (each event is in the kernel once written, so
it survives the process). A session starts with a JSON header line: the program, its
SHA-256, the machine state the stream was computed from, whether lines carry N
numbers, grbl's planner size. Events follow, one a line: `S seq` sent, `A seq ok` /
`A seq E<code>` answered, `D seq` discarded by a reset, `R seq partial x y z` the
resume point a stop worked out (machine mm), `C seq` completed up to seq. `vcnc stream
--resume` reads the last session: a resume point if one was written; otherwise the
last acknowledged and last sent lines bound the window in which the machine position
decides (machine.grbl.resume).
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

from machine.grbl.state import MachineState

FORMAT = "vcnc-grbl-ledger 1"
SUFFIX = ".vcnc-ledger"


class JournalError(ValueError):
    """The ledger file is missing, not a ledger, or for another program."""


def default_path(program) -> Path:
    return Path(str(program) + SUFFIX)


def program_hash(program) -> str:
    return hashlib.sha256(Path(program).read_bytes()).hexdigest()


class Journal:
    def __init__(self, path, header: dict):
        self.path = Path(path)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        self._write(json.dumps({"format": FORMAT, **header}, sort_keys=True))

    def _write(self, text: str) -> None:
        os.write(self._fd, (text + "\n").encode("ascii"))

    def event(self, text: str) -> None:
        self._write(text)

    def close(self) -> None:
        os.close(self._fd)


@dataclass
class Session:
    header: dict
    sent: list[int] = field(default_factory=list)
    acked: dict[int, str] = field(default_factory=dict)
    resume: tuple | None = None  # (seq, partial, (x, y, z))
    completed: int | None = None

    @property
    def state(self) -> MachineState:
        return MachineState.from_json(self.header["state"])

    @property
    def last_acknowledged(self) -> int:
        seq = self.header["first"] - 1
        while self.acked.get(seq + 1) == "ok":
            seq += 1
        return seq

    @property
    def last_sent(self) -> int:
        return max(self.sent, default=self.header["first"] - 1)


def read_sessions(path) -> list[Session]:
    path = Path(path)
    if not path.exists():
        raise JournalError(f"{path}: no ledger (a stream writes one beside the program, or to --ledger FILE)")
    sessions: list[Session] = []
    for n, raw in enumerate(path.read_text("ascii", "replace").splitlines(), 1):
        if raw.startswith("{"):
            try:
                header = json.loads(raw)
            except json.JSONDecodeError:
                if n == len(path.read_text().splitlines()):
                    break  # the last line was cut off by a kill
                raise JournalError(f"{path}:{n}: not a ledger header") from None
            if header.get("format") != FORMAT:
                raise JournalError(f"{path}:{n}: not a {FORMAT} file")
            sessions.append(Session(header))
            continue
        if not sessions:
            raise JournalError(f"{path}:{n}: event before any header")
        s, parts = sessions[-1], raw.split()
        try:
            if parts[0] == "S":
                s.sent.append(int(parts[1]))
            elif parts[0] == "A":
                s.acked[int(parts[1])] = parts[2]
            elif parts[0] == "R":
                s.resume = (int(parts[1]), parts[2] == "1", tuple(float(v) for v in parts[3:6]))
            elif parts[0] == "C":
                s.completed = int(parts[1])
        except (IndexError, ValueError):
            continue  # a line cut off by a kill
    if not sessions:
        raise JournalError(f"{path}: empty ledger")
    return sessions
