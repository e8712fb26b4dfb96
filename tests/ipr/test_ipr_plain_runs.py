"""ipr.plain_runs: long stretches of plain G0/G1 lines read and run by compiled kernels give, bit for
bit, what the line-by-line path gives (entities, errors, warnings), whatever the lines are."""
from __future__ import annotations

import os

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
    st.builds(lambda c, n: f"{c}{n}", st.sampled_from("XYZFxyzfXYZ"), _number),
    st.sampled_from(["G0", "G1", "G00", "G01", "g1", "G1.", "G 1", "G2", "G3", "G001", "G0.5"]),
    st.sampled_from(["M3 S1000", "(comment)", "; note", "G91", "G90", "G20", "G21", "G17", "G18", "F0", "X1.2.3",
                     "X[1+2]", "#1=3", "X#1", "N", "T1", "I1", "R2"]))


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
