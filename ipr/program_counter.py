"""The execution model: a program counter over the program's lines, a call stack and loop state.

The interpreter (ipr.interpreter) runs straight stretches of lines, as fast as ever; when it
meets a control line (an O-word, M98, M99) it stops there and hands the line to the
`Executor`, which decides where execution goes on: the next line, a branch, the top of a
loop, a subroutine (in this file or in a subroutine file), back to the caller. Nothing is
unrolled: a loop of ten million iterations holds one loop record, and entities are produced
(and may be consumed, ipr.iter_entities) as execution goes.

Semantics are LinuxCNC's "O Codes" chapter: labels are matched by name (`o100`, `o<name>`),
`call` binds up to 30 arguments to #1..#30 in a new local scope (ipr.parameters), `endsub` and
`return` may give a value (#<_value>), subroutines may be defined later in the file or in
`<name>.ngc` files searched in the program's folder and the machine file's `subroutine_path`;
Fanuc `M98 P<n> L<count>` runs the lines after `O<n>` up to `M99` `count` times.

Limits (ipr.modal.Setup): loop iterations over the whole run (E-LOOP-LIMIT) and the depth of
nested calls (E-CALL-DEPTH), so a runaway program is an error at its line, never a hang.
"""
from __future__ import annotations

from pathlib import Path

from ipr.entities import set_file
from ipr.errors import BlockError
from ipr.expressions import compile_expression
from ipr.oword import OWord
from ipr.source import Source, read_text

STRETCH_LINES = 4096   # lines handed to the interpreter at a time (iter_entities yields in between)
_BRANCHES = ("elseif", "else", "endif")


class Loop:
    __slots__ = ("kind", "start", "remaining")

    def __init__(self, kind: str, start: int, remaining: int = 0):
        self.kind = kind            # "while" | "do" | "repeat"
        self.start = start          # the line of its opening O-word
        self.remaining = remaining  # repeat: iterations still to run


class Frame:
    """One level of the call stack: where to return, what to restore, its own loops."""

    __slots__ = ("kind", "label", "source", "start", "return_source", "return_pc", "saved", "repeats",
                 "loops", "call_line")

    def __init__(self, kind, label, source, start, return_source, return_pc, saved, repeats, call_line):
        self.kind = kind              # "main" | "sub" (O-word call) | "m98" (Fanuc subprogram)
        self.label = label
        self.source = source
        self.start = start            # first line of the body
        self.return_source = return_source
        self.return_pc = return_pc
        self.saved = saved            # the caller's local parameters (sub) or None
        self.repeats = repeats        # m98: runs still to go, this one included
        self.loops: dict[str, Loop] = {}
        self.call_line = call_line


class Executor:
    """Drives an ipr.interpreter.Interpreter over a Source with a program counter."""

    def __init__(self, interp, source: Source, texts: dict[Path, str] | None = None):
        self.interp = interp
        self.setup = interp.setup
        self.params = interp.state.params
        self.main = source
        source.keep = source.keep or self.setup.m99_repeat   # M99 goes back to line 1
        self.src = source
        self.pc = 1
        self.frames = [Frame("main", "", source, 1, None, 0, None, 1, 0)]
        self.iterations = 0
        self.last_line = 0
        self.finished = False
        self._files: dict[Path, Source] = {}
        self._texts = {} if texts is None else texts   # subroutine file -> text, possibly shared
        folder = None if source.file.startswith("<") else Path(source.file).resolve().parent
        self.search_dirs = [d for d in [folder, *map(Path, self.setup.subroutine_path)] if d is not None]

    # ---- running --------------------------------------------------------------------
    def run(self) -> None:
        while self.step():
            pass

    def step(self) -> bool:
        """Run one stretch of lines or one control line; False when the program is over."""
        if self.finished:
            return False
        interp, src, pc = self.interp, self.src, self.pc
        interp.file = src.file   # diagnostics name the file the line is in
        errors = len(interp.diagnostics)
        try:
            ow = src.owords[pc] if pc in src.owords else _UNKNOWN
            if ow is _UNKNOWN or ow is None:
                self._stretch(src, pc)
            else:
                self._oword(pc, ow)
        except BlockError as err:
            self._stop()
            interp._fail(err, err.line or self.pc, src.text(self.pc) or "")
        if len(interp.diagnostics) > errors and (len(self.frames) > 1 or self.frames[0].loops):
            self._stop()   # inside a loop or call, later lines would repeat or depend on the error
        self.src.trim(self.pc)
        return not self.finished

    def _stop(self) -> None:
        self.finished = True
        self.interp.done = True

    def _stretch(self, src: Source, pc: int) -> None:
        """Lines from pc through the interpreter, up to a control line or the end."""
        interp = self.interp
        end = src.stretch_end.get(pc)
        lines = src.chunk(pc, STRETCH_LINES) if end is None else src.lines[pc - src.base:end - src.base]
        if not lines:
            return self._end_of_file()
        interp.file = src.file
        mark = len(interp.out)
        last = interp.run(lines, pc, src.memo if src.keep else None)
        if src is not self.main:
            for e in interp.out[mark:]:
                set_file(e, src.file)
        self.last_line = last
        control = interp.control
        if control is None:
            if interp.done:
                self.finished = True
            self.pc = last + 1
            return
        interp.control = None
        interp.done = False
        n, what = control
        if n > pc:
            src.stretch_end[pc] = n
        self.pc = n
        if isinstance(what, OWord):
            src.owords[n] = what
            src.keep = True
            self._oword(n, what)
        else:
            self._subprogram(n, what)

    def _end_of_file(self) -> None:
        frame = self.frames[-1]
        if frame.kind != "main":
            raise BlockError("E-OWORD", f"the file ends inside subroutine {frame.label} (no endsub / M99); "
                             f"called at line {frame.call_line}", col=1, line=self.last_line or 1)
        for label, loop in frame.loops.items():
            raise BlockError("E-OWORD", f"o{label} {loop.kind} is never closed", col=1, line=loop.start)
        self.finished = True

    # ---- O-words --------------------------------------------------------------------
    def _value(self, ow: OWord, i: int, n: int) -> float:
        self.params.line = n
        compiled = self.src.compiled
        key = (n, i)
        if key not in compiled:   # control lines repeat (loop tests): compiled at their first run
            compiled[key] = compile_expression(ow.args[i])
        try:
            return compiled[key](self.params)
        except BlockError as err:
            err.col = err.col or ow.arg_cols[i]
            raise

    def _jump(self, n: int, label: str, keywords: tuple[str, ...], what: str) -> int:
        target = self.src.find(n, label, keywords)
        if target is None:
            raise BlockError("E-OWORD", f"o{label} {what}: no matching o{label} {' / '.join(keywords)}", col=1)
        return target

    def _count(self, n: int, iterations: int = 1) -> None:
        self.iterations += iterations
        if self.iterations > self.setup.max_loop_iterations:
            raise BlockError("E-LOOP-LIMIT", f"more than {self.setup.max_loop_iterations:,} loop iterations "
                             "(machine file key max_loop_iterations)", col=1, line=n)

    def _oword(self, n: int, ow: OWord) -> None:
        kind, label, frame = ow.keyword, ow.label, self.frames[-1]
        loops = frame.loops
        if kind == "sub":   # a definition met in the flow: remember it, go on after its endsub
            self.src.subs.setdefault(label, n)
            self.pc = self._jump(n, label, ("endsub",), "sub") + 1
        elif kind in ("endsub", "return"):
            if frame.kind != "sub":
                raise BlockError("E-OWORD", f"o{label} {kind} outside a called subroutine", col=1)
            value = self._value(ow, 0, n) if ow.args else None
            self._return(value)
        elif kind == "call":
            self._call(label, [self._value(ow, i, n) for i in range(len(ow.args))], n)
        elif kind == "if":
            self._branch(n, ow)
        elif kind in ("elseif", "else"):   # reached from a branch that ran: leave the if
            self.pc = self._jump(n, label, ("endif",), kind) + 1
        elif kind == "endif":
            self.pc = n + 1
        elif kind == "while":
            loop = loops.get(label)
            if loop is not None and loop.kind == "do":   # the end of a do ... while
                if self._value(ow, 0, n):
                    self._count(n)
                    self.pc = loop.start + 1
                else:
                    del loops[label]
                    self.pc = n + 1
            elif self._value(ow, 0, n):
                if loop is None:
                    loops[label] = Loop("while", n)
                self.pc = n + 1
            else:
                loops.pop(label, None)
                self.pc = self._jump(n, label, ("endwhile",), "while") + 1
        elif kind == "do":
            loops[label] = Loop("do", n)
            self.pc = n + 1
        elif kind == "repeat":
            count = round(self._value(ow, 0, n))
            if count > 0:
                self._count(n, count)   # counted ahead: a count past the limit fails at once
                loops[label] = Loop("repeat", n, count)
                self.pc = n + 1
            else:
                self.pc = self._jump(n, label, ("endrepeat",), "repeat") + 1
        elif kind in ("endwhile", "endrepeat"):
            loop = loops.get(label)
            if loop is None or loop.kind != kind[3:]:
                raise BlockError("E-OWORD", f"o{label} {kind} without o{label} {kind[3:]}", col=1)
            if kind == "endwhile":
                self._count(n)
                self.pc = loop.start
            else:
                loop.remaining -= 1
                if loop.remaining > 0:
                    self.pc = loop.start + 1
                else:
                    del loops[label]
                    self.pc = n + 1
        elif kind in ("break", "continue"):
            self._break_continue(n, ow, loops)

    def _branch(self, n: int, ow: OWord) -> None:
        """An if (and the elseifs after it while their conditions are false)."""
        line, cond = n, self._value(ow, 0, n)
        while not cond:
            line = self._jump(line, ow.label, _BRANCHES, "if")
            branch = self.src.oword(line)
            if branch.keyword != "elseif":
                break
            cond = self._value(branch, 0, line)
        self.pc = line + 1

    def _break_continue(self, n: int, ow: OWord, loops: dict) -> None:
        label = ow.label
        loop = loops.get(label)
        if loop is None:
            raise BlockError("E-OWORD", f"o{label} {ow.keyword} outside an o{label} loop", col=1)
        end_kw = {"while": "endwhile", "repeat": "endrepeat", "do": "while"}[loop.kind]
        end = self._jump(loop.start, label, (end_kw,), loop.kind)
        if ow.keyword == "break":
            del loops[label]
            self.pc = end + 1
        elif loop.kind == "while":
            self._count(n)
            self.pc = loop.start
        else:
            self.pc = end   # endrepeat counts down, the do's while tests its condition

    # ---- calls --------------------------------------------------------------------------
    def _call(self, label: str, args: list[float], n: int) -> None:
        if len(self.frames) > self.setup.max_call_depth:
            raise BlockError("E-CALL-DEPTH", f"call of o<{label}> nested {len(self.frames)} deep (at most "
                             f"{self.setup.max_call_depth})", col=1)
        src, line = self._definition(label, fanuc=False)
        saved = self.params.enter_call(args)
        self.frames.append(Frame("sub", label, src, line + 1, self.src, n + 1, saved, 1, n))
        self.src, self.pc = src, line + 1

    def _return(self, value: float | None) -> None:
        frame = self.frames.pop()
        self.params.leave_call(frame.saved)
        self.params["_value_returned"] = 0.0 if value is None else 1.0
        if value is not None:
            self.params["_value"] = value
        self.src, self.pc = frame.return_source, frame.return_pc

    def _subprogram(self, n: int, what: tuple) -> None:
        """M98 P<n> L<count> / M99 (the interpreter has executed the rest of the block)."""
        frame = self.frames[-1]
        if what[0] == "m98":
            _, number, count = what
            if len(self.frames) > self.setup.max_call_depth:
                raise BlockError("E-CALL-DEPTH", f"M98 P{number} nested {len(self.frames)} deep", col=1)
            if count < 1:
                self.pc = n + 1
                return
            src, line = self._definition(number, fanuc=True)
            self._count(n, count - 1)   # the runs after the first, counted ahead
            self.frames.append(Frame("m98", number, src, line + 1, self.src, n + 1, None, count, n))
            self.src, self.pc = src, line + 1
        elif frame.kind == "m98":
            frame.repeats -= 1
            if frame.repeats > 0:
                self.pc = frame.start
            else:
                self.frames.pop()
                self.src, self.pc = frame.return_source, frame.return_pc
        elif frame.kind == "main" and self.setup.m99_repeat:
            self._count(n)
            self.pc = 1
        else:
            raise BlockError("E-OWORD", "M99 outside an M98 subprogram (the main program repeats endlessly "
                             "only with the machine file's m99_repeat = true)", col=1)

    def _definition(self, label: str, fanuc: bool) -> tuple[Source, int]:
        """Where a subroutine starts: this file, the main file, then `<label>.ngc` on the search path."""
        for src in dict.fromkeys((self.src, self.main)):
            line = src.find_definition(label, fanuc)
            if line is not None:
                return src, line
        name = f"{label}.ngc" if not fanuc else f"O{label}.ngc"
        for folder in self.search_dirs:
            path = folder / name
            if path.is_file():
                src = self._file(path)
                line = src.find_definition(label, fanuc)
                if line is not None:
                    return src, line
        where = ", ".join(str(d) for d in self.search_dirs) or "no folder (a program read from a string)"
        what = f"O{label} (M98 P{label})" if fanuc else f"o<{label}> sub"
        raise BlockError("E-SUB-NOT-FOUND", f"{what} is neither in the program nor in {name} in {where}", col=1)

    def _file(self, path: Path) -> Source:
        if path not in self._files:
            if path not in self._texts:
                self._texts[path] = read_text(path)
            self._files[path] = Source(str(path), self._texts[path].split("\n"))
        return self._files[path]


_UNKNOWN = object()
