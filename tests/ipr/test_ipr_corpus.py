"""Every real program in ../shared/corpus/linuxcnc parses; the NURBS ones give the curves they describe.

The expected figures (group counts, degrees, knots, weights, end points, feeds) were read off
the program files by hand.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import corpus_files, require_corpus

import ipr
from ipr.entities import MOTION_TYPES, Nurbs

# the CLI of the interpreter running the tests, never a `vcnc` that happens to be on PATH
VCNC = [sys.executable, "-m", "machine.cli"]

# First block of a NURBS group: G5.2, or a G6.2 that is not one of the closing knot-only blocks.
_GROUP_START = re.compile(r"^\s*G0?(5\.2|6\.2(?!\s*K))", re.IGNORECASE)

# file -> (groups, degree, feed mm/min, end point of each group)
NURBS_FILES = {
    "g5_butterfly_xy.ngc": (6, 2, 300.0, [(0, -29.56, 0), (0, 0, 0), (-2.94, -23.50, 0), (4.30, -5.00, 0),
                                             (12.03, 13.00, 0), (-2.00, -1.00, 0)]),
    "g5_nurbs_xy.ngc": (1, 2, 100.0, [(0, 0, 0)]),
    "g5_trident_3planes.ngc": (3, 3, 300.0, [(10, 0, 0), (0, 10, 0), (0, 0, 10)]),
    "g6_farfalla.ngc": (1, 4, 290.0, [(54.492, 52.139, -1)]),
    "g6_homer.ngc": (16, 3, 290.0, None),
    "g6_mazatrol_3planes.ngc": (3, 3, 290.0, [(100, 0.012, 0), (0, 100, 0.012), (0.012, 0, 100)]),
    "g6_stella.ngc": (1, 2, 290.0, [(63.562, 106.120, -1)]),
    "g6_unipa.ngc": (7, None, 290.0, [(19.550, 119.323, -1), (51.150, 143.427, -1), (68.846, 145.629, -1),
                                      (69.058, 147.472, -1), (79.431, 131.556, -1), (124.703, 87.512, -1),
                                      (131.270, 103.021, -1)]),
}


@pytest.mark.parametrize("path", corpus_files())
def test_corpus_program_parses(path: Path) -> None:
    program = ipr.parse_file(path)
    motions = program.motions()
    assert motions, "a corpus program with no motion at all"
    for w in program.warnings:
        assert w.severity in ("warning", "notice") and w.line >= 1 and w.col >= 1, str(w)
    # the motions chain from the origin: each starts where the previous one ended
    starts = np.array([m.start for m in motions])
    ends = np.array([(0.0, 0.0, 0.0)] + [m.end for m in motions[:-1]])
    gaps = np.abs(starts - ends).max(axis=1)
    assert gaps.max() <= 1e-9, f"{motions[int(gaps.argmax())]!r} does not start where the previous motion ended"


def _group_lines(path: Path) -> list[int]:
    return [n for n, text in enumerate(path.read_text().splitlines(), 1) if _GROUP_START.match(text)]


@pytest.mark.parametrize("name", sorted(NURBS_FILES))
def test_nurbs_groups(name: str) -> None:
    path = require_corpus() / name
    n_groups, degree, feed_mm_min, ends = NURBS_FILES[name]
    first_lines = _group_lines(path)
    assert len(first_lines) == n_groups  # cross-checks the hand count against the file
    program = ipr.parse_file(path)
    motions = program.motions()
    curves = [m for m in motions if isinstance(m, Nurbs)]
    assert [c.line for c in curves] == first_lines
    for c in curves:
        prev = motions[motions.index(c) - 1]
        assert c.start == pytest.approx(prev.end, abs=1e-9), f"curve at line {c.line} jumps"
        assert c.feed_mm_s == pytest.approx(feed_mm_min / 60.0)
        if degree is not None:
            assert c.degree == degree
        n = len(c.points)
        assert c.points.shape == (n, 3) and c.weights.shape == (n,) and len(c.knots) == n + c.degree + 1
        assert np.all(c.weights > 0) and np.all(np.diff(c.knots) >= 0)
    if ends is not None:
        for c, end in zip(curves, ends):
            assert c.end == pytest.approx(end, abs=1e-9)


def _normalised(knots) -> np.ndarray:
    k = np.asarray(knots, dtype=float)
    return (k - k[0]) / (k[-1] - k[0])


def test_g6_knots_and_weights_as_written() -> None:
    corpus = require_corpus()
    (farfalla,) = [m for m in ipr.parse_file(corpus / "g6_farfalla.ngc").motions() if isinstance(m, Nurbs)]
    assert len(farfalla.points) == 51
    assert _normalised(farfalla.knots) == pytest.approx(np.r_[[0] * 5, np.arange(1, 47), [47] * 5] / 47)
    assert farfalla.weights[[3, 11, 14, 15]] == pytest.approx([1.2, 2, 5, 3])
    assert tuple(farfalla.points[4]) == pytest.approx((69.575, 51.358, -1))

    (stella,) = [m for m in ipr.parse_file(corpus / "g6_stella.ngc").motions() if isinstance(m, Nurbs)]
    assert len(stella.points) == 16 and stella.weights == pytest.approx(np.ones(16))
    assert _normalised(stella.knots) == pytest.approx(np.r_[[0] * 3, np.arange(1, 14), [14] * 3] / 14)

    unipa = [m for m in ipr.parse_file(corpus / "g6_unipa.ngc").motions() if isinstance(m, Nurbs)]
    assert [c.degree for c in unipa] == [3, 3, 1, 3, 3, 3, 1]
    assert unipa[1].weights == pytest.approx([1, 2.1019057984, 1.00022038115968, 1.00000003305717])
    assert _normalised(unipa[2].knots) == pytest.approx([0, 0, 1, 1])


def test_g6_q_word_gives_a_notice() -> None:
    path = require_corpus() / "g6_stella.ngc"
    notices = [w for w in ipr.parse_file(path).warnings if w.severity == "notice"]
    assert notices and all(w.line in _group_lines(path) for w in notices), notices


def _same(a, b) -> bool:
    if isinstance(a, Nurbs) or isinstance(b, Nurbs):
        return (type(a) is type(b) and a.line == b.line and a.degree == b.degree and a.feed_mm_s == b.feed_mm_s
                and np.array_equal(a.knots, b.knots) and np.array_equal(a.weights, b.weights)
                and np.array_equal(a.points, b.points) and a.path == b.path)
    return a == b


@pytest.mark.parametrize("name", ["g1_lhchips4.ngc", "g5_butterfly_xy.ngc", "g6_unipa.ngc"])
def test_streaming_equals_whole_file(name: str) -> None:
    path = require_corpus() / name
    whole = ipr.parse_file(path).entities
    with path.open() as f:
        streamed = list(ipr.iter_entities(f, str(path)))
    assert len(streamed) == len(whole)
    assert all(_same(a, b) for a, b in zip(streamed, whole))
    assert sum(isinstance(e, MOTION_TYPES) for e in whole) > 0


def test_cli_parse_small_program() -> None:
    path = require_corpus() / "g5_nurbs_xy.ngc"
    done = subprocess.run([*VCNC, "parse", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    done = subprocess.run([*VCNC, "parse", "--json", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    items = json.loads(done.stdout)
    kinds = [i["kind"] for i in items]
    assert kinds.count("nurbs") == 1 and set(kinds) == {"rapid", "nurbs"}
    at = kinds.index("nurbs")
    curve = items[at]
    assert curve["line"] == 11 and curve["degree"] == 2 and curve["feed_mm_min"] == pytest.approx(100.0)
    assert curve["start"] == pytest.approx([0, 0, 0]) and curve["end"] == pytest.approx([0, 0, 0])
    # the four rapids after the curve trace its control polygon
    assert [i["end"] for i in items[at + 1:at + 5]] == [[0, 1, 0], [2, 2, 0], [2, 0, 0], [0, 0, 0]]


def test_cli_parse_reports_an_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.ngc"
    bad.write_text("G21\nG1 X1 F100\nG1 X2 Q\n")
    done = subprocess.run([*VCNC, "parse", str(bad)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1
    assert re.search(rf"{re.escape(str(bad))}:3:\d+: error\[[A-Z0-9-]+\]: ", done.stderr), done.stderr
