"""machine.check: the check before motion covers everything that will execute and holds nothing of it
past a bound (machine.check.KEEP_UNITS: below it, the run takes the entities the check kept)."""
from __future__ import annotations

import dataclasses
import tracemalloc

import pytest

import ipr
import ipr.interpretation
import machine.check
from ipo.config import default_config
from ipr.entities import Line
from machine.check import CheckedProgram
from machine.controller import Controller, ProgramRejected

LOOP = ("G21 G90 G0 X0 Y0 Z0\n#1=0\no1 repeat [{count}]\n  #1=[#1+1]\n  G1 X[#1 MOD 2] Y[#1/{count}*10] F3000\n"
        "o1 endrepeat\nM2\n")


def test_a_loop_is_checked_without_holding_its_moves(tmp_path, monkeypatch):
    # the interpretation hands out batches of BATCH entities: small here, so that 5,000 moves are
    # many batches and holding them all would show; the check keeps at most two batches of them
    monkeypatch.setattr(ipr.interpretation, "BATCH", 256)
    monkeypatch.setattr(machine.check, "KEEP_UNITS", 256)
    path = tmp_path / "loop.ngc"
    ctl = Controller(default_config())
    path.write_text(LOOP.format(count=10))
    ctl.check(path)   # the caches of a first check (shapes, plans) are not what is measured
    path.write_text(LOOP.format(count=5_000))
    tracemalloc.start()
    try:
        program = ctl.check(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # 5,000 Line entities alone take more than 1 MB; the check keeps a few facts of them
    assert peak < 400_000, f"the check peaked at {peak / 1e6:.2f} MB of Python objects"
    assert not isinstance(program.entities, list)
    assert program.motion_count == 5_001 and program.last_line == 7 and program.start_mm == (0, 0, 0)


def test_the_run_gets_the_entities_the_check_saw(tmp_path):
    (tmp_path / "hole.ngc").write_text("o<hole> sub\n  G0 X#1 Y#2\n  G1 Z-1 F100\n  G0 Z1\no<hole> endsub\nM2\n")
    path = tmp_path / "grid.ngc"
    path.write_text("G21 G90 G0 Z1\n#2=0\no1 while [#2 LT 3]\n  o<hole> call [#2*10] [5]\n  #2=[#2+1]\n"
                    "o1 endwhile\nG0 X0 Y0\nM2\n")
    program = Controller(default_config()).check(path)
    reference = ipr.parse_file(path, setup=ipr.Setup.from_machine(default_config()))
    assert list(program.entities) == reference.entities
    assert list(program.entities) == reference.entities   # every iteration gives them all again
    assert isinstance(program.entities, list)   # a small program: the check kept them
    assert program.motion_count == 11 and program.last_line == 8 and program.rapid_lines == {1, 2, 4, 7}


def test_a_travel_excursion_in_a_loop_is_one_reason_at_its_farthest(tmp_path):
    cfg = default_config()
    x = dataclasses.replace(cfg.axes[0], max_mm=100.0)
    path = tmp_path / "ramp.ngc"
    path.write_text("G21 G90 G0 X0 Y0 Z0\n#1=0\no1 while [#1 LT 150]\n  #1=[#1+1]\n  G1 X#1 F3000\n"
                    "o1 endwhile\nG0 X0\nM2\n")
    with pytest.raises(ProgramRejected) as info:
        Controller(dataclasses.replace(cfg, axes=(x, cfg.axes[1], cfg.axes[2]))).check(path)
    assert info.value.reasons == [
        f"{path}:5:1: error[E-TRAVEL]: X reaches 150.0000 mm, above the travel limit 100.0000 mm"]


def test_interpreter_errors_alone_are_reported(tmp_path):
    path = tmp_path / "bad.ngc"
    path.write_text("G21 G90\nG1 X5000 F100\nG1 X1 Y\nM2\n")   # X5000 is past the travel too
    with pytest.raises(ProgramRejected) as info:
        Controller(default_config()).check(path)
    assert [r.split(": ")[:2] for r in info.value.reasons] == [[f"{path}:3:8", "error[E-SYNTAX]"]]


def test_a_program_held_whole_gives_the_same_facts():
    moves = [Line(3, (0, 0, 0), (1, 0, 0), 10.0), Line(4, (1, 0, 0), (1, 2, 0), 10.0)]
    program = CheckedProgram.of(ipr.Program("t.nc", moves))
    assert (program.start_mm, program.motion_count, program.last_line) == ((0, 0, 0), 2, 4)
    assert program.entities is moves
