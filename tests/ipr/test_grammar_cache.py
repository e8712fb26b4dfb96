"""The grammar's parse tables cached between processes (ipr.syntax.grammar_cache_file, issue 22).

A parser loaded from the cache must parse exactly as one built from the grammar in this
process; a corrupt cache file must cost a rebuild, never a wrong parse or an error; without
a usable cache directory the parser is built per process.
"""
from __future__ import annotations

import pytest
from lark import Lark

from ipr import syntax

LINES = [
    "N10 G01 X1.5 Y-2 Z.25 F1200 (a comment) (MSG, hello)",
    "G06.2 P3 K0 X0 Y0 Z0 R1",
    "#1 = [2 * SIN[30] + #<_tool>] #<depth>=-1.5",
    "/ G02 X[#1 + 2] Y[ABS[-3]] I1 J0 ; end",
    "g1 x[#1 + 2] y[abs[-3]] (print, #1)",
    "%",
]
BAD = ["G01 X1 Y", "G01 X$"]


def _parses(parser: Lark) -> list:
    out = [parser.parse(line) for line in LINES]
    for line in BAD:
        with pytest.raises(Exception) as err:
            parser.parse(line)
        out.append(type(err.value).__name__)
    return out


def test_a_parser_loaded_from_the_cache_parses_as_one_built_here(tmp_path):
    fresh = _parses(syntax.build_parser(syntax._ToBlock(), False))
    assert fresh[0][0].words == (("N", 10.0), ("G", 1.0), ("X", 1.5), ("Y", -2.0), ("Z", 0.25), ("F", 1200.0))
    assert fresh[0][1] == (1, 5, 9, 14, 18, 23)  # the columns of the words, counted by hand
    path = tmp_path / "gcode.lark-cache"
    assert _parses(syntax.build_parser(syntax._ToBlock(), str(path))) == fresh
    written = path.stat().st_mtime_ns
    assert _parses(syntax.build_parser(syntax._ToBlock(), str(path))) == fresh
    assert path.stat().st_mtime_ns == written  # loaded, not rebuilt


def test_a_corrupt_cache_file_is_rebuilt(tmp_path):
    fresh = _parses(syntax.build_parser(syntax._ToBlock(), False))
    path = tmp_path / "gcode.lark-cache"
    syntax.build_parser(syntax._ToBlock(), str(path))
    good = path.read_bytes()
    path.write_bytes(good[: len(good) // 2])
    assert _parses(syntax.build_parser(syntax._ToBlock(), str(path))) == fresh
    rewritten = path.stat().st_mtime_ns
    assert _parses(syntax.build_parser(syntax._ToBlock(), str(path))) == fresh
    assert path.stat().st_mtime_ns == rewritten  # the rewritten file loads


def test_the_cache_lives_under_xdg_cache_home_named_by_the_grammar(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    name = syntax.grammar_cache_file()
    assert name.startswith(str(tmp_path / "vcnc" / "grammar" / "gcode-"))
    blocked = tmp_path / "file"
    blocked.write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))  # a file where the directory should be
    assert syntax.grammar_cache_file() is False
