"""Cutter radius compensation G40/G41/G42/G41.1/G42.1 in the XY plane, as LinuxCNC does it.

A port of LinuxCNC's interp_convert.cc (convert_straight_comp1/2, convert_arc_comp1/2,
convert_cutter_compensation_on/off) and interp_queue.cc (move_endpoint_and_flush): the first
move after G41/G42 ends tangent to the tool circle about its programmed end point (entry);
every later move is offset by the tool radius to its side; at a convex corner an arc about the
programmed corner joins the offset moves (a traverse for G0); at a concave corner the move
held back in the queue is cut short where the offset paths meet, and a gouge is an error
(E-COMP) where rs274 reports one. After G40 the next move runs from the compensated point to
its programmed end (exit); an arc may not be that move.

All in machine mm (G10 L2 R rotations are refused with compensation). The held-back moves
are `Queued` records in the modal state's `comp` (a `Comp`, replaced, never mutated), turned
into entities when they are flushed, each starting where the one before ended.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from ipr.entities import Arc, Line, Rapid
from ipr.errors import BlockError
from ipr.gcodes import COMP_LEFT, COMP_LEFT_DYNAMIC, COMP_RIGHT_DYNAMIC

SMALL = 0.05          # TOLERANCE_CONCAVE_CORNER, radians
EQUAL = 1e-6          # TOLERANCE_EQUAL
LEFT, RIGHT = 1, -1


class Queued(NamedTuple):
    """A held-back move: kind "rapid" | "line" | "arc", its end, and what a later move may change;
    or kind "event" (`path` holds the event entity: it runs in its place among the moves)."""

    kind: str
    line: int
    end: tuple | None
    feed_mm_s: float | None
    path: object
    center: tuple | None = None
    turn: int = 0                  # arcs: +1 counter-clockwise, -1 clockwise
    direction: tuple = (0.0, 0.0)  # lines: the programmed direction, for the gouge check


class Comp(NamedTuple):
    side: int             # LEFT, RIGHT, or 0: compensation is off, the exit move comes next
    radius: float
    first: bool           # no move yet since G41/G42
    programmed: tuple     # the programmed (uncompensated) point, machine mm
    emitted: tuple        # where the first queued move starts: the end of the last one run
    queue: tuple = ()
    endpoint: tuple | None = None   # the start the gouge check measures from (None: not known)


def _inside(side: int, turn: int) -> bool:
    """TOOL_INSIDE_ARC."""
    return (side == LEFT and turn > 0) or (side == RIGHT and turn < 0)


def turn_on(st, spec, vals, radius_of, code: int, notices: list) -> None:
    """G41/G42 (D: tool number, or the tool in the spindle), G41.1/G42.1 (D: diameter). A tool
    missing from the tool table has radius zero (a warning, as for G43); with radius zero the
    moves run as programmed, as in LinuxCNC."""
    where = spec.where["comp"]
    if st.plane != "XY":
        raise BlockError("E-COMP", "cutter radius compensation works in the XY plane only (G17)", where)
    if st.comp is not None and st.comp.side:
        raise BlockError("E-COMP", "cutter radius compensation is already on (G40 first)", where)
    if st.rotation_deg:
        raise BlockError("E-COMP", "cutter radius compensation in a rotated coordinate system is not supported",
                         where)
    side = LEFT if code in (COMP_LEFT, COMP_LEFT_DYNAMIC) else RIGHT
    d = vals[spec.index["D"]] if "D" in spec.index else None
    if code in (COMP_LEFT_DYNAMIC, COMP_RIGHT_DYNAMIC):
        if d is None:
            raise BlockError("E-WORD-MISSING", f"G{code // 10}.1 needs a D word (the tool diameter)", where)
        radius = d * st.unit / 2.0
    else:
        if d is not None and (d != round(d) or d < 0):
            raise BlockError("E-VALUE", f"G{code // 10} D{d:g}: D is a tool number", spec.index["D"])
        tool = st.tool_in_spindle if d is None else int(d)
        radius = radius_of(tool)
        if radius is None:
            notices.append(("W-TOOL-UNKNOWN", f"tool D{tool} is not in the tool table: zero cutter radius, "
                            "the moves run as programmed", spec.index.get("D")))
            radius = 0.0
    if radius < 0.0:
        radius, side = -radius, -side
    st.comp = Comp(side, radius, True, st.pos, st.pos) if radius > 0.0 else None


def turn_off(st, out: list) -> None:
    """G40: flush the held-back moves; the next move is the exit move from the compensated point."""
    comp = st.comp
    if comp is None or not comp.side:
        return
    if comp.first:
        st.comp = None
        return
    emitted = _flush(out, comp, st.pos[:2])
    st.comp = Comp(0, comp.radius, True, comp.programmed, emitted)


def flush_all(st, out: list) -> None:
    """End of program: every held-back move (and event) runs as it is."""
    comp = st.comp
    if comp is not None and comp.queue:
        st.comp = comp._replace(emitted=_dequeue(out, comp), queue=(), endpoint=None)


def hold(st, events: list) -> None:
    """Events of a block while moves are held back run after them, in program order."""
    comp = st.comp
    st.comp = comp._replace(queue=comp.queue + tuple(Queued("event", e.line, None, None, e) for e in events))


def base(st):
    """The point G91 words and missing axis words refer to: the programmed one under compensation."""
    return st.comp.programmed if st.comp is not None else st.pos


def _emit(out: list, start, q: Queued):
    if q.kind == "event":
        out.append(q.path)
        return start
    if q.kind == "rapid":
        out.append(Rapid(q.line, start, q.end, q.path))
    elif q.kind == "line":
        out.append(Line(q.line, start, q.end, q.feed_mm_s, q.path))
    else:
        out.append(Arc(q.line, start, q.end, (q.center[0], q.center[1], start[2]), "XY", q.turn > 0,
                       q.feed_mm_s, 0, q.path))
    return q.end


def _flush(out: list, comp: Comp, xy) -> tuple:
    """move_endpoint_and_flush: every queued move ends at xy (checked for gouges), then all run;
    returns where the last one ends."""
    x, y = xy
    moved = []
    for q in comp.queue:
        if q.kind == "event":
            moved.append(q)
            continue
        if q.kind == "arc":
            r1 = math.hypot(q.end[0] - q.center[0], q.end[1] - q.center[1])
            r2 = math.hypot(x - q.center[0], y - q.center[1])
            if abs(r1 - r2) > 0.01:
                raise BlockError("E-COMP", "an arc in a concave corner cannot be reached by the tool without "
                                 "gouging")
        elif comp.endpoint is not None:
            dx, dy = q.direction
            if dx * (x - comp.endpoint[0]) + dy * (y - comp.endpoint[1]) < 0.0:
                raise BlockError("E-COMP", "a move in a concave corner cannot be reached by the tool without "
                                 "gouging (the offset path would run backwards)")
        moved.append(q._replace(end=(x, y, q.end[2])))
    return _dequeue(out, comp._replace(queue=tuple(moved)))


def _dequeue(out: list, comp: Comp) -> tuple:
    pos = comp.emitted
    for q in comp.queue:
        pos = _emit(out, pos, q)
    return pos


def straight(st, kind: str, line: int, end, feed_mm_s, out: list) -> None:
    """A G0/G1 under compensation (`end`: the programmed end, machine mm)."""
    comp = st.comp
    r, side = comp.radius, comp.side
    cx, cy, cz = st.pos
    px, py, pz = end
    path = st.path
    if comp.first:   # convert_straight_comp1
        distance = math.hypot(px - cx, py - cy)
        if distance <= r:
            raise BlockError("E-COMP", f"the compensation entry move ({distance:.4f} mm) is not longer than the "
                             f"tool radius ({r:.4f} mm)")
        alpha = math.atan2(py - cy, px - cx) + (math.pi / 2 if side == LEFT else -math.pi / 2)
        e = (px + r * math.cos(alpha), py + r * math.sin(alpha), pz)
        q = Queued(kind, line, e, feed_mm_s, path, direction=(math.cos(alpha), math.sin(alpha)))
        st.comp = comp._replace(first=False, programmed=end, queue=comp.queue + (q,), endpoint=(cx, cy))
        st.pos = e
        return
    opx, opy, _ = comp.programmed
    if py == opy and px == opx:   # no XY motion: Z only, held back with the rest
        q = Queued(kind, line, (cx, cy, pz), feed_mm_s, path)
        st.comp = comp._replace(programmed=end, queue=comp.queue + (q,))
        st.pos = (cx, cy, pz)
        return
    theta = math.atan2(cy - opy, cx - opx)
    alpha = math.atan2(py - opy, px - opx)
    if side == LEFT:
        if theta < alpha:
            theta += 2 * math.pi
        beta, gamma = theta - alpha - math.pi / 2, math.pi / 2
    else:
        if alpha < theta:
            alpha += 2 * math.pi
        beta, gamma = alpha - theta - math.pi / 2, -math.pi / 2
    e = (px + r * math.cos(alpha + gamma), py + r * math.sin(alpha + gamma), pz)
    mid = (opx + r * math.cos(alpha + gamma), opy + r * math.sin(alpha + gamma))
    front = _front(comp)
    concave = beta < -SMALL or beta > math.pi + SMALL or (
        beta > math.pi - SMALL and front is not None and front.kind == "arc"
        and ((side == RIGHT and front.turn > 0) or (side == LEFT and front.turn < 0)))
    if not concave and beta > SMALL:   # convex: an arc about the programmed corner (a traverse for G0)
        emitted = _flush(out, comp, (cx, cy))
        corner = (Queued("arc", line, (mid[0], mid[1], cz), feed_mm_s, path, (opx, opy), -side)
                  if kind == "line" else Queued("rapid", line, (mid[0], mid[1], cz), None, path))
        emitted = _dequeue(out, Comp(side, r, False, comp.programmed, emitted, (corner,)))
        endpoint = mid
    elif concave:
        if front is None or front.kind != "arc":
            halfcorner = (beta + math.pi) / 2.0
            if halfcorner == 0.0:
                raise BlockError("E-COMP", "a zero degree inside corner cannot be compensated")
            retreat = r / math.tan(halfcorner)
            mid = (cx + retreat * math.cos(theta + gamma), cy + retreat * math.sin(theta + gamma))
        else:
            mid = _arc_to_line_corner(front, side, r, opx, opy, px, py)
        emitted = _flush(out, comp, mid)
        endpoint = mid   # move_endpoint_and_flush ends with set_endpoint
    else:
        emitted = _dequeue(out, comp)
        endpoint = (cx, cy)
    q = Queued(kind, line, e, feed_mm_s, path, direction=(px - opx, py - opy))
    st.comp = Comp(side, r, False, end, emitted, (q,), endpoint)
    st.pos = e


def _front(comp: Comp) -> Queued | None:
    """qc().front(): the first held-back move."""
    return next((q for q in comp.queue if q.kind != "event"), None)


def _arc_to_line_corner(prev: Queued, side: int, r: float, opx, opy, px, py):
    oldrad = math.hypot(prev.center[1] - prev.end[1], prev.center[0] - prev.end[0])
    base_dir = math.atan2(py - opy, px - opx)
    theta = base_dir + math.pi / 2 if prev.turn > 0 else base_dir - math.pi / 2
    phi = math.atan2(prev.center[1] - opy, prev.center[0] - opx)
    inside = _inside(side, prev.turn)
    oldrad_uncomp = oldrad + r if inside else oldrad - r
    d = oldrad_uncomp * math.cos(theta - phi)
    ratio = (d - r if inside else d + r) / oldrad
    if not -1.0 <= ratio <= 1.0:
        raise BlockError("E-COMP", "an arc followed by a line makes a corner the compensated tool cannot fit in "
                         "without gouging")
    flip = (prev.turn > 0) == inside
    angle = (-math.acos(ratio) if flip else math.acos(ratio)) + theta + math.pi
    return prev.center[0] + oldrad * math.cos(angle), prev.center[1] + oldrad * math.sin(angle)


def arc(st, line: int, end, center_xy, turn: int, feed_mm_s, out: list) -> None:
    """A G2/G3 under compensation: `center_xy` of the programmed arc (from the programmed start,
    or from the current point for the entry arc), `turn` +1 G3 / -1 G2."""
    comp = st.comp
    r, side = comp.radius, comp.side
    cx, cy, cz = st.pos
    ex, ey, ez = end
    path = st.path
    inside = _inside(side, turn)
    if comp.first:   # convert_arc_comp1
        if math.hypot(ex - cx, ey - cy) <= r:
            raise BlockError("E-COMP", "the compensation entry arc does not reach beyond the tool radius")
        ccx, ccy = center_xy
        gamma = math.atan2(ccy - ey, ccx - ex) if inside else math.atan2(ey - ccy, ex - ccx)
        nx, ny = ex + r * math.cos(gamma), ey + r * math.sin(gamma)
        b_len = math.hypot(cy - ny, cx - nx) / 2.0
        ab = math.atan2(ccy - ny, ccx - nx)
        a_ang = math.atan2(cy - ny, cx - nx) - ab
        if abs(math.cos(a_ang)) < EQUAL:
            raise BlockError("E-COMP", "the tool radius is not smaller than the arc's radius")
        c_len = b_len / math.cos(a_ang)
        centre = (nx + c_len * math.cos(ab), ny + c_len * math.sin(ab))
        q = Queued("arc", line, (nx, ny, ez), feed_mm_s, path, centre, turn)
        st.comp = comp._replace(first=False, programmed=end, queue=comp.queue + (q,), endpoint=(cx, cy))
        st.pos = (nx, ny, ez)
        return
    opx, opy, _ = comp.programmed
    ccx, ccy = center_xy
    arc_radius = math.hypot(ccx - ex, ccy - ey)
    theta = math.atan2(cy - opy, cx - opx)
    theta = theta - math.pi / 2 if side == LEFT else theta + math.pi / 2
    delta = math.atan2(ccy - opy, ccx - opx)
    alpha = delta - math.pi / 2 if turn > 0 else delta + math.pi / 2
    beta = theta - alpha if side == LEFT else alpha - theta
    if beta > 1.5 * math.pi:
        beta -= 2 * math.pi
    elif beta < -math.pi / 2:
        beta += 2 * math.pi
    if inside:
        gamma = math.atan2(ccy - ey, ccx - ex)
        if arc_radius <= r:
            raise BlockError("E-COMP", f"the tool radius ({r:.4f} mm) is not smaller than the arc's radius "
                             f"({arc_radius:.4f} mm)")
    else:
        gamma = math.atan2(ey - ccy, ex - ccx)
        delta += math.pi
    new_end = (ex + r * math.cos(gamma), ey + r * math.sin(gamma), ez)
    front = _front(comp)
    q = Queued("arc", line, new_end, feed_mm_s, path, (ccx, ccy), turn)
    if beta < -SMALL or beta > math.pi + SMALL or (abs(beta - math.pi) < SMALL and not inside):
        if front is None or front.kind != "arc":
            ny = arc_radius * math.sin(beta - math.pi / 2)
            dist = arc_radius - r if inside else arc_radius + r
            ratio = (ny + r if inside else ny - r) / dist
            if not -1.0 <= ratio <= 1.0:
                raise BlockError("E-COMP", "an arc in a concave corner cannot be reached by the tool without "
                                 "gouging")
            if inside:
                angle = theta + math.asin(ratio) if turn > 0 else theta - math.asin(ratio)
            else:
                angle = theta + math.pi - math.asin(ratio) if turn > 0 else theta + math.pi + math.asin(ratio)
            mid = (ccx + dist * math.cos(angle), ccy + dist * math.sin(angle))
        else:
            oldrad = math.hypot(front.center[1] - front.end[1], front.center[0] - front.end[0])
            newrad = arc_radius - r if inside else arc_radius + r
            arc_cc = math.hypot(front.center[1] - ccy, front.center[0] - ccx)
            if oldrad == 0 or arc_cc == 0:
                raise BlockError("E-COMP", "two arcs with the same centre meet in a concave corner")
            a = (oldrad ** 2 + arc_cc ** 2 - newrad ** 2) / (2 * oldrad * arc_cc)
            if not -1.0 <= a <= 1.0:
                raise BlockError("E-COMP", "two arcs make a corner the compensated tool cannot fit in without "
                                 "gouging")
            pullback = math.acos(a)
            cc_dir = math.atan2(ccy - front.center[1], ccx - front.center[0])
            sign = 1.0 if (turn > 0) == _inside(side, front.turn) else -1.0
            d = cc_dir + sign * pullback
            mid = (front.center[0] + oldrad * math.cos(d), front.center[1] + oldrad * math.sin(d))
        emitted = _flush(out, comp, mid)
        endpoint = mid   # move_endpoint_and_flush ends with set_endpoint
    elif beta > SMALL:   # convex: an arc about the programmed corner first
        mid = (opx + r * math.cos(delta), opy + r * math.sin(delta))
        emitted = _dequeue(out, comp)
        corner = Queued("arc", line, (mid[0], mid[1], cz), feed_mm_s, path, (opx, opy), -side)
        emitted = _dequeue(out, Comp(side, r, False, comp.programmed, emitted, (corner,)))
        endpoint = mid
    else:
        emitted = _dequeue(out, comp)
        endpoint = (cx, cy)
    st.comp = Comp(side, r, False, end, emitted, (q,), endpoint)
    st.pos = new_end
