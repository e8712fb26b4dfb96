"""ipr.interpretation: a whole program in batches, and ProgramText interpreted again and again."""
from __future__ import annotations

import pytest

import ipr
import ipr.interpretation as interpretation
from ipr import GCodeError, ProgramText, Setup
from ipr.entities import Line


def test_text_lines_are_the_lines_of_split_at_any_chunk_size(monkeypatch):
    text = "G0 X1\r\n\nG1 X2 F100\n(comment)\nG1 Y3\n" * 7
    for chunk in (1, 3, 7, 20, 1 << 20):
        monkeypatch.setattr(interpretation, "_CHUNK_CHARS", chunk)
        for t in (text, text.rstrip("\n"), "", "\n", "G0 X1"):
            assert list(interpretation.text_lines(t)) == t.split("\n")


def test_streaming_yields_the_moves_compensation_holds_at_the_end():
    # cutter compensation holds a move back until it sees the next one; at the end of a program
    # without M2 the interpreter's finish hands it over, and a stream must yield it too
    text = "G21 G90 G17\nG0 X0 Y0\nG41 D1 G1 X10 Y0 F100\nG1 Y10\nG1 X0\n"
    setup = Setup(tool_radii_mm={1: 1.0})
    whole = ipr.parse_text(text, setup=setup).entities
    assert [type(e).__name__ for e in whole] == ["Rapid", "Line", "Line", "Line"]
    assert list(ipr.iter_entities(text.split("\n"), setup=setup)) == whole
    assert [e for batch in ProgramText("<string>", text).interpret(setup) for e in batch] == whole


def test_every_error_is_raised_once_the_batches_run_out():
    run = ProgramText("p.nc", "G0 X1\nG33 X2 K1\nG1 X3 F100\nG1 Y2 Z\nG1 Y4\n").interpret(all_errors=True)
    seen = []
    with pytest.raises(GCodeError) as info:
        for batch in run:
            seen += batch
    assert [(d.line, d.code) for d in info.value.diagnostics] == [(2, "E-GCODE-UNSUPPORTED"), (4, "E-SYNTAX")]
    assert [(type(e).__name__, e.line) for e in seen] == [("Rapid", 1), ("Line", 3), ("Line", 5)]


def test_a_program_text_reads_its_subroutine_files_once(tmp_path):
    (tmp_path / "side.ngc").write_text("o<side> sub\n  G1 X#1 F100\no<side> endsub\nM2\n")
    main = tmp_path / "main.ngc"
    main.write_text("G21 G90\no<side> call [5]\no<side> call [7]\nM2\n")
    text = ProgramText.read(main)
    first = [e for batch in text.interpret() for e in batch]
    (tmp_path / "side.ngc").write_text("o<side> sub\n  G1 Y#1 F100\no<side> endsub\nM2\n")
    again = [e for batch in text.interpret() for e in batch]
    assert again == first   # the text read at the first call, not the file changed since
    assert [e.end for e in first if isinstance(e, Line)] == [(5, 0, 0), (7, 0, 0)]
    assert [e.end for e in ipr.parse_file(main).entities if isinstance(e, Line)] == [(0, 5, 0), (0, 7, 0)]
    assert {e.file for e in first if isinstance(e, Line)} == {str(tmp_path / "side.ngc")}


def test_a_loop_is_handed_out_in_bounded_batches():
    count = 10_000
    run = ProgramText("loop.ngc", f"G21 G90 G0 X0 Y0\n#1=0\no1 repeat [{count}]\n  #1=[#1+1]\n"
                                  f"  G1 X[#1 MOD 2] Y#1 F600\no1 endrepeat\nM2\n").interpret()
    sizes, last = [], None
    for batch in run:
        sizes.append(len(batch))
        last = batch[-1]
    # one iteration makes one entity: they are gathered into batches, never more than one batch held
    assert sum(sizes) == count + 2 and sizes[:2] == [interpretation.BATCH] * 2 and max(sizes) == interpretation.BATCH
    assert last.line == 7 and run.last_line == 7
