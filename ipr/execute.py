"""One block's effects, in RS274NGC's order of execution, on a staged modal state.

Called by ipr.interpreter for every block that is not a plain G0/G1 move and not part
of a NURBS group: feed, spindle and tool, dwell, plane, units, tool length, coordinate
system, path control, distance modes, G92, motion (lines, arcs, the start of a NURBS
group) and stops. Writes go to the Staged view and outputs to `out`/`notices`; the
caller commits them only if nothing raised.
"""
from __future__ import annotations

from dataclasses import replace

from ipr import cutter_comp, cycles, gcodes, modes, nurbs_blocks, offsets, splines
from ipr.arcs import make_arc
from ipr.block import AXES, CYCLES, BlockSpec
from ipr.entities import (EXACT_PATH, EXACT_STOP, PLANE_AXES, Coolant, Dwell, Line, PathControl, ProgramEnd, Rapid,
                          Spindle, Stop, ToolChange)
from ipr.dialect import allows_zero_normal_offset, dwell_seconds
from ipr.errors import BlockError
from ipr.gcodes import (ABSOLUTE, ARC_ABSOLUTE, COMPENSATION_OFF, COOLANT_OFF, DATA_SET, DWELL,
                        FEED_PER_MINUTE, FLOOD_ON, HOME_G28, HOME_G28_SET, HOME_G30, HOME_G30_SET,
                        INVERSE_TIME, LOCAL_OFFSET, MACHINE_COORDS, MIST_ON, MOTION_ARC_CCW, MOTION_ARC_CW,
                        MOTION_LINEAR, MOTION_RAPID, NURBS_FANUC, NURBS_LINUXCNC, NURBS_LINUXCNC_END,
                        NURBS_MOTIONS, OFFSET_SET, OPTIONAL_STOP, PLANE_XY, PLANE_XZ, PLANE_YZ, PROGRAM_END,
                        PROGRAM_END_RESET, RETRACT_R, SPINDLE_CCW, SPINDLE_CW, SPINDLE_STOP, SPLINE_CUBIC,
                        SPLINE_QUADRATIC, TOOL_CHANGE, UNITS_INCH)
from ipr.mcodes import execute_mcodes
from ipr.modal import INCH_MM, Setup, Staged, rotate_xy, target, to_machine

# a helix of more turns than this is refused: its samples alone would fill memory (a thread
# milled in one block has a few dozen turns)
MAX_ARC_TURNS = 1000

_PLANES = {PLANE_XY: "XY", PLANE_XZ: "ZX", PLANE_YZ: "YZ"}
_SPINDLE = {SPINDLE_CW: "cw", SPINDLE_CCW: "ccw", SPINDLE_STOP: None}
_BASIC_M = {"stop", "coolant"}   # M groups handled here; the rest (and M6's group) in ipr.mcodes


def execute_block(st: Staged, spec: BlockSpec, vals: list, out: list, notices: list, line: int,
                  setup: Setup, motion_before: int | None) -> None:
    """Everything a (non-NURBS-group) block does; `motion_before` is the modal motion."""
    idx, g, m = spec.index, spec.g, spec.m
    if "feed_mode" in g:
        modes.set_feed_mode(st, spec, g["feed_mode"])
    if "F" in idx:
        if vals[idx["F"]] < 0.0:
            raise BlockError("E-VALUE", f"negative feed rate F{vals[idx['F']]:g}", idx["F"])
        st.feed_mm_s = vals[idx["F"]] * st.unit / 60.0  # before a G20/G21 of this block
    if "O" in idx:
        st.program_number = _whole(vals[idx["O"]], "O", idx["O"])
    if "spindle_mode" in g:
        modes.set_spindle_mode(st, spec, vals, out, line, g["spindle_mode"])
    _spindle_tool(st, spec, vals, out, notices, line, setup)
    if m.keys() - _BASIC_M or "dialect_g" in g:
        execute_mcodes(st, spec, vals, out, line, setup)
    if g.get("nonmodal") == DWELL:
        p = vals[idx["P"]]
        if p < 0.0:
            raise BlockError("E-VALUE", f"negative dwell time P{p:g}", idx["P"])
        out.append(Dwell(line, dwell_seconds(setup.dialect, p)))
    if "plane" in g and st.comp is not None and st.comp.side and st.plane != _PLANES[g["plane"]]:
        raise BlockError("E-COMP", "the plane cannot change while cutter radius compensation is on",
                         spec.where["plane"])
    _modes(st, spec, vals, notices, setup)
    comp = g.get("comp")
    if comp == COMPENSATION_OFF:
        cutter_comp.turn_off(st, out)
    elif comp is not None:
        cutter_comp.turn_on(st, spec, vals, lambda t: (offsets.tool_entry(st, setup, t) or (None, None))[1], comp,
                            notices)
    nonmodal = g.get("nonmodal")
    breaks_comp = (DATA_SET, HOME_G28, HOME_G30, MACHINE_COORDS, OFFSET_SET, LOCAL_OFFSET)
    if st.comp is not None and st.comp.side and (nonmodal in breaks_comp or "g92_apply" in g):
        raise BlockError("E-COMP", "G10, G28, G30, G52, G53 and G92 cannot be used with cutter radius "
                         "compensation on (G40 first)", spec.where["nonmodal" if nonmodal else "g92_apply"])
    if nonmodal == DATA_SET:
        offsets.g10(st, spec, vals, setup)
    elif nonmodal in (HOME_G28, HOME_G30):
        offsets.stored_return(st, spec, vals, out, line)
    elif nonmodal in (HOME_G28_SET, HOME_G30_SET):
        offsets.store_position(st, spec)
    elif nonmodal in (OFFSET_SET, LOCAL_OFFSET):
        offsets.g92(st, spec, vals)
    if "g92_apply" in g:
        offsets.g92_apply(st, g["g92_apply"])
    if "motion" in g:
        st.motion = g["motion"]
    holding = st.comp is not None and st.comp.queue
    if holding and out:   # events run after the moves compensation holds back
        cutter_comp.hold(st, out[:])
        out.clear()
    if spec.moves(motion_before):
        _motion(st, spec, vals, out, notices, line, motion_before, setup.dialect)
    stop = m.get("stop")
    if stop is not None:
        if stop in (PROGRAM_END, PROGRAM_END_RESET):
            if st.comp is not None:
                cutter_comp.flush_all(st, out)
            out.append(ProgramEnd(line))
            st.ended = True
        elif st.comp is not None and st.comp.queue:
            cutter_comp.hold(st, [Stop(line, optional=stop == OPTIONAL_STOP)])
        else:
            out.append(Stop(line, optional=stop == OPTIONAL_STOP))


def _spindle_tool(st: Staged, spec: BlockSpec, vals, out, notices, line: int, setup: Setup) -> None:
    idx, m = spec.index, spec.m
    if "S" in idx:
        rpm = vals[idx["S"]]
        if rpm < 0.0:
            raise BlockError("E-VALUE", f"negative spindle speed S{rpm:g}", idx["S"])
        st.spindle_rpm = rpm
    if "T" in idx:
        st.tool_selected = _whole(vals[idx["T"]], "T", idx["T"])
    if m.get("toolchange") == TOOL_CHANGE:
        tool = st.tool_selected
        if tool is None:
            raise BlockError("E-WORD-MISSING", "M6 needs a T word (no tool selected)", spec.where["toolchange"])
        if tool and tool not in setup.tool_lengths_mm:
            notices.append(("W-TOOL-UNKNOWN", f"tool T{tool} is not in the tool table", idx.get("T")))
        st.tool_in_spindle = tool
        out.append(ToolChange(line, tool))
    spindle = m.get("spindle")
    if spindle not in _SPINDLE:
        spindle = None
    if spindle is not None:
        st.spindle_dir = _SPINDLE[spindle]
    if spindle is not None or ("S" in idx and st.spindle_dir is not None):
        out.append(Spindle(line, st.spindle_rpm, st.spindle_dir))
    coolant = m.get("coolant")
    if coolant is not None:
        st.mist = coolant == MIST_ON or (st.mist and coolant != COOLANT_OFF)
        st.flood = coolant == FLOOD_ON or (st.flood and coolant != COOLANT_OFF)
        out.append(Coolant(line, st.mist, st.flood))


def _modes(st: Staged, spec: BlockSpec, vals, notices, setup: Setup) -> None:
    g, idx = spec.g, spec.index
    if "plane" in g:
        st.plane = _PLANES[g["plane"]]
    if "units" in g:
        st.unit = INCH_MM if g["units"] == UNITS_INCH else 1.0
    if "tool_length" in g:
        offsets.tool_length(st, spec, vals, notices, setup, g["tool_length"])
    if "coord" in g:
        offsets.select_coord(st, setup, g["coord"])
    path = g.get("path")
    if path == gcodes.EXACT_PATH:
        st.path = EXACT_PATH
    elif path == gcodes.EXACT_STOP:
        st.path = EXACT_STOP
    elif path == gcodes.BLEND:
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
        st.absolute = d == ABSOLUTE
    ad = g.get("arc_distance")
    if ad is not None:
        st.arc_absolute = ad == ARC_ABSOLUTE
    if "retract" in g:
        st.retract_r = g["retract"] == RETRACT_R


def _motion(st: Staged, spec: BlockSpec, vals, out, notices, line: int, motion_before: int | None,
            dialect: str) -> None:
    motion = st.motion
    g53 = spec.g.get("nonmodal") == MACHINE_COORDS
    if g53 and not st.absolute:
        raise BlockError("E-G53", "G53 cannot be used in G91 (incremental)", spec.where["nonmodal"])
    if motion in CYCLES:
        return cycles.run_cycle(st, spec, vals, out, notices, line, motion_before, dialect)
    comp, end = st.comp, None
    if comp is not None:
        where = spec.where.get("motion", spec.index[spec.axes[0]] if spec.axes else None)
        plain = motion in (MOTION_RAPID, MOTION_LINEAR, MOTION_ARC_CW, MOTION_ARC_CCW)
        if not plain or g53 or st.feed_mode == INVERSE_TIME:
            raise BlockError("E-COMP", "under cutter radius compensation only G0, G1, G2 and G3 moves in G94/G95 "
                             "are supported", where)
        end = target(st, spec, vals, comp.programmed)
        if not comp.side:   # the exit move after G40: from the compensated point to the programmed end
            if motion in (MOTION_ARC_CW, MOTION_ARC_CCW):
                raise BlockError("E-COMP", "the first move after G40 cannot be an arc", where)
            st.comp = None
        else:
            return _comp_motion(st, spec, vals, out, notices, line, motion, end, where, dialect)
    if spec.polar is not None and motion in (SPLINE_CUBIC, SPLINE_QUADRATIC, NURBS_LINUXCNC, NURBS_FANUC):
        raise BlockError("E-POLAR", "polar coordinates (@, ^) only with G0, G1, G2, G3 and the canned cycles",
                         spec.polar)
    if motion in NURBS_MOTIONS:
        if st.rotation_deg:
            raise BlockError("E-OFFSET", "NURBS blocks in a rotated coordinate system (G10 L2 R) are not "
                             "supported", spec.where.get("motion"))
        return nurbs_blocks.start_group(st, spec, vals, line, notices)
    if motion == NURBS_LINUXCNC_END:
        raise BlockError("E-NURBS-BLOCK", "G5.3 without an open G5.2 group", spec.where.get("motion"))
    if end is None:
        end = target(st, spec, vals, st.pos, machine=g53)
    if motion == MOTION_RAPID:
        out.append(Rapid(line, st.pos, end, st.path))
    else:
        word = spec.where.get("motion", spec.index[spec.axes[0]] if spec.axes else None)
        if st.feed_mm_s <= 0.0:
            raise BlockError("E-FEED-ZERO", "feed move with feed rate zero (program an F word)", word)
        if motion in (SPLINE_CUBIC, SPLINE_QUADRATIC):
            if st.feed_mode == INVERSE_TIME:
                raise BlockError("E-FEED-MODE", "G5/G5.1 splines in inverse time feed (G93) are not supported",
                                 word)
            out.append(splines.spline(st, spec, vals, motion_before,
                                      modes.move_feed_mm_s(st, spec, vals, word, st.pos, end), line))
            return
        if motion == MOTION_LINEAR:
            feed_mm_s = modes.move_feed_mm_s(st, spec, vals, word, st.pos, end)
            out.append(Line(line, st.pos, end, feed_mm_s, st.path))
        else:
            arc = _arc(st, spec, vals, end, st.feed_mm_s, line, dialect, notices)
            if st.feed_mode != FEED_PER_MINUTE:
                arc = replace(arc, feed_mm_s=modes.move_feed_mm_s(st, spec, vals, word, st.pos, end, arc))
            out.append(arc)
    st.pos = end


def _comp_motion(st, spec, vals, out, notices, line: int, motion: int, end, where, dialect: str) -> None:
    """A G0..G3 under compensation (ipr.cutter_comp), `end` the programmed end point."""
    if motion == MOTION_RAPID:
        return cutter_comp.straight(st, "rapid", line, end, None, out)
    if st.feed_mm_s <= 0.0:
        raise BlockError("E-FEED-ZERO", "feed move with feed rate zero (program an F word)", where)
    comp, tool_pos = st.comp, st.pos
    start = tool_pos if comp.first else comp.programmed   # rs274's arc_data_comp_ijk / arc_data_ijk
    st.pos = start
    arc = _arc(st, spec, vals, end, st.feed_mm_s, line, dialect, notices) if motion != MOTION_LINEAR else None
    st.pos = tool_pos
    feed_mm_s = modes.move_feed_mm_s(st, spec, vals, where, start, end, arc)
    if arc is None:
        return cutter_comp.straight(st, "line", line, end, feed_mm_s, out)
    if arc.turns:
        raise BlockError("E-COMP", "full turns (P) of an arc under cutter radius compensation are not supported",
                         spec.index["P"])
    return cutter_comp.arc(st, line, end, arc.center[:2], 1 if arc.ccw else -1, feed_mm_s, out)


def _arc(st: Staged, spec: BlockSpec, vals, end, feed_mm_s: float, line: int, dialect: str, notices):
    idx, plane = spec.index, st.plane
    a, b, n = PLANE_AXES[plane]
    where = spec.where.get("motion")
    normal_offset = "IJK"[n]
    if normal_offset in idx:
        if vals[idx[normal_offset]] != 0.0 or not allows_zero_normal_offset(dialect):
            raise BlockError("E-ARC-FORMAT", f"{normal_offset} word in a {plane} arc", idx[normal_offset])
        notices.append(("N-RECORDED", f"{normal_offset}0 on a {plane} arc read as absent ({dialect} dialect)",
                        idx[normal_offset]))
    offs = [letter for letter in "IJK" if letter in idx and letter != normal_offset]
    if "R" in idx and offs:
        raise BlockError("E-ARC-FORMAT", "arc with both R and I/J/K", idx["R"])
    turns = 0
    if "P" in idx:
        p = vals[idx["P"]]
        if not (p == round(p) and 1 <= p <= MAX_ARC_TURNS):
            raise BlockError("E-VALUE", f"arc turns P{p:g} must be a whole number from 1 to {MAX_ARC_TURNS}",
                             idx["P"])
        turns = int(p) - 1
    ccw = st.motion == MOTION_ARC_CCW
    if "R" in idx:
        if AXES[a] not in idx and AXES[b] not in idx and spec.polar is None:
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
        p = [0.0, 0.0, 0.0]
        p[a], p[b] = vals[idx[ia]] * unit, vals[idx[ib]] * unit
        c = to_machine(st, p)
        center = (c[a], c[b])
    else:
        d = [0.0, 0.0, 0.0]
        d[a] = vals[idx[ia]] * unit if ia in idx else 0.0
        d[b] = vals[idx[ib]] * unit if ib in idx else 0.0
        d[0], d[1] = rotate_xy(st, d[0], d[1])
        center = (st.pos[a] + d[a], st.pos[b] + d[b])
    return make_arc(line, st.pos, end, plane, ccw, feed_mm_s, st.path, center_ab=center, turns=turns,
                    word=idx[offs[0]], unit_mm=unit)


def _whole(value: float, letter: str, word: int) -> int:
    if value != round(value) or value < 0:
        raise BlockError("E-VALUE", f"{letter}{value:g} must be a whole number >= 0", word)
    return int(value)
