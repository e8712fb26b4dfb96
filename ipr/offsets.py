"""Positions and offsets: G10 tables, G28/G30 stored positions, G92/G52, G43 tool length,
the coordinate system's XY rotation (G10 L2 R).

The chain from program to machine coordinates is LinuxCNC's (emccanon's
rotate_and_offset_pos): program + G92 offset, rotated about Z by the active system's
rotation, + the G54..G59.3 offset, + the tool length offset on Z. The tables live in
the modal state as replaced (never mutated) dicts: `coord_table` (code -> x, y, z, deg)
over the machine file's `work_offsets_mm`, `tool_table` (tool -> length, radius) over
its `[tools]`. G28/G30 positions are machine coordinates, kept per run; the machine file
gives their starting values (`g28_mm`, `g30_mm`; zero where absent, as rs274's empty
parameter file).
"""
from __future__ import annotations

from ipr.entities import Rapid
from ipr.errors import BlockError
from ipr.gcodes import (HOME_G28, HOME_G28_SET, LOCAL_OFFSET, OFFSET_CANCEL, OFFSET_SUSPEND, TOOL_LENGTH_ADD,
                        TOOL_LENGTH_DYNAMIC, TOOL_LENGTH_OFF, WORK_OFFSET_G59_3)
from ipr.modal import ZERO3, Setup, target, to_program

COORD_CODES = (540, 550, 560, 570, 580, 590, 591, 592, 593)   # G10 L2 P1..P9


def coord_entry(st, setup: Setup, code: int) -> tuple[float, float, float, float]:
    """x, y, z (machine mm) and XY rotation (degrees) of a coordinate system."""
    if code in st.coord_table:
        return st.coord_table[code]
    return (*setup.work_offset(code), 0.0)


def select_coord(st, setup: Setup, code: int) -> None:
    x, y, z, deg = coord_entry(st, setup, code)
    st.coord = code
    st.coord_offset = (x, y, z)
    st.rotation_deg = deg
    st.set_offsets()


def tool_entry(st, setup: Setup, tool: int) -> tuple[float, float] | None:
    """(length_mm, radius_mm) of a tool, None if neither table names it."""
    if tool in st.tool_table:
        return st.tool_table[tool]
    if tool in setup.tool_lengths_mm or tool in setup.tool_radii_mm:
        return float(setup.tool_lengths_mm.get(tool, 0.0)), float(setup.tool_radii_mm.get(tool, 0.0))
    return None


def _given(spec, vals, unit: float) -> dict[int, float]:
    return {k: vals[i] * unit for k, i in spec.axis_idx}


def g10(st, spec, vals, setup: Setup) -> None:
    """G10 L1/L10/L11 (tool table) and L2/L20 (coordinate systems). Values are absolute."""
    idx, where = spec.index, spec.where["nonmodal"]
    if "L" not in idx or "P" not in idx:
        raise BlockError("E-OFFSET", "G10 needs an L word and a P word", where)
    lval, pval = vals[idx["L"]], vals[idx["P"]]
    if pval != round(pval) or lval not in (1, 2, 10, 11, 20):
        raise BlockError("E-OFFSET", f"G10 L{lval:g} P{pval:g}: L must be 1, 2, 10, 11 or 20 and P whole",
                         idx["L"])
    p, given = int(pval), _given(spec, vals, st.unit)
    if lval in (2, 20):
        if not 0 <= p <= 9:
            raise BlockError("E-OFFSET", f"G10 L{lval:g} P{p}: P must be 0 (active) or 1..9 (G54..G59.3)",
                             idx["P"])
        code = st.coord if p == 0 else COORD_CODES[p - 1]
        x, y, z, deg = coord_entry(st, setup, code)
        new = [x, y, z]
        if lval == 2:
            for k, v in given.items():
                new[k] = v
            if "R" in idx:
                deg = vals[idx["R"]]
        else:
            if "R" in idx:
                raise BlockError("E-OFFSET", "R is not allowed in G10 L20", idx["R"])
            # the offset that puts the current position at the given coordinates (unrotated)
            here = [st.pos[0] - st.g92[0], st.pos[1] - st.g92[1], st.pos[2] - st.tool_offset - st.g92[2]]
            for k, v in given.items():
                new[k] = here[k] - v
        table = dict(st.coord_table)
        table[code] = (new[0], new[1], new[2], deg)
        st.coord_table = table
        if code == st.coord:
            select_coord(st, setup, code)
        return
    if p < 1:
        raise BlockError("E-OFFSET", f"G10 L{lval:g} P{p}: the tool number must be >= 1", idx["P"])
    length, radius = tool_entry(st, setup, p) or (0.0, 0.0)
    if "R" in idx:
        radius = vals[idx["R"]] * st.unit
    if 2 in given:
        if lval == 1:
            length = given[2]
        else:   # L10/L11: the length that makes the current position read Z in G54 (L10) / G59.3 (L11)
            system = st.coord_offset if lval == 10 else coord_entry(st, setup, WORK_OFFSET_G59_3)[:3]
            length = st.pos[2] - system[2] - st.g92[2] - given[2]
    table = dict(st.tool_table)
    table[p] = (length, radius)
    st.tool_table = table


def stored_return(st, spec, vals, out: list, line: int) -> None:
    """G28/G30: rapid to the intermediate point (the axis words), then to the stored position
    (only the named axes, or all of them when none is named)."""
    home = st.g28 if spec.g["nonmodal"] == HOME_G28 else st.g30
    if spec.axes:
        mid = target(st, spec, vals, st.pos)
        out.append(Rapid(line, st.pos, mid, st.path))
        end = list(mid)
        for k, _ in spec.axis_idx:
            end[k] = home[k]
        out.append(Rapid(line, mid, tuple(end), st.path))
    else:
        out.append(Rapid(line, st.pos, st.pos, st.path))
        out.append(Rapid(line, st.pos, tuple(home), st.path))
        end = home
    st.pos = tuple(end)


def store_position(st, spec) -> None:
    """G28.1/G30.1: the current machine position becomes the stored one."""
    if spec.axes:
        raise BlockError("E-OFFSET", "G28.1/G30.1 take no axis words", spec.index[spec.axes[0]])
    if spec.g["nonmodal"] == HOME_G28_SET:
        st.g28 = st.pos
    else:
        st.g30 = st.pos


def g92(st, spec, vals) -> None:
    """G92: the G92 offset that makes the current position read the given values; G52 sets
    the offset itself (a local coordinate system)."""
    gg = list(st.g92)
    here = to_program(st, st.pos)
    for k, v in _given(spec, vals, st.unit).items():
        gg[k] = v if spec.g["nonmodal"] == LOCAL_OFFSET else gg[k] + here[k] - v
    st.g92 = st.g92_stored = tuple(gg)
    st.set_offsets()


def g92_apply(st, code: int) -> None:
    """G92.1 clears the G92 offset, G92.2 stops applying it, G92.3 applies the kept one."""
    if code == OFFSET_CANCEL:
        st.g92 = st.g92_stored = ZERO3
    elif code == OFFSET_SUSPEND:
        st.g92 = ZERO3
    else:
        st.g92 = st.g92_stored
    st.set_offsets()


def tool_length(st, spec, vals, notices: list, setup: Setup, code: int) -> None:
    """G43 [H], G43.1 Z (dynamic), G43.2 H (adds a tool's length), G49."""
    idx = spec.index
    if code == TOOL_LENGTH_OFF:
        st.tool_offset = 0.0
    elif code == TOOL_LENGTH_DYNAMIC:
        st.tool_offset = vals[idx["Z"]] * st.unit if "Z" in idx else 0.0
    else:
        if code == TOOL_LENGTH_ADD and "H" not in idx:
            raise BlockError("E-WORD-MISSING", "G43.2 needs an H word", spec.where["tool_length"])
        h = st.tool_in_spindle
        if "H" in idx:
            v = vals[idx["H"]]
            if v != round(v) or v < 0:
                raise BlockError("E-VALUE", f"H{v:g} must be a whole number >= 0", idx["H"])
            h = int(v)
        length = 0.0
        if h:
            entry = tool_entry(st, setup, h)
            if entry is None:
                notices.append(("W-TOOL-UNKNOWN", f"tool H{h} is not in the tool table: zero "
                                "length offset", idx.get("H")))
            else:
                length = entry[0]
        st.tool_offset = st.tool_offset + length if code == TOOL_LENGTH_ADD else length
    st.set_offsets()
