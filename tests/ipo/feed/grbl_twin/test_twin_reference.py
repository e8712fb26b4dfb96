"""The grbl twin against grbl 1.1h itself: job times measured on grbl-sim (tests/data/grbl_sim,
provenance in measured.json) and grbl's planner arithmetic by hand."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from ipo.config import default_config
from ipo.feed.grbl_twin.twin import motion_span
from ipo.feed.grbl_twin.wire import MOVE, WireLine
from ipo.grbl_settings import GrblSettings, read_dump
from ipr import parse_file
from machine.grbl.program import stream_groups
from machine.grbl.wire import wire_lines

DATA = Path(__file__).resolve().parents[3] / "data" / "grbl_sim"
MEASURED = json.loads((DATA / "measured.json").read_text())
SIM_BYTE_S = 66 / 16e6  # grbl-sim's byte period at 115200 (2*UBRR0+1 ticks, doubled by U2X0)
SIM_CLIENT_S = 1e-4  # our client's answer-to-next-line latency at -t 0.1 (about 1 ms of wall time)


def _measured_case(case):
    settings = read_dump(DATA / case["settings"])
    program = parse_file(DATA / case["program"])
    lines = wire_lines(stream_groups(program.entities, default_config()))
    baud = case["wire_baud"] or 10.0 / SIM_BYTE_S
    first, end = motion_span(lines, settings, baud=baud, reply_latency_s=SIM_CLIENT_S)
    return end - first


@pytest.mark.parametrize("case", MEASURED["cases"], ids=lambda c: f"{c['program']}@{c['settings']}")
def test_job_time_matches_grbl_sim(case):
    assert _measured_case(case) == pytest.approx(case["motion_s"], rel=0.01)


def test_one_move_is_grbl_trapezoid():
    """100 mm at F3000 with 500 mm/s^2 from rest to rest: L/v + v/a = 2.1 s, a little longer from the
    step timer: a step lasts ceil(ticks) + 1 ticks of 16 MHz (CTC mode); at 250 steps/mm and 50 mm/s
    that is 1281-1282 ticks for 1280, about 0.1 % on the cruise."""
    st = GrblSettings((250.0,) * 3, (6000.0,) * 3, (500.0,) * 3, 0.01, 0.002)
    first, end = motion_span([WireLine(12, 1, MOVE, (100.0, 0.0, 0.0), 3000.0)], st)
    ideal = 100.0 / 50.0 + 50.0 / 500.0
    assert end - first == pytest.approx(ideal, rel=2e-3)
    assert end - first > ideal
