"""Real-time playback: the planned periods paced at the interpolation period, with
feed hold, live override and stop from the keyboard, and missed deadlines counted.

Live override and feed hold scale time, not the plan: the playback advances along
the planned points by `scale` planned periods per real period (linear interpolation
in between, re-quantised to BLU), so at scale 1 the drive receives exactly the
planned stream. The live scale only goes down from the plan (0 … 1; run above
100 % with --feed-override, which the feed stage plans within the limits), so no
axis limit can be exceeded by turning the knob. The scale ramps at
0.5·a_min·T/v per period (v the planned feed), which keeps the slowdown's own
deceleration within half the smallest axis acceleration limit.

The planner runs ahead in its own thread (`prefetch`), so that a slow planning step
(a long look-ahead window, numba loading a kernel on first use) is absorbed by the
queue instead of starving the drive.

Deadlines: the drive starts once the player has worked one lead time ahead and
then takes period k at t0 + (lead + k)·T; every period produced after its own
deadline counts as a miss.
"""
from __future__ import annotations

import math
import os
import queue
import select
import sys
import threading
import time

import numpy as np
from numba import njit

from ipo.contracts import LIMIT_DWELL, PeriodBatch

CHUNK_S = 0.02  # periods produced per wake-up
LEAD_S = 0.1  # how far ahead of the drive the player works


PREFETCH_ITEMS = 16  # planned batches and events queued ahead of the player


def prefetch(items, depth: int = PREFETCH_ITEMS):
    """Iterate `items` in a worker thread, `depth` items ahead; errors re-raise here."""
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()
    done = object()

    def work():
        try:
            for item in items:
                while not stop.is_set():
                    try:
                        q.put((item, None), timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            q.put((done, None))
        except BaseException as err:  # handed to the consumer, which re-raises it
            q.put((done, err))

    worker = threading.Thread(target=work, name="vcnc-planner", daemon=True)
    worker.start()
    try:
        while True:
            item, err = q.get()
            if item is done:
                if err is not None:
                    raise err
                return
            yield item
    finally:
        stop.set()


@njit(cache=True)
def _resample(pts, tau, scale, target, rate, n, final, out, idx, scales):
    """Advance tau by a ramped scale per period over the planned points; returns (k, tau, scale)."""
    end = pts.shape[0] - 1
    k = 0
    while k < n:
        if scale < target:
            scale = min(target, scale + rate)
        elif scale > target:
            scale = max(target, scale - rate)
        tau = min(tau + scale, float(end))
        i = int(math.floor(tau))
        f = tau - i
        for a in range(3):
            if i >= end:
                out[k, a] = pts[end, a]
            else:
                out[k, a] = pts[i, a] + f * (pts[i + 1, a] - pts[i, a])
        idx[k] = min(end, int(math.ceil(tau)))
        scales[k] = scale
        k += 1
        if final and tau >= end:
            break
    return k, tau, scale


class Keyboard:
    """Single keys from a terminal without Enter (cbreak mode); no keys when stdin is not a terminal."""

    def __init__(self):
        self._fd = sys.stdin.fileno() if sys.stdin is not None and sys.stdin.isatty() else None
        self._saved = None

    def __enter__(self):
        if self._fd is not None:
            import termios
            import tty
            self._saved = termios.tcgetattr(self._fd)
            tty.setcbreak(self._fd)
        return self

    def __exit__(self, *exc):
        if self._saved is not None:
            import termios
            termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)

    def keys(self) -> str:
        if self._fd is None:
            return ""
        out = ""
        while select.select([self._fd], [], [], 0)[0]:
            ch = os.read(self._fd, 1).decode(errors="ignore")
            if not ch:
                break
            out += ch
        return out

    def wait_key(self, allowed: str) -> str:
        """Block until one of `allowed` is pressed; without a terminal, the first allowed key."""
        if self._fd is None:
            return allowed[0]
        while True:
            for ch in self.keys():
                if ch in allowed:
                    return ch
            time.sleep(0.02)


class Player:
    """Feeds the drive in real time; `keys` returns the keys pressed since the last call."""

    def __init__(self, keys=lambda: "", status=lambda player: None, clock=time.perf_counter, sleep=time.sleep):
        self.keys, self.status, self.clock, self.sleep = keys, status, clock, sleep
        self.deadline_misses = 0
        self.stopped = False
        self.state = "run"
        self.override = 1.0  # the live target scale, 0.1 … 1
        self.drive = None

    def attach(self, drive) -> None:
        lim = drive.limits
        self.drive, self.blu, self.T = drive, lim.blu_mm, lim.period_s
        self.a_min = float(np.min(lim.max_accel_mm_s2))
        self.chunk = max(1, round(CHUNK_S / self.T))
        self.lead = max(self.chunk, round(LEAD_S / self.T))
        self.pts = drive.position_mm[None, :].astype(float)
        self.feed = np.zeros(1)
        self.limit = np.zeros(1, np.int8)
        self.line = np.full(1, drive.line, np.int32)
        self.tau, self.scale = 0.0, 1.0
        self.last_blu = drive.position_blu.copy()
        self.out = np.empty((self.chunk, 3))
        self.idx = np.empty(self.chunk, np.int64)
        self.scales = np.empty(self.chunk)
        _resample(self.pts, 0.0, 0.0, 0.0, 0.0, 1, True, self.out, self.idx, self.scales)
        self.k = 0  # periods delivered
        self.t0 = None  # the clock starts with the first chunk: planning the first batch is start-up
        self._status_at = 0.0

    def detach(self) -> None:
        self._drain()
        self.status(self)

    def _drain(self) -> None:
        """Wait until the drive has taken every period produced so far."""
        if self.t0 is None:
            return
        wait = self.t0 + (self.lead + self.k) * self.T - self.clock()
        if wait > 0 and not self.stopped:
            self.sleep(wait)

    def play(self, batch: PeriodBatch) -> None:
        self.pts = np.concatenate((self.pts, batch.pos_mm))
        self.feed = np.concatenate((self.feed, batch.feed_mm_s))
        self.limit = np.concatenate((self.limit, batch.limit))
        self.line = np.concatenate((self.line, batch.line))
        while not self.stopped and len(self.pts) - 1 - self.tau >= self.chunk + 1:
            self._step(final=False)

    def flush(self) -> None:
        """Play to the last planned point (the machine stands there before an event)."""
        while not self.stopped and self.tau < len(self.pts) - 1:
            self._step(final=True)

    def pause(self, wait) -> bool:
        """An M0: wall time spent waiting is not machine time; `wait` returns True to resume."""
        self._drain()
        self.state = "paused"
        self.status(self)
        resume = wait()
        self.t0 = self.clock() - self.k * self.T  # prime the buffer again before moving on
        self.state = "run" if resume else "stopped"
        return resume

    def _handle_keys(self) -> None:
        for ch in self.keys():
            if ch == " ":
                self.state = "run" if self.state == "hold" else "hold"
            elif ch in "sSqQ":
                self.state = "stopping"
            elif ch in "+=":
                self.override = min(1.0, round(self.override + 0.1, 1))
            elif ch in "-_":
                self.override = max(0.1, round(self.override - 0.1, 1))

    def _step(self, final: bool) -> None:
        if self.t0 is None:
            self.t0 = self.clock()
        self._handle_keys()
        target = self.override if self.state == "run" else 0.0
        ahead = self.feed[int(self.tau):int(self.tau) + 2 * self.chunk + 2]
        rate = 0.5 * self.a_min * self.T / max(float(ahead.max()), 1.0)
        k, self.tau, self.scale = _resample(self.pts, self.tau, self.scale, target, rate, self.chunk, final,
                                            self.out, self.idx, self.scales)
        pos_blu = np.rint(self.out[:k] / self.blu).astype(np.int64)
        inc = np.diff(np.vstack((self.last_blu, pos_blu)), axis=0)
        idx, scales = self.idx[:k], self.scales[:k]
        limit = np.where(scales > 0, self.limit[idx], LIMIT_DWELL).astype(np.int8)
        self.drive.receive(PeriodBatch(pos_blu * self.blu, inc, self.feed[idx] * scales, limit, self.line[idx]))
        self.last_blu = pos_blu[-1]
        first = self.k
        self.k += k
        now = self.clock()
        late = math.floor((now - self.t0) / self.T) - self.lead - first + 1  # periods past their deadline
        self.deadline_misses += min(k, max(0, late))
        drop = int(self.tau)
        if drop:
            self.pts, self.feed = self.pts[drop:], self.feed[drop:]
            self.limit, self.line = self.limit[drop:], self.line[drop:]
            self.tau -= drop
        if self.state == "stopping" and self.scale == 0.0:
            self.stopped = True
        if now - self._status_at > 0.1:
            self._status_at = now
            self.status(self)
        wait = self.t0 + self.k * self.T - self.clock()  # stay `lead` periods ahead of the drive
        if wait > 0:
            self.sleep(wait)
