"""Job time before a stream and time remaining during it.

The program is planned with the machine configuration's planner (ipo.config.PLANNERS): for
a grbl stream that is the grbl twin with the board's own `$$` and the link's baud rate, fed
the very lines the stream sends (machine.grbl.wire), so the estimate is what grbl will do,
look-ahead, arcs and serial link included; `vcnc` plans with vcnc's own IPO instead. The
periods of each program line give that line's time (a dwell's standing periods included;
M0 pauses, which wait for the operator, are not), and the remaining time from a stream
line is the sum over the program lines from its own on.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class JobEstimate:
    total_s: float
    after_s: np.ndarray  # after_s[i]: time from stream line seq[i] on
    seq: np.ndarray  # stream line numbers, ascending

    @classmethod
    def plan(cls, groups, config, start_mm) -> JobEstimate:
        """The estimate for stream_groups' (entity, lines), the machine standing at start_mm."""
        from machine.planners import plan_with_lines

        groups = list(groups)
        entities = [e for e, _ in groups if e is not None]
        lines = [l for _, ls in groups for l in ls]
        plan = plan_with_lines(config, groups)
        per_line: dict[int, int] = {}
        for b in plan(entities, config, start_mm=tuple(start_mm)):
            if hasattr(b, "inc_blu"):
                src, n = np.unique(np.asarray(b.line), return_counts=True)
                for s, k in zip(src.tolist(), n.tolist()):
                    per_line[s] = per_line.get(s, 0) + k
        times = {s: n * config.period_s for s, n in per_line.items()}
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
