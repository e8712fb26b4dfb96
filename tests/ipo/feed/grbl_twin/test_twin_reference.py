"""The grbl twin against grbl 1.1h itself: job times and speed profiles measured on grbl-sim
(tests/data/grbl_sim, provenance in measured.json), and grbl's planner arithmetic by hand."""
from __future__ import annotations

import dataclasses
import functools
import statistics

import numpy as np
import pytest

from grbl_sim_cases import SIM_CLIENT_S, cases
from ipo.config import default_config
from ipo.feed.grbl_twin.twin import motion_span, plan_periods
from ipo.feed.grbl_twin.wire import MOVE, WireLine
from ipo.grbl_settings import GrblSettings

CASES = cases()
MEDIAN_BAR, WORST_BAR = 0.01, 0.03  # issue 18's bar on job time
# what the twin does on these programs, kept as a guard: a tenth of the median bar, a third of the worst
MEDIAN_HELD, WORST_HELD = 0.001, 0.01


@functools.cache
def _predicted(k: int) -> float:
    case = CASES[k]
    first, last = motion_span(case.wire(), case.settings, baud=case.baud, answer_s=SIM_CLIENT_S)
    return last - first


@pytest.mark.parametrize("k", range(len(CASES)), ids=[c.label for c in CASES])
def test_job_time_matches_grbl_sim(k):
    if CASES[k].text is None:
        pytest.skip(f"{CASES[k].raw['program']}: ../shared/corpus is absent")
    assert _predicted(k) == pytest.approx(CASES[k].motion_s, rel=WORST_BAR)


def test_job_times_meet_the_bar_together():
    errors = [abs(_predicted(k) / c.motion_s - 1) for k, c in enumerate(CASES) if c.text is not None]
    assert len(errors) >= 8
    assert statistics.median(errors) <= MEDIAN_HELD and max(errors) <= WORST_HELD


@pytest.mark.parametrize("case", [c for c in CASES if "profile_mm_s" in c.raw], ids=lambda c: c.label)
def test_speed_profile_matches_grbl_sim(case):
    """The twin's periods (the stream every plot and comparison reads) against grbl-sim's step log:
    the chord travelled in each window of profile_dt_s from each one's first motion, over dt."""
    dt = case.raw["profile_dt_s"]
    want = np.asarray(case.raw["profile_mm_s"])
    first, _ = motion_span(case.wire(), case.settings, baud=case.baud, answer_s=SIM_CLIENT_S)
    cfg = dataclasses.replace(default_config(), grbl_settings=case.settings, grbl_baud=int(case.baud))
    pos = np.concatenate([b.pos_mm for b in plan_periods(case.entities(), cfg, wire=case.wire(),
                                                         answer_s=SIM_CLIENT_S) if hasattr(b, "pos_mm")])
    t = cfg.period_s * np.arange(1, len(pos) + 1)
    grid = first + dt * np.arange(len(want) + 1)
    at = np.array([np.interp(grid, t, pos[:, k]) for k in range(3)]).T
    got = np.linalg.norm(np.diff(at, axis=0), axis=1) / dt
    peak = want.max()
    assert np.median(np.abs(got - want)) <= 0.005 * peak
    assert np.max(np.abs(got - want)) <= 0.05 * peak


def test_one_move_is_grbl_trapezoid():
    """100 mm at F3000 with 500 mm/s^2 from rest to rest: L/v + v/a = 2.1 s, a little longer from the
    step timer: a step lasts ceil(ticks) + 1 ticks of 16 MHz (CTC mode); at 250 steps/mm and 50 mm/s
    that is 1281-1282 ticks for 1280, about 0.1 % on the cruise."""
    st = GrblSettings((250.0,) * 3, (6000.0,) * 3, (500.0,) * 3, 0.01, 0.002)
    first, end = motion_span([WireLine(12, 1, MOVE, (100.0, 0.0, 0.0), 3000.0)], st)
    ideal = 100.0 / 50.0 + 50.0 / 500.0
    assert end - first == pytest.approx(ideal, rel=2e-3)
    assert end - first > ideal
