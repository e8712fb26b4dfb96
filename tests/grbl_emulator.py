"""A TEST DOUBLE for grbl 1.1's serial protocol -- not grbl.

It answers like grbl 1.1 as far as vcnc's link uses it, and is as strict as grbl
where being kind would hide a fault:
- a 128-byte RX buffer (taking 127 bytes, as forks whose ring is the buffer size do);
- a 15-block planner whose blocks run only after a cycle start: grbl starts the cycle
  when its RX buffer has no complete line left, when the planner is full, or before
  an M-code or dwell; until then it reports Idle with blocks queued. Blocks drain
  at `drain_s_per_block` (whole blocks, or with `partial_blocks` a hold stops inside one);
- a feed hold decelerates for `hold_decel_s` (Hold:1), then holds (Hold:0) and takes
  no more lines until `~`; a hold with no cycle running holds at once, nothing moved;
- a soft reset loses the planner and the RX buffer, resets the parser's modes, G92 and
  the tool length offset (G54-G59 stay), and raises ALARM:3 only if it came while moving;
- machine coordinates with G54-G59, G92, G53 and G10 L2/L20 (tests/grbl_double_parser.py),
  `$G`, `$#`, `$$`, `$I` (options: V, N with `line_numbers`, M with `mist`), `$X`, `$H`,
  `$C` check mode, `$J=` jogging with cancel 0x85, `$N=value` settings;
- status reports in the 1.1 format: MPos, Bf (when $10 has bit 2), Ln (built with
  line numbers, while a numbered block runs), FS, Ov (feed, rapid, spindle), WCO.
Faults are injected on purpose: an error or alarm on a chosen line, a dropped
connection, garbage bytes, slow answers, silence. Served over a pty pair or a
127.0.0.1 socket from a thread.
"""
from __future__ import annotations

import math
import re
import socket
import time
from collections import deque
from dataclasses import dataclass, field

from grbl_double_parser import ParserState
from machine.increments.receiver import Endpoint
from pty_endpoint import PtyEndpoint

BANNER = b"Grbl 1.1h ['$' for help]\r\n"
JOG_CANCEL = 0x85


@dataclass
class Faults:
    error_on: dict[str, int] = field(default_factory=dict)  # line text -> error code, once
    alarm_on: dict[str, int] = field(default_factory=dict)  # line text -> alarm code, once
    drop_after_lines: int | None = None  # close the connection after this many lines (once)
    hang_after_lines: int | None = None  # stop answering anything after this many lines
    garbage_every: int | None = None  # send garbage after every n-th ok
    ack_delay_s: float = 0.0  # time grbl spends on each line before answering
    realtime_delay_s: float = 0.0  # realtime bytes take effect this late ("within tens of ms")


DEFAULT_SETTINGS = {0: 10, 1: 25, 10: 3, 11: 0.01, 12: 0.002, 13: 0, 20: 0, 21: 0, 22: 0,
                    100: 250.0, 101: 250.0, 102: 250.0, 110: 6000.0, 111: 6000.0, 112: 6000.0,
                    120: 1000.0, 121: 1000.0, 122: 1000.0, 130: 2000.0, 131: 2000.0, 132: 2000.0}


class GrblDouble:
    """The protocol state machine; `receive` takes bytes, `tick` advances time; output in `outbox`.
    `pos` is the machine position; `executed` lists (line, machine target) as blocks ran."""

    def __init__(self, *, rx_size=128, planner_blocks=15, drain_s_per_block=0.0, wco=(5.0, -3.0, 1.0),
                 mpos=(0.0, 0.0, 0.0), settings=None, faults: Faults | None = None, partial_blocks: bool = False,
                 line_numbers: bool = False, mist: bool = True, hold_decel_s: float = 0.0,
                 early_discard: bool = False):
        self.rx_size, self.planner_blocks = rx_size, planner_blocks
        self.drain_s = drain_s_per_block
        self.partial_blocks = partial_blocks  # a hold stops inside the running block (lines and arcs)
        self.partials: list[tuple[str, tuple]] = []  # blocks cut short by a reset: (line, where)
        self.line_numbers, self.mist, self.hold_decel_s = line_numbers, mist, hold_decel_s
        # grbl drops a block from its planner once the stepper has prepared all of it, while it
        # still runs: Bf then counts one block less and Ln names the next line
        self.early_discard = early_discard
        self.settings = dict(settings or DEFAULT_SETTINGS)
        self.faults = faults or Faults()
        self.outbox = bytearray()
        self.rx = bytearray()
        self.max_rx_fill = 0
        self.rx_overflow = 0
        self.planner: deque = deque()  # (line, machine target, arc, N)
        self.pos = [float(v) for v in mpos]  # machine position
        self.gc = ParserState({c: [0.0, 0.0, 0.0] for c in (54, 55, 56, 57, 58, 59)}, self.pos)
        self.gc.offsets[54] = [float(v) for v in wco]
        self.executed: list[tuple[str, tuple | None]] = []  # (line, machine target) in the order it took effect
        self.moves_at_first_hold: int | None = None  # motions executed when the first feed hold took effect
        self.lines_received = 0
        self.received: list[str] = []  # every non-empty line as it arrived
        self.state, self.sub = "Idle", 0
        self.cycle = False  # a cycle start has been given: planner blocks run
        self.check_mode = False
        self.alarm_lock = False
        self.ov = [100, 100, 100]  # feed, rapid, spindle
        self.hung = False
        self._reports = 0
        self._realtime: deque = deque()  # (due time, byte)
        self._ov_reported = list(self.ov)
        self._t_block = 0.0
        self._hold_done = 0.0
        self._busy_until = 0.0
        self.outbox += BANNER

    @property
    def wco(self) -> tuple:
        return tuple(self.gc.wco)

    @property
    def wpos(self) -> list[float]:
        return [p - o for p, o in zip(self.pos, self.gc.wco)]

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

    def _moving(self) -> bool:
        return self.state in ("Run", "Jog", "Home") or (self.state == "Hold" and self.sub == 1)

    def _apply_realtime(self, now: float) -> None:
        while self._realtime and self._realtime[0][0] <= now:
            c = self._realtime.popleft()[1]
            if c == 0x3F:
                self._status(now)
            elif c == 0x21 and self.state in ("Idle", "Run"):
                self._drain(now)
                if self.moves_at_first_hold is None:
                    self.moves_at_first_hold = sum(target is not None for _, target in self.executed)
                if self.state == "Run":
                    if self.partial_blocks and self.planner and self.drain_s:
                        self.pos = self._inside(self.planner[0], min(1.0, (now - self._t_block) / self.drain_s))
                    self.state, self.sub, self._hold_done = "Hold", (1 if self.hold_decel_s else 0), \
                        now + self.hold_decel_s
                else:  # no cycle running: grbl holds at once, nothing moves
                    self.state, self.sub = "Hold", 0
                self.cycle = False
            elif c == 0x7E and self.state == "Hold" and self.sub == 0:
                self.cycle = bool(self.planner)
                self.state, self._t_block = ("Run" if self.planner else "Idle"), now
            elif c == 0x18:
                if self.partial_blocks and self.planner and self.pos != list(self.planner[0][1]):
                    self.partials.append((self.planner[0][0], tuple(self.pos)))
                self._reset()
            elif c == JOG_CANCEL and self.state == "Jog":
                self.planner.clear()
                self.state, self.cycle = "Idle", False
            elif 0x90 <= c <= 0x94:
                f = {0x90: 100, 0x91: self.ov[0] + 10, 0x92: self.ov[0] - 10, 0x93: self.ov[0] + 1,
                     0x94: self.ov[0] - 1}[c]
                self.ov[0] = min(200, max(10, f))
            elif 0x95 <= c <= 0x97:
                self.ov[1] = {0x95: 100, 0x96: 50, 0x97: 25}[c]
            elif 0x99 <= c <= 0x9D:
                s = {0x99: 100, 0x9A: self.ov[2] + 10, 0x9B: self.ov[2] - 10, 0x9C: self.ov[2] + 1,
                     0x9D: self.ov[2] - 1}[c]
                self.ov[2] = min(200, max(10, s))

    def _reset(self):
        moving = self._moving()
        self.rx.clear()
        self.planner.clear()
        self.cycle = False
        self._busy_until = 0.0
        if moving:
            self.outbox += b"ALARM:3\r\n"
            self.alarm_lock = True
        self.gc.reset(self.pos)
        self.check_mode = False
        self.state, self.sub = ("Alarm" if self.alarm_lock else "Idle"), 0
        self._reports = 0
        self.outbox += BANNER
        if self.alarm_lock:
            self.outbox += b"[MSG:'$H'|'$X' to unlock]\r\n"

    def _status(self, now: float):
        if self.state == "Hold" and self.sub == 1 and now >= self._hold_done:
            self.sub = 0
        mpos = ",".join(f"{p:.3f}" for p in self.pos)
        state = f"{self.state}:{self.sub}" if self.state == "Hold" else self.state
        s = f"<{state}|MPos:{mpos}"
        queued = list(self.planner)
        if self.early_discard and queued and self.state in ("Run", "Hold"):
            queued = queued[1:]
        if int(self.settings.get(10, 1)) & 2:
            s += f"|Bf:{self.planner_blocks - len(queued)},{self.rx_size - 1 - len(self.rx)}"
        if self.line_numbers and queued and queued[0][3] is not None:
            s += f"|Ln:{queued[0][3]}"
        s += f"|FS:{self.gc.feed:.0f},0"
        if self._reports % 10 == 0:
            s += "|WCO:" + ",".join(f"{o:.3f}" for o in self.gc.wco)
        elif self._reports % 10 == 1 or self.ov != self._ov_reported:  # Ov at once when it changed
            s += "|Ov:" + ",".join(str(v) for v in self.ov)
            self._ov_reported = list(self.ov)
        self._reports += 1
        self.outbox += (s + ">\r\n").encode()

    # --- time ---------------------------------------------------------------
    def tick(self, now: float) -> None:
        if self.hung:
            return
        self._apply_realtime(now)
        if self.state == "Hold" and self.sub == 1 and now >= self._hold_done:
            self.sub = 0
        self._drain(now)
        while not self.hung and now >= self._busy_until and not (self.state == "Hold" and self.sub == 0) \
                and (i := self.rx.find(b"\n")) >= 0:
            raw = bytes(self.rx[:i]).decode("ascii", "replace").rstrip("\r")
            line = re.sub(r"\s|\(.*?\)", "", raw).upper()
            moves = bool(re.search(r"[XYZ]", line)) and not line.startswith("$") and not self.check_mode
            if moves and len(self.planner) >= self.planner_blocks:
                self._cycle_start(now)  # a full planner starts the cycle (motion_control.c)
                break  # grbl takes the line only once a planner block is free
            if not moves and re.search(r"M|G4", line) and self.planner and not self.check_mode:
                self._cycle_start(now)  # M-codes and dwells wait for the planner to empty
                break
            del self.rx[: i + 1]
            self._line(raw, now)
            if self.faults.ack_delay_s:
                self._busy_until = now + self.faults.ack_delay_s
        if self.rx.find(b"\n") < 0 and self.planner:
            self._cycle_start(now)  # nothing left to parse: auto cycle start (protocol.c)
        self._drain(now)

    def _cycle_start(self, now: float) -> None:
        if self.state == "Idle" and not self.cycle and self.planner:
            self.cycle, self.state, self._t_block = True, "Run", now

    def _drain(self, now: float):
        while self.state in ("Run", "Jog") and self.planner and now - self._t_block >= self.drain_s:
            text, target, _, _ = self.planner.popleft()
            self.pos = list(target)
            self.executed.append((text, tuple(target)))
            self._t_block += self.drain_s if self.drain_s else 0.0
            if not self.drain_s:
                self._t_block = now
        if self.state in ("Run", "Jog") and not self.planner:
            self.state, self.cycle = "Idle", False

    def _inside(self, block, f: float) -> list[float]:
        """The point a fraction f along a block that starts at the machine position."""
        _, target, arc, _ = block
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
            self.alarm_lock, self.cycle = True, False
            self.state = "Alarm"
            self.outbox += f"ALARM:{code}\r\n".encode()
            return self._answer("error:9")
        if line.startswith("$"):
            return self._system(line, now)
        if self.state == "Alarm":
            return self._answer("error:9")
        code, block, effect = self.gc.parse(line, self.mist)
        if code == 0 and not self.check_mode:
            if block is not None:
                self.planner.append((line, *block))
            elif effect is not None and effect[0] in ("dwell", "mcode"):
                self.executed.append((line, None))
                if effect[0] == "mcode" and 0 in effect[1]:
                    self.state, self.sub = "Hold", 0
        self._answer("ok" if code == 0 else f"error:{code}")

    def _system(self, line: str, now: float):
        if line == "$$":
            for k in sorted(self.settings):
                self._answer(f"${k}={self.settings[k]:.3f}" if isinstance(self.settings[k], float)
                             else f"${k}={self.settings[k]}")
        elif line == "$I":
            opts = "V" + ("N" if self.line_numbers else "") + ("M" if self.mist else "")
            self._answer("[VER:1.1h.20190825:]")
            self._answer(f"[OPT:{opts},{self.planner_blocks},{self.rx_size}]")
        elif line == "$G":
            self._answer(self.gc.modal_report())
        elif line == "$#":
            for text in self.gc.params_report():
                self._answer(text)
        elif line == "$X":
            if self.state == "Alarm":
                self._answer("[MSG:Caution: Unlocked]")
                self.alarm_lock, self.state = False, "Idle"
        elif line == "$H":
            if not int(self.settings.get(22, 0)):
                return self._answer("error:5")
            self.pos = [0.0, 0.0, 0.0]
            self.gc.pos = list(self.pos)
            self.alarm_lock, self.state = False, "Idle"
        elif line == "$C":
            if self.state not in ("Idle", "Check"):
                return self._answer("error:8")
            if self.check_mode:
                self._answer("[MSG:Disabled]")
                self._answer("ok")
                self._reset()
                return
            self.check_mode, self.state = True, "Check"
            self._answer("[MSG:Enabled]")
        elif line.startswith("$J="):
            return self._jog(line[3:], now)
        elif m := re.match(r"^\$(\d+)=(-?[0-9.]+)$", line):
            if self.state not in ("Idle", "Alarm"):
                return self._answer("error:8")
            self.settings[int(m.group(1))] = float(m.group(2))
        else:
            return self._answer("error:3")
        self._answer("ok")

    def _jog(self, words: str, now: float):
        if self.state not in ("Idle", "Jog"):
            return self._answer("error:8")
        if re.search(r"G[0-3](?!\d)|M", words):
            return self._answer("error:16")
        if "F" not in words:
            return self._answer("error:22")
        saved = (self.gc.motion, self.gc.incremental, self.gc.inch, self.gc.feed)
        code, block, _ = self.gc.parse("G1" + words, self.mist)
        self.gc.motion, self.gc.incremental, self.gc.inch, self.gc.feed = saved  # a jog leaves the modes alone
        if code == 0 and block is not None:
            self.planner.append(("$J=" + words, *block))
            self.state, self._t_block = "Jog", now
        self._answer("ok" if code == 0 else f"error:{code}")


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
