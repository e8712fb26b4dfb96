"""LinuxCNC 2.9's canon layer (src/emc/task/emccanon.cc): motion entities -> planner moves.

What task does between the interpreter and the planner, per canonical call:
- STRAIGHT_TRAVERSE (G0): a line at the axis-limited speed (getStraightVelocity) and
  acceleration (getStraightAcceleration), no feed;
- STRAIGHT_FEED (G1): under G64 with a naive-CAM tolerance (Q, or P when Q is not given) the
  points are chained while every chained point stays within the tolerance of the line from
  the chain's start to the newest point (`linkable`, at most 100 points), and the chain is
  sent as one line (`flush_segments`) when it breaks, the feed changes, or anything else comes;
- ARC_FEED (G2/G3): in G17 under G64, an arc whose chord deviation is within the naive-CAM
  tolerance becomes two chained lines (through its middle); any other arc is sent as a
  circle with the speed and acceleration of its plane (the normal share sqrt(3)/2 of the
  lowest in-plane axis acceleration bounds its speed), a helix or spiral by its length;
- NURBS_FEED (G5.2): biarcs (ipo.feed.linuxcnc_twin.biarcs), each an ARC_FEED;
- SET_MOTION_CONTROL_MODE (G61, G61.1, G64): flushes the chain, then the planner's terminal
  condition and blend tolerance for the moves after it (a canned cycle runs in G61, and
  after it restores the canon's mode: before any G64 that is the start-up 0.001 in).
Feeds are in mm/s, as ipr hands them over.
"""
from __future__ import annotations

import math

from ipo.feed.linuxcnc_twin import vec as v
from ipo.feed.linuxcnc_twin.biarcs import biarc_moves, nurbs_plane
from ipo.feed.linuxcnc_twin.segments import ARC, FEED, TERM_EXACT, TERM_PARABOLIC, TERM_STOP, TRAVERSE
from ipo.feed.linuxcnc_twin.tp import TrajectoryPlanner
from ipo.feed.linuxcnc_twin.vec import CART_FUZZ, Vec
from ipr.entities import PLANE_AXES, Arc, Line, Nurbs, PathControl, Rapid

MAX_CHAIN = 100  # linkable(): a chain longer than this is sent
# INIT_CANON's blend tolerance, 0.001 in: the planner starts without it (tolerance 0), but a
# canned cycle saves the canon's mode before switching to G61 and restores it after itself
STARTUP_TOL_MM = 0.001 * 25.4


def path_mode(path: PathControl, after_startup: bool) -> tuple[int, float, float]:
    """(terminal condition, blend tolerance P, naive-CAM tolerance Q) of a path-control mode;
    `after_startup`: the start-up mode is back after another (a canned cycle's G61)."""
    if path.exact_stop:
        return (TERM_EXACT if path.exact_path else TERM_STOP), 0.0, 0.0
    if path.startup:
        return TERM_PARABOLIC, STARTUP_TOL_MM if after_startup else 0.0, 0.0
    p = path.blend_tol_mm or 0.0
    q = path.merge_tol_mm if path.merge_tol_mm is not None else p
    return TERM_PARABOLIC, p, q


class Canon:
    """The canon state task keeps: where the last sent move ends, feed, path mode, the chain."""

    def __init__(self, tp: TrajectoryPlanner, start: Vec):
        self.tp = tp
        s = tp.s
        self.vmax: Vec = tuple(s.axis_velocity_mm_s)
        self.amax: Vec = tuple(s.axis_accel_mm_s2)
        self.end_point: Vec = start
        self.feed = 0.0
        self.mode: tuple[int, float, float] = (TERM_PARABOLIC, 0.0, 0.0)
        self.left_startup = False  # a mode other than the start-up one has been set
        self.chain: list[tuple[Vec, int]] = []
        tp.goal = start

    # ---- modal changes -----------------------------------------------------------------
    def set_path(self, path: PathControl) -> None:
        self.left_startup |= not path.startup
        mode = path_mode(path, self.left_startup)
        if mode != self.mode:
            self.flush()
            self.mode = mode
            self.tp.term_cond, self.tp.tolerance = mode[0], mode[1]

    def set_feed(self, feed_mm_s: float) -> None:
        if feed_mm_s != self.feed:
            self.flush()
            self.feed = feed_mm_s

    # ---- moves ---------------------------------------------------------------------------
    def motion(self, e) -> None:
        """One motion entity, as the interpreter's canonical calls for it."""
        self.set_path(e.path)
        if isinstance(e, Rapid):
            self.flush()
            vel, acc, _ = self._straight(e.end)
            if vel and acc:
                self.tp.add_line(e.end, TRAVERSE, vel, vel, acc, e.line)
            self.end_point = e.end
            return
        self.set_feed(e.feed_mm_s)
        if isinstance(e, Line):
            self.see_segment(e.end, e.line)
        elif isinstance(e, Arc):
            self.arc_feed(e.end, e.center, e.plane, (e.turns + 1) * (1 if e.ccw else -1), e.line)
        elif isinstance(e, Nurbs):
            self.nurbs_feed(e)
        else:
            raise TypeError(f"the LinuxCNC twin cannot handle {type(e).__name__}")

    def _straight(self, end: Vec) -> tuple[float, float, float]:
        """(getStraightVelocity's vel, getStraightAcceleration's acc, its tmax) from end_point."""
        d = [abs(end[i] - self.end_point[i]) for i in range(3)]
        d = [x if x >= CART_FUZZ else 0.0 for x in d]
        if not any(d):
            return self.feed, 0.0, 0.0
        dtot = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
        tv = max(d[i] / self.vmax[i] for i in range(3) if d[i])
        ta = max(d[i] / self.amax[i] for i in range(3) if d[i])
        return dtot / tv, dtot / ta, tv

    def see_segment(self, end: Vec, line_no: int) -> None:
        if self.chain and not self._linkable(end):
            self.flush()
        self.chain.append((end, line_no))

    def _linkable(self, end: Vec) -> bool:
        if self.mode[0] != TERM_PARABOLIC or self.mode[2] == 0 or len(self.chain) > MAX_CHAIN:
            return False
        if end == self.end_point:
            return False
        m = v.sub(end, self.end_point)
        mm = v.dot(m, m)
        for p, _ in self.chain:
            t0 = min(1.0, max(0.0, v.dot(m, v.sub(p, self.end_point)) / mm))
            if v.mag(v.sub(p, v.add(self.end_point, v.scale(m, t0)))) > self.mode[2]:
                return False
        return True

    def flush(self) -> None:
        """flush_segments: the chain as one line to its last point."""
        if not self.chain:
            return
        end, line_no = self.chain[-1]
        vmax, acc, _ = self._straight(end)
        vel = min(vmax, self.feed)
        if vel and acc:
            self.tp.add_line(end, FEED, vel, vmax, acc, line_no)
        self.end_point = end
        self.chain.clear()

    def arc_feed(self, end: Vec, center: Vec, plane: str, rotation: int, line_no: int) -> None:
        """ARC_FEED: center lies in the start's plane (ipr) or the end's (LinuxCNC); the
        planner's circle init puts it into the start's plane either way."""
        ia, ib, ic = PLANE_AXES[plane]
        last = self.chain[-1][0] if self.chain else self.end_point
        if plane == "XY" and self.mode[0] == TERM_PARABOLIC and self.mode[2] > 0:
            dev, mid = _chord_deviation(last, end, center, rotation)
            if dev < self.mode[2]:
                self.see_segment((mid[0], mid[1], (last[2] + end[2]) / 2), line_no)
                self.see_segment(end, line_no)
                return
        self.flush()
        start = self.end_point
        normal = [0.0, 0.0, 0.0]
        normal[ic] = 1.0
        ps = (start[ia] - center[ia], start[ib] - center[ib])
        pe = (end[ia] - center[ia], end[ib] - center[ib])
        th0, th1 = math.atan2(ps[1], ps[0]), math.atan2(pe[1], pe[0])
        r0, r1 = math.hypot(*ps), math.hypot(*pe)
        if rotation < 0:
            th1 = th1 - 2 * math.pi if th1 + 1e-12 >= th0 else th1
        else:
            th1 = th1 + 2 * math.pi if th1 - 1e-12 <= th0 else th1
        turns = rotation - 1 if rotation > 1 else (rotation + 1 if rotation < -1 else 0)
        full = th1 - th0 + 2.0 * math.pi * turns
        spiral = r1 - r0
        dr = spiral / abs(full)
        r_min = min(r0, r1)
        v_axes = min(self.vmax[ia], self.vmax[ib])
        a_axes = min(self.amax[ia], self.amax[ib])
        v_planar = min(math.sqrt(a_axes * math.sqrt(3.0) / 2.0 * math.hypot(dr, r_min)), v_axes)
        _, _, t_motion = self._straight(end)
        spiral_len = math.hypot(r_min * abs(full), spiral)
        total = math.hypot(spiral_len, end[ic] - start[ic])
        v_max = total / max(t_motion, spiral_len / v_planar)
        d = [abs(end[i] - start[i]) for i in range(3)]
        tt_motion = max([d[i] / self.amax[i] for i in range(3) if d[i] >= CART_FUZZ], default=0.0)
        a_max = total / max(tt_motion, spiral_len / a_axes)
        vel = min(self.feed, v_max)
        c3 = list(center)
        c3[ic] = end[ic]
        turn = rotation - 1 if rotation > 0 else rotation
        if vel and a_max:
            self.tp.add_circle(end, tuple(c3), tuple(normal), turn, ARC, vel, v_max, a_max, line_no)
        self.end_point = end

    def nurbs_feed(self, e: Nurbs) -> None:
        self.flush()
        plane = nurbs_plane(e)
        ia, ib, _ = PLANE_AXES[plane]
        for move in biarc_moves(e):
            here = self.chain[-1][0] if self.chain else self.end_point
            p = list(here)
            p[ia], p[ib] = move[1]
            if move[0] == "line":
                self.see_segment(tuple(p), e.line)
            else:
                c = list(here)
                c[ia], c[ib] = move[2]
                self.arc_feed(tuple(p), tuple(c), plane, move[3], e.line)


def _chord_deviation(start: Vec, end: Vec, center: Vec, rotation: int) -> tuple[float, tuple[float, float]]:
    """emccanon's chord_deviation (XY): the arc's sagitta and its middle point."""
    th1 = math.atan2(start[1] - center[1], start[0] - center[0])
    th2 = math.atan2(end[1] - center[1], end[0] - center[0])
    r = math.hypot(start[1] - center[1], start[0] - center[0])
    for _ in range(2):
        dth = th2 - th1
        if rotation < 0 and dth >= -1e-5:
            th2 -= 2 * math.pi
        elif rotation >= 0 and dth <= 1e-5:
            th2 += 2 * math.pi
    included = abs(th2 - th1)
    mid = (th2 + th1) / 2
    return r * (1 - math.cos(included / 2)), (center[0] + r * math.cos(mid), center[1] + r * math.sin(mid))
