"""Frame layout of the increment protocol (docs/increment-protocol.md), little-endian:

    sync 0xA5 0x5A | type u8 | body | crc16 u16
    DATA  0x01  host -> drive  seq u16, periods u8 (1..255), axes u8, periods*axes int16 increments (BLU)
    HELLO 0x04  host -> drive  (no body) start of a session: the drive empties its buffer, expects seq 0
    POLL  0x05  host -> drive  (no body) asks for an ACK with the current free space
    ACK   0x81  drive -> host  seq u16 (last DATA accepted in order, 0xFFFF before any), free u16 (periods)
    NAK   0x82  drive -> host  seq u16 (the DATA it expects next), free u16

The CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) over type and body.
"""
from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass

import numpy as np

SYNC = b"\xa5\x5a"
DATA, HELLO, POLL, ACK, NAK = 0x01, 0x04, 0x05, 0x81, 0x82
NO_SEQ = 0xFFFF
MAX_PERIODS = 255
SEQ_MOD = 0x10000
_BODY_LEN = {HELLO: 0, POLL: 0, ACK: 4, NAK: 4}


class FrameError(ValueError):
    """Increments that do not fit a frame."""


def crc16(data: bytes) -> int:
    return binascii.crc_hqx(data, 0xFFFF)  # CRC-16/CCITT-FALSE


def _frame(kind: int, body: bytes) -> bytes:
    head = bytes((kind,)) + body
    return SYNC + head + struct.pack("<H", crc16(head))


def data_frame(seq: int, inc_blu: np.ndarray) -> bytes:
    inc = np.asarray(inc_blu)
    n, axes = inc.shape
    if not 1 <= n <= MAX_PERIODS:
        raise FrameError(f"a frame carries 1..{MAX_PERIODS} periods, not {n}")
    if inc.size and (inc.max() > 32767 or inc.min() < -32768):
        raise FrameError(f"an increment of {int(np.abs(inc).max())} BLU in one period does not fit int16")
    return _frame(DATA, struct.pack("<HBB", seq % SEQ_MOD, n, axes) + inc.astype("<i2").tobytes())


def hello_frame() -> bytes:
    return _frame(HELLO, b"")


def poll_frame() -> bytes:
    return _frame(POLL, b"")


def ack_frame(seq: int, free: int) -> bytes:
    return _frame(ACK, struct.pack("<HH", seq % SEQ_MOD, min(free, 0xFFFF)))


def nak_frame(expected: int, free: int) -> bytes:
    return _frame(NAK, struct.pack("<HH", expected % SEQ_MOD, min(free, 0xFFFF)))


@dataclass(frozen=True, slots=True)
class Frame:
    kind: int
    seq: int = 0
    free: int = 0
    inc_blu: np.ndarray | None = None  # (periods, axes) int64 for DATA


class FrameParser:
    """Finds frames in a byte stream; bytes that are not a valid frame are skipped
    (counted in `bad_crc` or `skipped`), so a corrupt frame never yields data."""

    def __init__(self):
        self.buf = bytearray()
        self.bad_crc = 0
        self.skipped = 0

    def feed(self, data: bytes) -> list[Frame]:
        self.buf += data
        out = []
        while True:
            i = self.buf.find(SYNC)
            if i < 0:
                keep = 1 if self.buf.endswith(SYNC[:1]) else 0
                self.skipped += len(self.buf) - keep
                del self.buf[: len(self.buf) - keep]
                return out
            if i:
                self.skipped += i
                del self.buf[:i]
            if len(self.buf) < 3:
                return out
            kind = self.buf[2]
            if kind == DATA:
                if len(self.buf) < 7:
                    return out
                n, axes = self.buf[5], self.buf[6]
                body_len = 4 + 2 * n * axes
            elif kind in _BODY_LEN:
                body_len = _BODY_LEN[kind]
            else:
                self.skipped += 2
                del self.buf[:2]
                continue
            total = 3 + body_len + 2
            if len(self.buf) < total:
                return out
            head = bytes(self.buf[2: 3 + body_len])
            (crc,) = struct.unpack_from("<H", self.buf, 3 + body_len)
            if crc != crc16(head) or (kind == DATA and not 1 <= head[3] <= MAX_PERIODS):
                self.bad_crc += 1
                del self.buf[:2]  # resynchronise on the next sync pattern
                continue
            del self.buf[:total]
            if kind == DATA:
                seq, n, axes = struct.unpack_from("<HBB", head, 1)
                inc = np.frombuffer(head, dtype="<i2", offset=5).reshape(n, axes).astype(np.int64)
                out.append(Frame(DATA, seq, 0, inc))
            elif kind in (ACK, NAK):
                seq, free = struct.unpack_from("<HH", head, 1)
                out.append(Frame(kind, seq, free))
            else:
                out.append(Frame(kind))
