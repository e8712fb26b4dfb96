"""Execute blocks against the modal state: text lines in, entities out.

Per line: ipr.syntax gives the words (through the shape cache for simple lines),
ipr.block checks them against the modal groups (cached per signature), and the block
is executed on a staged view of the state, committed only if nothing failed. Plain
G0/G1 blocks (axis words, F, N only) take a short path with the same checks.
"""
from __future__ import annotations

from collections.abc import Iterable

from ipr import nurbs_blocks
from ipr.block import BlockSpec, analyse
from ipr.entities import Diagnostic, GCodeError, Line, Message, Rapid
from ipr.errors import BlockError
from ipr.execute import execute_block
from ipr.expressions import evaluate, param_key
from ipr.modal import ModalState, Setup, Staged
from ipr.shapes import MARK, expression_block, split_parts, template_for
from ipr.syntax import LineSyntaxError, parse_line_columns

MAX_VALUE = 1e31   # the fast path reads at most 30 digits; expressions may go further


def spec_letter(spec: BlockSpec, word: int) -> str:
    for letter, i in spec.index.items():
        if i == word:
            return letter
    return "G/M"


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
        self._started = False   # a block with words has been read (then % no longer opens)
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
        self.run((text,), line)

    def run(self, lines: Iterable[str], first: int = 1) -> int:
        """Interpret lines numbered from `first` until they run out or the program ends;
        returns the number of the last line read."""
        state, plans = self.state, self._plans
        n = first - 1
        for n, text in enumerate(lines, first):
            if self.done:
                return n - 1
            parts = split_parts(text)
            shape = MARK.join(parts[0::2])
            plan = plans[shape] if shape in plans else self._plan(shape)
            if MARK in text:   # the shapes' slot marker itself: such a line takes the full grammar
                plan = None
            try:
                if plan is None:
                    self._full(n, text)
                    continue
                fast = plan[2]
                if fast is not None and state.nurbs is None:
                    motion = fast[0] if fast[0] is not None else state.motion
                    if motion == 10 or motion == 0:
                        self._linear(motion, fast, parts, n)
                        continue
                self._template(plan, parts, n, text)
            except BlockError as err:
                self._fail(err, n, text)
        return n

    def _template(self, plan, parts: list[str], line: int, text: str) -> None:
        """A simple line (words with plain numbers) that is not a plain G0/G1 move."""
        tpl, spec, _ = plan
        if not tpl.letters:
            return
        self._started = True
        if tpl.delete and self.setup.block_delete:
            return
        if spec.__class__ is BlockError:
            raise spec
        vals = list(tpl.fixed)
        for i, s in zip(tpl.slots, parts[1::2]):
            vals[i] = float(s)
        self._execute(spec, vals, (), (), line, text)

    def _full(self, line: int, text: str) -> None:
        """A line that is not simple: expressions, parameters, comments, syntax errors."""
        block = expression_block(text)
        if block is None:
            try:
                block, _ = parse_line_columns(text)
            except LineSyntaxError as e:
                raise BlockError("E-SYNTAX", e.message, col=e.col) from None
        if block.percent:
            # % opens a program on its first line and then closes it; anywhere else it is wrong
            if self._percents == 0 and not self._started:
                self._percents = 1
            elif self._percents == 1:
                self.done = True
            else:
                raise BlockError("E-SYNTAX", "% may only open a program (first line) and close it", col=1)
            return
        if block.words or block.assigns:
            self._started = True
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
        self._started = True
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
                                     col=_col(parts, end_abs.first_part))
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
        if base.nurbs is not None and (idx.keys() - {"N"}) | g.keys() | m.keys():
            if g.get("motion", base.nurbs.kind) in (base.nurbs.kind, 53):
                nurbs = nurbs_blocks.continue_group(st, spec, vals)
                if nurbs is not None:
                    out.append(nurbs)
                return self._commit(st, out, notices, assigns, line, text)
            group = base.nurbs
            base.nurbs = None  # the group is dropped; this block then runs on its own
            self._fail(BlockError("E-NURBS-INCOMPLETE", f"{group.name} group begun here is incomplete: "
                                  f"line {line} starts another motion", col=1, line=group.line),
                       group.line, "")
            return self._execute(spec, vals, assigns, messages, line, text)
        execute_block(st, spec, vals, out, notices, line, self.setup, base.motion)
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


def _col(parts: list[str], p: int) -> int:
    """1-based column of the letter just before the slot number parts[p]."""
    return len("".join(parts[:p]))
