"""A program made ready for one grbl machine: interpreted from the machine's real
state, turned into stream lines, and checked against the build before a byte goes out.

`build_job` interprets the program from where grbl stands (machine.grbl.state),
writes the lines in grbl's work frame (G53 moves in machine coordinates), and lists
what the user must know before anything moves: moves that depend on an axis the
program never set, and lines the build cannot take (`$I` options: M7 needs mist
coolant `M`; S is ignored without variable spindle `V`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from machine.grbl.program import GRBL_RESET_MODAL, StreamLine, stream_groups
from machine.grbl.state import COORD_CODES, MachineState, program_setup, unset_axes
from machine.grbl.words import Format

G53_WORD = 53.0


@dataclass
class Job:
    lines: list[StreamLine]
    notices: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # say so before moving
    entities: list = field(default_factory=list)
    groups: list = field(default_factory=list)  # (entity, its lines) in stream order: stream_groups


def machine_at_zero() -> MachineState:
    """grbl right after a reset at machine zero, all offsets zero (for --dry-run without a port)."""
    zero = (0.0, 0.0, 0.0)
    return MachineState(zero, zero, "G54", {c: zero for c in COORD_CODES}, zero, 0.0, False, False, "XY", 0,
                        GRBL_RESET_MODAL)


def g53_lines(text_lines: list[str], file: str | None = None) -> frozenset[tuple[str | None, int]]:
    """(file, line) of the source lines whose block has G53 (read with the interpreter's
    own line parser); file is None for the program itself, as in the entities."""
    from ipr import parse_line

    out = set()
    for i, text in enumerate(text_lines, 1):
        if "53" not in text:
            continue
        try:
            words = parse_line(text).words
        except Exception:  # the interpreter has already accepted the program; a line it skips has no G53 move
            continue
        if any(letter == "G" and value == G53_WORD for letter, value in words):
            out.add((file, i))
    return frozenset(out)


def _g53_in(src: list[str], entities) -> frozenset:
    """G53 lines of the program and of the subroutine files its entities came from."""
    keys = set(g53_lines(src))
    for f in {e.file for e in entities if getattr(e, "file", None)}:
        keys |= g53_lines(Path(f).read_bytes().decode("utf-8", "replace").split("\n"), f)
    return frozenset(keys)


def build_job(path, config, state: MachineState, *, numbered: bool = False, frame_mm=None) -> Job:
    """The stream of the program at `path` for a machine in `state`, written in the work
    frame `frame_mm` (default: the state's WCO); raises ipr's GCodeError or
    StreamProgramError before anything is sent."""
    from ipr import iter_entities, parse_text
    from ipr.entities import Nurbs

    text = Path(path).read_bytes().decode("utf-8", "replace")
    setup = program_setup(state, config)
    program = parse_text(text, str(path), setup=setup)
    src = text.removeprefix("\ufeff").split("\n")
    job = Job([], entities=program.entities)
    has_nurbs = any(isinstance(e, Nurbs) for e in program.entities)
    job.groups = list(stream_groups(program.entities, config, start_mm=state.mpos_mm,
                                    fmt_=Format(tuple(frame_mm or state.wco_mm), config.blu_mm / 10.0, numbered),
                                    modal=state.modal, g53_lines=_g53_in(src, program.entities),
                                    notices=job.notices, ipo_from_start=has_nurbs))
    job.lines = [line for _, lines in job.groups for line in lines]
    unset = unset_axes(lambda s: iter_entities(iter(src), str(path), setup=s), setup)
    if unset:
        first, axes = unset[0]
        w = [p - o for p, o in zip(state.mpos_mm, state.wco_mm)]
        where = " ".join(f"{a}{w['XYZ'.index(a)]:.3f}" for a in axes)
        lines = ", ".join(str(n) for n, _ in unset[:6]) + (", ..." if len(unset) > 6 else "")
        job.warnings.append(f"program line {first} moves before the program sets {', '.join(axes)}: "
                            f"{'they stay' if len(axes) > 1 else 'it stays'} where the machine stands "
                            f"({where} work); moves that depend on it: program lines {lines}")
    return job


def option_problems(lines: list[StreamLine], options: str) -> tuple[list[str], list[str]]:
    """(errors, warnings) of the stream against grbl's `$I` build options."""
    errors, warnings = [], []
    if "M" not in options:
        bad = next((l for l in lines if "M7" in l.text), None)
        if bad is not None:
            errors.append(f"program line {bad.source_line} turns on mist coolant (M7), but this grbl build has "
                          f"no mist coolant ($I options {options or 'none'} lack M): grbl would answer error:20 "
                          f"mid-stream; nothing was sent")
    if "V" not in options and any("S" in l.text and l.text.lstrip("N0123456789").startswith(("M3", "M4"))
                                  for l in lines):
        warnings.append("this grbl build has no variable spindle ($I options lack V): S words are ignored, "
                        "the spindle runs at its one speed")
    return errors, warnings
