"""Execute blocks against the modal state: text lines in, entities out.

Per line: ipr.syntax gives the words (through the shape cache for simple lines),
ipr.block checks them against the modal groups (cached per signature), and the block
is executed on a staged view of the state, committed only if nothing failed. Plain
G0..G3 blocks run through a function made per line shape (ipr.plain), which hands
anything unusual back to the general path.

Control lines (O-words, M98, M99) are not executed here: the interpreter stops on them
(`control` says which, `done` is set) and ipr.program_counter decides where to go on.
"""
from __future__ import annotations

from ipr import cutter_comp, nurbs_blocks
from ipr.block import BlockSpec, analyse
from ipr.entities import Diagnostic, GCodeError, Message
from ipr.dialect import sender_command
from ipr.errors import BlockError
from ipr.execute import execute_block
from ipr.expressions import evaluate, param_key
from ipr.gcodes import SUBPROGRAM_RETURN
from ipr.knockon import KnockOn
from ipr.memo import ReadLine
from ipr.plain import step_for
from ipr.modal import ModalState, Setup, Staged
from ipr.oword import parse_oword
from ipr.parameters import substitute
from ipr.shapes import MARK, expression_block, split_parts, template_for
from ipr.syntax import Block, LineSyntaxError, parse_line_columns

MAX_VALUE = 1e31   # the fast path reads at most 30 digits; expressions may go further
_NEW = object()    # a shape without a plan yet
SCAN_LINES = 256   # a stretch this long is scanned for plain runs (ipr.plain_runs) first


def spec_letter(spec: BlockSpec, word: int) -> str:
    for letter, i in spec.index.items():
        if i == word:
            return letter
    return "G/M"



def _exponent_note(text: str, col: int) -> str:
    """What an error at an E right after a digit (`X1e5`, `R1E-15`) most likely means."""
    if 1 < col <= len(text) and text[col - 1] in "eE" and (text[col - 2].isdigit() or text[col - 2] == "."):
        return " (exponent notation is not G-code: the E starts a word of its own; write the number out)"
    return ""

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
        self._value_steps: dict = {}   # block signature -> ipr.plain step for evaluated words (or None)
        self._percents = 0
        self._started = False   # a block with words has been read (then % no longer opens)
        self.done = False
        self.knock_on = KnockOn()
        self.control = None      # (line, OWord or ("m98", label, count) / ("m99",)) stopped on

    # ---- errors -------------------------------------------------------------------
    def _fail(self, err: BlockError, line: int, text: str) -> None:
        if self.all_errors:
            if self.knock_on.follows(err.code):
                return
            self.knock_on.refused(self._words(text), line)
        col = err.col
        if col is None:
            col = 1
            if err.word is not None:
                try:
                    col = parse_line_columns(text)[1][err.word]
                except (LineSyntaxError, IndexError):
                    col = 1
        diag = Diagnostic(self.file, err.line or line, col, err.code, err.message + _exponent_note(text, col))
        self.diagnostics.append(diag)
        if not self.all_errors:
            raise GCodeError([diag])

    @staticmethod
    def _words(text: str):
        """The (letter, number) words of a refused line (expressions as None), None if it does not parse."""
        try:
            block, _ = parse_line_columns(text)
        except LineSyntaxError:
            return None
        return [(letter, v if v.__class__ is float else None) for letter, v in block.words]

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
            spec = analyse(tuple(zip(tpl.letters, tpl.fixed)), self.setup.dialect)
            step = None
            if spec.__class__ is BlockSpec and not tpl.delete:
                part = {w: 2 * j + 1 for j, w in enumerate(tpl.slots)}   # word -> index in parts
                step = step_for(spec, part)
            plan = (tpl, spec, step)
        self._plans[shape] = plan
        return plan

    def feed(self, line: int, text: str) -> None:
        """Interpret one line."""
        self.run((text,), line)

    def run(self, lines: list[str], first: int = 1, memo: dict | None = None) -> int:
        """Interpret lines numbered from `first` until they run out or the program ends;
        returns the number of the last line read. `memo` (line -> what reading it gave) keeps
        the lines of a program that may run them again (loops, subroutines: ipr.source)."""
        if self.done:
            return first - 1
        if memo is None and len(lines) >= SCAN_LINES:
            return self._run_scanned(lines, first)
        return self._run_lines(lines, first, memo)

    def _run_scanned(self, lines: list[str], first: int) -> int:
        """A long stretch read at once: its runs of plain G0..G3 lines by ipr.plain_runs, the other
        lines (and a plain line it hands back) one by one."""
        from ipr import plain_runs   # numba: loaded for long programs only

        scanned = plain_runs.Scanned(lines)
        if not scanned.usable:
            return self._run_lines(lines, first, None)
        plain, state, i, n = scanned.plain, self.state, 0, len(lines)
        while i < n:
            if plain[i] and state.nurbs is None and not state.detour and not self.knock_on.doubt:
                done = plain_runs.run(scanned, i, first + i, state, self.out)
                if done:
                    self._started = True
                    i += done
                    continue
            j = i + 1
            while j < n and not plain[j]:
                j += 1
            last = self._run_lines(lines[i:j], first + i, None)
            if self.done:
                return last
            i = j
        return first + n - 1

    def _run_lines(self, lines: list[str], first: int, memo: dict | None) -> int:
        state, get, append, doubt = self.state, self._plans.get, self.out.append, self.knock_on.doubt
        started = self._started
        n, entry = first - 1, None
        for n, text in enumerate(lines, first):
            if memo is not None and n in memo:
                entry = memo[n]
                plan, parts = entry.plan, entry.parts
            else:
                parts = split_parts(text)
                shape = MARK.join(parts[0::2])
                plan = get(shape, _NEW)
                if plan is _NEW:
                    plan = self._plan(shape)
                if MARK in text:   # the shapes' slot marker itself: the full grammar
                    plan = None
                if memo is not None:
                    entry = memo[n] = ReadLine(plan, parts)
            try:
                if plan is None:
                    self._full(n, text, entry)
                elif plan[2] is not None and plan[2](parts, n, state, append):
                    if not started:
                        self._started = started = True
                    if doubt:
                        self.knock_on.settled(plan[1])
                    continue   # a plain move never ends the program
                else:
                    self._template(plan, parts, n, text)
            except BlockError as err:
                self._fail(err, n, text)
            started = self._started
            if self.done:
                return n
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

    def _full(self, line: int, text: str, entry: ReadLine | None = None) -> None:
        """A line that is not simple: expressions, parameters, comments, syntax errors. A line
        read before (`entry`) is not parsed again, and from its second run on its expressions
        are compiled (ipr.expressions.compile_expression)."""
        if entry is not None and entry.block is not None:
            block = entry.block
            if entry.words is None:
                entry.compile(self.setup.dialect)
        else:
            block = self._read(line, text)
            if block is None:
                return
            if entry is not None:
                entry.block = block
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
        params.line = line
        words, assigned = (None, None) if entry is None else (entry.words, entry.assigns)
        if not block.words and not block.messages and self.state.nurbs is None:
            # parameter assignments alone (loop counters): no codes to check, no state but the table
            params.update(self._assignments(block, assigned))
            return
        vals = self._values(block, words)
        for i, ((letter, _), v) in enumerate(zip(block.words, vals)):
            if letter in "GM" and not -MAX_VALUE < v < MAX_VALUE:   # before the codes are looked up
                raise BlockError("E-VALUE", f"{letter} value {v:g} is out of range", i)
        assigns = self._assignments(block, assigned)
        messages = block.messages
        if any(m.__class__ is not str for m in messages):
            messages = tuple(m if m.__class__ is str else substitute(m[1], params) for m in messages)
        if entry is not None and entry.spec is not None:
            sig, spec = entry.spec
        else:
            sig = tuple((letter, v if letter in "GM" else None) for (letter, _), v in zip(block.words, vals))
            spec = analyse(sig, self.setup.dialect)
        if spec.__class__ is BlockError:
            raise spec
        if not assigns and not messages and not block.delete and self._short(sig, spec, vals, line):
            return
        self._execute(spec, vals, assigns, messages, line, text)

    def _read(self, line: int, text: str) -> Block | None:
        """The Block of a line, or None for a control line (an O-word: `control` is set)."""
        if sender_command(text):
            raise BlockError("E-DIALECT", "a grbl system command ($H, $X, $$, $J=...) is for the sender, not "
                             "G-code: vcnc runs the G-code and has no grbl settings", col=text.index("$") + 1)
        block = expression_block(text)
        if block is not None:
            return block
        try:
            return parse_line_columns(text)[0]
        except LineSyntaxError as e:
            oword = parse_oword(text)
            if oword is None:
                raise BlockError(e.code, e.message, col=e.col) from None
            self._started = True
            self.control = (line, oword)
            self.done = True
            return None

    def _values(self, block: Block, compiled) -> list[float]:
        """The words' values: constants as they are, expressions evaluated (by their compiled form)."""
        params, vals = self.state.params, []
        for i, (_, v) in enumerate(block.words):
            if v.__class__ is float:
                vals.append(v)
                continue
            try:
                vals.append(evaluate(v, params) if compiled is None else compiled[i](params))
            except BlockError as err:
                err.word = i
                raise
        return vals

    def _assignments(self, block: Block, compiled) -> list:
        """(key, value) of each #...= of the line, checked writable; applied after the line."""
        params = self.state.params
        out = [(param_key(k, params), evaluate(v, params) if compiled is None else compiled[j](params))
               for j, (k, v) in enumerate(block.assigns)]
        for key, _ in out:
            params.check_writable(key)
        return out

    def _short(self, sig: tuple, spec, vals: list, line: int) -> bool:
        """A plain G0..G3 block whose numbers came from expressions, through ipr.plain's step
        (values in range only: the general path reports the others)."""
        step = self._value_steps.get(sig, _NEW)
        if step is _NEW:
            step = self._value_steps[sig] = step_for(spec, {i: i for i in range(len(vals))})
        if step is None or not all(-MAX_VALUE < v < MAX_VALUE for v in vals):
            return False
        if not step(vals, line, self.state, self.out.append):
            return False
        if self.knock_on.doubt:
            self.knock_on.settled(spec)
        return True

    def finish(self, last_line: int) -> None:
        """End of input: an open NURBS group is an error; the knock-on errors left out are noted."""
        if self.state.comp is not None:
            cutter_comp.flush_all(self.state, self.out)
        for root, message in self.knock_on.summary():
            self.warnings.append(Diagnostic(self.file, root, 1, "N-KNOCK-ON", message, "notice"))
        group = self.state.nurbs
        if group is not None:
            self.state.nurbs = None
            self._fail(BlockError("E-NURBS-INCOMPLETE", f"{group.name} group begun here is incomplete at "
                                  f"the end of the program (line {last_line})", col=1, line=group.line),
                       group.line, "")

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
        control = _subprogram(spec, vals) if "subprogram" in m else None
        execute_block(st, spec, vals, out, notices, line, self.setup, base.motion)
        if self.knock_on.doubt:
            self.knock_on.settled(spec)
        self._commit(st, out, notices, assigns, line, text)
        if control is not None and not self.done:
            self.control = (line, control)
            self.done = True

    def _commit(self, st: Staged, out, notices, assigns, line: int, text: str) -> None:
        st.commit()
        if assigns:
            self.state.params.update(assigns)
        self.out.extend(out)
        for code, message, word in notices:
            self._notice(code, message, line, text, word, "warning" if code.startswith("W") else "notice")
        if self.state.ended:
            self.done = True


def _subprogram(spec: BlockSpec, vals: list) -> tuple:
    """M98 P<n> [L<count>] -> ("m98", "n", count); M99 -> ("m99",)."""
    if spec.m["subprogram"] == SUBPROGRAM_RETURN:
        return ("m99",)
    idx = spec.index
    number, count = vals[idx["P"]], vals[idx["L"]] if "L" in idx else 1.0
    for letter, v in (("P", number), ("L", count)):
        if v != round(v) or v < 0:
            raise BlockError("E-VALUE", f"M98 {letter}{v:g} must be a whole number >= 0", idx[letter])
    return ("m98", str(int(number)), int(count))
