"""Every fault of issue 17 against the grbl test double, through the CLI: the
positions grbl is commanded to match the program's G-code semantics (written out by
hand here), no line is lost or run twice, and the resume line is the right one.

The double is strict where grbl is (tests/grbl_emulator.py): blocks run only after a
cycle start, a reset throws the planner away, Ln is reported by a build with line
numbers, and G53 / G54 offsets / $G / $# behave as in grbl 1.1.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from grbl_emulator import Faults, GrblDouble, PtyServer, SocketServer
from machine.cli import main

ROOT = Path(__file__).resolve().parents[3]


def _run(args, tmp_path):
    return CliRunner().invoke(main, ["stream", *args, "--ledger", str(tmp_path / "ledger"), "--poll-hz", "20"])


def _write(tmp_path, text, name="p.nc"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def _ran(d):
    return [t for _, t in d.executed if t is not None]


def test_axes_the_program_never_named_stay_where_the_machine_is(tmp_path):
    """Machine at X50 Y50 Z0 (machine = work, no offsets): `G0 Z5` / `G1 X10` moves Z, then X
    only. The old stream sent G0X0Y0Z5: a diagonal rapid to X0 Y0 the program never asked for."""
    d = GrblDouble(mpos=(50.0, 50.0, 0.0), wco=(0.0, 0.0, 0.0))
    prog = _write(tmp_path, "G21 G90\nG0 Z5\nG1 X10 F600\nM2\n")
    with PtyServer(d).start() as srv:
        res = _run([prog, "--port", srv.port], tmp_path)
    assert res.exit_code == 0, res.output
    assert _ran(d) == [(50.0, 50.0, 5.0), (10.0, 50.0, 5.0)]
    assert [t for t in d.received if not t.startswith("$")] == ["G0Z5", "G1F600X10", "M2"]
    assert "program line 2 moves before the program sets X, Y" in res.output
    assert "X50.000 Y50.000" in res.output


def test_g53_goes_out_as_g53_with_a_work_offset(tmp_path):
    """G54 Z offset -20: `G53 G0 Z-2` goes to machine Z-2 (the old stream sent work Z-2,
    machine Z-22, 20 mm lower); the following G54 move is in work coordinates again."""
    d = GrblDouble(mpos=(0.0, 0.0, -30.0), wco=(0.0, 0.0, -20.0))
    prog = _write(tmp_path, "G90 G54\nG53 G0 Z-2\nG0 X10 Y5\nG1 Z-1 F300\nM2\n")
    with PtyServer(d).start() as srv:
        res = _run([prog, "--port", srv.port], tmp_path)
    assert res.exit_code == 0, res.output
    assert _ran(d) == [(0.0, 0.0, -2.0), (10.0, 5.0, -2.0), (10.0, 5.0, -21.0)]
    assert "G53G0Z-2" in d.received


def test_g10_g92_and_g28_move_where_their_semantics_say(tmp_path):
    """vcnc's interpreter keeps G10 L2, G92 and G28 (grbl's stored G28 from `$#`) and sends
    the resulting positions in grbl's start frame: G54 Z-20 at the start, machine at
    X50 Y50 Z-10. By hand: Z5 -> machine Z-15; G54 Z becomes -25, Z5 -> -20; G92 X0 at
    X50 makes X10 machine 60; G28 goes to the stored (0, 0, 0); after G92.1, X1 -> 1."""
    d = GrblDouble(mpos=(50.0, 50.0, -10.0), wco=(0.0, 0.0, -20.0))
    prog = _write(tmp_path, "G90 G0 Z5\nG10 L2 P1 Z-25\nG0 Z5\nG92 X0\nG0 X10\nG92.1\nG28\nG0 X1\nM2\n")
    with PtyServer(d).start() as srv:
        res = _run([prog, "--port", srv.port], tmp_path)
    assert res.exit_code == 0, res.output
    assert _ran(d) == [(50.0, 50.0, -15.0), (50.0, 50.0, -20.0), (60.0, 50.0, -20.0), (0.0, 0.0, 0.0),
                       (1.0, 0.0, 0.0)]


def test_error_before_the_cycle_started_resumes_from_the_first_line(tmp_path):
    """grbl parses slowly (its RX buffer still holds lines), so it has not started the
    cycle when line 5 is rejected: the reset throws away the planned lines 2-4 and
    nothing moved. The resume line is the first motion, not 'none of lines 5..10'."""
    text = "G0 X1 Y1 Z1\nG1 X2 F600\nG1 X3\nG1 Y7\nG1 X4\nG1 X5\nG1 X6\nG1 X7\nM2\n"
    d = GrblDouble(wco=(0.0, 0.0, 0.0), drain_s_per_block=0.2,
                   faults=Faults(error_on={"Y7": 20}, ack_delay_s=0.05))
    prog = _write(tmp_path, text)
    with PtyServer(d).start() as srv:
        res = _run([prog, "--port", srv.port], tmp_path)
        assert res.exit_code == 1
        assert "error:20 on stream line 4 (program line 4" in res.output
        assert _ran(d) == []  # nothing moved
        assert "--resume   (stream line 1, program line 1" in res.output
        d.faults.error_on.clear()
        res = _run([prog, "--port", srv.port, "--resume"], tmp_path)
    assert res.exit_code == 0, res.output
    assert _ran(d) == [(1, 1, 1), (2, 1, 1), (3, 1, 1), (3, 7, 1), (4, 7, 1), (5, 7, 1), (6, 7, 1), (7, 7, 1)]


def test_line_numbers_name_the_running_line(tmp_path):
    """A build with line numbers (`$I` option N): lines carry N<seq>, the stop uses `Ln`."""
    text = "G0 Z1\n" + "".join(f"G1 X{i} F600\n" for i in range(1, 31)) + "M2\n"
    d = GrblDouble(wco=(0.0, 0.0, 0.0), drain_s_per_block=0.05, line_numbers=True, partial_blocks=True,
                   faults=Faults(error_on={"N12X11": 20}))
    prog = _write(tmp_path, text)
    with PtyServer(d).start() as srv:
        res = _run([prog, "--port", srv.port], tmp_path)
        assert res.exit_code == 1
        assert d.received[4] == "N1G0Z1" and d.received[5] == "N2G1F600X1"
        d.faults.error_on.clear()
        res = _run([prog, "--port", srv.port, "--resume"], tmp_path)
    assert res.exit_code == 0, res.output
    ends = [(0.0, 0.0, 1.0)] + [(float(i), 0.0, 1.0) for i in range(1, 31)]
    assert _ran(d) == ends


def _program_60(tmp_path):
    text = "G21 G90\nG0 Z2\nG1 Z-1 F300\n" + "".join(f"G1 X{i + 1} Y{3 * (i % 2)} F1200\n" for i in range(60))
    text += "G0 Z5\nM2\n"
    ends = [(0.0, 0.0, 2.0), (0.0, 0.0, -1.0)] + [(float(i + 1), 3.0 * (i % 2), -1.0) for i in range(60)]
    return _write(tmp_path, text), ends + [(60.0, 3.0, 5.0)]


def _spawn(args, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-c", "from machine.cli import main; main()", "stream", *args, "--ledger",
                             str(tmp_path / "ledger"), "--poll-hz", "20", "--no-estimate"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, text=True)


def _wait_for(pred, timeout_s=30.0):
    t_end = time.monotonic() + timeout_s
    while not pred():
        assert time.monotonic() < t_end, "timed out"
        time.sleep(0.01)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
@pytest.mark.slow
def test_ctrl_c_sigterm_and_a_closed_terminal_hold_reset_and_print_the_resume_line(tmp_path, sig):
    """The signal holds the feed: no block runs after it; the reset comes once grbl
    reports Hold:0; the resume line is printed and --resume finishes the program with
    every motion run exactly once."""
    prog, ends = _program_60(tmp_path)
    d = GrblDouble(wco=(0.0, 0.0, 0.0), drain_s_per_block=0.05, hold_decel_s=0.15)
    with SocketServer(d).start() as srv:
        proc = _spawn([prog, "--port", srv.port], tmp_path)
        _wait_for(lambda: len(_ran(d)) >= 10)
        proc.send_signal(sig)
        ran_at_signal = len(_ran(d))
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 1, out
        # the hold is the sender's answer to the signal: before the program's end, and after it at most the
        # block running then finishes (counted from grbl's hold, not the test's signal: a loaded host delays
        # the sender's Python handler while grbl drains more blocks, as a real board would)
        assert d.moves_at_first_hold is not None, "no feed hold reached grbl"
        assert ran_at_signal <= d.moves_at_first_hold < len(ends)
        assert len(_ran(d)) <= d.moves_at_first_hold + 1
        assert d.state == "Idle"  # held, then reset at standstill: no ALARM:3
        m = re.search(r"--resume   \(stream line (\d+)", out)
        assert m, out
        assert int(m.group(1)) == len(_ran(d)) + 1  # the first line that did not run
        res = _run([prog, "--port", srv.port, "--resume"], tmp_path)
    assert res.exit_code == 0, res.output
    assert _ran(d) == ends


def test_sigkill_mid_stream_then_resume_from_the_ledger(tmp_path):
    """After SIGKILL nothing is printed, but the ledger on disk holds every line sent and
    acknowledged: grbl runs what it had, and --resume continues after its last line."""
    prog, ends = _program_60(tmp_path)
    d = GrblDouble(wco=(0.0, 0.0, 0.0), drain_s_per_block=0.03)
    with SocketServer(d).start() as srv:
        proc = _spawn([prog, "--port", srv.port], tmp_path)
        _wait_for(lambda: len(_ran(d)) >= 10)
        proc.kill()
        proc.communicate(timeout=30)
        ledger = (tmp_path / "ledger").read_text().splitlines()
        assert ledger[0].startswith("{") and any(l.startswith("A ") for l in ledger)
        _wait_for(lambda: d.state == "Idle" and not d.planner)
        res = _run([prog, "--port", srv.port, "--resume"], tmp_path)
    assert res.exit_code == 0, res.output
    assert _ran(d) == ends  # no line lost, none run twice


def test_mist_coolant_on_a_build_without_it_is_refused_before_the_first_byte(tmp_path):
    d = GrblDouble(mist=False)
    prog = _write(tmp_path, "G0 Z1\nM7\nG1 X1 F100\n")
    with PtyServer(d).start() as srv:
        res = _run([prog, "--port", srv.port], tmp_path)
    assert res.exit_code == 1 and "no mist coolant" in res.output
    assert all(t.startswith("$") for t in d.received) and _ran(d) == []
