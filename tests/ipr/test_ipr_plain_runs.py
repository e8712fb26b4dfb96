"""ipr.plain_runs: long stretches of plain G0..G3 lines read and run by compiled kernels give, bit for
bit, what the line-by-line path gives (entities, errors, warnings), whatever the lines are."""
from __future__ import annotations

import math
import os
import random

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import ipr
import ipr.interpreter as interpreter
from ipr import GCodeError

SETTINGS = settings(max_examples=int(os.environ.get("VCNC_FUZZ_EXAMPLES", "60")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

_digits = st.text("0123456789", min_size=0, max_size=18)
_number = st.builds(lambda sign, a, point, b: f"{sign}{a}{point}{b}", st.sampled_from(["", "", "-", "+"]),
                    _digits, st.sampled_from(["", ".", "."]), _digits)
_blank = st.sampled_from(["", " ", " ", "  ", "\t"])
_word = st.one_of(
    st.builds(lambda c, n: f"{c}{n}", st.sampled_from("XYZFxyzfXYZIJKRijkr"), _number),
    st.sampled_from(["G0", "G1", "G00", "G01", "g1", "G1.", "G 1", "G2", "G3", "G02", "g03", "G001", "G0.5", "G4"]),
    st.sampled_from(["M3 S1000", "(comment)", "; note", "G91", "G90", "G20", "G21", "G17", "G18", "F0", "X1.2.3",
                     "X[1+2]", "#1=3", "X#1", "N", "T1", "I1", "R2", "G19", "G90.1", "G91.1", "P2"]))


@st.composite
def plain_line(draw) -> str:
    words = draw(st.lists(_word, min_size=0, max_size=5))
    line = draw(_blank).join(words) if draw(st.booleans()) else " ".join(words)
    if draw(st.integers(0, 5)) == 0:
        line = f"N{draw(st.integers(0, 99999))} " + line
    return draw(_blank) + line + draw(st.sampled_from(["", "", " ", "\r", "\t"]))


def _read(text: str):
    try:
        program = ipr.parse_text(text, "p.nc", all_errors=True)
        return program.entities, [str(w) for w in program.warnings]
    except GCodeError as err:
        return [str(d) for d in err.diagnostics]


def _line_by_line(text: str):
    scan_lines = interpreter.SCAN_LINES
    interpreter.SCAN_LINES = 10 ** 9
    try:
        return _read(text)
    finally:
        interpreter.SCAN_LINES = scan_lines


@SETTINGS
@given(st.lists(plain_line(), min_size=1, max_size=12), st.integers(0, 3))
@example(["G1 X1 F100", " X2", "G0 Z5", "x-.5 y+1. z0.000000000000001"], 0)
@example(["G1 X1.1234567890123456 F100", "G1 X12345678901234567"], 0)   # past 15 digits: the Python path
@example(["G91", "G1 X0.1 F100", "Y0.2"], 1)
@example(["G0 X1 F100", "G1 ", "X2", "G00", "Y3"], 0)   # a G word alone sets the mode
@example(["G1 X1 F100", "G1 F0", "X2"], 2)   # G1 at feed zero: the Python path reports it
@example(["G1 X13.1 Y-33.3 F13.1", "X123.456 F33.3", "G0 Z7.3"], 2)   # inch: any other order rounds apart
def test_scanned_runs_equal_the_line_by_line_path(body, preamble) -> None:
    head = ["", "G21 G90 G17", "G20 G91 F30", "G0 X1 Y1 Z1"][preamble]
    lines = [head] + body * (interpreter.SCAN_LINES // len(body) + 1)
    text = "\n".join(lines) + "\nM2\n"
    assert _read(text) == _line_by_line(text)


def test_a_cam_program_takes_the_scanned_path(monkeypatch) -> None:
    """The corpus's kind of program, 1,000 lines: scanned, every entity is the line-by-line one's."""
    lines = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z5", "G1 Z0 F1200"]
    lines += [f"G1 X{i * 0.1:.3f} Y{(i % 7) * 0.25:.3f} Z{-0.001 * i:.4f}" if i % 9 else f"G2 X{i * 0.1:.3f} Y0 R5"
              for i in range(1, 1000)]
    text = "\n".join(lines) + "\nM2\n"
    calls = []
    from ipr import plain_runs
    monkeypatch.setattr(plain_runs, "run", lambda *a, _run=plain_runs.run: calls.append(1) or _run(*a))
    scanned = _read(text)
    assert calls, "the scanned path did not run"
    assert scanned == _line_by_line(text) and len(scanned[0]) == 1002


@pytest.mark.parametrize("text, value", [("X3.2040", 3.204), ("X-0.1539", -0.1539), ("x.5", 0.5), ("X1.", 1.0),
                                         ("X+7", 7.0), ("X-0", -0.0), ("X000123.4500", 123.45),
                                         ("X999999999999999", 999999999999999.0), ("X0.0000000000000000000001", 1e-22)])
def test_scanned_numbers_are_pythons_floats(text: str, value: float) -> None:
    from ipr import plain_runs
    scanned = plain_runs.Scanned([text])
    assert scanned.plain[0] and scanned.values[0, 0] == value == float(text[1:])
    assert str(scanned.values[0, 0]) == str(float(text[1:]))   # -0.0 too


def test_lines_read_from_a_file_keep_their_numbers(tmp_path) -> None:
    """A file's lines end with their line break (iter_entities over an open file)."""
    lines = ["G21 G90 G0 X0 Y0", "G1 X1 F600\r"] + [f" X{i} Y{i % 3}" for i in range(2, 600)] + ["G2 X0 Y0 R400", "M2"]
    path = tmp_path / "p.nc"
    path.write_text("\n".join(lines) + "\n")
    with path.open() as f:
        streamed = list(ipr.iter_entities(f, str(path)))
    assert streamed == ipr.parse_file(path).entities and streamed[-2].line == 601


def _arc_program(seed: int) -> str:
    """G1 moves and I/J/K arcs in every plane, unit and distance mode, their ends off the circle
    by amounts around every threshold of ipr.arcs.center_from_offsets (none, the rounding of the
    printed numbers, its tolerance, the spiral limit, beyond), zero radii and full circles, now
    and then an offset the plane does not take."""
    rng = random.Random(seed)
    lines, pos, plane, incremental = ["G21 G90 G17 G64 F600 G0 X0 Y0 Z0"], [0.0, 0.0, 0.0], (0, 1, 2), False
    arc, inch = False, 1.0

    def coordinates(end: list, keep: tuple = ()) -> list[str]:
        """The axis words to `end`: those of `keep` and, if it moves, the others most of the time."""
        return [f"{'XYZ'[k]}{end[k] - (pos[k] if incremental else 0.0):.{rng.choice([3, 4, 6])}f}" for k in range(3)
                if k in keep or (end[k] != pos[k] or rng.random() < 0.5) and rng.random() < 0.9]

    for _ in range(interpreter.SCAN_LINES * 4):
        if rng.random() < 0.15:   # where the interpreter is again after a refused block (ipr.knockon)
            lines += [f"G90 G0 X{pos[0]:.4f} Y{pos[1]:.4f} Z{pos[2]:.4f} F300"] + (["G91"] if incremental else [])
            arc = False
        elif rng.random() < 0.04:
            mode = rng.choice(["G17", "G18", "G19", "G20", "G21", "G90", "G91"])
            plane = {"G17": (0, 1, 2), "G18": (2, 0, 1), "G19": (1, 2, 0)}.get(mode, plane)
            incremental = {"G90": False, "G91": True}.get(mode, incremental)
            scale = {"G20": 1 / inch / 25.4, "G21": inch}.get(mode, 1.0)
            pos, inch = [p * scale for p in pos], {"G20": 25.4, "G21": 1.0}.get(mode, inch)
            lines.append(mode)
            arc = False
        elif rng.random() < 0.4:
            end = [p + rng.uniform(-2, 2) for p in pos]
            lines.append("G1 " + " ".join(coordinates(end)))
            pos, arc = end, False
        else:
            a, b, normal = plane if rng.random() < 0.95 else rng.sample(range(3), 3)
            radius = rng.choice([0.0, 1e-10, 0.01, 1.0, 1.0, 10.0, 10.0, 400.0])
            centre = [p + rng.uniform(-1, 1) * radius for p in pos]
            r0 = math.hypot(pos[a] - centre[a], pos[b] - centre[b])
            tolerance = max(0.002 if inch == 1.0 else 0.0002, 0.001 * r0)   # ipr.arcs: the spec's, in program units
            off = rng.choice([0.0, 0.0, 1e-7, 0.5, 0.9, 0.999, 1.001, 1.1, 3.0, 3000.0]) * tolerance * rng.choice([1, -1])
            angle = rng.uniform(0, 2 * math.pi)
            end = list(pos)
            end[a], end[b] = centre[a] + (r0 + off) * math.cos(angle), centre[b] + (r0 + off) * math.sin(angle)
            end[normal] += rng.choice([0.0, 0.0, 1.5])
            offsets = [f"{'IJK'[k]}{centre[k] - pos[k]:.{rng.choice([4, 6])}f}" for k in (a, b)]
            feed = rng.choice(["", "", " F300"] * 6 + [" F0", " F-3"])
            motion = rng.choice(["G2", "G3", "G02"] + ([""] * 3 if arc else []))
            lines.append(f"{motion} {' '.join(coordinates(end, (a, b)) + offsets)}{feed}")
            pos, arc = end, True
    return "\n".join(lines) + "\nM2\n"


def _outcome(text: str) -> tuple:
    """Entities (repr: -0.0 is not 0.0), warnings and errors, all errors reported."""
    interp = interpreter.Interpreter("p.nc", all_errors=True)
    interp.finish(interp.run(text.split("\n")))
    return [repr(e) for e in interp.out], interp.warnings, [str(d) for d in interp.diagnostics]


@pytest.mark.parametrize("seed", range(2))
def test_arcs_equal_the_line_by_line_path(seed: int, monkeypatch) -> None:
    """Arcs taken by the kernel or handed back: the same entities to the last bit, the same
    warnings and errors."""
    from ipr import plain_runs
    text = _arc_program(seed)
    taken = []
    monkeypatch.setattr(plain_runs, "run", lambda s, i, *a, _run=plain_runs.run: taken.append(
        sum(s.motions[i:i + (d := _run(s, i, *a))] >= 20)) or d)
    scanned = _outcome(text)
    assert sum(taken) > 30 and len(scanned[2]) > 20   # arcs the kernel took, errors the Python path reports
    monkeypatch.setattr(interpreter, "SCAN_LINES", 10 ** 9)
    assert scanned == _outcome(text)
