"""The increment protocol: frames, CRC, resending, and a whole IPO run through a
receiver over a pty / a loopback socket ending at the simulated drive's BLU position."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ipo.config import default_config
from ipo.feed.planner import plan_periods
from ipr import parse_file
from machine.drive import Drive, DriveLimits
from machine.increments import frames as F
from machine.increments.link import IncrementLink
from machine.increments.receiver import IncrementReceiver, SocketEndpoint
from pty_endpoint import PtyEndpoint

CFG = default_config()
DEMO = Path(__file__).resolve().parents[2] / "programs" / "demo.nc"


def test_crc_is_ccitt_false():
    assert F.crc16(b"123456789") == 0x29B1  # the catalogued check value of CRC-16/CCITT-FALSE


def test_data_frame_layout_by_hand():
    inc = np.array([[1, -2, 300]])
    frame = F.data_frame(0x0102, inc)
    body = bytes([0x01, 0x02, 0x01, 1, 3]) + bytes([1, 0, 0xFE, 0xFF, 0x2C, 0x01])
    assert frame == b"\xa5\x5a" + body + F.crc16(body).to_bytes(2, "little")


def test_parser_skips_noise_and_rejects_a_corrupt_frame():
    a = F.data_frame(0, np.array([[1, 2, 3], [4, 5, 6]]))
    b = F.data_frame(1, np.array([[7, 8, 9]]))
    bad = bytearray(b)
    bad[8] ^= 0x40
    p = F.FrameParser()
    out = p.feed(b"\x00\xa5noise" + a[:5]) + p.feed(a[5:] + bytes(bad) + b"\xa5" + F.ack_frame(0, 99))
    assert [f.kind for f in out] == [F.DATA, F.ACK]
    assert out[0].inc_blu.tolist() == [[1, 2, 3], [4, 5, 6]] and out[1].free == 99
    assert p.bad_crc == 1


def test_increments_beyond_int16_are_refused():
    with pytest.raises(F.FrameError, match="int16"):
        F.data_frame(0, np.array([[40000, 0, 0]]))
    with pytest.raises(F.FrameError, match="1..255"):
        F.data_frame(0, np.zeros((256, 3), np.int64))


def _ipo_batches():
    prog = parse_file(DEMO)
    return [b for b in plan_periods(prog.entities, CFG) if hasattr(b, "inc_blu")]


@pytest.fixture(scope="module")
def batches():
    return _ipo_batches()


@pytest.mark.parametrize("endpoint", [PtyEndpoint, SocketEndpoint])
def test_ipo_run_through_the_receiver_ends_at_the_drive_position(batches, endpoint):
    limits = DriveLimits.from_config(CFG)
    simulated = Drive(limits)
    for b in batches:
        simulated.receive(b)
    summed = sum(np.asarray(b.inc_blu, np.int64).sum(axis=0) for b in batches)  # independent of both
    remote = IncrementReceiver(capacity_periods=2048, drive=Drive(limits))
    with endpoint(remote).start() as ep:
        link = IncrementLink(ep.port)
        res = link.send(batches)
        link.close()
    assert res.periods == sum(len(b) for b in batches) == remote.executed_periods
    assert remote.duplicates == res.resent_frames  # a resend after a slow answer is recognised, not taken twice
    assert remote.position_blu.tolist() == simulated.position_blu.tolist() == summed.tolist()
    assert remote.drive.position_blu.tolist() == summed.tolist()
    end_mm = np.array(parse_file(DEMO).motions()[-1].end)
    assert summed.tolist() == np.rint(end_mm / CFG.blu_mm).astype(int).tolist()


def _corrupt_at(offsets, drop=False):
    """Tests: flip (or drop) the bytes at these stream offsets on their way to the drive."""
    seen = {"n": 0}

    def mangle(data: bytes) -> bytes:
        lo = seen["n"]
        seen["n"] += len(data)
        out = bytearray(data)
        for off in sorted(offsets, reverse=True):
            if lo <= off < lo + len(data):
                if drop:
                    del out[off - lo: off - lo + 40]
                else:
                    out[off - lo] ^= 0x5A
        return bytes(out)
    return mangle


@pytest.mark.parametrize("drop", [False, True])
def test_corrupt_or_lost_frames_are_resent(batches, drop):
    summed = sum(np.asarray(b.inc_blu, np.int64).sum(axis=0) for b in batches)
    remote = IncrementReceiver(capacity_periods=1024)
    with SocketEndpoint(remote, mangle=_corrupt_at([3000, 25000, 60000], drop=drop)).start() as ep:
        link = IncrementLink(ep.port, resend_timeout_s=0.05)
        res = link.send(batches)
        link.close()
    assert res.resent_frames >= 3 and res.naks >= 1
    assert remote.parser.bad_crc + remote.naks >= 3
    assert remote.position_blu.tolist() == summed.tolist()
    assert remote.executed_periods == res.periods


def test_flow_control_waits_for_a_slow_drive():
    inc = np.tile(np.array([[3, -1, 0]]), (3000, 1))
    remote = IncrementReceiver(capacity_periods=300, period_s=1e-4)
    with PtyEndpoint(remote).start() as ep:
        link = IncrementLink(ep.port, resend_timeout_s=0.05)
        res = link.send([inc])
        link.close()
    assert remote.position_blu.tolist() == [9000, -3000, 0]
    assert remote.duplicates == res.resent_frames
    assert res.frames == 3000 // 255 + 1
