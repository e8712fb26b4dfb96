"""Fuzz: programs built from the grammar's constructs and mutated corpus programs, through
parse, the whole-program check and a bounded run.

Properties (issue 16):
- parse raises only GCodeError, the check only ProgramRejected, the run nothing: only
  vcnc's error types escape;
- every error has a line and a column (`file:line:col: error[CODE]: message`);
- a program the check passes never faults (no travel limit reached, no planner refusal) and
  never crawls: it ends within a budget of twice the time of each motion from standstill to
  standstill at min(F, rapid, and on an arc sqrt(a R)) plus its ramps, a NURBS at no less than
  1 mm/s along its control polygon (which bounds its length), plus dwells and 2 s.
The machine has a travel of +-40 mm, so that random arcs and NURBS bulges often reach it.

CI runs a derandomised slice (a fixed sequence of examples); the long run for developers is
`VCNC_FUZZ_LONG=1 python -m pytest -m slow tests/test_fuzz.py`.
"""
from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ipo.config import default_config
from ipr import parse_text
from ipr.entities import Arc, Dwell, GCodeError, Line, Nurbs, Rapid
from machine.controller import Controller, ProgramRejected

ROOT = Path(__file__).resolve().parents[1]
TRAVEL_MM = 40.0
CONFIG = dataclasses.replace(default_config(), axes=tuple(
    dataclasses.replace(a, min_mm=-TRAVEL_MM, max_mm=TRAVEL_MM) for a in default_config().axes))
REASON = re.compile(r"^.+:\d+:\d+: error\[[A-Z0-9-]+\]: .+")
SEEDS = [ROOT / "programs" / n for n in ("demo.nc", "circle_g2.nc", "circle_nurbs.nc", "curve000.nc")]
FAST = settings(max_examples=25, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
LONG = settings(max_examples=2000, deadline=None, suppress_health_check=list(HealthCheck))

coord = st.one_of(st.floats(-30, 30).map(lambda v: f"{v:.3f}"), st.sampled_from(["0", "45", "-45", "2000", ".5"]))
feed = st.sampled_from(["600", "1200", "3000", "6000"])
weight = st.one_of(st.floats(0.2, 5).map(lambda v: f"{v:.4f}"),
                   st.sampled_from(["1", "0.000001", "1000000", "0.000000000000001", "1000000000000000", "0"]))


@st.composite
def nurbs_group(draw) -> list[str]:
    order = draw(st.integers(2, 5))
    n = draw(st.integers(order, order + 4))
    inner = sorted(draw(st.lists(st.sampled_from([0.1, 0.25, 0.5, 0.75, 0.9]), min_size=n - order, max_size=n - order)))
    knots = [0.0] * order + inner + [1.0] * order
    pts = [(draw(coord), draw(coord)) for _ in range(n - 1)]
    lines = [f"G6.2 P{order} K0 X{draw(coord)} Y{draw(coord)} R{draw(weight)} F{draw(feed)}"]
    lines += [f"K{k:g} X{x} Y{y} R{draw(weight)}" for k, (x, y) in zip(knots[1:n], pts)]
    return lines + [f"K{k:g}" for k in knots[n:]]


@st.composite
def g52_group(draw) -> list[str]:
    n = draw(st.integers(2, 6))
    lines = [f"G5.2 X{draw(coord)} Y{draw(coord)} P{draw(weight)} L{draw(st.integers(2, 4))} F{draw(feed)}"]
    return lines + [f"X{draw(coord)} Y{draw(coord)} P{draw(weight)}" for _ in range(n)] + ["G5.3"]


def block(draw_one) -> st.SearchStrategy:
    return st.one_of(
        st.builds(lambda x, y, z: f"G0 X{x} Y{y} Z{z}", coord, coord, coord),
        st.builds(lambda x, y, f: f"G1 X{x} Y{y} F{f}", coord, coord, feed),
        st.builds(lambda g, x, y, i, j, f: f"{g} X{x} Y{y} I{i} J{j} F{f}", st.sampled_from(["G2", "G3"]), coord,
                  coord, coord, coord, feed),
        st.builds(lambda g, x, y, r, f: f"{g} X{x} Y{y} R{r} F{f}", st.sampled_from(["G2", "G3"]), coord, coord,
                  coord, feed),
        st.builds(lambda p: f"G2 X0 Y0 I5 J0 P{p} F3000", st.sampled_from(["1", "2", "0", "1.5", "1000000000"])),
        st.sampled_from(["G17", "G18", "G19", "G90", "G91", "G21", "G20", "G61", "G64 P0.01", "G64", "G4 P0.01",
                         "M3 S1000", "M5", "#1=5", "G1 X#1 F600", "G1 X[1+2*3] F600", "(a comment)", "; note",
                         "G0 X1e5", "N10 G1 X1 F600", "%"]),
        st.text(alphabet="GXYZIJKRPFSMLN#[]+-*/.0123456789 ()e;", max_size=20),
        nurbs_group(), g52_group(),
    )


@st.composite
def built_program(draw) -> str:
    blocks = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z0"]
    for item in draw(st.lists(block(None), min_size=1, max_size=8)):
        blocks += item if isinstance(item, list) else [item]
    return "\n".join(blocks + ["M2"]) + "\n"


@st.composite
def mutated_program(draw) -> str:
    lines = draw(st.sampled_from(SEEDS)).read_text().splitlines()
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["delete_char", "insert", "replace_number", "duplicate", "drop", "swap"]))
        line = lines[i]
        if op == "delete_char" and line:
            k = draw(st.integers(0, len(line) - 1))
            lines[i] = line[:k] + line[k + 1:]
        elif op == "insert":
            k = draw(st.integers(0, len(line)))
            lines[i] = line[:k] + draw(st.sampled_from([" X", "G", "9", "-", ".", "[", "#", "e", "K1", " P3"])) + line[k:]
        elif op == "replace_number":
            lines[i] = re.sub(r"-?\d+(\.\d*)?", lambda m: draw(coord), line, count=1)
        elif op == "duplicate":
            lines.insert(i, line)
        elif op == "drop" and len(lines) > 1:
            del lines[i]
        elif op == "swap" and i + 1 < len(lines):
            lines[i], lines[i + 1] = lines[i + 1], lines[i]
    return "\n".join(lines) + "\n"


def _budget_s(program) -> float:
    a = min(ax.max_accel_mm_s2 for ax in CONFIG.axes)
    total = 2.0
    for e in program.entities:
        if isinstance(e, (Rapid, Line)):
            v = CONFIG.rapid_mm_s if isinstance(e, Rapid) else min(e.feed_mm_s, CONFIG.rapid_mm_s)
            total += math.dist(e.start, e.end) / v + 2 * v / a
        elif isinstance(e, Arc):
            v = min(e.feed_mm_s, CONFIG.rapid_mm_s, math.sqrt(a * max(e.radius_mm, 1e-9)))
            total += abs(e.sweep_rad) * e.radius_mm / v + math.hypot(*np.subtract(e.end, e.start)) / v + 2 * v / a
        elif isinstance(e, Nurbs):
            polygon = float(np.sum(np.linalg.norm(np.diff(e.points, axis=0), axis=1)))
            total += polygon / 1.0 + 2 * CONFIG.rapid_mm_s / a
        elif isinstance(e, Dwell):
            total += e.seconds
    return 2 * total


class _PeriodCap:
    """A trace sink that stops the run (as Ctrl-C would) once it has seen more periods than allowed."""

    def __init__(self, periods: int):
        self.left = periods

    def write(self, rows) -> None:
        self.left -= len(rows["t_s"])
        if self.left < 0:
            raise KeyboardInterrupt


def check_program(text: str, tmp_path: Path) -> None:
    try:
        parse_text(text, "fuzz.nc", all_errors=True)
    except GCodeError as err:
        assert err.diagnostics and all(d.line >= 1 and d.col >= 1 for d in err.diagnostics), err
    path = tmp_path / "fuzz.nc"
    path.write_text(text)
    controller = Controller(CONFIG)
    try:
        program = controller.check(path)
    except ProgramRejected as rejected:
        assert rejected.reasons and all(REASON.match(r) for r in rejected.reasons), rejected.reasons
        return
    budget_s = _budget_s(program)
    controller.sinks = [_PeriodCap(int(budget_s / CONFIG.period_s))]
    result = controller.run(program)
    assert result.state != "interrupted", f"still running after the budget of {budget_s:.1f} s:\n{text}"
    assert result.state == "completed", f"{result.state}: {result.fault}\n{text}"


@FAST
@given(text=built_program())
def test_built_programs(tmp_path_factory, text):
    check_program(text, tmp_path_factory.mktemp("f"))


@FAST
@given(text=mutated_program())
def test_mutated_programs(tmp_path_factory, text):
    check_program(text, tmp_path_factory.mktemp("f"))


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("VCNC_FUZZ_LONG"), reason="the long fuzz run: set VCNC_FUZZ_LONG=1")
@LONG
@given(text=st.one_of(built_program(), mutated_program()))
def test_long_fuzz(tmp_path_factory, text):
    check_program(text, tmp_path_factory.mktemp("f"))
