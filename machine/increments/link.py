"""The host end of the increment protocol over pyserial's `serial_for_url`.

Go-back-N: DATA frames go out while the periods not yet acknowledged fit in the free
space the drive last announced; an ACK releases every frame up to its sequence
number, a NAK (corrupt or out-of-order frame at the drive) or a silent timeout sends
every unacknowledged frame again, from the oldest.
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator

import numpy as np
import serial

from machine.increments import frames as F


class IncrementLinkError(RuntimeError):
    """The drive did not answer like an increment-protocol receiver."""


@dataclass(slots=True)
class SendResult:
    periods: int
    frames: int
    resent_frames: int
    naks: int
    sum_blu: np.ndarray  # the increments sent, summed per axis


def frame_chunks(batches: Iterable, max_periods: int) -> Iterator[np.ndarray]:
    """The increments of PeriodBatches (or (N, axes) arrays) cut into runs of at most max_periods."""
    for b in batches:
        inc = np.asarray(getattr(b, "inc_blu", b), dtype=np.int64)
        for i in range(0, len(inc), max_periods):
            yield inc[i:i + max_periods]


class IncrementLink:
    def __init__(self, url: str, *, baud: int = 115200, resend_timeout_s: float = 0.25,
                 answer_timeout_s: float = 5.0, read_timeout_s: float = 0.002):
        self.ser = serial.serial_for_url(url, baudrate=baud, timeout=read_timeout_s, write_timeout=5.0)
        self.parser = F.FrameParser()
        self.resend_timeout_s = resend_timeout_s
        self.answer_timeout_s = answer_timeout_s
        self.free = 0
        self.capacity = 0  # the drive's buffer, in periods, as announced at HELLO

    def close(self) -> None:
        self.ser.close()

    def _answers(self) -> list[F.Frame]:
        data = self.ser.read(1)
        if data and self.ser.in_waiting:
            data += self.ser.read(self.ser.in_waiting)
        return [f for f in self.parser.feed(data) if f.kind in (F.ACK, F.NAK)] if data else []

    def hello(self) -> int:
        """Start a session; returns the drive's free buffer space in periods."""
        self.ser.write(F.hello_frame())
        t_end = time.monotonic() + self.answer_timeout_s
        while time.monotonic() < t_end:
            for fr in self._answers():
                if fr.kind == F.ACK and fr.seq == F.NO_SEQ:
                    self.free = self.capacity = fr.free
                    return fr.free
        raise IncrementLinkError("no ACK to HELLO: is an increment-protocol drive at the other end?")

    def send(self, batches: Iterable, on_progress: Callable[[int], None] | None = None,
             wait_drained: bool = True) -> SendResult:
        """Stream the batches' inc_blu (or (N, axes) arrays) to the drive; returns once every
        frame is acknowledged and, with `wait_drained`, the drive has executed them all."""
        if not self.free:
            self.hello()
        chunks = frame_chunks(batches, min(F.MAX_PERIODS, self.free))
        pending = next(chunks, None)
        seq = 0
        unacked: deque[tuple[int, int, bytes]] = deque()  # (seq, periods, frame)
        in_flight = 0
        res = SendResult(0, 0, 0, 0, np.zeros(3, np.int64))
        t_answer = t_resend = time.monotonic()
        nak_resent = None  # (expected seq, time) of the last go-back on a NAK
        while pending is not None or unacked:
            while pending is not None and in_flight + len(pending) <= self.free:
                frame = F.data_frame(seq, pending)
                self.ser.write(frame)
                unacked.append((seq, len(pending), frame))
                in_flight += len(pending)
                res.frames += 1
                res.periods += len(pending)
                if len(res.sum_blu) != pending.shape[1]:
                    res.sum_blu = np.zeros(pending.shape[1], np.int64)
                res.sum_blu += pending.sum(axis=0)
                seq = (seq + 1) % F.SEQ_MOD
                pending = next(chunks, None)
            now = time.monotonic()
            for fr in self._answers():
                t_answer = now
                # release every frame up to the one acknowledged (NAK: up to the one before `expected`)
                done = fr.seq if fr.kind == F.ACK else (fr.seq - 1) % F.SEQ_MOD
                if any(s == done for s, _, _ in unacked):
                    while unacked:
                        s, n, _ = unacked.popleft()
                        in_flight -= n
                        if s == done:
                            break
                self.free = fr.free
                if fr.kind == F.NAK:
                    res.naks += 1
                    # the frames already in flight behind a lost one draw NAKs too: go back once
                    if nak_resent is None or nak_resent[0] != fr.seq or now - nak_resent[1] > self.resend_timeout_s:
                        self._resend(unacked, res)
                        nak_resent = (fr.seq, now)
                        t_resend = now
            if on_progress:
                on_progress(res.periods)
            if now - max(t_answer, t_resend) > self.resend_timeout_s:
                if now - t_answer > self.answer_timeout_s:
                    raise IncrementLinkError(f"the drive stopped answering; {len(unacked)} frames unacknowledged")
                if unacked:
                    self._resend(unacked, res)
                else:
                    self.ser.write(F.poll_frame())  # blocked on free space: ask the drive for news
                t_resend = now
        if wait_drained:
            self.drain()
        return res

    def drain(self) -> None:
        """Poll until the drive's buffer is empty (free space back to its capacity)."""
        t_answer = time.monotonic()
        while self.free < self.capacity:
            self.ser.write(F.poll_frame())
            t_poll = time.monotonic()
            while time.monotonic() - t_poll < self.resend_timeout_s and self.free < self.capacity:
                for fr in self._answers():
                    self.free, t_answer = fr.free, time.monotonic()
            if time.monotonic() - t_answer > self.answer_timeout_s:
                raise IncrementLinkError("the drive stopped answering while its buffer drained")

    def _resend(self, unacked, res: SendResult) -> None:
        for _, _, frame in unacked:
            self.ser.write(frame)
            res.resent_frames += 1
