"""A session with a grbl 1.1 board over pyserial's `serial_for_url` (a device path,
socket://host:port, rfc2217://host:port or loop://): bytes in and out, status
polls, commands outside a stream, soft reset, and the machine's state (`?`, `$G`,
`$#`) a stream starts from. Streams themselves: machine.grbl.streamer.
"""
from __future__ import annotations

import queue
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Iterable

import serial

from machine.grbl import protocol as P
from machine.grbl.ledger import Fault, Ledger
from machine.grbl.program import StreamLine
from machine.grbl.resume import ResumePoint, find_resume
from machine.grbl.state import MachineState, machine_state, parse_modal, parse_params


class LinkError(RuntimeError):
    """The board did not behave like grbl 1.1 (no banner, no status, refused a command)."""


@dataclass(slots=True)
class ConnectInfo:
    banner: str
    settings: dict[int, float]
    build: P.BuildInfo
    warnings: list[str]
    alarm: bool
    state: MachineState | None = None


@dataclass(slots=True)
class StreamResult:
    completed: bool
    ledger: Ledger
    fault: Fault | None = None
    resume: ResumePoint | None = None  # where the next session continues (None after a lost connection)
    status: P.Status | None = None  # after the stream (after the reset, when it stopped)
    held: P.Status | None = None  # when a stop found grbl standing still, before the reset
    before_hold: P.Status | None = None  # the last status before the feed hold went out
    rx_fill: list[int] = field(default_factory=list)  # unanswered bytes after each send


class GrblLink:
    def __init__(self, url: str, *, baud: int = 115200, poll_interval_s: float = 0.2,
                 stall_timeout_s: float = 10.0, settle_s: float = 0.1, reset_timeout_s: float = 5.0,
                 idle_timeout_s: float = 600.0, read_timeout_s: float = 0.005, hold_timeout_s: float = 30.0):
        self.url = url
        self.poll_interval_s = poll_interval_s
        self.stall_timeout_s = stall_timeout_s
        self.settle_s = settle_s
        self.reset_timeout_s = reset_timeout_s
        self.idle_timeout_s = idle_timeout_s
        self.hold_timeout_s = hold_timeout_s  # longest deceleration a feed hold may take
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
        self._stop_reason: str | None = None
        self.status_at_stop: P.Status | None = None  # the last status before a requested stop's hold
        self._stop_lock = threading.Lock()
        self.line_numbers = False  # the build reports Ln: lines go out with N<seq>
        self.options = ""

    def request_stop(self, reason: str) -> None:
        """Stop the stream safely (hold, reset, resume line); safe from a signal handler or
        thread. The feed hold goes out at once: grbl takes a realtime byte anywhere in
        the stream, even inside a line, so no motion waits for the stream loop."""
        with self._stop_lock:
            first = self._stop_reason is None
            self._stop_reason = self._stop_reason or reason
        if first:
            self.status_at_stop = self.status
            try:
                self._write(P.FEED_HOLD)
            except (serial.SerialException, OSError):
                pass  # the stream loop reports the closed port

    @property
    def stop_requested(self) -> str | None:
        return self._stop_reason

    def error(self, message: str) -> LinkError:
        return LinkError(message)

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
        self.options = build.options
        self.line_numbers = "N" in build.options
        warnings = P.compare_settings(settings, config) if config is not None else []
        if settings.get(13, 0.0):
            warnings.append("grbl reports in inches ($13=1); vcnc reads positions as mm")
        if 10 in settings and not int(settings[10]) & 2:
            mask = int(settings[10])
            warnings.append(f"grbl's status reports carry no planner or RX buffer state ($10={mask}); "
                            f"set $10={mask | 2} to see planner blocks free")
        return ConnectInfo(banner, settings, build, warnings, st.state == "Alarm", self.read_state())

    def read_state(self) -> MachineState:
        """Where the machine stands and the parser's modes and offsets (`?`, `$G`, `$#`)."""
        st = self.query_status()
        modal = parse_modal(self.command("$G"))
        params = parse_params(self.command("$#"))
        coord = next((w for w in modal if w.startswith("G5") and len(w) == 3), "G54")
        o, g92, tlo = params[coord], params["G92"], params["TLO"][0]
        wco = (o[0] + g92[0], o[1] + g92[1], o[2] + g92[2] + tlo)
        mpos = st.mpos or tuple(w + c for w, c in zip(st.wpos, wco))
        self._wco = wco
        return machine_state(mpos, wco, modal, params)

    def stream(self, lines: Iterable[StreamLine], ledger: Ledger, *, resume: ResumePoint | None = None,
               on_progress: Callable[["GrblLink", Ledger], None] | None = None,
               progress_interval_s: float = 0.1) -> StreamResult:
        """Send `lines` with character counting (machine.grbl.streamer). With `resume`, the
        modal state the line runs in is restored first and a partial line is sent from the
        machine position."""
        from machine.grbl.streamer import stream

        if self.status is not None and self.status.state == "Alarm":
            raise LinkError("grbl is in alarm: unlock it ($X, `--unlock`) or home it before streaming")
        return stream(self, lines, ledger, StreamResult(False, ledger), resume=resume,
                      on_progress=on_progress, progress_interval_s=progress_interval_s)

    def resume_point(self, lines: Iterable[StreamLine],
                     max_lines: int = 256) -> tuple[ResumePoint, list[StreamLine]]:
        """Where the machine stands on the stream that starts with `lines` (a new session's
        --resume-from): returns the point and the lines read ahead for it."""
        st = self.query_status()
        if st.mpos is None:
            raise LinkError("grbl gave no machine position (WPos without a WCO)")
        window = []
        for line in lines:
            window.append(line)
            if len(window) >= max_lines:
                break
        return find_resume(window, st.mpos), window


