"""G64 Q: consecutive G1 moves that stay within Q of one straight line become that line.

LinuxCNC's "naive CAM detector" (emccanon.cc, see_segment / linkable / flush_segments), done
the same way before the feed stage builds its pieces and blends (so that the G64 P blends see
the merged corners): the end points of consecutive feed moves are chained while every point
of the chain lies within Q of the segment from where the chain starts to the newest point;
a point that does not fits starts a new chain, and a chain is sent as one line from its start
to its last point. As in LinuxCNC a chain holds at most MAX_CHAIN points, only G1 moves under
G64 with Q > 0 and the same feed and path control take part, and anything else (a rapid, an
arc, a NURBS, any event) ends the chain first, so that nothing moves to another place on the
path. The merged line keeps the line number of its first move: a run stopped inside it resumes
from a line that repeats it whole rather than one that skips a part.

The merged path lies within Q of the programmed one: each programmed point is within Q of the
merged segment, and so is every programmed segment between two of them (the distance to a
segment is convex).
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
from numba import njit

from ipr.entities import Line

# emccanon.cc linkable(): a chain of more than 100 points takes no more
MAX_CHAIN = 101


@njit(cache=True)
def _within(x0, y0, z0, x1, y1, z1, points, n, tol_mm):
    """Each of the first n points (N, 3) within tol_mm of the segment (x0, y0, z0) -> (x1, y1, z1)."""
    mx, my, mz = x1 - x0, y1 - y0, z1 - z0
    mm = mx * mx + my * my + mz * mz
    for k in range(n):
        px, py, pz = points[k, 0] - x0, points[k, 1] - y0, points[k, 2] - z0
        f = min(max((px * mx + py * my + pz * mz) / mm, 0.0), 1.0) if mm > 0.0 else 0.0
        dx, dy, dz = px - f * mx, py - f * my, pz - f * mz
        if dx * dx + dy * dy + dz * dz > tol_mm * tol_mm:
            return False
    return True


def merge_collinear(entities: Iterable) -> Iterator:
    """The entities with each chain of G1 moves within its Q of one line as that line."""
    chain: list[Line] = []  # the moves merged so far; chain[0].start is where the line starts
    ends = np.empty((MAX_CHAIN, 3))  # their end points, the first len(chain) rows

    def flush() -> Iterator:
        if len(chain) == 1:
            yield chain[0]
        elif chain:
            first = chain[0]
            yield Line(first.line, first.start, chain[-1].end, first.feed_mm_s, first.path)
        chain.clear()

    for e in entities:
        # not mergeable (written out: a function call per entity of every program costs ~10 %
        # of this loop)
        if type(e) is not Line or e.path.exact_stop or not (e.path.merge_tol_mm or 0.0) > 0.0:
            if chain:  # most programs have no Q: no generator per entity for an empty chain
                yield from flush()
            yield e
            continue
        if chain:
            head = chain[0]
            linkable = (e.feed_mm_s == head.feed_mm_s and e.path == head.path and len(chain) < MAX_CHAIN
                        and e.end != head.start
                        and _within(*head.start, *e.end, ends, len(chain), e.path.merge_tol_mm))
            if not linkable:
                yield from flush()
        ends[len(chain)] = e.end
        chain.append(e)
    yield from flush()
