"""Hypothesis: programs built from O-word constructs, random and mutated, never raise anything but
ipr.entities.GCodeError, every diagnostic points at a real line of a real file, and a run ends
(loops are bounded by a small iteration limit, calls by the depth limit)."""
from __future__ import annotations

import os

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ipr
from ipr.entities import GCodeError

SETTINGS = settings(max_examples=int(os.environ.get("VCNC_FUZZ_EXAMPLES", "150")), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
LIMITED = ipr.Setup(max_loop_iterations=500)

_labels = st.sampled_from(["1", "2", "100", "<a>", "<sub b>", "<C>"])
_conds = st.sampled_from(["[#1 LT 3]", "[1]", "[0]", "[#<_x> GT -1]", "[#2]", "[EXISTS[#<q>]]", "[1/0]",
                          "[#1 EQ 2 OR #2 GT 1]", "[", "[]", "[#<nope>]"])
_plain = st.sampled_from(["G0 X#1", "G1 X[#1*2] F100", "#1=[#1+1]", "#2=[#2+#1]", "G0 Y#<_value>",
                          "(debug, v=#1 #<a>)", "M2", "G2 X0 Y0 I1", "#<q>=1", "M98 P7", "M99", "O7",
                          "#<_g>=[#<_g>+1]", "G0 X[#5420+1]", ""])


@st.composite
def oword_line(draw) -> str:
    label = draw(_labels)
    keyword = draw(st.sampled_from(["sub", "endsub", "return", "call", "if", "elseif", "else", "endif",
                                    "while", "endwhile", "do", "break", "continue", "repeat", "endrepeat",
                                    "frob"]))
    args = ""
    if keyword in ("if", "elseif", "while", "repeat"):
        args = " " + draw(_conds)
    elif keyword in ("call", "return", "endsub"):
        args = "".join(f" [{draw(st.integers(-3, 5))}]" for _ in range(draw(st.integers(0, 3))))
    return f"o{label} {keyword}{args}"


@st.composite
def structured(draw, depth: int = 0) -> list[str]:
    """Mostly well-formed nests of constructs, to reach deep into the executor."""
    lines: list[str] = []
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["plain", "plain", "while", "repeat", "if", "do", "call"]))
        label = draw(_labels)
        body = draw(structured(depth + 1)) if depth < 2 else [draw(_plain)]
        if kind == "plain":
            lines.append(draw(_plain))
        elif kind == "while":
            lines += [f"o{label} while {draw(_conds)}", *body, f"o{label} endwhile"]
        elif kind == "repeat":
            lines += [f"o{label} repeat [{draw(st.integers(-1, 4))}]", *body, f"o{label} endrepeat"]
        elif kind == "do":
            lines += [f"o{label} do", *body, f"o{label} while {draw(_conds)}"]
        elif kind == "if":
            lines += [f"o{label} if {draw(_conds)}", *body, f"o{label} else", draw(_plain), f"o{label} endif"]
        else:
            lines += [f"o{label} call [{draw(st.integers(0, 3))}]", f"o{label} sub", *body, f"o{label} endsub"]
    return lines


def _check(text: str, all_errors: bool) -> None:
    lines = text.split("\n")
    try:
        ipr.parse_text(text, "fuzz.ngc", setup=LIMITED, all_errors=all_errors)
    except GCodeError as err:
        for d in err.diagnostics:
            assert d.file == "fuzz.ngc" and 1 <= d.line <= len(lines), str(d)
            assert 1 <= d.col <= len(lines[d.line - 1]) + 1, str(d)


@SETTINGS
@given(st.lists(st.one_of(oword_line(), _plain), min_size=1, max_size=25), st.booleans())
def test_random_oword_programs_raise_only_gcode_errors(lines, all_errors):
    _check("\n".join(lines), all_errors)


@SETTINGS
@given(structured(), st.data(), st.booleans())
def test_mutated_structured_programs_raise_only_gcode_errors(lines, data, all_errors):
    lines = list(lines)
    for _ in range(data.draw(st.integers(0, 3))):
        if not lines:
            break
        i = data.draw(st.integers(0, len(lines) - 1))
        how = data.draw(st.sampled_from(["drop", "duplicate", "swap", "truncate"]))
        if how == "drop":
            del lines[i]
        elif how == "duplicate":
            lines.insert(i, lines[i])
        elif how == "swap":
            j = data.draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        else:
            lines[i] = lines[i][:data.draw(st.integers(0, len(lines[i])))]
    _check("\n".join(lines), all_errors)
    # the streamed run agrees with the whole run: same entities or the same first error
    text = "\n".join(lines)
    try:
        whole = ipr.parse_text(text, "fuzz.ngc", setup=LIMITED).entities
    except GCodeError as err:
        whole = str(err.diagnostics[0])
    try:
        streamed = list(ipr.iter_entities(iter(lines), "fuzz.ngc", setup=LIMITED))
    except GCodeError as err:
        streamed = str(err.diagnostics[0])
    if isinstance(whole, str) or isinstance(streamed, str):
        assert streamed == whole, (whole, streamed)
    else:
        assert streamed == whole
