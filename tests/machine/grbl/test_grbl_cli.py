"""`vcnc stream` end to end against the grbl test double and the increment receiver."""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from grbl_emulator import GrblDouble, PtyServer
from ipo.config import default_config
from ipr import parse_file
from machine.cli import main
from machine.grbl.job import build_job, machine_at_zero
from machine.grbl.program import stream_lines
from machine.increments import frames as F
from machine.increments.receiver import IncrementReceiver, SocketEndpoint

DEMO = Path(__file__).resolve().parents[3] / "programs" / "demo.nc"


def _expected_lines():
    prog = parse_file(DEMO)
    return list(stream_lines(prog.entities, default_config(), ipo_from_start=True))


def _lines_for(double):
    """The stream for DEMO on a machine standing where `double` stands, in its G54 frame."""
    zero = machine_at_zero()
    state = dataclasses.replace(zero, mpos_mm=tuple(double.pos), wco_mm=double.wco,
                                offsets_mm={**zero.offsets_mm, "G54": double.wco})
    return build_job(DEMO, default_config(), state).lines


def test_dry_run_writes_exactly_the_stream():
    res = CliRunner().invoke(main, ["stream", str(DEMO), "--dry-run"])
    assert res.exit_code == 0, res.output
    want = "".join(l.text + "\n" for l in _expected_lines())
    assert res.stdout_bytes.decode("ascii") == want
    assert all(len(t) <= 79 for t in want.splitlines())


def test_a_clean_stream_sends_exactly_the_dry_run_lines(tmp_path):
    """On a machine at zero with no offsets (what --dry-run assumes) the stream is the dry run's."""
    dry = CliRunner().invoke(main, ["stream", str(DEMO), "--dry-run"]).stdout_bytes.decode("ascii").splitlines()
    d = GrblDouble(wco=(0.0, 0.0, 0.0))
    with PtyServer(d).start() as srv:
        res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", srv.port, "--poll-hz", "20",
                                        "--ledger", str(tmp_path / "l")])
    assert res.exit_code == 0, res.output
    assert d.received[:4] == ["$$", "$I", "$G", "$#"] and d.received[4:] == dry
    # not a terminal: plain status lines, with the job time from the grbl twin of the board's $$
    assert "job time (grbl 1.1 twin: $$ of the board, 115200 baud)" in res.output and "acknowledged" in res.output
    assert "remaining ~" in res.output
    assert d.max_rx_fill <= 127 and d.rx_overflow == 0


def test_increment_frames_sent_are_the_dry_run_frames():
    dry = CliRunner().invoke(main, ["stream", str(DEMO), "--dry-run", "--protocol", "increments"]).stdout_bytes
    want = F.FrameParser().feed(dry)
    seen = bytearray()
    remote = IncrementReceiver(capacity_periods=4096)
    with SocketEndpoint(remote, mangle=lambda b: seen.extend(b) or b).start() as ep:
        res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", ep.port, "--protocol", "increments"])
    assert res.exit_code == 0, res.output
    got = F.FrameParser().feed(bytes(seen))
    assert got[0].kind == want[0].kind == F.HELLO
    data = {f.seq: f.inc_blu for f in got if f.kind == F.DATA}  # a resend repeats a seq
    want_data = [f for f in want if f.kind == F.DATA]
    assert sorted(data) == [f.seq for f in want_data]
    assert all(np.array_equal(data[f.seq], f.inc_blu) for f in want_data)
    assert {f.kind for f in got[1:]} <= {F.DATA, F.POLL}


def test_stream_resume_after_error_through_the_cli(tmp_path):
    d = GrblDouble(drain_s_per_block=0.01, mpos=(3.0, 4.0, 5.0))  # planner never runs dry
    lines = _lines_for(d)
    bad = lines[len(lines) // 2]
    d.faults.error_on[bad.text] = 33
    led = ["--ledger", str(tmp_path / "demo.ledger")]
    with PtyServer(d).start() as srv:
        res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", srv.port, "--poll-hz", "20", *led])
        assert res.exit_code == 1
        assert f"error:33 on stream line {bad.seq} (program line {bad.source_line}" in res.output
        resume = int(re.search(r"--resume-from (\d+)", res.output).group(1))
        assert resume <= bad.seq
        assert f"--resume   (stream line {resume}" in res.output
        res = CliRunner().invoke(main, ["stream", str(DEMO), "--port", srv.port, "--resume", "--poll-hz", "20", *led])
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
