"""The interpreter's shortcuts change nothing: with the G0..G3 step functions (ipr.plain), the
scanned runs of plain lines (ipr.plain_runs) and the shape templates (ipr.shapes) switched off,
every program gives the same entities, warnings and errors through the general path and the
full grammar."""
from __future__ import annotations

import random

import pytest
from conftest import corpus_files

import ipr
import ipr.interpreter
from ipr.entities import Nurbs


def _canon(entity):
    """Nurbs compare by identity (numpy arrays): compare their contents instead."""
    if isinstance(entity, Nurbs):
        return ("nurbs", entity.line, entity.degree, entity.knots.tolist(), entity.weights.tolist(),
                entity.points.tolist(), entity.feed_mm_s, entity.path)
    return entity


def _outcome(text: str):
    """Entities, warnings and errors of a program read with all_errors."""
    interp = ipr.interpreter.Interpreter("p.nc", all_errors=True)
    interp.finish(interp.run(text.split("\n")))
    return [_canon(e) for e in interp.out], interp.warnings, [str(d) for d in interp.diagnostics]


def _general_only(monkeypatch):
    monkeypatch.setattr(ipr.interpreter, "step_for", lambda *a: None)
    monkeypatch.setattr(ipr.interpreter, "SCAN_LINES", 10 ** 9)   # no runs of plain lines (ipr.plain_runs)
    monkeypatch.setattr(ipr.interpreter, "template_for", lambda shape: None)
    monkeypatch.setattr(ipr.interpreter, "expression_block", lambda text: None)


def _random_program(seed: int) -> str:
    rng = random.Random(seed)
    lines = ["G21 G90 G17 F300"]
    for _ in range(400):
        r = rng.random()
        if r < 0.06:
            lines.append(rng.choice(["G90", "G91", "G20", "G21", "G92 X1 Y2", "G92.1", "G55", "G54",
                                     "G61", "G64 P0.01", "F0", "F120", "G80", "M3 S100", "G18", "G17"]))
        elif r < 0.1:
            lines.append(rng.choice(["G1 X1 F-5", "X1 Y1 I2", "G0 X1 X2", "/G1 X100", "N7 G1 Z-1", "G19",
                                     "G90.1", "G91.1"]))
        elif r < 0.25:   # arcs: full circles (valid in most planes), helices, radius format (often not)
            lines.append(rng.choice(["G2 I3", "G3 J-2 Z1", "G2 K1.5 F200", "G3 I1 J1", "G2 I0.5 X0",
                                     f"G3 X{rng.uniform(-9, 9):.3f} Y{rng.uniform(-9, 9):.3f} R{rng.uniform(-40, 40):.3f}",
                                     f"G2 Z{rng.uniform(-9, 9):.2f} X{rng.uniform(-9, 9):.2f} R{rng.uniform(-40, 40):.2f}",
                                     "I2", f" X{rng.uniform(-9, 9):.2f} R30"]))
        else:
            words = [f"{a}{rng.uniform(-50, 50):.{rng.randint(0, 4)}f}" for a in "XYZ" if rng.random() < 0.6]
            head = rng.choice(["", "", "G1 ", "G0 ", "G01 ", "g1"])
            feed = f" F{rng.randint(0, 900)}" if rng.random() < 0.2 else ""
            lines.append(head + " ".join(words) + feed)
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("seed", range(6))
def test_random_programs_same_through_general_path(seed, monkeypatch):
    text = _random_program(seed)
    fast = _outcome(text)
    assert len(fast[0]) > 200 and fast[2]     # moves and errors both
    _general_only(monkeypatch)
    assert _outcome(text) == fast


@pytest.mark.parametrize("path", corpus_files("g[156]_*.ngc"))
def test_corpus_same_through_general_path(path, monkeypatch):
    lines = path.read_text().split("\n")[:6000]   # the head of the big ones is plenty
    text = "\n".join(lines)
    fast = _outcome(text)
    assert fast[0] and not fast[2]
    _general_only(monkeypatch)
    assert _outcome(text) == fast
