"""Plain G0/G1/G2/G3 blocks through one function per line shape.

A plain block has only a G0..G3 code (or none), axis words, F, N and, for arcs, I/J/K or
R; nearly all lines of CAM output are plain. For such a shape, `compile_step` and
`compile_arc_step` make a function doing what ipr.execute.execute_block does with it —
F to mm/s, the end point from the axis words in the active distance mode, the Line,
Rapid or Arc (ipr.arcs.make_arc, the same geometry and checks), the new position, feed
and motion mode — with the numbers read straight from the line's parts
(ipr.shapes.split_parts). Where the block needs more (another motion mode, a negative or
zero feed, G90.1, an arc format the plane does not allow, a NURBS group open) the
function returns False having changed nothing (also while `detour` is set: cutter
compensation, G93/G95, a rotated coordinate system), and the interpreter runs the block on the
general path, which also reports the errors. tests/test_ipr_paths.py compares the two.
"""
from __future__ import annotations

from collections.abc import Callable

from ipr.arcs import make_arc
from ipr.entities import PLANE_AXES, Line, Rapid
from ipr.gcodes import MOTION_ARC_CCW, MOTION_ARC_CW, MOTION_LINEAR, MOTION_RAPID

_TEMPLATE = """\
def step(p, n, s, append):
    if s.nurbs is not None or s.detour:
        return False
{motion}    u = s.unit
{feed}{move}{commit}    return True
"""
_MODAL_MOTION = f"""\
    m = s.motion
    if m != {MOTION_LINEAR} and m != {MOTION_RAPID}:
        return False
"""
# F read from the line (F is in the units active before the block's G20/G21: none here)
_LINE_FEED = """\
    f = float(p[{f_part}]) * u / 60.0
    if f < 0.0:
        return False
"""
_ZERO_FEED = f"""\
    if m == {MOTION_LINEAR} and f == 0.0:
        return False
"""
_MOVE = """\
    pos = s.pos
    if s.absolute:
        o = s.offset
        end = ({absolute},)
    else:
        end = ({incremental},)
{append}    s.pos = end
"""
_APPEND = {MOTION_RAPID: "    append(Rapid(n, pos, end, s.path))\n",
           MOTION_LINEAR: "    append(Line(n, pos, end, f, s.path))\n",
           None: f"    if m == {MOTION_LINEAR}:\n        append(Line(n, pos, end, f, s.path))\n"
                 "    else:\n        append(Rapid(n, pos, end, s.path))\n"}


def _end_sources(axis_parts: dict[int, int]) -> tuple[str, str]:
    """Source of the end point from `pos`, parts `p`, unit `u`, offset `o`: G90 and G91."""
    absolute, incremental = [], []
    for k in range(3):
        if k in axis_parts:
            absolute.append(f"float(p[{axis_parts[k]}]) * u + o[{k}]")
            incremental.append(f"pos[{k}] + float(p[{axis_parts[k]}]) * u")
        else:
            absolute.append(f"pos[{k}]")
            incremental.append(f"pos[{k}]")
    return ", ".join(absolute), ", ".join(incremental)


def compile_step(motion: int | None, f_part: int | None,
                 axis_parts: dict[int, int]) -> Callable[[list, int, object, Callable], bool]:
    """The step function of a plain G0/G1 shape: `motion` is its code (None: modal),
    `f_part` the index of F's number in the parts, `axis_parts` axis 0..2 -> index.
    step(parts, line, state, append) -> handled. It writes the state only once every check
    has passed, and only what the shape changes (the modal feed is never negative)."""
    absolute, incremental = _end_sources(axis_parts)
    feed = _LINE_FEED.format(f_part=f_part) if f_part is not None else "    f = s.feed_mm_s\n"
    if axis_parts and motion != MOTION_RAPID:
        feed += _ZERO_FEED
    move = _MOVE.format(absolute=absolute, incremental=incremental, append=_APPEND[motion]) if axis_parts else ""
    commit = ("    s.feed_mm_s = f\n" if f_part is not None else "") + ("    s.motion = m\n" if motion is not None else "")
    source = _TEMPLATE.format(motion=_MODAL_MOTION if motion is None else f"    m = {motion}\n",
                              feed=feed, move=move, commit=commit)
    namespace = {"Line": Line, "Rapid": Rapid, "float": float}
    exec(source, namespace)
    return namespace["step"]


def compile_arc_step(motion: int | None, f_part: int | None, axis_parts: dict[int, int],
                     offset_parts: dict[int, int], r_part: int | None, word: int):
    """The step function of a plain G2/G3 shape. `offset_parts` maps the axis of each of
    I/J/K present to its index in the parts, `r_part` is R's; `word` is the word index the
    general path gives arc errors (R, or the first of I/J/K present)."""
    absolute, incremental = _end_sources(axis_parts)
    namespace = {"float": float}
    exec(f"def ends(p, pos, u, o):\n    return ({absolute},), ({incremental},)\n", namespace)
    ends = namespace["ends"]
    given_axes = set(axis_parts)

    def step(p, n, s, append):
        if s.nurbs is not None or s.arc_absolute or s.detour:
            return False
        m = s.motion if motion is None else motion
        if m != MOTION_ARC_CW and m != MOTION_ARC_CCW:
            return False
        u = s.unit
        f = float(p[f_part]) * u / 60.0 if f_part is not None else s.feed_mm_s
        if f <= 0.0:
            return False
        a, b, normal = PLANE_AXES[s.plane]
        if r_part is None:
            if normal in offset_parts or (a not in offset_parts and b not in offset_parts):
                return False
        elif a not in given_axes and b not in given_axes:
            return False
        pos = s.pos
        end = ends(p, pos, u, s.offset)[0 if s.absolute else 1]
        if r_part is None:
            center = (pos[a] + (float(p[offset_parts[a]]) * u if a in offset_parts else 0.0),
                      pos[b] + (float(p[offset_parts[b]]) * u if b in offset_parts else 0.0))
            arc = make_arc(n, pos, end, s.plane, m == MOTION_ARC_CCW, f, s.path, center_ab=center, word=word, unit_mm=u)
        else:
            arc = make_arc(n, pos, end, s.plane, m == MOTION_ARC_CCW, f, s.path, radius_mm=float(p[r_part]) * u,
                           word=word, unit_mm=u)
        append(arc)
        s.pos = end
        s.feed_mm_s = f
        s.motion = m
        return True

    return step


def step_for(spec, part: dict[int, int]):
    """The step function of an ipr.block.BlockSpec if it is a plain G0..G3 block, reading word i's
    value from parts[part[i]]; None for any other spec."""
    axis_parts = {k: part[i] for k, i in spec.axis_idx}
    if spec.linear:
        return compile_step(spec.motion, part.get(spec.f_index), axis_parts)
    if not spec.plain_arc:
        return None
    idx = spec.index
    offsets = {k: part[idx[letter]] for k, letter in enumerate("IJK") if letter in idx}
    word = idx["R"] if "R" in idx else idx[next(c for c in "IJK" if c in idx)]
    return compile_arc_step(spec.motion, part.get(spec.f_index), axis_parts, offsets, part.get(idx.get("R")), word)
