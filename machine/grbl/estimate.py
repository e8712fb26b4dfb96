"""Job time before a stream and time remaining during it, from vcnc's own planner.

vcnc's IPO (`ipo.feed.planner.plan_periods`) plans the program with the machine file's
limits; the periods of each program line times the period give that line's time, and
the remaining time from a stream line is the sum over the program lines from its own
on. grbl plans with its own settings and 15-block look-ahead, so this is vcnc's
estimate, not grbl's (dwells count; M0 pauses do not).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class JobEstimate:
    total_s: float
    after_s: np.ndarray  # after_s[i]: time from stream line seq_of[i] on
    seq: np.ndarray  # stream line numbers, ascending

    @classmethod
    def plan(cls, entities, lines, config, start_mm) -> JobEstimate:
        from ipo.feed.planner import plan_periods

        per_line: dict[int, int] = {}
        for b in plan_periods(entities, config, start_mm=tuple(start_mm)):
            if hasattr(b, "inc_blu"):
                src, n = np.unique(np.asarray(b.line), return_counts=True)
                for s, k in zip(src.tolist(), n.tolist()):
                    per_line[s] = per_line.get(s, 0) + k
        dwell = {e.line: e.seconds for e in entities if type(e).__name__ == "Dwell"}
        times = {s: n * config.period_s for s, n in per_line.items()}
        for s, t in dwell.items():
            times[s] = times.get(s, 0.0) + t
        # each program line's time counted once, at its first stream line
        seen, own = set(), []
        for l in lines:
            own.append(times.get(l.source_line, 0.0) if l.source_line not in seen else 0.0)
            seen.add(l.source_line)
        own_arr = np.asarray(own, float)
        after = np.cumsum(own_arr[::-1])[::-1] if len(own_arr) else own_arr
        return cls(float(sum(times.values())), after, np.asarray([l.seq for l in lines], np.int64))

    def remaining_s(self, running_seq: int) -> float:
        """Time from stream line `running_seq` on (0 past the end)."""
        i = int(np.searchsorted(self.seq, running_seq))
        return float(self.after_s[i]) if i < len(self.after_s) else 0.0
