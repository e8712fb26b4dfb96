"""Plain G0/G1 blocks through one generated function per line shape.

A plain block has only G0 or G1 (or no G-code), axis words, F and N (BlockSpec.linear);
most lines of CAM output are plain. For such a shape, `compile_step` writes a Python
function doing what ipr.execute.execute_block does with it — F to mm/s, the end point
from the axis words in the active distance mode, the Line or Rapid, the new position,
feed and motion mode — with the numbers read straight from the line's parts
(ipr.shapes.split_parts). Where the block needs more (no G0/G1 mode active, a negative
or zero feed, a NURBS group open) the function returns False having changed nothing, and
the interpreter runs the block on the general path, which also reports the errors.
"""
from __future__ import annotations

from collections.abc import Callable

from ipr.entities import Line, Rapid

_TEMPLATE = """\
def step(p, n, s, append):
    if s.nurbs is not None:
        return False
    m = {motion}
    if m != 10 and m != 0:
        return False
    u = s.unit
    f = {feed}
    if f < 0.0 or m == 10 and f == 0.0 and {has_axes}:
        return False
{move}    s.feed_mm_s = f
    s.motion = m
    return True
"""
_MOVE = """\
    pos = s.pos
    if s.absolute:
        o = s.offset
        end = ({absolute},)
    else:
        end = ({incremental},)
    if m == 10:
        append(Line(n, pos, end, f, s.path))
    else:
        append(Rapid(n, pos, end, s.path))
    s.pos = end
"""


def compile_step(motion: int | None, f_part: int | None,
                 axis_parts: dict[int, int]) -> Callable[[list, int, object, Callable], bool]:
    """The step function of a plain shape: `motion` is its G0/G1 code (None: modal),
    `f_part` the index of F's number in the parts, `axis_parts` axis 0..2 -> index.
    step(parts, line, state, append) -> handled."""
    absolute, incremental = [], []
    for k in range(3):
        if k in axis_parts:
            absolute.append(f"float(p[{axis_parts[k]}]) * u + o[{k}]")
            incremental.append(f"pos[{k}] + float(p[{axis_parts[k]}]) * u")
        else:
            absolute.append(f"pos[{k}]")
            incremental.append(f"pos[{k}]")
    move = _MOVE.format(absolute=", ".join(absolute), incremental=", ".join(incremental))
    source = _TEMPLATE.format(
        motion="s.motion" if motion is None else motion,
        feed="s.feed_mm_s" if f_part is None else f"float(p[{f_part}]) * u / 60.0",
        has_axes=bool(axis_parts), move=move if axis_parts else "")
    namespace = {"Line": Line, "Rapid": Rapid, "float": float}
    exec(source, namespace)
    return namespace["step"]
