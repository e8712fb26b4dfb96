"""Run LinuxCNC's standalone interpreter (`rs274 -g FILE`) and read its canonical calls back.

rs274 prints motion in the program's current units and in the current work coordinate
system; this module converts every move to machine millimetres (adding the printed G5x,
G92 and tool length offsets) so it compares directly with vcnc's entities.

ARC_FEED(first_end, second_end, first_center, second_center, rotation, axis_end, a, b, c)
names the active plane's axes in RS274NGC order (XY: X,Y,Z; XZ: Z,X,Y; YZ: Y,Z,X), the
same order as ipr.entities.PLANE_AXES; |rotation| is the number of revolutions (P).
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import pytest

from ipr.entities import PLANE_AXES

RS274 = shutil.which("rs274")
INCH_MM = 25.4
HALF_LAST_DIGIT = 0.5e-4  # rs274 prints lengths with "%.4f"

_PLANES = {"CANON_PLANE_XY": "XY", "CANON_PLANE_XZ": "ZX", "CANON_PLANE_YZ": "YZ"}


class CanonMove(NamedTuple):
    """One STRAIGHT_TRAVERSE / STRAIGHT_FEED / ARC_FEED, in machine mm."""

    kind: str  # "rapid" | "line" | "arc"
    end_mm: tuple[float, float, float]
    feed_mm_s: float | None
    tol_mm: float  # half the last printed digit, in mm: the comparison tolerance
    center_mm: tuple[float, float, float] | None = None
    plane: str | None = None
    rotation: int | None = None
    # path control in force: G61 (exact path) or G64 with its P blend and naive-CAM (Q) tolerances
    exact_stop: bool = False
    blend_tol_mm: float = 0.0
    merge_tol_mm: float = 0.0


def require_rs274() -> str:
    if RS274 is None:
        pytest.skip("LinuxCNC's rs274 is not installed (Debian package linuxcnc-uspace; .ci/run installs it)")
    return RS274


@contextmanager
def private_home() -> Iterator[dict[str, str]]:
    """The environment for one rs274 run. rs274 keeps its tool table in $HOME/.tool.mmap
    (LinuxCNC's tooldata_mmap.cc): runs at the same moment would share it (crashes, another
    run's tools) and a run would start from the tools the previous one left, so each run gets
    a HOME of its own."""
    with tempfile.TemporaryDirectory() as home:
        yield {**os.environ, "HOME": home}


def run_rs274(path: Path, var_file: Path | None = None, tool_table: Path | None = None) -> str:
    """rs274's canon output for `path`; raises with rs274's own message if it rejects the program.
    rs274 alone reads a tool table's lengths and diameters in inches."""
    # -b turns block delete on, as it is by default in vcnc (ipr.Setup.block_delete)
    cmd = ([require_rs274(), "-g", "-b"] + (["-v", str(var_file)] if var_file else [])
           + (["-t", str(tool_table)] if tool_table else []) + [str(path)])
    with private_home() as env:
        done = subprocess.run(cmd, capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=120, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"rs274 rejected {path}: {done.stderr.strip()}")
    return done.stdout


def _numbers(args: str) -> list[float]:
    return [float(t) for t in args.replace(",", " ").split()]


def canon_moves(output: str) -> list[CanonMove]:
    """The moves in rs274's output, converted to machine mm, with the feed in force for each."""
    mm_per_unit = 1.0
    g5x = g92 = (0.0, 0.0, 0.0)
    tool_z_mm = 0.0
    plane = "XY"
    feed_mm_s = 0.0
    rotation_rad = 0.0
    per_rev, rpm = False, 0.0   # G95: the printed feed is per revolution
    path = (False, 0.0, 0.0)
    moves: list[CanonMove] = []
    for text in output.splitlines():
        # "   12 N..... NAME(args)": plain string splitting, 169k lines must read in well under a second
        head, paren, args = text.partition("(")
        if not paren:
            continue
        name = head.rsplit(None, 1)[-1]
        args = args.rstrip().removesuffix(")")
        if name == "USE_LENGTH_UNITS":
            mm_per_unit = INCH_MM if "INCHES" in args else 1.0
        elif name == "SET_G5X_OFFSET":
            g5x = tuple(v * mm_per_unit for v in _numbers(args)[1:4])
        elif name == "SET_G92_OFFSET":
            g92 = tuple(v * mm_per_unit for v in _numbers(args)[0:3])
        elif name == "USE_TOOL_LENGTH_OFFSET":
            tool_z_mm = _numbers(args)[2] * mm_per_unit
        elif name == "SELECT_PLANE":
            plane = _PLANES[args.strip()]
        elif name == "SET_MOTION_CONTROL_MODE":
            mode, _, tol = args.partition(",")
            path = (mode.strip() != "CANON_CONTINUOUS", float(tol or 0.0) * mm_per_unit, path[2])
        elif name == "SET_NAIVECAM_TOLERANCE":
            path = (path[0], path[1], float(args) * mm_per_unit)
        elif name == "SET_FEED_RATE":
            feed_mm_s = _numbers(args)[0] * mm_per_unit / 60.0
        elif name == "SET_FEED_MODE":
            per_rev = _numbers(args)[1] == 1
        elif name == "SET_SPINDLE_SPEED":
            rpm = _numbers(args)[1]
        elif name == "SET_XY_ROTATION":
            rotation_rad = math.radians(_numbers(args)[0])
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            offset = (g5x[0] + g92[0], g5x[1] + g92[1], g5x[2] + g92[2] + tool_z_mm)
            v = _numbers(args)
            if rotation_rad:   # emccanon: program + G92, rotated, + G5x (+ tool)
                offset = (g5x[0], g5x[1], offset[2])
                v = _rotated(v, name, plane, g92, mm_per_unit, rotation_rad)
            move_feed = feed_mm_s * rpm if per_rev else feed_mm_s
            tol = HALF_LAST_DIGIT * mm_per_unit
            if name == "ARC_FEED":
                a, b, n = PLANE_AXES[plane]
                end = [0.0, 0.0, 0.0]
                end[a], end[b], end[n] = v[0], v[1], v[5]
                center = [0.0, 0.0, 0.0]
                center[a], center[b] = v[2], v[3]
                end_mm = tuple(end[i] * mm_per_unit + offset[i] for i in range(3))
                # the centre's normal-axis coordinate is left as NaN: vcnc puts it at the start's
                center_mm = tuple(center[i] * mm_per_unit + offset[i] if i != n else float("nan")
                                  for i in range(3))
                moves.append(CanonMove("arc", end_mm, move_feed, tol, center_mm, plane, int(v[4]), *path))
            else:
                end_mm = (v[0] * mm_per_unit + offset[0], v[1] * mm_per_unit + offset[1],
                          v[2] * mm_per_unit + offset[2])
                kind = "rapid" if name == "STRAIGHT_TRAVERSE" else "line"
                moves.append(CanonMove(kind, end_mm, None if kind == "rapid" else move_feed, tol, None, None, None,
                                       *path))
    return moves


def _rotated(v: list[float], name: str, plane: str, g92, mm_per_unit: float, rad: float) -> list[float]:
    """A canon call's numbers with G92 added and X/Y (and an XY arc's centre) rotated, in program units."""
    v = list(v)
    c, s = math.cos(rad), math.sin(rad)
    gx, gy = g92[0] / mm_per_unit, g92[1] / mm_per_unit

    def turn(x, y):
        x, y = x + gx, y + gy
        return x * c - y * s, x * s + y * c
    if name != "ARC_FEED":
        v[0], v[1] = turn(v[0], v[1])
    elif plane == "XY":
        v[0], v[1] = turn(v[0], v[1])
        v[2], v[3] = turn(v[2], v[3])
    else:
        raise ValueError("rotated arcs outside G17 are not read")
    return v
