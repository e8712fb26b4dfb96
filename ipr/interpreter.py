"""Execute blocks against the modal state: text lines in, entities out.

Per line: ipr.syntax gives the words (through the shape cache for simple lines),
ipr.block checks them against the modal groups (cached per signature), and the block
is executed on a staged view of the state, committed only if nothing failed. Plain
G0/G1 blocks (axis words, F, N only) take a short path with the same checks.
"""
from __future__ import annotations

from collections.abc import Iterable

from ipr import nurbs_blocks
from ipr.arcs import make_arc
from ipr.block import AXES, BlockSpec, analyse
from ipr.entities import (EXACT_STOP, PLANE_AXES, Coolant, Diagnostic, Dwell, GCodeError, Line,
                          Message, PathControl, ProgramEnd, Rapid, Spindle, Stop, ToolChange)
from ipr.errors import BlockError
from ipr.expressions import evaluate, param_key
from ipr.modal import INCH_MM, ModalState, Setup, Staged
from ipr.syntax import LineSyntaxError, parse_line_columns, split_parts, template_for

_PLANES = {170: "XY", 180: "ZX", 190: "YZ"}
MAX_VALUE = 1e30   # the fast path reads at most 30 digits; expressions may go further


def spec_letter(spec: BlockSpec, word: int) -> str:
    for letter, i in spec.index.items():
        if i == word:
            return letter
    return "G/M"


def target(st, spec: BlockSpec, vals, base, machine: bool = False):
    """End point of the block's axis words from `base` (machine mm), as the distance mode says."""
    end = list(base)
    unit = st.unit
    if machine:
        for k, i in spec.axis_idx:
            end[k] = vals[i] * unit
    elif st.absolute:
        off = st.offset
        for k, i in spec.axis_idx:
            end[k] = vals[i] * unit + off[k]
    else:
        for k, i in spec.axis_idx:
            end[k] = base[k] + vals[i] * unit
    return tuple(end)


class Interpreter:
    """Feeds lines one at a time; `out` receives entities, `diagnostics` errors,
    `warnings` warnings and notices. Raises GCodeError at the first error unless
    `all_errors`."""

    def __init__(self, file: str = "<string>", setup: Setup | None = None, all_errors: bool = False):
        self.file = file
        self.setup = setup or Setup()
        self.all_errors = all_errors
        self.state = ModalState(self.setup)
        self.out: list = []
        self.diagnostics: list[Diagnostic] = []
        self.warnings: list[Diagnostic] = []
        self._plans: dict = {}
        self._percents = 0
        self.program_number: int | None = None
        self.done = False

    # ---- errors -------------------------------------------------------------------
    def _fail(self, err: BlockError, line: int, text: str) -> None:
        col = err.col
        if col is None:
            col = 1
            if err.word is not None:
                try:
                    col = parse_line_columns(text)[1][err.word]
                except (LineSyntaxError, IndexError):
                    col = 1
        diag = Diagnostic(self.file, err.line or line, col, err.code, err.message)
        self.diagnostics.append(diag)
        if not self.all_errors:
            raise GCodeError([diag])

    def _notice(self, code: str, message: str, line: int, text: str, word: int | None,
                severity: str = "notice") -> None:
        col = 1
        if word is not None:
            col = parse_line_columns(text)[1][word]
        self.warnings.append(Diagnostic(self.file, line, col, code, message, severity))

    # ---- lines --------------------------------------------------------------------
    def _plan(self, shape: str):
        """The cached plan of a line shape: None (not simple: full grammar), or
        (template, spec or BlockError, short-path data)."""
        if len(self._plans) > 4096:
            self._plans.clear()
        tpl = template_for(shape)
        if tpl is None:
            plan = None
        else:
            spec = analyse(tuple(zip(tpl.letters, tpl.fixed)))
            fast = None
            if spec.__class__ is BlockSpec and spec.linear and not tpl.delete:
                part = {w: 2 * j + 1 for j, w in enumerate(tpl.slots)}   # word -> index in parts
                axis_parts = {k: part[i] for k, i in spec.axis_idx}
                ends = _end_functions(axis_parts) if axis_parts else (None, None)
                fast = (spec.motion, part.get(spec.f_index), *ends)
            plan = (tpl, spec, fast)
        self._plans[shape] = plan
        return plan

    def feed(self, line: int, text: str) -> None:
        """Interpret one line."""
        if not self.done:
            parts = split_parts(text)
            self._feed_parts(line, text, parts, self._plan_of(parts))

    def run(self, lines: Iterable[str], first: int = 1) -> int:
        """Interpret lines numbered from `first` until they run out or the program ends;
        returns the number of the last line read. Plain G0/G1 lines are done inline."""
        state, out, plans = self.state, self.out, self._plans
        n = first - 1
        for n, text in enumerate(lines, first):
            if self.done:
                return n - 1
            parts = split_parts(text)
            shape = "\x00".join(parts[0::2])
            plan = plans[shape] if shape in plans else self._plan(shape)
            if "\x00" in text:   # the shape's slot marker: such a line takes the full grammar
                plan = None
            fast = plan[2] if plan is not None else None
            if fast is not None and state.nurbs is None:
                motion = fast[0] if fast[0] is not None else state.motion
                if motion == 10 or motion == 0:
                    _, f_part, end_abs, end_inc = fast
                    unit = state.unit
                    feed_mm_s = float(parts[f_part]) * unit / 60.0 if f_part is not None else state.feed_mm_s
                    if feed_mm_s > 0.0 or motion == 0 and feed_mm_s == 0.0:
                        if end_abs is not None:
                            pos = state.pos
                            end = (end_abs(parts, pos, unit, state.offset) if state.absolute
                                   else end_inc(parts, pos, unit, state.offset))
                            if motion == 10:
                                out.append(Line(n, pos, end, feed_mm_s, state.path))
                            else:
                                out.append(Rapid(n, pos, end, state.path))
                            state.pos = end
                        state.feed_mm_s = feed_mm_s
                        state.motion = motion
                        continue
            self._feed_parts(n, text, parts, plan)   # everything else, and the error cases
        return n

    def _plan_of(self, parts: list[str]):
        if any("\x00" in p for p in parts):
            return None
        shape = "\x00".join(parts[0::2])
        return self._plans[shape] if shape in self._plans else self._plan(shape)

    def _feed_parts(self, line: int, text: str, parts: list[str], plan) -> None:
        try:
            if plan is None:
                return self._full(line, text)
            tpl, spec, fast = plan
            if not tpl.letters or tpl.delete and self.setup.block_delete:
                return
            if spec.__class__ is BlockError:
                raise spec
            if fast is not None and self.state.nurbs is None:
                motion = fast[0] if fast[0] is not None else self.state.motion
                if motion == 10 or motion == 0:
                    return self._linear(motion, fast, parts, line)
            vals = list(tpl.fixed)
            for i, s in zip(tpl.slots, parts[1::2]):
                vals[i] = float(s)
            self._execute(spec, vals, (), (), line, text)
        except BlockError as err:
            self._fail(err, line, text)

    def _full(self, line: int, text: str) -> None:
        """A line off the fast path: full grammar, expressions, parameters."""
        try:
            block, _ = parse_line_columns(text)
        except LineSyntaxError as e:
            raise BlockError("E-SYNTAX", e.message, col=e.col) from None
        if block.percent:
            self._percents += 1
            self.done = self._percents == 2  # the second % ends the program
            return
        if block.delete and self.setup.block_delete:
            return
        params = self.state.params
        vals = [v if v.__class__ is float else self._eval(v, i) for i, (_, v) in enumerate(block.words)]
        assigns = [(param_key(k, params), evaluate(v, params)) for k, v in block.assigns]
        spec = analyse(tuple((l, v if l in "GM" else None) for (l, _), v in zip(block.words, vals)))
        if spec.__class__ is BlockError:
            raise spec
        self._execute(spec, vals, assigns, block.messages, line, text)

    def _eval(self, node, word: int) -> float:
        try:
            return evaluate(node, self.state.params)
        except BlockError as err:
            err.word = word
            raise

    def finish(self, last_line: int) -> None:
        """End of input: an open NURBS group is an error."""
        group = self.state.nurbs
        if group is not None:
            self.state.nurbs = None
            self._fail(BlockError("E-NURBS-INCOMPLETE", f"{group.name} group begun here is incomplete at "
                                  f"the end of the program (line {last_line})", col=1, line=group.line),
                       group.line, "")

    # ---- the short path: G0/G1 with axis words, F, N ---------------------------------
    def _linear(self, motion: int, fast: tuple, parts: list, line: int) -> None:
        """G0/G1 with only axis words, F and N: same checks as _execute, less overhead."""
        s = self.state
        _, f_part, end_abs, end_inc = fast
        feed_mm_s = s.feed_mm_s
        if f_part is not None:
            f = float(parts[f_part])
            if f < 0.0:
                raise BlockError("E-VALUE", f"negative feed rate F{f:g}", col=_col(parts, f_part))
            feed_mm_s = f * s.unit / 60.0
        if end_abs is not None:
            pos = s.pos
            unit = s.unit
            end = (end_abs if s.absolute else end_inc)(parts, pos, unit, s.offset)
            if motion == 10:
                if feed_mm_s <= 0.0:
                    raise BlockError("E-FEED-ZERO", "G1 move with feed rate zero (program an F word)",
                                     col=_col(parts, _first_slot(end_abs)))
                self.out.append(Line(line, pos, end, feed_mm_s, s.path))
            else:
                self.out.append(Rapid(line, pos, end, s.path))
            s.pos = end
        s.feed_mm_s = feed_mm_s
        s.motion = motion

    # ---- the general path ---------------------------------------------------------
    def _execute(self, spec: BlockSpec, vals: list, assigns, messages, line: int, text: str) -> None:
        base = self.state
        err = spec.check_usage(base.motion)
        if err is not None:
            raise err
        for i, v in enumerate(vals):
            if not -MAX_VALUE < v < MAX_VALUE:
                raise BlockError("E-VALUE", f"{spec_letter(spec, i)} value {v:g} is out of range", i)
        st = Staged(base)
        out: list = [Message(line, m) for m in messages]
        notices: list = []
        idx, g, m = spec.index, spec.g, spec.m
        if base.nurbs is not None and spec.index.keys() | g.keys() | m.keys():
            if g.get("motion", base.nurbs.kind) in (base.nurbs.kind, 53):
                nurbs = nurbs_blocks.continue_group(st, spec, vals, target)
                if nurbs is not None:
                    out.append(nurbs)
                return self._commit(st, out, notices, assigns, line, text)
            group = base.nurbs
            base.nurbs = None  # the group is dropped; this block then runs on its own
            self._fail(BlockError("E-NURBS-INCOMPLETE", f"{group.name} group begun here is incomplete: "
                                  f"line {line} starts another motion", col=1, line=group.line),
                       group.line, "")
            return self._execute(spec, vals, assigns, messages, line, text)
        if "F" in idx:
            if vals[idx["F"]] < 0.0:
                raise BlockError("E-VALUE", f"negative feed rate F{vals[idx['F']]:g}", idx["F"])
            st.feed_mm_s = vals[idx["F"]] * st.unit / 60.0  # before a G20/G21 of this block
        if "O" in idx:
            number = _whole(vals[idx["O"]], "O", idx["O"])
            st.after_commit.append(lambda: setattr(self, "program_number", number))
        self._spindle_tool(st, spec, vals, out, notices, line)
        if g.get("nonmodal") == 40:
            p = vals[idx["P"]]
            if p < 0.0:
                raise BlockError("E-VALUE", f"negative dwell time P{p:g}", idx["P"])
            out.append(Dwell(line, p))
        self._modes(st, spec, vals, notices)
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
        if spec.moves(base.motion) and nonmodal != 920:
            self._motion(st, spec, vals, out, notices, line)
        stop = m.get("stop")
        if stop is not None:
            out.append(ProgramEnd(line) if stop in (20, 300) else Stop(line, optional=stop == 10))
            if stop in (20, 300):
                st.ended = True
        self._commit(st, out, notices, assigns, line, text)

    def _commit(self, st: Staged, out, notices, assigns, line: int, text: str) -> None:
        st.commit()
        if assigns:
            self.state.params.update(assigns)
        self.out.extend(out)
        for code, message, word in notices:
            self._notice(code, message, line, text, word, "warning" if code.startswith("W") else "notice")
        if self.state.ended:
            self.done = True

    def _spindle_tool(self, st: Staged, spec: BlockSpec, vals, out, notices, line: int) -> None:
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
            if tool and tool not in self.setup.tool_lengths_mm:
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

    def _modes(self, st: Staged, spec: BlockSpec, vals, notices) -> None:
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
                if h in self.setup.tool_lengths_mm:
                    length = float(self.setup.tool_lengths_mm[h])
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
            st.coord_offset = self.setup.work_offset(g["coord"])
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

    def _motion(self, st: Staged, spec: BlockSpec, vals, out, notices, line: int) -> None:
        motion = st.motion
        g53 = spec.g.get("nonmodal") == 530
        if g53 and not st.absolute:
            raise BlockError("E-G53", "G53 cannot be used in G91 (incremental)", spec.where["nonmodal"])
        if motion in (52, 62):
            return nurbs_blocks.start_group(st, spec, vals, line, target, notices)
        if motion == 53:
            raise BlockError("E-NURBS-BLOCK", "G5.3 without an open G5.2 group", spec.where.get("motion"))
        end = target(st, spec, vals, st.pos, machine=g53)
        if motion == 0:
            out.append(Rapid(line, st.pos, end, st.path))
        else:
            feed_mm_s = st.feed_mm_s
            if feed_mm_s <= 0.0:
                word = spec.where.get("motion", spec.index[spec.axes[0]] if spec.axes else None)
                raise BlockError("E-FEED-ZERO", f"feed move with feed rate zero (program an F word)", word)
            if motion == 10:
                out.append(Line(line, st.pos, end, feed_mm_s, st.path))
            else:
                out.append(self._arc(st, spec, vals, end, feed_mm_s, line))
        st.pos = end

    def _arc(self, st: Staged, spec: BlockSpec, vals, end, feed_mm_s: float, line: int):
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


def _end_functions(axis_parts: dict[int, int]):
    """The compiled word template of a plain G0/G1 shape: two functions from the line's
    parts (ipr.syntax.split_parts) to the end point, absolute (G90) and incremental (G91).
    `axis_parts` maps axis 0..2 to the index of its number in parts; omitted axes stay."""
    absolute, incremental = [], []
    for k in range(3):
        if k in axis_parts:
            absolute.append(f"float(p[{axis_parts[k]}]) * u + o[{k}]")
            incremental.append(f"pos[{k}] + float(p[{axis_parts[k]}]) * u")
        else:
            absolute.append(f"pos[{k}]")
            incremental.append(f"pos[{k}]")
    make = "lambda p, pos, u, o: ({},)"
    end_abs = eval(make.format(", ".join(absolute)), {"float": float})
    end_inc = eval(make.format(", ".join(incremental)), {"float": float})
    end_abs.first_part = end_inc.first_part = min(axis_parts.values())
    return end_abs, end_inc


def _first_slot(end_function) -> int:
    return end_function.first_part


def _col(parts: list[str], p: int) -> int:
    """1-based column of the letter just before the slot number parts[p]."""
    return len("".join(parts[:p]))


def _whole(value: float, letter: str, word: int) -> int:
    if value != round(value) or value < 0:
        raise BlockError("E-VALUE", f"{letter}{value:g} must be a whole number >= 0", word)
    return int(value)
