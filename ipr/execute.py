"""One block's effects, in RS274NGC's order of execution, on a staged modal state.

Called by ipr.interpreter for every block that is not a plain G0/G1 move and not part
of a NURBS group: feed, spindle and tool, dwell, plane, units, tool length, coordinate
system, path control, distance modes, G92, motion (lines, arcs, the start of a NURBS
group) and stops. Writes go to the Staged view and outputs to `out`/`notices`; the
caller commits them only if nothing raised.
"""
from __future__ import annotations

from ipr import nurbs_blocks
from ipr.arcs import make_arc
from ipr.block import AXES, BlockSpec
from ipr.entities import (EXACT_STOP, PLANE_AXES, Coolant, Dwell, Line, PathControl, ProgramEnd, Rapid,
                          Spindle, Stop, ToolChange)
from ipr.errors import BlockError
from ipr.modal import INCH_MM, Setup, Staged, target

_PLANES = {170: "XY", 180: "ZX", 190: "YZ"}


def execute_block(st: Staged, spec: BlockSpec, vals: list, out: list, notices: list, line: int,
                  setup: Setup, motion_before: int | None) -> None:
    """Everything a (non-NURBS-group) block does; `motion_before` is the modal motion."""
    idx, g, m = spec.index, spec.g, spec.m
    if "F" in idx:
        if vals[idx["F"]] < 0.0:
            raise BlockError("E-VALUE", f"negative feed rate F{vals[idx['F']]:g}", idx["F"])
        st.feed_mm_s = vals[idx["F"]] * st.unit / 60.0  # before a G20/G21 of this block
    if "O" in idx:
        st.program_number = _whole(vals[idx["O"]], "O", idx["O"])
    _spindle_tool(st, spec, vals, out, notices, line, setup)
    if g.get("nonmodal") == 40:
        p = vals[idx["P"]]
        if p < 0.0:
            raise BlockError("E-VALUE", f"negative dwell time P{p:g}", idx["P"])
        out.append(Dwell(line, p))
    _modes(st, spec, vals, notices, setup)
    nonmodal = g.get("nonmodal")
    if nonmodal == 920:
        pos, unit, gg = st.pos, st.unit, list(st.g92)
        for k, i in spec.axis_idx:
            gg[k] = pos[k] - st.coord_offset[k] - (st.tool_offset if k == 2 else 0.0) - vals[i] * unit
        st.g92 = tuple(gg)
        st.set_offsets()
    elif nonmodal == 921:
        st.g92 = (0.0, 0.0, 0.0)
        st.set_offsets()
    if "motion" in g:
        st.motion = g["motion"]
    if spec.moves(motion_before) and nonmodal != 920:
        _motion(st, spec, vals, out, notices, line)
    stop = m.get("stop")
    if stop is not None:
        out.append(ProgramEnd(line) if stop in (20, 300) else Stop(line, optional=stop == 10))
        if stop in (20, 300):
            st.ended = True


def _spindle_tool(st: Staged, spec: BlockSpec, vals, out, notices, line: int, setup: Setup) -> None:
    idx, m = spec.index, spec.m
    if "S" in idx:
        rpm = vals[idx["S"]]
        if rpm < 0.0:
            raise BlockError("E-VALUE", f"negative spindle speed S{rpm:g}", idx["S"])
        st.spindle_rpm = rpm
    if "T" in idx:
        st.tool_selected = _whole(vals[idx["T"]], "T", idx["T"])
    if m.get("toolchange") == 60:
        tool = st.tool_selected
        if tool is None:
            raise BlockError("E-WORD-MISSING", "M6 needs a T word (no tool selected)", spec.where["toolchange"])
        if tool and tool not in setup.tool_lengths_mm:
            notices.append(("W-TOOL-UNKNOWN", f"tool T{tool} is not in the tool table", idx.get("T")))
        st.tool_in_spindle = tool
        out.append(ToolChange(line, tool))
    spindle = m.get("spindle")
    if spindle is not None:
        st.spindle_dir = {30: "cw", 40: "ccw", 50: None}[spindle]
    if spindle is not None or ("S" in idx and st.spindle_dir is not None):
        out.append(Spindle(line, st.spindle_rpm, st.spindle_dir))
    coolant = m.get("coolant")
    if coolant is not None:
        st.mist = coolant == 70 or (st.mist and coolant != 90)
        st.flood = coolant == 80 or (st.flood and coolant != 90)
        out.append(Coolant(line, st.mist, st.flood))


def _modes(st: Staged, spec: BlockSpec, vals, notices, setup: Setup) -> None:
    g, idx = spec.g, spec.index
    if "plane" in g:
        st.plane = _PLANES[g["plane"]]
    if "units" in g:
        st.unit = INCH_MM if g["units"] == 200 else 1.0
    tl = g.get("tool_length")
    if tl == 430:
        h = _whole(vals[idx["H"]], "H", idx["H"]) if "H" in idx else st.tool_in_spindle
        length = 0.0
        if h:
            if h in setup.tool_lengths_mm:
                length = float(setup.tool_lengths_mm[h])
            else:
                notices.append(("W-TOOL-UNKNOWN", f"tool H{h} is not in the tool table: zero "
                                "length offset", idx.get("H")))
        st.tool_offset = length
        st.set_offsets()
    elif tl == 490:
        st.tool_offset = 0.0
        st.set_offsets()
    if "coord" in g:
        st.coord = g["coord"]
        st.coord_offset = setup.work_offset(g["coord"])
        st.set_offsets()
    path = g.get("path")
    if path == 610:
        st.path = EXACT_STOP
    elif path == 640:
        tol = [None, None]
        for j, letter in enumerate("PQ"):
            if letter in idx:
                v = vals[idx[letter]]
                if v < 0.0:
                    raise BlockError("E-VALUE", f"negative G64 tolerance {letter}{v:g}", idx[letter])
                tol[j] = v * st.unit
        st.path = PathControl(False, tol[0], tol[1])
    d = g.get("distance")
    if d is not None:
        st.absolute = d == 900
    ad = g.get("arc_distance")
    if ad is not None:
        st.arc_absolute = ad == 901


def _motion(st: Staged, spec: BlockSpec, vals, out, notices, line: int) -> None:
    motion = st.motion
    g53 = spec.g.get("nonmodal") == 530
    if g53 and not st.absolute:
        raise BlockError("E-G53", "G53 cannot be used in G91 (incremental)", spec.where["nonmodal"])
    if motion in (52, 62):
        return nurbs_blocks.start_group(st, spec, vals, line, notices)
    if motion == 53:
        raise BlockError("E-NURBS-BLOCK", "G5.3 without an open G5.2 group", spec.where.get("motion"))
    end = target(st, spec, vals, st.pos, machine=g53)
    if motion == 0:
        out.append(Rapid(line, st.pos, end, st.path))
    else:
        feed_mm_s = st.feed_mm_s
        if feed_mm_s <= 0.0:
            word = spec.where.get("motion", spec.index[spec.axes[0]] if spec.axes else None)
            raise BlockError("E-FEED-ZERO", "feed move with feed rate zero (program an F word)", word)
        if motion == 10:
            out.append(Line(line, st.pos, end, feed_mm_s, st.path))
        else:
            out.append(_arc(st, spec, vals, end, feed_mm_s, line))
    st.pos = end


def _arc(st: Staged, spec: BlockSpec, vals, end, feed_mm_s: float, line: int):
    idx, plane = spec.index, st.plane
    a, b, n = PLANE_AXES[plane]
    where = spec.where.get("motion")
    offs = [letter for letter in "IJK" if letter in idx]
    normal_offset = "IJK"[n]
    if "R" in idx and offs:
        raise BlockError("E-ARC-FORMAT", "arc with both R and I/J/K", idx["R"])
    if normal_offset in idx:
        raise BlockError("E-ARC-FORMAT", f"{normal_offset} word in a {plane} arc", idx[normal_offset])
    turns = 0
    if "P" in idx:
        p = vals[idx["P"]]
        if p != round(p) or p < 1:
            raise BlockError("E-VALUE", f"arc turns P{p:g} must be a whole number >= 1", idx["P"])
        turns = int(p) - 1
    ccw = st.motion == 30
    if "R" in idx:
        if AXES[a] not in idx and AXES[b] not in idx:
            raise BlockError("E-ARC-FORMAT", f"radius-format arc needs {AXES[a]} or {AXES[b]}", idx["R"])
        return make_arc(line, st.pos, end, plane, ccw, feed_mm_s, st.path,
                        radius_mm=vals[idx["R"]] * st.unit, turns=turns, word=idx["R"], unit_mm=st.unit)
    if not offs:
        raise BlockError("E-ARC-FORMAT", "arc needs R or I/J/K", where)
    unit = st.unit
    ia, ib = "IJK"[a], "IJK"[b]
    if st.arc_absolute:
        for letter in (ia, ib):
            if letter not in idx:
                raise BlockError("E-ARC-FORMAT", f"{letter} word missing in an absolute-centre (G90.1) arc",
                                 where)
        off = st.offset
        center = (vals[idx[ia]] * unit + off[a], vals[idx[ib]] * unit + off[b])
    else:
        center = (st.pos[a] + (vals[idx[ia]] * unit if ia in idx else 0.0),
                  st.pos[b] + (vals[idx[ib]] * unit if ib in idx else 0.0))
    return make_arc(line, st.pos, end, plane, ccw, feed_mm_s, st.path, center_ab=center, turns=turns,
                    word=idx[offs[0]], unit_mm=unit)


def _whole(value: float, letter: str, word: int) -> int:
    if value != round(value) or value < 0:
        raise BlockError("E-VALUE", f"{letter}{value:g} must be a whole number >= 0", word)
    return int(value)
