"""ipo.fit.move_runs: the free-junction pieces spliced into the plan's spans, against a per-move reference."""
from __future__ import annotations

import numpy as np

from ipo.fit.groups import Span
from ipo.fit.move_runs import _spliced


def _random_plan(rng, n_moves: int) -> list[Span]:
    cuts = np.sort(rng.choice(np.arange(1, n_moves), size=rng.integers(1, max(2, n_moves // 3)), replace=False))
    bounds = [0, *cuts.tolist(), n_moves]
    spans = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        kind = rng.integers(3)
        spans.append(Span(a, b) if kind == 0 else Span(a, b, one_moves=("move",)) if kind == 1
                     else Span(a, b, fit="group"))
    return spans


def _random_new(rng, spans: list[Span]) -> list[Span]:
    """Disjoint stretches made of whole one-move spans and parts of kept spans (never a group), as
    free_junctions replans them."""
    owner = np.concatenate([[i] * (s.last - s.first) for i, s in enumerate(spans)])
    free = np.array([spans[i].fit is None for i in owner])
    new, m = [], 0
    while m < len(owner):
        if not free[m] or rng.random() < 0.5:
            m += 1
            continue
        end = m
        while end < len(owner) and free[end] and rng.random() < 0.8:
            end += 1
        if end == m:
            m += 1
            continue
        lo = m if spans[owner[m]].kept else spans[owner[m]].first  # a one-move span is never cut
        hi = end if spans[owner[end - 1]].kept else spans[owner[end - 1]].last
        if hi > lo and lo >= (new[-1].last if new else 0) and all(free[lo:hi]):
            new.append(Span(lo, hi, one_moves=("new",)))
        m = max(hi, m + 1)
    return new


def test_spliced_against_per_move_owners():
    rng = np.random.default_rng(7)
    for _ in range(300):
        n_moves = int(rng.integers(4, 40))
        spans = _random_plan(rng, n_moves)
        new = _random_new(rng, spans)
        out = _spliced(spans, new)
        assert [s.first for s in out][0] == 0 and out[-1].last == n_moves
        assert all(a.last == b.first for a, b in zip(out[:-1], out[1:]))  # a partition, in path order
        for m in range(n_moves):
            got = next(s for s in out if s.first <= m < s.last)
            inside = [s for s in new if s.first <= m < s.last]
            was = next(s for s in spans if s.first <= m < s.last)
            if inside:
                assert got is inside[0]
            elif was.kept:
                assert got.kept and was.first <= got.first and got.last <= was.last
            else:
                assert got is was
