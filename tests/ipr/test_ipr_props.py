"""Property tests of the interpreter's input handling.

1. Random, mutated and hostile input never raises anything but ipr.entities.GCodeError, and
   every diagnostic points at a real place (line >= 1, 1 <= col <= length of that line + 1).
2. The fast line path (`ipr.parse_line`) gives exactly what the full lark grammar
   (`ipr.parse_line_full`) gives, on random valid lines and on broken ones (the same
   Block, or the same ipr.syntax.LineSyntaxError column and message).
"""
from __future__ import annotations

import math
import os
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import ipr
from ipr.entities import MOTION_TYPES, Dwell, GCodeError, Nurbs
from ipr.syntax import LineSyntaxError

# VCNC_FUZZ_EXAMPLES=5000 for a deep run; the default keeps the suite fast.
SETTINGS = settings(max_examples=int(os.environ.get("VCNC_FUZZ_EXAMPLES", "100")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

# ---- valid lines ---------------------------------------------------------------------------------

_sp = st.sampled_from(["", "", "", " ", "  ", "\t"])
_digits = st.integers(0, 99999).map(str)
_unsigned = st.one_of(
    _digits,
    st.tuples(_digits, _digits).map(lambda t: f"{t[0]}.{t[1]}"),
    _digits.map(lambda d: f"{d}."),
    _digits.map(lambda d: f".{d}"),
)
_number = st.builds(lambda sign, s, n: f"{sign}{s}{n}", st.sampled_from(["", "", "-", "+"]), _sp, _unsigned)
_name = st.text("abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=8)
_param = st.one_of(st.integers(1, 5399).map(lambda n: f"#{n}"), _name.map(lambda n: f"#<{n}>"))
_FUNCS = ["ABS", "ACOS", "ASIN", "COS", "EXP", "FIX", "FUP", "LN", "ROUND", "SIN", "SQRT", "TAN"]
_OPS = ["+", "-", "*", "/", "MOD", "**", "AND", "OR", "XOR", "EQ", "NE", "GT", "GE", "LT", "LE"]


def _case(text: str, draw) -> str:
    return "".join(c.lower() if draw(st.booleans()) else c for c in text)


@st.composite
def expression(draw, depth: int = 0) -> str:
    """A bracketed RS274NGC expression (syntactically valid; its value may be an error)."""
    atom = st.one_of(_number, _param)
    if depth >= 2:
        body = draw(atom)
    else:
        kind = draw(st.sampled_from(["atom", "binary", "func", "atan", "nested"]))
        if kind == "atom":
            body = draw(atom)
        elif kind == "binary":
            parts = [draw(st.one_of(atom, expression(depth + 1)))]
            for _ in range(draw(st.integers(1, 3))):
                parts += [draw(st.sampled_from(_OPS)), draw(st.one_of(atom, expression(depth + 1)))]
            body = " ".join(parts)
        elif kind == "func":
            body = f"{draw(st.sampled_from(_FUNCS))}{draw(expression(depth + 1))}"
        elif kind == "atan":
            body = f"ATAN{draw(expression(depth + 1))}/{draw(expression(depth + 1))}"
        else:
            body = draw(expression(depth + 1))
    return _case(f"[{body}]", draw)


_value = st.one_of(_number, _number, _number, expression(), _param)
_WORD_LETTERS = "GMXYZIJKFSTPQRLHN"
_comment = st.one_of(
    st.text(st.characters(blacklist_characters="()\n\r", blacklist_categories=("Cs",)), max_size=12)
    .map(lambda t: f"({t})"),
    st.text("abc ,", max_size=10).map(lambda t: f"(MSG,{t})"),
)


@st.composite
def valid_line(draw) -> str:
    """A syntactically valid block: words (maybe spaced, lowercase), comments, expressions, assignments."""
    parts = []
    if draw(st.integers(0, 9)) == 0:
        parts.append("/")
    if draw(st.booleans()):
        parts.append(f"{draw(st.sampled_from('Nn'))}{draw(_sp)}{draw(st.integers(0, 9999))}")
    for _ in range(draw(st.integers(0, 6))):
        kind = draw(st.sampled_from(["word"] * 6 + ["comment", "assign"]))
        if kind == "word":
            letter = draw(st.sampled_from(_WORD_LETTERS))
            if letter in "GM":
                code = draw(st.sampled_from(["0", "00", "1", "01", "2", "3", "4", "17", "18", "19", "20", "21",
                                             "5.2", "5.3", "6.2", "06.2", "40", "43", "49", "53", "54", "55",
                                             "61", "64", "80", "90", "91", "90.1", "91.1", "92", "92.1", "94"]))
                value = code if letter == "G" else draw(st.sampled_from(["0", "1", "2", "3", "4", "5", "6", "7",
                                                                         "8", "9", "30"]))
            else:
                value = draw(_value)
            parts.append(f"{_case(letter, draw)}{draw(_sp)}{value}")
        elif kind == "comment":
            parts.append(draw(_comment))
        else:
            parts.append(f"{draw(_param)}{draw(_sp)}={draw(_sp)}{draw(_value)}")
    line = "".join(p + draw(_sp) for p in parts)
    if draw(st.integers(0, 4)) == 0:
        line += "; " + draw(st.text("abc XYZ()[]#", max_size=10))
    return line


# ---- broken and hostile lines --------------------------------------------------------------------

_HOSTILE = [
    "[1/0]", "[1 MOD 0]", "[SQRT[-1]]", "[LN[0]]", "[LN[-1]]", "[ACOS[2]]", "[ASIN[-2]]", "[10**400]",
    "[EXP[1000]]", "[-8**[1/3]]", "[0**-1]", "[FIX[" + "9" * 400 + "]]", "[ROUND[" + "9" * 400 + "]]",
    "9" * 400, "1" + "0" * 30, "[ATAN[0]/[0]]", "[TAN[90]]", "#99999", "#-1", "#0", "#[1/0]", "#<>",
    "#<undefined_name>", "#1.5", "[" * 300 + "1" + "]" * 300, "[" * 40, "]" * 5, "[1+]", "[*2]",
    "[COS]", "[ATAN[1]]", "[FOO[1]]", "..5", "1.2.3", "--1", "+-1", "1e5", "0x10", "nan", "inf", "",
]
_FRAGMENTS = _HOSTILE + ["G", "X", "#", "=", "(", ")", ";", "%", "/", "O12", "G1", "G2", "G6.2", "G5.2", "G5.3",
                         "G41", "G93", "G28", "G4 P", "M6", "M99", "T", "R", "K", "L9", "P99", "Q", "E5", "@", "\\",
                         "é", "\x00", "\x7f", "\ufeff", "中"]


@st.composite
def mutated_line(draw) -> str:
    """A valid line with random cuts, insertions (including hostile fragments) and truncation."""
    line = draw(valid_line())
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["insert", "delete", "truncate", "fragment"]))
        at = draw(st.integers(0, len(line)))
        if op == "insert":
            line = line[:at] + draw(st.text(min_size=1, max_size=3)) + line[at:]
        elif op == "delete":
            line = line[:at] + line[at + draw(st.integers(1, 4)):]
        elif op == "truncate":
            line = line[:at]
        else:
            letter = draw(st.sampled_from(_WORD_LETTERS + "ABCDEUVW"))
            line = line[:at] + f" {letter}{draw(st.sampled_from(_FRAGMENTS))} " + line[at:]
    return line


_decoded_bytes = st.binary(max_size=40).flatmap(
    lambda b: st.sampled_from([b.decode("latin-1"), b.decode("utf-8", errors="replace")]))
any_line = st.one_of(mutated_line(), mutated_line(), _decoded_bytes, st.text(max_size=30), valid_line())

# A context that makes motion words meaningful (units, feed, a position): errors then come from the block.
_PREAMBLE = ["G21 G90 G17 F100", "G0 X1 Y2 Z3", "#1=2 #<s>=0.5"]


def _check_diagnostics(diagnostics, lines: list[str]) -> None:
    assert diagnostics, "GCodeError without a diagnostic"
    for d in diagnostics:
        assert d.line >= 1 and d.col >= 1, str(d)
        assert d.code and d.message, str(d)
        if d.line <= len(lines):
            assert d.col <= len(lines[d.line - 1]) + 1, f"{d} is past the end of {lines[d.line - 1]!r}"
        else:
            assert d.line == len(lines) + 1, f"{d} is beyond the end of a {len(lines)}-line program"


def _check_finite(program) -> None:
    """Accepted input must not smuggle inf/nan into the motion (e.g. X followed by 400 nines)."""
    for m in program.entities:
        if isinstance(m, Dwell):
            assert math.isfinite(m.seconds), f"non-finite dwell {m!r}"
        if isinstance(m, MOTION_TYPES):
            values = [*m.start, *m.end, *getattr(m, "center", ()), m.feed_mm_s or 0.0,
                      *(m.points.ravel().tolist() if hasattr(m, "points") else ())]
            assert all(math.isfinite(v) for v in values), f"non-finite value in {m!r}"


@SETTINGS
@given(st.lists(any_line, min_size=1, max_size=4), st.booleans(), st.booleans())
@example(["G1 X\x00 F100"], True, False)  # a NUL byte once passed the fast path as an empty slot
@example(["0/()G0(\x0c\x85)G0G0; "], False, True)  # form feed / NEL are not line breaks
@example(["G0G0(\x0cA); ", ""], False, True)
def test_garbage_only_raises_gcode_error(body: list[str], preamble: bool, all_errors: bool) -> None:
    text = "\n".join((_PREAMBLE if preamble else []) + body) + "\n"
    lines = text.split("\n")[:-1]
    try:
        program = ipr.parse_text(text, "fuzz.ngc", all_errors=all_errors)
    except GCodeError as err:
        _check_diagnostics(err.diagnostics, lines)
        assert all(d.file == "fuzz.ngc" and d.severity == "error" for d in err.diagnostics)
        return
    for w in program.warnings:
        assert w.line >= 1 and w.col >= 1, str(w)
    _check_finite(program)


# Where each hostile value goes: a coordinate, a feed, an arc radius, a dwell, a parameter.
_HOSTILE_CONTEXTS = ["G1 X{v}", "G1 X2 F{v}", "G2 X2 Y1 R{v}", "G4 P{v}", "#1={v}\nG1 X#1", "G6.2 P4 K{v}"]


@pytest.mark.parametrize("value", _HOSTILE, ids=[f"{i:02d}:{v[:12]}" for i, v in enumerate(_HOSTILE)])
def test_hostile_values_give_clear_errors(value: str) -> None:
    """Every hostile value in every context: a GCodeError with a place, or a finite program."""
    problems = []
    for context in _HOSTILE_CONTEXTS:
        text = "G21 G90 F100\nG0 X1 Y1\n" + context.format(v=value) + "\n"
        try:
            try:
                program = ipr.parse_text(text, "hostile.ngc")
            except GCodeError as err:
                _check_diagnostics(err.diagnostics, text.split("\n")[:-1])
                continue
            _check_finite(program)
        except Exception as exc:  # noqa: BLE001 - collect every context's failure for one report
            first_line = str(exc).splitlines()[0][:200] if str(exc) else ""
            problems.append(f"{context.format(v=value[:40])!r}: {type(exc).__name__}: {first_line}")
    assert not problems, "\n".join(problems)


_NURBS_GROUPS = [
    ["G06.2 P4 K0. X0. Y0. Z0. R1. F5000.", "K0. X10. Y5. Z0. R1.", "K0. X20. Y-5. Z0. R2.", "K0. X30. Y0. Z0. R1.",
     "K1.", "K1.", "K1.", "K1.", "G1 X0"],
    ["G5.2 X0 Y1 P1 L3", "X2 Y2 P1", "X2 Y0 P1", "X0 Y0 P2", "G5.3", "G0 X1"],
    ["G6.2 X0 Y0 R1 K0 P3 Q1", "X1 Y2 R1 K0", "X3 Y2 R1.5 K0", "X4 Y0 R1 K1", "X6 Y1 R1 K2",
     "G6.2 K3", "G6.2 K3", "G6.2 K3", "G1 X0 Y0"],
]
_NUMBER_TOKEN = re.compile(r"(?<=[A-Za-z])[-+]?[0-9.]+")


@st.composite
def mutated_nurbs_program(draw) -> str:
    """A NURBS group (Fanuc G06.2, LinuxCNC G5.2 or G6.2) with lines dropped, repeated, swapped or
    cut, and numbers replaced: exercises the group and knot-vector validation."""
    lines = list(draw(st.sampled_from(_NURBS_GROUPS)))
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["drop", "repeat", "swap", "cut", "number", "number", "plane", "g91"]))
        if op == "drop" and len(lines) > 1:
            del lines[i]
        elif op == "repeat":
            lines.insert(i, lines[i])
        elif op == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == "cut":
            lines[i] = lines[i][:draw(st.integers(0, len(lines[i])))]
        elif op == "number":
            spans = [m.span() for m in _NUMBER_TOKEN.finditer(lines[i])]
            if spans:
                a, b = spans[draw(st.integers(0, len(spans) - 1))]
                value = draw(st.sampled_from(["0", "-1", "1", "2", "7", "0.5", "1e3", "-0", "99999999", "6", "1."]))
                lines[i] = lines[i][:a] + value + lines[i][b:]
        elif op == "plane":
            lines.insert(i, draw(st.sampled_from(["G18", "G19", "G17", "G20", "G91", "G92 X1"])))
        else:
            lines.insert(0, "G91")
    return "G21 G90 G17 F600\nG0 X0 Y0 Z0\n" + "\n".join(lines) + "\n"


@SETTINGS
@given(mutated_nurbs_program(), st.booleans())
def test_mutated_nurbs_groups_only_raise_gcode_error(text: str, all_errors: bool) -> None:
    try:
        program = ipr.parse_text(text, "nurbs.ngc", all_errors=all_errors)
    except GCodeError as err:
        _check_diagnostics(err.diagnostics, text.split("\n")[:-1])
        return
    _check_finite(program)
    for curve in (m for m in program.entities if isinstance(m, Nurbs)):  # what is accepted is a valid curve
        n, p = len(curve.points), curve.degree
        assert 1 <= p <= 5 and len(curve.knots) == n + p + 1 and n >= p + 1
        assert np.all(np.diff(curve.knots) >= 0) and np.all(curve.weights > 0)
        assert np.all(curve.knots[:p + 1] == curve.knots[0]) and np.all(curve.knots[-p - 1:] == curve.knots[-1])


def _outcome(parse, line: str):
    """The Block, or where and why the line was rejected (the two paths must agree on both)."""
    try:
        return ("ok", parse(line))
    except LineSyntaxError as err:
        assert 1 <= err.col <= len(line) + 1, f"column {err.col} outside {line!r}"
        return ("error", err.col, err.message)


@SETTINGS
@given(valid_line())
def test_fast_path_equals_full_grammar_on_valid_lines(line: str) -> None:
    assert _outcome(ipr.parse_line, line) == _outcome(ipr.parse_line_full, line)


@SETTINGS
@given(st.one_of(mutated_line(), st.text(st.characters(blacklist_characters="\r\n"), max_size=30)))
@example(" X\x00 ")
def test_fast_path_equals_full_grammar_on_broken_lines(line: str) -> None:
    line = line.replace("\n", " ").replace("\r", " ")
    assert _outcome(ipr.parse_line, line) == _outcome(ipr.parse_line_full, line)


def test_fast_path_equals_full_grammar_on_corpus_shapes() -> None:
    """Hand-picked line shapes from the corpus and the spec, spacing and case variants included."""
    lines = ["G1 X0.0000 Y1.0000", "G01 X0.0006 Y1.0000", " X3.1940 Z-0.1539", "G3 X3.094 Y4.858 Z-0.154 I0.0013 K0.0205",
             "Y[#2*-56.12] Z[#3*-27.725]", "G1 Z[#3*-25.372] F[#4*100]", "#1 = .5", " Z5.0 G43  H00 M8",
             "G6.2 X54.493 Y52.139 R1 K0 P5 Q1", "    X55.507 Y52.139 R1 K0", "G6.2 K47", "G5.2 X3.53   Y-1.50   P2",
             "g1 x 1 y - 2.5 f 100", "G1 X1 (comment) Y2 ; more", "(MSG, hello world)", "N10 G0 X1", "/G1 X5",
             "G06.2 P4 K0. X0. Y0. Z0. R1. F5000.", "K1.", "%", "", "   ", "G1 X1.Y2.", "G1X-.5Y+.5"]
    for line in lines:
        assert _outcome(ipr.parse_line, line) == _outcome(ipr.parse_line_full, line), line


# ---- compiled expressions (loops run their lines' expressions compiled) ---------------------------

def _value_or_error(f):
    try:
        return f()
    except Exception as err:   # noqa: BLE001 - the error itself is what is compared
        return type(err).__name__, str(err)


@SETTINGS
@given(expression(), st.lists(st.floats(-1e3, 1e3), min_size=5, max_size=5))
@example("[[EXP[700]*EXP[700]] GT 0]", [0.0] * 5)   # an overflow inside is an error, whatever the result
@example("[1/[EXP[709]+EXP[709]+EXP[709]]]", [0.0] * 5)   # 1/inf would be 0
@example("[#1/0]", [0.0] * 5)
@example("[2**EXP[7]]", [0.0] * 5)
@example("[#[#1+0.5]]", [0.25] * 5)
@example("[-#[EXP[800]]]", [0.0] * 5)
def test_compiled_expressions_equal_the_tree_walk(text: str, values: list[float]) -> None:
    from ipr.expressions import compile_expression, evaluate
    from ipr.modal import ModalState, Setup

    try:
        node = ipr.parse_line_full(f"X{text}").words[0][1]
    except LineSyntaxError:
        return
    params = ModalState(Setup()).params
    params.update({1: values[0], 2: values[1], 3: values[2], "a": values[3], "_g": values[4]})
    walked = _value_or_error(lambda: evaluate(node, params))
    compiled = _value_or_error(lambda: compile_expression(node)(params))
    assert walked == compiled or (walked != walked and compiled != compiled)   # nan is no outcome, but alike


@SETTINGS
@given(st.lists(st.sampled_from([
    "#1=[#1+1]", "#2=[#2*1.5-#1]", "G1 X[#1 MOD 7] Y[#2/3] F[100+#1]", "G0 Z[SQRT[#1]]",
    "G1 X[#1] Y[COS[#1*30]*5]", "G2 X[#1+1] Y0 R[2+#1/10]", "G91 G1 X0.5", "G90", "#<_v>=[#<_v>+#2]",
    "G1 X#<_v>"]), min_size=1, max_size=6), st.integers(1, 6))
def test_a_loop_runs_its_lines_as_they_run_written_out(body: list[str], count: int) -> None:
    """A loop body run `count` times (read once, its expressions compiled) gives the moves of the
    same lines written out `count` times (each line read and walked once)."""
    head = "G21 G90 G17 G0 X0 Y0 Z0 F100\n#1=1\n#2=1\n#<_v>=0\n"
    looped = head + f"o1 repeat [{count}]\n" + "\n".join(body) + "\no1 endrepeat\nM2\n"
    written = head + "\n".join(body * count) + "\nM2\n"

    def moves(text):
        try:
            return [(type(e).__name__, getattr(e, "end", None), getattr(e, "feed_mm_s", None))
                    for e in ipr.parse_text(text).entities]
        except GCodeError as err:
            return [d.code for d in err.diagnostics]
    assert moves(looped) == moves(written)
