"""A TEST DOUBLE for grbl 1.1's serial protocol -- not grbl.

It answers like grbl 1.1 as far as vcnc's link uses it: a 128-byte RX buffer (taking
127 bytes, as forks whose ring is the buffer size do; grbl 1.1 on AVR takes 128), a
15-block planner drained at a configurable rate (whole blocks: the position jumps to
each block's end, or with `partial_blocks` a hold stops inside one), ok / error:N / ALARM:N,
1.1-format status reports (MPos + WCO, Bf, FS, Ov), realtime bytes (? ! ~ 0x18,
feed overrides 0x90-0x94), `$$`, `$I`, `$X`, and a small G-code subset (G0-G4,
G17-G19, G21, G90, G91.1, G94, M0-M9, M30). Faults are injected on purpose: an error
or alarm on a chosen line, a dropped connection, garbage bytes, slow answers, silence.
Served over a pty pair or a 127.0.0.1 socket from a thread.
"""
from __future__ import annotations

import math
import re
import socket
import time
from collections import deque
from dataclasses import dataclass, field

from machine.increments.receiver import Endpoint, PtyEndpoint

BANNER = b"Grbl 1.1h ['$' for help]\r\n"
WORD_RE = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+))")


@dataclass
class Faults:
    error_on: dict[str, int] = field(default_factory=dict)  # line text -> error code, once
    alarm_on: dict[str, int] = field(default_factory=dict)  # line text -> alarm code, once
    drop_after_lines: int | None = None  # close the connection after this many lines (once)
    hang_after_lines: int | None = None  # stop answering anything after this many lines
    garbage_every: int | None = None  # send garbage after every n-th ok
    ack_delay_s: float = 0.0  # time grbl spends on each line before answering
    realtime_delay_s: float = 0.0  # realtime bytes take effect this late ("within tens of ms")


class GrblDouble:
    """The protocol state machine; `receive` takes bytes, `tick` advances time; output in `outbox`."""

    def __init__(self, *, rx_size=128, planner_blocks=15, drain_s_per_block=0.0, wco=(5.0, -3.0, 1.0),
                 settings=None, faults: Faults | None = None, partial_blocks: bool = False):
        self.rx_size, self.planner_blocks = rx_size, planner_blocks
        self.drain_s = drain_s_per_block
        self.partial_blocks = partial_blocks  # a hold stops inside the running block (lines and arcs)
        self.partials: list[tuple[str, tuple]] = []  # blocks cut short by a reset: (line, where)
        self.wco = tuple(wco)
        self.settings = settings or {0: 10, 1: 25, 10: 3, 11: 0.01, 12: 0.002, 13: 0, 20: 0, 21: 0, 22: 0,
                                     100: 250.0, 101: 250.0, 102: 250.0, 110: 6000.0, 111: 6000.0,
                                     112: 6000.0, 120: 1000.0, 121: 1000.0, 122: 1000.0,
                                     130: 2000.0, 131: 2000.0, 132: 2000.0}
        self.faults = faults or Faults()
        self.outbox = bytearray()
        self.rx = bytearray()
        self.max_rx_fill = 0
        self.rx_overflow = 0
        self.planner: deque = deque()
        self.pos = [0.0, 0.0, 0.0]  # work coordinates of the machine
        self.executed: list[tuple[str, tuple | None]] = []  # (line, target) in the order it took effect
        self.lines_received = 0
        self.received: list[str] = []  # every non-empty line as it arrived
        self.state, self.sub = "Idle", 0
        self.alarm_lock = False
        self.feed_ov = 100
        self.hung = False
        self._reports = 0
        self._realtime: deque = deque()  # (due time, byte)
        self._ov_reported = 100
        self._t_block = 0.0
        self._busy_until = 0.0
        self._reset_modal()
        self.outbox += BANNER

    def _reset_modal(self):
        self.parser_pos = list(self.pos)
        self.motion, self.feed, self.plane = 0, None, 17

    # --- bytes in ---------------------------------------------------------
    def receive(self, data: bytes, now: float) -> None:
        if self.hung:
            return
        for c in data:
            if c in b"?!~\x18" or c >= 0x80:
                self._realtime.append((now + self.faults.realtime_delay_s, c))
            elif len(self.rx) >= self.rx_size - 1:
                self.rx_overflow += 1
            else:
                self.rx.append(c)
                self.max_rx_fill = max(self.max_rx_fill, len(self.rx))
        self._apply_realtime(now)

    def _apply_realtime(self, now: float) -> None:
        while self._realtime and self._realtime[0][0] <= now:
            c = self._realtime.popleft()[1]
            if c == 0x3F:
                self._status()
            elif c == 0x21:
                if self.state == "Run" or (self.state == "Idle" and self.planner):
                    self._drain(now)
                    if self.partial_blocks and self.planner and self.drain_s:
                        self.pos = self._inside(self.planner[0], min(1.0, (now - self._t_block) / self.drain_s))
                    self.state, self.sub = "Hold", 0
            elif c == 0x7E:
                if self.state == "Hold":
                    self.state, self._t_block = ("Run" if self.planner else "Idle"), now
            elif c == 0x18:
                if self.partial_blocks and self.planner and self.pos != list(self.planner[0][1]):
                    self.partials.append((self.planner[0][0], tuple(self.pos)))
                self._reset()
            elif 0x90 <= c <= 0x94:
                self.feed_ov = {0x90: 100, 0x91: self.feed_ov + 10, 0x92: self.feed_ov - 10,
                                0x93: self.feed_ov + 1, 0x94: self.feed_ov - 1}[c]
                self.feed_ov = min(200, max(10, self.feed_ov))

    def _reset(self):
        moving = self.state == "Run" or (self.state == "Idle" and self.planner)
        self.rx.clear()
        self.planner.clear()
        self._busy_until = 0.0
        if moving:
            self.outbox += b"ALARM:3\r\n"
            self.alarm_lock = True
        self._reset_modal()
        self.state = "Alarm" if self.alarm_lock else "Idle"
        self._reports = 0
        self.outbox += BANNER
        if self.alarm_lock:
            self.outbox += b"[MSG:'$H'|'$X' to unlock]\r\n"

    def _status(self):
        mpos = ",".join(f"{p + o:.3f}" for p, o in zip(self.pos, self.wco))
        state = f"{self.state}:{self.sub}" if self.state == "Hold" else self.state
        free_rx = self.rx_size - 1 - len(self.rx)
        feed = self.feed or 0.0
        s = f"<{state}|MPos:{mpos}|Bf:{self.planner_blocks - len(self.planner)},{free_rx}|FS:{feed:.0f},0"
        if self._reports % 10 == 0:
            s += "|WCO:" + ",".join(f"{o:.3f}" for o in self.wco)
        elif self._reports % 10 == 1 or self.feed_ov != self._ov_reported:  # Ov at once when it changed
            s += f"|Ov:{self.feed_ov},100,100"
            self._ov_reported = self.feed_ov
        self._reports += 1
        self.outbox += (s + ">\r\n").encode()

    # --- time ---------------------------------------------------------------
    def tick(self, now: float) -> None:
        if self.hung:
            return
        self._apply_realtime(now)
        self._drain(now)
        while not self.hung and now >= self._busy_until and (i := self.rx.find(b"\n")) >= 0:
            raw = bytes(self.rx[:i]).decode("ascii", "replace").rstrip("\r")
            line = re.sub(r"\s|\(.*?\)", "", raw).upper()
            moves = bool(re.search(r"[XYZ]", line)) and not line.startswith("$")
            if moves and len(self.planner) >= self.planner_blocks:
                break  # grbl takes the line only once a planner block is free
            if not moves and ("M" in line or line.startswith("G4")) and self.planner:
                break  # M-codes and dwells wait for the planner to empty
            del self.rx[: i + 1]
            self._line(raw, now)
            if self.faults.ack_delay_s:
                self._busy_until = now + self.faults.ack_delay_s
        self._drain(now)

    def _drain(self, now: float):
        if self.state == "Idle" and self.planner:
            self.state, self._t_block = "Run", now
        while self.state == "Run" and self.planner and now - self._t_block >= self.drain_s:
            text, target, _ = self.planner.popleft()
            self.pos = list(target)
            self.executed.append((text, tuple(target)))
            self._t_block += self.drain_s if self.drain_s else 0.0
            if not self.drain_s:
                self._t_block = now
        if self.state == "Run" and not self.planner:
            self.state = "Idle"

    def _inside(self, block, f: float) -> list[float]:
        """The point a fraction f along a block that starts at the machine position."""
        _, target, arc = block
        s = self.pos
        if arc is None:
            return [p + f * (t - p) for p, t in zip(s, target)]
        a, b, n, ca, cb, ccw = arc
        a0 = math.atan2(s[b] - cb, s[a] - ca)
        a1 = math.atan2(target[b] - cb, target[a] - ca)
        sweep = (a1 - a0) % (2 * math.pi) if ccw else -((a0 - a1) % (2 * math.pi))
        sweep = sweep or (2 * math.pi if ccw else -2 * math.pi)
        r = math.hypot(s[a] - ca, s[b] - cb)
        out = list(s)
        out[a], out[b] = ca + r * math.cos(a0 + f * sweep), cb + r * math.sin(a0 + f * sweep)
        out[n] = s[n] + f * (target[n] - s[n])
        return out

    # --- lines ------------------------------------------------------------
    def _answer(self, text: str):
        self.outbox += (text + "\r\n").encode()
        if text == "ok" and self.faults.garbage_every and self.lines_received % self.faults.garbage_every == 0:
            self.outbox += b"\x00\xfe\xffzz#garbage\r\nok?\xc3\r\n"

    def _line(self, raw: str, now: float):
        line = re.sub(r"\s|\(.*?\)", "", raw).upper()
        if line:
            self.lines_received += 1
            self.received.append(raw)
        f = self.faults
        if f.hang_after_lines is not None and self.lines_received > f.hang_after_lines:
            self.hung = True
            return
        if len(line) > 79:
            return self._answer("error:11")
        if not line:
            return self._answer("ok")
        if line in f.error_on:
            return self._answer(f"error:{f.error_on.pop(line)}")
        if line in f.alarm_on:
            code = f.alarm_on.pop(line)
            self.planner.clear()
            self.alarm_lock = True
            self.state = "Alarm"
            self.outbox += f"ALARM:{code}\r\n".encode()
            return self._answer("error:9")
        if line.startswith("$"):
            return self._system(line)
        if self.state == "Alarm":
            return self._answer("error:9")
        code = self._gcode(line)
        self._answer("ok" if code == 0 else f"error:{code}")

    def _system(self, line: str):
        if line == "$$":
            for k in sorted(self.settings):
                self._answer(f"${k}={self.settings[k]:.3f}" if isinstance(self.settings[k], float)
                             else f"${k}={self.settings[k]}")
        elif line == "$I":
            self._answer("[VER:1.1h.20190825:]")
            self._answer(f"[OPT:V,{self.planner_blocks},{self.rx_size}]")
        elif line == "$X":
            if self.state == "Alarm":
                self._answer("[MSG:Caution: Unlocked]")
                self.alarm_lock, self.state = False, "Idle"
        else:
            return self._answer("error:3")
        self._answer("ok")

    def _gcode(self, line: str) -> int:
        pos = 0
        words: dict[str, float] = {}
        gs, ms = [], []
        for m in WORD_RE.finditer(line):
            if m.start() != pos:
                return 1
            pos = m.end()
            letter, value = m.group(1), float(m.group(2))
            if letter == "G":
                gs.append(value)
            elif letter == "M":
                ms.append(value)
            elif letter in words:
                return 25
            elif letter in "XYZIJKFPSTN":
                words[letter] = value
            else:
                return 20
        if pos != len(line):
            return 2 if pos else 1
        motion = self.motion
        for g in gs:
            if g in (0, 1, 2, 3):
                motion = int(g)
            elif g in (17, 18, 19):
                self.plane = int(g)
            elif g == 4:
                if "P" not in words:
                    return 28
                self.executed.append((line, None))
                return 0
            elif g not in (21, 90, 91.1, 94, 54):
                return 20
        for m in ms:
            if m not in (0, 1, 2, 30, 3, 4, 5, 7, 8, 9):
                return 20
            if m == 0:
                self.state, self.sub = "Hold", 0
        if "F" in words:
            self.feed = words["F"]
        axes = [words.get(a) for a in "XYZ"]
        if any(a is not None for a in axes):
            target = [p if a is None else a for p, a in zip(self.parser_pos, axes)]
            if motion in (1, 2, 3) and not self.feed:
                return 22
            if motion in (2, 3):
                a, b = {17: (0, 1), 18: (2, 0), 19: (1, 2)}[self.plane]
                off = {0: "I", 1: "J", 2: "K"}
                if off[a] not in words and off[b] not in words:
                    return 35
                ca = self.parser_pos[a] + words.get(off[a], 0.0)
                cb = self.parser_pos[b] + words.get(off[b], 0.0)
                r0 = math.hypot(self.parser_pos[a] - ca, self.parser_pos[b] - cb)
                r1 = math.hypot(target[a] - ca, target[b] - cb)
                if abs(r0 - r1) > max(0.005, 0.001 * r0):
                    return 33
            arc = None
            if motion in (2, 3):
                n = 3 - a - b
                arc = (a, b, n, ca, cb, motion == 3)
            self.motion = motion
            self.parser_pos = target
            self.planner.append((line, tuple(target), arc))
        elif ms or (not gs and words.keys() - {"F"}):
            self.executed.append((line, None))
        return 0


class PtyServer(PtyEndpoint):
    """The double on the master side of a pty pair; `port` is the slave's device path."""


class SocketServer(Endpoint):
    """The double behind 127.0.0.1:<port>; serves one connection after another, keeping
    its machine state across them (like a board whose host went away)."""

    def __init__(self, double: GrblDouble, *, banner_on_connect: bool = True):
        super().__init__(double)
        self.banner_on_connect = banner_on_connect
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(1)
        self.sock.settimeout(0.01)
        self.port = f"socket://127.0.0.1:{self.sock.getsockname()[1]}"
        self.connections = 0

    def _run(self):
        d = self.target
        while not self._stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except socket.timeout:
                d.tick(time.monotonic())
                d.outbox.clear()  # nobody listening: what grbl sends is lost
                continue
            self.connections += 1
            if not self.banner_on_connect:
                d.outbox.clear()
            start = d.lines_received
            with conn:
                while not self._stop.is_set():
                    if not self._pump(conn, lambda: conn.recv(4096), conn.sendall):
                        break
                    drop = d.faults.drop_after_lines
                    if drop is not None and d.lines_received - start >= drop:
                        d.faults.drop_after_lines = None
                        break
        self.sock.close()
