"""A session with a grbl 1.1 board over pyserial's `serial_for_url` (a device path,
socket://host:port, rfc2217://host:port or loop://).

Streaming uses grbl's character-counting protocol: the bytes of the lines not yet
answered never exceed the RX buffer (the size `$I` reports, else 128), so grbl always
has its next line at hand and never loses a byte. `?` is polled every
`poll_interval_s`. A stop (error:N, ALARM:N) holds the feed, soft-resets grbl once
it stands still (no alarm, position kept) and reads where the machine stopped, from
which `find_resume` names the line to resume from.
"""
from __future__ import annotations

import queue
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Callable, Iterable

import serial

from machine.grbl import protocol as P
from machine.grbl.ledger import Fault, Ledger
from machine.grbl.program import StreamLine, resume_text
from machine.grbl.resume import ResumeError, ResumePoint, find_resume


class LinkError(RuntimeError):
    """The board did not behave like grbl 1.1 (no banner, no status, refused a command)."""


@dataclass(slots=True)
class ConnectInfo:
    banner: str
    settings: dict[int, float]
    build: P.BuildInfo
    warnings: list[str]
    alarm: bool


@dataclass(slots=True)
class StreamResult:
    completed: bool
    ledger: Ledger
    fault: Fault | None = None
    resume: ResumePoint | None = None  # where the next session continues (None after a lost connection)
    status: P.Status | None = None
    rx_fill: list[int] = field(default_factory=list)  # unanswered bytes after each send


class GrblLink:
    def __init__(self, url: str, *, baud: int = 115200, poll_interval_s: float = 0.2,
                 stall_timeout_s: float = 10.0, settle_s: float = 0.1, reset_timeout_s: float = 5.0,
                 idle_timeout_s: float = 600.0, read_timeout_s: float = 0.005):
        self.url = url
        self.poll_interval_s = poll_interval_s
        self.stall_timeout_s = stall_timeout_s
        self.settle_s = settle_s
        self.reset_timeout_s = reset_timeout_s
        self.idle_timeout_s = idle_timeout_s
        self.ser = serial.serial_for_url(url, baudrate=baud, timeout=read_timeout_s, write_timeout=5.0)
        self.rx_size = P.RX_BUFFER_DEFAULT
        self.planner_blocks = P.PLANNER_BLOCKS_DEFAULT
        self.status: P.Status | None = None
        self.garbage: list[str] = []
        self.messages: list[str] = []
        self.alarm: int | None = None
        self._wco = None
        self._buf = bytearray()
        self._last_rx = time.monotonic()
        self._realtime: queue.Queue[bytes] = queue.Queue()

    # --- bytes in and out -------------------------------------------------
    def close(self) -> None:
        self.ser.close()

    def realtime(self, byte: bytes) -> None:
        """Queue a realtime command (`?`, `!`, `~`, 0x18, 0x90-0x94); safe from another thread."""
        if len(byte) != 1 or byte[0] not in P.REALTIME_BYTES:
            raise ValueError(f"{byte!r} is not a grbl realtime command")
        self._realtime.put(byte)

    def _write(self, data: bytes) -> None:
        self.ser.write(data)

    def _flush_realtime(self) -> None:
        while not self._realtime.empty():
            self._write(self._realtime.get_nowait())

    def _read(self) -> list[P.Response]:
        """Whatever complete lines have arrived (waits at most one read timeout)."""
        data = self.ser.read(1)
        if data:
            n = self.ser.in_waiting
            if n:
                data += self.ser.read(n)
            self._last_rx = time.monotonic()
            self._buf += data
        out = []
        while (i := self._buf.find(b"\n")) >= 0:
            raw, self._buf = bytes(self._buf[:i]).rstrip(b"\r"), self._buf[i + 1:]
            if not raw.strip():
                continue
            r = P.classify(raw)
            if r.kind == "status":
                try:
                    self.status = P.parse_status(r.text, self._wco)
                    self._wco = self.status.wco
                except P.StatusError:
                    r = P.Response("garbage", r.text)
            if r.kind == "garbage":
                self.garbage.append(r.text)
            elif r.kind == "feedback":
                self.messages.append(r.text)
            elif r.kind == "alarm":
                self.alarm = r.code
            out.append(r)
        return out

    def _until(self, want: Callable[[P.Response], bool], timeout_s: float, poll: bool = False) -> list[P.Response]:
        """Read until a response satisfies `want`; returns everything read, that one last."""
        got, t_end, t_poll = [], time.monotonic() + timeout_s, 0.0
        while time.monotonic() < t_end:
            if poll and time.monotonic() - t_poll >= self.poll_interval_s:
                self._write(P.STATUS_QUERY)
                t_poll = time.monotonic()
            for r in self._read():
                got.append(r)
                if want(r):
                    return got
        raise LinkError(f"{self.url}: no answer within {timeout_s:g} s (last lines: "
                        f"{[r.text for r in got[-3:]]})")

    def query_status(self, timeout_s: float = 2.0) -> P.Status:
        self._write(P.STATUS_QUERY)
        self._until(lambda r: r.kind == "status", timeout_s)
        return self.status

    def wait_state(self, states: tuple[str, ...], timeout_s: float) -> P.Status:
        self._until(lambda r: r.kind == "status" and self.status.state in states, timeout_s, poll=True)
        return self.status

    def command(self, text: str, timeout_s: float = 5.0) -> list[str]:
        """Send one line outside a stream and return grbl's lines before its `ok`."""
        if len(text) > P.MAX_LINE_CHARS:
            raise LinkError(f"{text!r} is longer than grbl's {P.MAX_LINE_CHARS}-character line buffer")
        self._write(text.encode("ascii") + b"\n")
        got = self._until(lambda r: r.kind in ("ok", "error"), timeout_s)
        if got[-1].kind == "error":
            raise LinkError(f"grbl refused {text!r}: error:{got[-1].code} {P.error_meaning(got[-1].code)}")
        return [r.text for r in got[:-1] if r.kind not in ("status", "garbage")]

    def soft_reset(self, ledger: Ledger | None = None) -> str:
        """0x18 and wait for the banner; answers that beat the reset still count, the rest is dropped."""
        self._write(P.SOFT_RESET)
        t_end = time.monotonic() + self.reset_timeout_s
        while time.monotonic() < t_end:
            for r in self._read():
                if r.kind in ("ok", "error") and ledger is not None and ledger.waiting:
                    ledger.answered(r.kind == "ok", r.code)
                elif r.kind == "banner":
                    if ledger is not None:
                        ledger.discard_waiting()
                    self._wco = None
                    self._settle()
                    return r.text
        raise LinkError(f"{self.url}: no 'Grbl 1.1x ['$' for help]' banner after a soft reset")

    def _settle(self) -> None:
        t_end = time.monotonic() + self.settle_s
        while time.monotonic() < t_end:
            self._read()

    # --- session ------------------------------------------------------------
    def connect(self, config=None, *, unlock: bool = False) -> ConnectInfo:
        """Wake grbl (if `?` gets no answer), wait for any motion to finish, soft-reset it into
        a known state and read its settings and build info; warn where $110-$122 disagree
        with `config`. With `unlock`, an alarm is cleared with $X."""
        # `?` first: a wake's line ends would complete (and run) a partial line a previous
        # session left in grbl's RX buffer, while the soft reset below clears it.
        try:
            st = self.query_status(timeout_s=self.reset_timeout_s / 2)
        except LinkError:
            self._write(P.WAKE)
            self._settle()
            st = self.query_status(timeout_s=self.reset_timeout_s)
        if st.state in ("Run", "Jog", "Home"):
            st = self.wait_state(("Idle", "Alarm", "Hold"), self.idle_timeout_s)
        if st.state in ("Hold", "Door"):
            raise LinkError(f"grbl is in {st.state}; resume it (~) or reset it before streaming")
        self.alarm = None
        banner = self.soft_reset()
        if not P.BANNER_RE.match(banner).group(1).startswith("1.1"):
            raise LinkError(f"{banner!r}: vcnc streams to grbl 1.1 only")
        st = self.query_status()
        if st.state == "Alarm" and unlock:
            self.messages += self.command("$X")
            st = self.query_status()
        settings = P.parse_settings(self.command("$$"))
        build = P.parse_build_info(self.command("$I"))
        if build.rx_buffer_bytes:
            self.rx_size, self.planner_blocks = build.rx_buffer_bytes, build.planner_blocks
        warnings = P.compare_settings(settings, config) if config is not None else []
        if settings.get(13, 0.0):
            warnings.append("grbl reports in inches ($13=1); vcnc reads positions as mm")
        if 10 in settings and not int(settings[10]) & 2:
            mask = int(settings[10])
            warnings.append(f"grbl's status reports carry no planner or RX buffer state ($10={mask}); "
                            f"set $10={mask | 2} to see planner blocks free")
        return ConnectInfo(banner, settings, build, warnings, st.state == "Alarm")

    def stream(self, lines: Iterable[StreamLine], ledger: Ledger, *, resume: ResumePoint | None = None,
               on_progress: Callable[["GrblLink", Ledger], None] | None = None,
               progress_interval_s: float = 0.1) -> StreamResult:
        """Send `lines` with character counting until all are answered or something stops it.
        With `resume`, the modal state in force before its line is restored first and a
        partial line is sent from the machine position."""
        if self.status is not None and self.status.state == "Alarm":
            raise LinkError("grbl is in alarm: unlock it ($X, `--unlock`) or home it before streaming")
        it = iter(lines)
        setup: deque[str] = deque()
        nxt = next(it, None)
        if resume is not None and nxt is not None:
            setup.extend(nxt.restore)
            if resume.partial:
                nxt = StreamLine(nxt.seq, nxt.source_line, resume_text(nxt, resume.at_mm), resume.at_mm,
                                 nxt.end_mm, True, nxt.restore, nxt.arc)
        recent: deque[StreamLine] = deque(maxlen=4 * (self.planner_blocks + 1) + self.rx_size)
        result = StreamResult(False, ledger)
        budget = self.rx_size - 1  # grbl 1.1 holds the full size (ring of size+1); some forks hold one less
        t_poll = t_prog = 0.0
        self._last_rx = time.monotonic()
        try:
            while True:
                while setup or nxt is not None:  # fill grbl's RX buffer as far as it goes
                    seq, text = (0, setup[0]) if setup else (nxt.seq, nxt.text)
                    data = text.encode("ascii") + b"\n"
                    if len(data) > P.MAX_LINE_CHARS + 1:
                        raise LinkError(f"stream line {seq} has {len(data) - 1} characters; grbl takes "
                                        f"{P.MAX_LINE_CHARS}")
                    if ledger.waiting_bytes + len(data) > budget:
                        break
                    self._write(data)
                    ledger.sent(seq, len(data))
                    result.rx_fill.append(ledger.waiting_bytes)
                    if setup:
                        setup.popleft()
                    else:
                        recent.append(nxt)
                        nxt = next(it, None)
                now = time.monotonic()
                draining = nxt is None and not setup and not ledger.waiting
                if now - t_poll >= (self.poll_interval_s / 4 if draining else self.poll_interval_s):
                    self._write(P.STATUS_QUERY)
                    t_poll = now
                self._flush_realtime()
                idle = False
                for r in self._read():
                    if r.kind in ("ok", "error"):
                        seq, _ = ledger.answered(r.kind == "ok", r.code)
                        if r.kind == "error" and result.fault is None:
                            line = next((l for l in recent if l.seq == seq), None)
                            src = line.source_line if line else 0
                            what = f"stream line {seq} (program line {src}, {line.text if line else ''!r})"
                            result.fault = Fault("error", f"grbl error:{r.code} on {what}: "
                                                 f"{P.error_meaning(r.code)}", seq, src)
                    elif r.kind == "alarm" and (result.fault is None or result.fault.kind != "alarm"):
                        result.fault = Fault("alarm", f"grbl ALARM:{r.code}: {P.alarm_meaning(r.code)} "
                                             f"Clear it with $X (or home, or reset) before resuming.", 0, 0)
                    elif r.kind == "banner":
                        result.fault = Fault("alarm", "grbl was reset during the stream (0x18, its reset pin "
                                             "or power)", 0, 0)
                        ledger.discard_waiting()
                    elif r.kind == "status" and draining:
                        idle = self.status.state == "Idle"
                if on_progress and now - t_prog >= progress_interval_s:
                    on_progress(self, ledger)
                    t_prog = now
                if result.fault:
                    self._stop(result, recent)
                    return result
                if idle:  # every line answered and the machine has run them all
                    result.completed = True
                    ledger.resume_from = (recent[-1].seq + 1) if recent else ledger.first
                    result.status = self.status
                    if on_progress:
                        on_progress(self, ledger)
                    return result
                if time.monotonic() - self._last_rx > self.stall_timeout_s:
                    result.fault = Fault("stalled", f"grbl stopped answering for {self.stall_timeout_s:g} s",
                                         0, 0)
                    self._lost(result, recent)
                    return result
        except (serial.SerialException, OSError) as exc:
            result.fault = Fault("disconnected", f"the port closed: {exc}", 0, 0)
            self._lost(result, recent)
            return result

    def _lost(self, result: StreamResult, recent: deque[StreamLine]) -> None:
        ledger = result.ledger
        ledger.connection_lost = True
        last = ledger.last_acknowledged
        result.fault.seq = last
        result.fault.source_line = next((l.source_line for l in recent if l.seq == last), 0)
        result.fault.message += (f"; last acknowledged stream line {last} (program line "
                                 f"{result.fault.source_line}); lines {last + 1}..{ledger.last_sent} "
                                 f"were sent without an answer. Reconnect and resume with "
                                 f"--resume-from {last + 1}: vcnc checks where the machine stands first.")

    def _stop(self, result: StreamResult, recent: deque[StreamLine]) -> None:
        """Hold, let the answers for lines grbl already has arrive, reset once still, find the resume line."""
        ledger = result.ledger
        self._write(P.FEED_HOLD)
        t_end = time.monotonic() + self.reset_timeout_s
        t_poll = t_answer = 0.0
        still = False
        done = None  # set when the hold finds grbl idle: every line answered ok by then has run
        while time.monotonic() < t_end:
            now = time.monotonic()
            if still and (not ledger.waiting or now - t_answer > self.settle_s):
                break  # lines grbl holds back until the planner empties will never be answered
            if now - t_poll >= self.poll_interval_s / 4:
                self._write(P.STATUS_QUERY)
                t_poll = now
            for r in self._read():
                if r.kind in ("ok", "error") and ledger.waiting:
                    ledger.answered(r.kind == "ok", r.code)
                    t_answer = time.monotonic()
                elif r.kind == "status":
                    was = still
                    still = self.status.state in ("Idle", "Alarm") or (self.status.state == "Hold"
                                                                       and self.status.substate == 0)
                    if still and not was:
                        t_answer = max(t_answer, time.monotonic())
                        if self.status.state == "Idle":
                            done = ledger.last_acknowledged
        self.soft_reset(ledger)
        st = self.query_status()
        result.status = st
        if st.wpos is None:
            raise LinkError("grbl gave no work position (WCO missing) after the reset")
        if done is not None:
            window = [l for l in recent if l.seq > done]
        else:
            window = _window(list(recent), ledger, self.planner_blocks)
        try:
            result.resume = find_resume(window, st.wpos)
        except ResumeError as exc:
            result.fault.message += f"; {exc}"
            return
        ledger.resume_from = result.resume.seq
        if result.fault.kind == "error" and 0 < result.fault.seq < result.resume.seq:
            # grbl goes on with the lines already in its buffer after an error: character
            # counting cannot take them back, and the hold may come too late to stop them
            result.fault.message += (f"; WARNING: grbl ran stream lines {result.fault.seq + 1}.."
                                     f"{result.resume.seq - 1} after rejecting line {result.fault.seq}, so "
                                     f"that line's motion was not made")
        result.fault.message += (f"; machine stopped at X{st.wpos[0]:.3f} Y{st.wpos[1]:.3f} Z{st.wpos[2]:.3f}; "
                                 f"resume with --resume-from {result.resume.seq}")

    def resume_point(self, lines: Iterable[StreamLine],
                     max_lines: int = 256) -> tuple[ResumePoint, list[StreamLine]]:
        """Where the machine stands on the stream that starts with `lines` (a new session's
        --resume-from): returns the point and the lines read ahead for it."""
        st = self.query_status()
        if st.wpos is None:
            raise LinkError("grbl gave no work position (WCO missing)")
        window = []
        for line in lines:
            window.append(line)
            if len(window) >= max_lines:
                break
        return find_resume(window, st.wpos), window


def _window(recent: list[StreamLine], ledger: Ledger, planner_blocks: int) -> list[StreamLine]:
    """The recent lines that may not have run: from planner_blocks + 1 motion lines before
    the last acknowledged one (grbl plans at most that many ahead) to the last sent."""
    last_ok = ledger.last_acknowledged
    idx = next((i for i, l in enumerate(recent) if l.seq > last_ok), len(recent))
    motions = 0
    while idx > 0 and motions <= planner_blocks:
        idx -= 1
        motions += recent[idx].motion
    return recent[idx:]
