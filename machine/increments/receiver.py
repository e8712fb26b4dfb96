"""The drive end of the increment protocol: accepts DATA frames in sequence, buffers
their periods, executes them at the period rate (or as fast as asked) and integrates
the increments into an exact BLU position. Served over a 127.0.0.1 socket from a thread
(the tests also serve it over a pty pair: tests/pty_endpoint.py), so the host side runs over
pyserial like against real hardware.
"""
from __future__ import annotations

import select
import socket
import threading
import time
from collections import deque

import numpy as np

from machine.increments import frames as F


class IncrementReceiver:
    """Protocol state; `receive(bytes, now)` and `tick(now)` fill `outbox`."""

    def __init__(self, *, axes: int = 3, capacity_periods: int = 4096, period_s: float | None = None,
                 start_blu=(0, 0, 0), drive=None):
        self.axes = axes
        self.capacity = capacity_periods
        self.period_s = period_s  # None: execute buffered periods at once
        self.position_blu = np.array(start_blu, dtype=np.int64)
        self.drive = drive  # optional machine.drive.Drive fed with what was executed
        self.parser = F.FrameParser()
        self.outbox = bytearray()
        self.buffer: deque[np.ndarray] = deque()
        self.buffered = 0
        self.expected = 0
        self.last = F.NO_SEQ
        self.executed_periods = 0
        self.duplicates = 0
        self.naks = 0
        self._announced = capacity_periods
        self._t_exec = None

    @property
    def free(self) -> int:
        return self.capacity - self.buffered

    def receive(self, data: bytes, now: float) -> None:
        bad_before = self.parser.bad_crc
        for fr in self.parser.feed(data):
            if fr.kind == F.HELLO:
                self.buffer.clear()
                self.buffered, self.expected, self.last = 0, 0, F.NO_SEQ
                self._ack()
            elif fr.kind == F.POLL:
                self._ack()
            elif fr.kind == F.DATA:
                self._data(fr)
        if self.parser.bad_crc > bad_before:
            self._nak()

    def _data(self, fr: F.Frame) -> None:
        n, axes = fr.inc_blu.shape
        behind = (self.expected - fr.seq) % F.SEQ_MOD
        if fr.seq == self.expected and axes == self.axes and n <= self.free:
            self.buffer.append(fr.inc_blu)
            self.buffered += n
            self.last, self.expected = fr.seq, (fr.seq + 1) % F.SEQ_MOD
            self._ack()
        elif 0 < behind <= F.SEQ_MOD // 2:  # a resend of a frame already taken: confirm again
            self.duplicates += 1
            self._ack()
        else:
            self._nak()

    def _ack(self) -> None:
        self.outbox += F.ack_frame(self.last, self.free)
        self._announced = self.free

    def _nak(self) -> None:
        self.naks += 1
        self.outbox += F.nak_frame(self.expected, self.free)
        self._announced = self.free

    def tick(self, now: float) -> None:
        if self._t_exec is None or not self.buffered:
            self._t_exec = now
        due = self.buffered if self.period_s is None else int((now - self._t_exec) / self.period_s)
        if due <= 0:
            return
        if self.period_s is not None:
            self._t_exec += due * self.period_s
        parts, left = [], min(due, self.buffered)
        while left:
            head = self.buffer[0]
            take = min(left, len(head))
            parts.append(head[:take])
            if take == len(head):
                self.buffer.popleft()
            else:
                self.buffer[0] = head[take:]
            left -= take
        inc = np.concatenate(parts)
        self._execute(inc)
        if self.free - self._announced >= F.MAX_PERIODS or (not self.buffered and self.free != self._announced):
            self._ack()  # tell the host there is room again

    def _execute(self, inc: np.ndarray) -> None:
        self.buffered -= len(inc)
        self.executed_periods += len(inc)
        if self.drive is not None:
            from ipo.contracts import PeriodBatch

            n = len(inc)
            pos = (self.position_blu + np.cumsum(inc, axis=0)) * self.drive.limits.blu_mm
            self.drive.receive(PeriodBatch(pos, inc, np.zeros(n), np.zeros(n, np.int8), np.zeros(n, np.int32)))
        self.position_blu = self.position_blu + inc.sum(axis=0)


class Endpoint:
    """Runs a byte-protocol state machine (receive/tick/outbox) behind a transport in a thread:
    the increment receiver here, and the grbl test double in tests/."""

    def __init__(self, target, mangle=None):
        self.target = target
        self.mangle = mangle  # tests: alter bytes in transit to the target
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self):
        self._thread.start()
        return self

    def stop(self):
        self._stop.set()
        self._thread.join(timeout=5)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()

    def _pump(self, fd, read, write) -> bool:
        ready, _, _ = select.select([fd], [], [], 0.0005)
        now = time.monotonic()
        if ready:
            try:
                data = read()
            except OSError:
                return False
            if not data:
                return False
            self.target.receive(self.mangle(data) if self.mangle else data, now)
        self.target.tick(now)
        if self.target.outbox:
            out, self.target.outbox = bytes(self.target.outbox), bytearray()
            try:
                write(out)
            except OSError:
                return False
        return True


class SocketEndpoint(Endpoint):
    """The receiver behind 127.0.0.1:<port>, one connection after another."""

    def __init__(self, target, mangle=None, host: str = "127.0.0.1", port: int = 0):
        super().__init__(target, mangle)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind((host, port))
        self.sock.listen(1)
        self.sock.settimeout(0.01)
        self.port = f"socket://{host}:{self.sock.getsockname()[1]}"

    def _run(self):
        while not self._stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except socket.timeout:
                self.target.tick(time.monotonic())
                continue
            with conn:
                while not self._stop.is_set() and self._pump(conn, lambda: conn.recv(65536), conn.sendall):
                    pass
        self.sock.close()


def main(argv=None) -> None:
    """`python -m machine.increments.receiver [--port N] [--period-s T]`: a drive to stream to
    (`vcnc stream FILE --protocol increments --port socket://127.0.0.1:N`); prints its position."""
    import argparse

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--port", type=int, default=5555)
    ap.add_argument("--period-s", type=float, default=None, help="execute in real time (default: at once)")
    ap.add_argument("--capacity", type=int, default=4096, help="buffer, in periods")
    args = ap.parse_args(argv)
    rx = IncrementReceiver(capacity_periods=args.capacity, period_s=args.period_s)
    with SocketEndpoint(rx, port=args.port).start() as ep:
        print(f"increment receiver on {ep.port}; Ctrl-C to stop", flush=True)
        try:
            last = None
            while True:
                time.sleep(0.5)
                now = (rx.executed_periods, tuple(rx.position_blu.tolist()))
                if now != last:
                    print(f"periods {now[0]:>9}  position {now[1]} BLU", flush=True)
                    last = now
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()
