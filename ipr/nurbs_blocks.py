"""How each block of a NURBS group is read (the data checks are in ipr.nurbs_groups).

G6.2 (Fanuc form, and LinuxCNC's): the first block carries P (order), K, R, axis words
and F; then one block per control point (axis words and/or R, with K); then `order`
knot-only blocks (K, optionally with G6.2 as LinuxCNC writes them) close the group.
G5.2: the current position is control point 0; X/Y (in the active plane) with P per
control point; G5.3 closes. In G91 a control point is relative to the previous one.
"""
from __future__ import annotations

from ipr.entities import PLANE_AXES
from ipr.errors import BlockError, code_name
from ipr.gcodes import NURBS_FANUC, NURBS_LINUXCNC, NURBS_LINUXCNC_END
from ipr.modal import target
from ipr.nurbs_groups import (FANUC_DEFAULT_ORDER, G5_DEFAULT_ORDER, NurbsGroup, check_knot,
                              check_order, check_start, check_weight, finish)

_G62_WORDS = frozenset("XYZKRN")
_G52_WORDS = frozenset("XYZPN")
AXIS_LETTERS = "XYZ"


def _plane_words(plane: str) -> tuple[str, str, str]:
    a, b, n = PLANE_AXES[plane]
    return AXIS_LETTERS[a], AXIS_LETTERS[b], AXIS_LETTERS[n]


def _check_g52_axes(st, spec) -> bool:
    """G5.2 control points are planar: both in-plane axes, never the normal one."""
    pa, pb, pn = _plane_words(st.plane)
    if pn in spec.index:
        raise BlockError("E-NURBS-BLOCK", f"G5.2 control points lie in the {st.plane} plane: "
                         f"no {pn} word", spec.index[pn])
    has_a, has_b = pa in spec.index, pb in spec.index
    if has_a != has_b:
        missing = pb if has_a else pa
        present = pa if has_a else pb
        raise BlockError("E-WORD-MISSING", f"G5.2 control point needs both {pa} and {pb}: {missing} is "
                         "missing", spec.index[present])
    return has_a


def start_group(st, spec, vals, line: int, notices: list) -> None:
    """A block whose motion is G6.2 or G5.2 while no group is open."""
    kind = spec.g.get("motion", st.motion)
    feed_mm_s = st.feed_mm_s
    where = spec.where.get("motion")
    if feed_mm_s <= 0.0:
        raise BlockError("E-FEED-ZERO", "NURBS move with feed rate zero (program an F word)", where)
    idx = spec.index
    if kind == NURBS_FANUC:
        order = check_order(vals[idx["P"]], idx["P"]) if "P" in idx else FANUC_DEFAULT_ORDER
        group = NurbsGroup(NURBS_FANUC, line, order, feed_mm_s, st.path)
        if "Q" in idx:
            notices.append(("N-Q-IGNORED", "Q word of G6.2 ignored: vcnc interpolates the NURBS "
                            "itself", idx["Q"]))
        if spec.axes:
            point = target(st, spec, vals, st.pos)
            check_start(point, st.pos, idx[spec.axes[0]])
        else:
            point = st.pos
        weight = check_weight(vals[idx["R"]], idx["R"]) if "R" in idx else 1.0
        group.points.append(point)
        group.weights.append(weight)
        if "K" in idx:
            group.knots.append(vals[idx["K"]])
    else:
        order = check_order(vals[idx["L"]], idx["L"]) if "L" in idx else G5_DEFAULT_ORDER
        group = NurbsGroup(NURBS_LINUXCNC, line, order, feed_mm_s, st.path)
        has_point = _check_g52_axes(st, spec)
        p = vals[idx["P"]] if "P" in idx else None
        group.points.append(st.pos)
        group.weights.append(1.0 if has_point or p is None else check_weight(p, idx["P"]))
        if has_point:
            if p is None:
                raise BlockError("E-WORD-MISSING", "G5.2 control point needs a P word (weight)", where)
            group.points.append(target(st, spec, vals, st.pos))
            group.weights.append(check_weight(p, idx["P"]))
    st.nurbs = group
    st.motion = kind


def continue_group(st, spec, vals) -> object | None:
    """A block inside an open group; returns the Nurbs when the block closes the group."""
    group: NurbsGroup = st.nurbs
    idx = spec.index
    allowed = _G62_WORDS if group.kind == NURBS_FANUC else _G52_WORDS
    for letter, i in idx.items():
        if letter not in allowed:
            raise BlockError("E-NURBS-BLOCK", f"{letter} word inside the {group.name} group begun at "
                             f"line {group.line}: only control points and knots may follow", i)
    for name, code in list(spec.g.items()) + list(spec.m.items()):
        if code not in (group.kind, NURBS_LINUXCNC_END) or name not in spec.g:
            letter = "G" if name in spec.g else "M"
            raise BlockError("E-NURBS-BLOCK", f"{code_name(letter, code / 10)} inside the {group.name} "
                             f"group begun at line {group.line}: only control points and knots may follow",
                             spec.where[name])
    if group.kind == NURBS_LINUXCNC:
        if spec.g.get("motion") == NURBS_LINUXCNC_END:
            if idx.keys() - {"N"}:
                raise BlockError("E-NURBS-BLOCK", "G5.3 takes no words", min(idx.values()))
            return _close(st, group, spec.where["motion"])
        if not _check_g52_axes(st, spec):
            pa, pb, _ = _plane_words(st.plane)
            raise BlockError("E-WORD-MISSING", f"G5.2 control point needs {pa} and {pb}",
                             min(idx.values(), default=None))
        if "P" not in idx:
            raise BlockError("E-WORD-MISSING", "G5.2 control point needs a P word (weight)",
                             idx[spec.axes[0]])
        point = target(st, spec, vals, group.points[-1])
        weight = check_weight(vals[idx["P"]], idx["P"])
        st.after_commit.append(lambda: (group.points.append(point), group.weights.append(weight)))
        return None
    if spec.g.get("motion") == NURBS_LINUXCNC_END:
        raise BlockError("E-NURBS-BLOCK", f"G5.3 inside the G6.2 group begun at line {group.line}",
                         spec.where["motion"])
    knot = vals[idx["K"]] if "K" in idx else None
    if knot is not None:
        check_knot(group, knot, idx["K"])
    if spec.axes or "R" in idx:
        if group.closing:
            word = idx[spec.axes[0]] if spec.axes else idx["R"]
            raise BlockError("E-NURBS-BLOCK", "control point after the closing knot blocks of the "
                             f"group begun at line {group.line}", word)
        point = target(st, spec, vals, group.points[-1])
        weight = check_weight(vals[idx["R"]], idx["R"]) if "R" in idx else 1.0

        def add_point():
            group.points.append(point)
            group.weights.append(weight)
            if knot is not None:
                group.knots.append(knot)
        st.after_commit.append(add_point)
        return None
    if knot is None:
        raise BlockError("E-NURBS-BLOCK", f"block without a knot or control point inside the G6.2 "
                         f"group begun at line {group.line}", min(idx.values(), default=None))
    if group.closing + 1 < group.order:
        def add_knot():
            group.knots.append(knot)
            group.closing += 1
        st.after_commit.append(add_knot)
        return None
    closed = NurbsGroup(NURBS_FANUC, group.line, group.order, group.feed_mm_s, group.path)
    closed.points, closed.weights = group.points, group.weights
    closed.knots, closed.closing = group.knots + [knot], group.order
    return _close(st, closed, idx["K"])


def _close(st, group: NurbsGroup, word: int | None):
    nurbs = finish(group, word)
    st.pos = group.points[-1]
    st.nurbs = None
    st.motion = None
    return nurbs
