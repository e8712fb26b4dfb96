"""`vcnc stream` end to end against the grbl test double and the increment receiver."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from grbl_emulator import Faults, GrblDouble, PtyServer
from ipo.config import default_config
from ipr import parse_file
from machine.cli import main
from machine.grbl.program import stream_lines
from machine.increments.receiver import IncrementReceiver, SocketEndpoint

DEMO = Path(__file__).resolve().parents[1] / "programs" / "demo.nc"


def _expected_lines():
    prog = parse_file(DEMO)
    return list(stream_lines(prog.entities, default_config(), ipo_from_start=True))


def test_dry_run_writes_exactly_the_stream():
    res = CliRunner().invoke(main, ["stream", str(DEMO), "--dry-run"])
    assert res.exit_code == 0, res.output
    want = "".join(l.text + "\n" for l in _expected_lines())
    assert res.stdout_bytes.decode("ascii") == want
    assert all(len(t) <= 79 for t in want.splitlines())


def test_stream_resume_after_error_through_the_cli():
    lines = _expected_lines()
    bad = lines[len(lines) // 2]
    d = GrblDouble(drain_s_per_block=0.01, faults=Faults(error_on={bad.text: 33}))  # planner never runs dry
    with PtyServer(d).start() as srv:
        res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", srv.port, "--poll-hz", "20"])
        assert res.exit_code == 1
        assert f"error:33 on stream line {bad.seq} (program line {bad.source_line}" in res.output
        resume = int(re.search(r"--resume-from (\d+)", res.output).group(1))
        assert resume <= bad.seq
        res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", srv.port, "--resume-from", str(resume),
                                        "--poll-hz", "20"])
    assert res.exit_code == 0, res.output
    ran = [t for _, t in d.executed if t is not None]
    want = [l.end_mm for l in lines if l.motion]
    assert len(ran) == len(want)
    assert np.allclose(ran, want, atol=1e-4)


def test_increments_through_the_cli_end_at_the_programs_end():
    remote = IncrementReceiver(capacity_periods=4096)
    with SocketEndpoint(remote).start() as ep:
        res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", ep.port, "--protocol", "increments"])
    assert res.exit_code == 0, res.output
    end = np.array(parse_file(DEMO).motions()[-1].end)
    assert remote.position_blu.tolist() == np.rint(end / default_config().blu_mm).astype(int).tolist()


def test_bad_port_and_missing_port_are_clear_errors():
    res = CliRunner().invoke(main, ["stream", str(DEMO)])
    assert res.exit_code == 2 and "--port is required" in res.output
    res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", "/dev/nonexistent-vcnc"])
    assert res.exit_code == 1 and "cannot open /dev/nonexistent-vcnc" in res.output
    res = CliRunner().invoke(main, ["stream", str(DEMO), "--dry-run", "--protocol", "increments",
                                    "--resume-from", "3"])
    assert res.exit_code == 2 and "grbl streams only" in res.output
