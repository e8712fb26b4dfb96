"""A run's digest: everything the report and the PNG draw, gathered as a trace sink.

The digest receives the drive's rows batch by batch (the same rows a trace writer
gets) and keeps, in memory independent of the run's length:
- min/max envelopes (machine.report.envelope) of the planned feed, each axis's
  velocity, acceleration and jerk (the drive's backward stencils of h periods, so
  their extremes are the run summary's maxima), and the servo's contour error;
- per bucket, the row of its first period (position, distance, feed, reason, line)
  and how many periods each limiting reason held;
and, growing with the program rather than with the periods, the runs of periods
on one source line: where each starts and the row of its last period (within one
period's step of the block's end point, so the 3-D path keeps every corner of a G1
program).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ipo.contracts import LIMIT_NAMES
from machine.report.envelope import Envelope, EnvelopeData

SIGNALS = ("feed", "vx", "vy", "vz", "ax", "ay", "az", "jx", "jy", "jz")
SERVO_SIGNAL = "contour_um"
# row of a path point: x, y, z (mm), s (mm along the path), feed (mm/s), limit code, line
ROW = ("x", "y", "z", "s", "feed", "limit", "line")
MAX_BUCKETS = 8192
PATH_SAMPLES = 32768  # the 3-D path's and the pick's positions between block ends: 4 per envelope bucket
CHUNK_PERIODS = 1 << 16  # batches are gathered to this size: a G1 program's batches are a few periods each


@njit(cache=True)
def _signals(ext, old, h, blu, period_s, feed, out, step):
    """Per period k (row old + k of the positions ext, BLU, the rows before it already seen): the
    feed, each axis's signed velocity, acceleration and jerk by the drive's backward stencils of h
    periods (NaN until the stencil has its rows), into out (n, 10); the path step (mm) into step."""
    ht = h * period_s
    for k in range(out.shape[0]):
        i = old + k
        out[k, 0] = feed[k]
        d2 = 0.0
        for a in range(3):
            d = ext[i, a] - ext[i - 1, a]
            d2 += float(d * d)
            out[k, 1 + a] = d * blu / period_s
            out[k, 4 + a] = ((ext[i, a] - 2 * ext[i - h, a] + ext[i - 2 * h, a]) * blu / ht**2
                             if i >= 2 * h else np.nan)
            out[k, 7 + a] = ((ext[i, a] - 3 * ext[i - h, a] + 3 * ext[i - 2 * h, a] - ext[i - 3 * h, a])
                             * blu / ht**3 if i >= 3 * h else np.nan)
        step[k] = np.sqrt(d2) * blu


@dataclass(slots=True)
class Digest:
    """A finished digest; periods are 0-based, period p ends at t = (p + 1)·period_s."""

    meta: dict
    signals: tuple[str, ...]
    env: EnvelopeData
    run_first_period: np.ndarray  # (R,) int64: first period of each run of one source line
    run_line: np.ndarray  # (R,) int32
    path_period: np.ndarray  # (P,) int64: the period each path point ends (-1: the start position)
    path_rows: np.ndarray  # (P, len(ROW)) float64

    @property
    def period_s(self) -> float:
        return float(self.meta["period_s"])

    @property
    def periods(self) -> int:
        return self.env.periods

    def line_at(self, period: int) -> int:
        """The source line executing in `period`."""
        k = int(np.searchsorted(self.run_first_period, period, side="right")) - 1
        return int(self.run_line[max(k, 0)])


class DigestSink:
    """A trace sink (write(rows)) that keeps a Digest of the run; `finish()` returns it."""

    def __init__(self, meta: dict, *, servo: bool = False, max_buckets: int = MAX_BUCKETS):
        self.meta = dict(meta)
        self.signals = SIGNALS + ((SERVO_SIGNAL,) if servo else ())
        self._h = int(meta.get("stencil_periods", 1))
        self._blu, self._T = float(meta["blu_mm"]), float(meta["period_s"])
        self._env = Envelope(len(self.signals), max_buckets=max_buckets, row_width=len(ROW),
                             categories=len(LIMIT_NAMES))
        self._samples = Envelope(0, max_buckets=PATH_SAMPLES, row_width=len(ROW))
        self._tail = np.zeros((0, 3), dtype=np.int64)  # the last 3h positions (BLU) for the stencils
        self._s_mm = 0.0
        self._last_row: np.ndarray | None = None
        self._last_line = None
        self._runs_first: list[np.ndarray] = []
        self._runs_line: list[np.ndarray] = []
        self._path_period: list[np.ndarray] = []
        self._path_rows: list[np.ndarray] = []
        self._pending: list[dict[str, np.ndarray]] = []
        self._pending_n = 0

    def write(self, rows: dict[str, np.ndarray]) -> None:
        n = len(rows["t_s"])
        if n == 0:
            return
        self._pending.append({k: np.array(v, copy=True) for k, v in rows.items()})
        self._pending_n += n
        if self._pending_n >= CHUNK_PERIODS:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        names = self._pending[0].keys()
        rows = {k: np.concatenate([part[k] for part in self._pending]) for k in names}
        self._pending, self._pending_n = [], 0
        self._digest(rows)

    def _digest(self, rows: dict[str, np.ndarray]) -> None:
        n = len(rows["t_s"])
        pos, inc = np.asarray(rows["pos_mm"], dtype=float), np.asarray(rows["inc_blu"], dtype=np.int64)
        first_period = self._env.periods
        if self._last_row is None:
            start = pos[0] - inc[0] * self._blu
            self._tail = np.rint(start / self._blu).astype(np.int64)[None, :]
            line0 = int(rows["line"][0])
            self._path_period.append(np.array([-1]))
            self._path_rows.append(np.array([[*start, 0.0, 0.0, 0.0, line0]]))
        pos_blu = np.rint(pos / self._blu).astype(np.int64)
        ext = np.concatenate((self._tail, pos_blu))
        feed, limit, line = (np.asarray(rows[k]) for k in ("feed_mm_s", "limit", "line"))
        values = np.empty((n, len(self.signals)))
        step = np.empty(n)
        _signals(ext, len(self._tail), self._h, self._blu, self._T, np.asarray(feed, dtype=np.float64), values, step)
        self._tail = ext[-3 * self._h:].copy()
        if len(self.signals) > 10:
            values[:, 10] = rows[SERVO_SIGNAL]
        s = self._s_mm + np.cumsum(step)
        self._s_mm = float(s[-1])

        def table(idx):
            return np.column_stack((pos[idx], s[idx], feed[idx], limit[idx], line[idx])).astype(np.float64)

        self._env.add(values, table, limit)
        self._samples.add(values[:, :0], table)

        prev = np.concatenate(([self._last_line if self._last_line is not None else line[0] - 1], line[:-1]))
        change = np.flatnonzero(line != prev)
        if len(change):
            self._runs_first.append(first_period + change)
            self._runs_line.append(line[change].astype(np.int32))
            ends = change[change > 0] - 1
            if self._last_row is not None and change[0] == 0:
                self._path_period.append(np.array([first_period - 1]))
                self._path_rows.append(self._last_row[None, :])
            self._path_period.append(first_period + ends)
            self._path_rows.append(table(ends))
        self._last_row = table(np.array([n - 1]))[0]
        self._last_line = line[-1]

    def close(self) -> Digest:
        return self.finish()

    def finish(self) -> Digest:
        self._flush()
        env, samples = self._env.finish(), self._samples.finish()
        periods = [*self._path_period, samples.first_period()]
        rows = [*self._path_rows, samples.first_rows]
        if self._last_row is not None:
            periods.append(np.array([env.periods - 1]))
            rows.append(self._last_row[None, :])
        period = np.concatenate(periods)
        table = np.concatenate(rows)
        period, keep = np.unique(period, return_index=True)
        empty = np.zeros(0, dtype=np.int64)
        return Digest(self.meta, self.signals, env,
                      np.concatenate(self._runs_first) if self._runs_first else empty,
                      np.concatenate(self._runs_line) if self._runs_line else empty.astype(np.int32),
                      period, table[keep])


def digest_trace(trace, batch: int = 1 << 16) -> Digest:
    """The digest of a whole trace (a loaded file or an in-memory run), fed in batches."""
    sink = DigestSink(trace.meta, servo=SERVO_SIGNAL in trace.columns)
    for i in range(0, len(trace), batch):
        sink.write({k: v[i:i + batch] for k, v in trace.columns.items()})
    return sink.finish()
