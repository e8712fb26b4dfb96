"""Differential test: vcnc's interpreter against LinuxCNC's `rs274 -g` on the same programs.

Every STRAIGHT_TRAVERSE / STRAIGHT_FEED / ARC_FEED rs274 prints must match vcnc's
Rapid / Line / Arc (end point, arc centre, plane, direction, turns, feed, G61/G64 P Q) to rs274's
printed precision (4 decimals, in the program's units). rs274's output is read and
converted to machine mm by tests/rs274.py.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from conftest import corpus_files
from rs274 import CanonMove, INCH_MM, canon_moves, require_rs274, run_rs274

import ipr
from ipr.entities import PLANE_AXES, Arc, GCodeError, Line, Rapid

_KIND = {Rapid: "rapid", Line: "line", Arc: "arc"}
_FLOAT_SLACK = 1e-9  # mm: float noise on top of the printed-precision tolerance


def _describe(move: CanonMove, entity) -> str:
    return f"vcnc {entity!r}\n  rs274 {move!r}"


def mismatches(moves: list[CanonMove], entities: list) -> list[str]:
    """Every disagreement between rs274's moves and vcnc's motion entities (empty when they agree)."""
    motions = [e for e in entities if type(e) in _KIND]
    problems = []
    if len(motions) != len(moves):
        problems.append(f"rs274 made {len(moves)} moves, vcnc {len(motions)} Rapid/Line/Arc entities")
    for i, (move, ent) in enumerate(zip(moves, motions)):
        if _KIND[type(ent)] != move.kind:
            problems.append(f"move {i}: kind {_KIND[type(ent)]} != {move.kind}: {_describe(move, ent)}")
            continue
        tol = move.tol_mm + _FLOAT_SLACK
        if any(abs(ent.end[k] - move.end_mm[k]) > tol for k in range(3)):
            problems.append(f"move {i}: end differs: {_describe(move, ent)}")
        if move.feed_mm_s is not None:
            feed_tol = move.tol_mm / 60.0 + 1e-9 * move.feed_mm_s
            if abs(ent.feed_mm_s - move.feed_mm_s) > feed_tol:
                problems.append(f"move {i}: feed {ent.feed_mm_s} mm/s != {move.feed_mm_s}: {_describe(move, ent)}")
        pc = ent.path
        blend_off = abs((pc.blend_tol_mm or 0.0) - move.blend_tol_mm) > tol / 100  # P prints 6 decimals
        merge_off = pc.merge_tol_mm is not None and abs(pc.merge_tol_mm - move.merge_tol_mm) > tol
        if pc.exact_stop != move.exact_stop or blend_off or merge_off:
            problems.append(f"move {i}: path control {pc} differs: {_describe(move, ent)}")
        if move.kind == "arc":
            a, b, _ = PLANE_AXES[move.plane]
            if ent.plane != move.plane:
                problems.append(f"move {i}: plane {ent.plane} != {move.plane}: {_describe(move, ent)}")
            elif any(abs(ent.center[k] - move.center_mm[k]) > tol for k in (a, b)):
                problems.append(f"move {i}: centre differs: {_describe(move, ent)}")
            if ent.ccw != (move.rotation > 0) or ent.turns != abs(move.rotation) - 1:
                problems.append(f"move {i}: direction/turns differ: {_describe(move, ent)}")
        if len(problems) > 20:
            problems.append("... (stopped after 20)")
            break
    return problems


@pytest.mark.parametrize("path", corpus_files("g1_*.ngc"))
@pytest.mark.slow
def test_corpus_matches_rs274(path: Path) -> None:
    """The corpus's G0–G3 programs (all of them, stellabee1's 169k lines included: ~1 s in rs274)."""
    require_rs274()
    with ThreadPoolExecutor(1) as pool:  # rs274 runs while vcnc parses
        output = pool.submit(run_rs274, path)
        entities = ipr.parse_file(path).entities
        moves = canon_moves(output.result())
    assert len(moves) > 1000  # every g1_* program is thousands of moves: guards against a broken reader
    problems = mismatches(moves, entities)
    assert not problems, "\n".join(problems)


# Small programs exercising the modal features of the spec, run through both interpreters,
# with the number of moves each makes, counted by hand.
PROGRAMS = {
    "incremental": (8, """G21 G90 G17
G0 X1 Y2 Z3
G91 G1 X1 Y-1 Z0.5 F120
X1
G2 X2 Y0 I1 J0
G3 X-1 Y1 R1 Z-0.5
G90 G1 X0 Y0 Z0
G91 G0 Z2
G90 X5
M2
"""),
    "g92_g53": (7, """G21 G90
G0 X5 Y6 Z7
G92 X0 Y0 Z0
G1 X1 F100
G2 X2 Y1 I0 J1
G53 G0 X1 Y1
G1 Y2
G92 X10
G1 X11 Y3
G92.1
G1 X1 Y1 Z1
M2
"""),
    "planes_and_r_format": (13, """G21 G90 G17
G0 X0 Y0 Z0
G1 X10 F300
G3 X0 Y10 R10
G2 X10 Y0 R-10
G18 G2 X20 Z0 I5 K0
G3 X10 Z0 R5
G2 X20 Z0 R-5.5
G19 G2 Y10 Z10 J5 K5
G3 Y0 Z0 R10
G2 Y-5 Z5 R-5
G17 G2 X10 Y-5 I-5 J0
G90.1 G3 X20 Y-5 I15 J-5
G91.1 G2 X20 Y-5 I-5 J0
M2
"""),
    "helix_and_turns": (5, """G21 G90 G17
G0 X10 Y0 Z0
G3 X10 Y0 Z-3 I-10 J0 P3 F200
G2 X-10 Y0 Z-5 I-10 J0
G18 G3 X0 Z-15 Y2 I10 K0 P2
G19 G2 Y2 Z-15 X5 J-3 K0
M2
"""),
    # F stands on its own line after a unit change: in a block that also holds G20/G21,
    # rs274 executes F first (RS274NGC order of execution), i.e. in the old units.
    "inch": (7, """G20 G90 G17
G0 X1 Y1 Z0.5
G1 X2 F10
G2 X3 Y2 I0 J1
G3 X2.5 Y2.5 R0.5
G21 G1 X10 Y10
F250
G1 X20
G20
G1 X0.5 F7.5
M2
"""),
    # ...and F in the same block as G20/G21, which RS274NGC executes before the unit change
    "feed_with_unit_change": (3, """G21 G90
G1 X1 F100
G20 G1 X1 F10
G21 G1 X5 F300
M2
"""),
    "path_control": (4, """G21
G61 G1 X1 F100
G64 P0.05 Q0.02 G1 X2
G64 G0 X4
G20 G64 P0.001 G1 X1
M2
"""),
    "expressions": (12, """G21 G90
#1=2
#<scale>=0.5
#2=[#1*3]
G1 X[#1*#<scale>] Y[SIN[30]*2] Z[ATAN[1]/[1]] F[100+20]
G1 X[2**3] Y[7 MOD 3] Z[ROUND[2.5]+FIX[-1.5]+FUP[1.2]]
G1 X[ABS[-4]+SQRT[9]] Y[EXP[1]] Z[LN[10]]
G1 X[ACOS[0.5]/10] Y[ASIN[0.5]/10] Z[TAN[45]+COS[60]]
#1=5 G1 X#1 Y#2
G1 X#1 Y[1 LT 2] Z[[3 GE 2] + [1 EQ 1] + [2 NE 2]]
G1 X[1 AND 0] Y[1 OR 0] Z[1 XOR 1]
G1 X[-#1] Y[--2] Z[1-2-3]
G1 X[1 + 2 * 3 ** 2] Y[2 ** 3 ** 2 / 32] Z[1 + 2 LT 4 AND 1]
G1 X[-2 ** 2] Y[10 - 4 - 3] Z[7 MOD 4 * 2]
G1 X[2 * 3 MOD 4] Y[1 OR 0 AND 0] Z[5 GT 3 EQ 1]
G1 X[-7 MOD 3] Y[ATAN[-1]/[-1]] Z[FIX[-2.5] + FUP[-2.5] + ROUND[-2.5] + ROUND[-0.5]]
M2
"""),
    "syntax": (7, """%
G21 G90
n10 g0 x1 y2 z3
G 1 X 1 . 5 Y - 2 F 60
G1 (inline comment) X2 (another) Y3 ; trailing comment
g2x3y2i0.5j-0.5
/G1 X100 Y100
G01 X+4 Y.5
G00 X4. Y-0.
X5
%
"""),
    "offsets_g54_g59": (7, """G21 G90
G0 X1 Y1 Z1
G54 G1 X2 F100
G55 G0 X0 Y0 Z0
G2 X1 Y1 I1 J0
G59 G0 X0 Y0 Z0
G53 G0 X0 Y0 Z0
G54 G1 X0 Y0 Z0
M2
"""),
}

# G54, G55 and G59 offsets, given to rs274 as a parameter file (rs274's standalone machine unit is the
# inch) and to vcnc as its Setup in mm: exactly representable at rs274's printed precision either way.
_OFFSETS_IN = {"G54": (5220 + 1, (1.0, 2.0, -0.5)), "G55": (5240 + 1, (-0.25, 0.5, 0.125)),
               "G59": (5320 + 1, (2.0, -1.0, 0.0))}


def _var_file(path: Path) -> Path:
    rows = [(5220, 1.0)]
    for first, xyz in _OFFSETS_IN.values():
        rows += [(first + k, v) for k, v in enumerate(xyz)]
    path.write_text("".join(f"{n}\t{v:.6f}\n" for n, v in rows))
    return path


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_modal_programs_match_rs274(name: str, tmp_path: Path) -> None:
    require_rs274()
    src = tmp_path / f"{name}.ngc"
    n_moves, text = PROGRAMS[name]
    src.write_text(text)
    setup = None
    var_file = None
    if name == "offsets_g54_g59":
        var_file = _var_file(tmp_path / "offsets.var")
        setup = ipr.Setup(work_offsets_mm={k: tuple(v * INCH_MM for v in xyz)
                                           for k, (_, xyz) in _OFFSETS_IN.items()})
    output = run_rs274(src, var_file)
    moves = canon_moves(output)
    assert len(moves) == n_moves
    problems = mismatches(moves, ipr.parse_file(src, setup=setup).entities)
    assert not problems, "\n".join(problems)


def test_reader_converts_inches_and_offsets(tmp_path: Path) -> None:
    """The rs274 reader itself, on a hand-computed case: G20 and a G92 offset reach machine mm."""
    require_rs274()
    src = tmp_path / "units.ngc"
    src.write_text("G20 G90\nG0 X1 Y2 Z0\nG92 X0 Y0\nG1 X1 F6\nG18 G2 X2 Z0 I0.5 K0\nM2\n")
    rapid, line, arc = canon_moves(run_rs274(src))
    assert rapid.end_mm == pytest.approx((25.4, 50.8, 0.0))
    assert line.end_mm == pytest.approx((50.8, 50.8, 0.0)) and line.feed_mm_s == pytest.approx(6 * 25.4 / 60)
    assert arc.plane == "ZX" and arc.rotation == -1
    assert arc.end_mm == pytest.approx((76.2, 50.8, 0.0))
    assert arc.center_mm[0] == pytest.approx(63.5) and arc.center_mm[2] == pytest.approx(0.0)
    assert math.isnan(arc.center_mm[1])


_AXIS_LETTERS = "XYZ"
_CENTRE_LETTERS = "IJK"


def random_program(seed: int, n_blocks: int) -> tuple[str, int]:
    """A seeded random G0–G3 program (planes, G90/G91, IJK and R arcs, helices, turns, G92, F),
    written with 4 decimals; returns the text and the number of moves it makes."""
    rng = np.random.default_rng(seed)
    pos = np.zeros(3)  # in the current work coordinates
    offset_now = np.zeros(3)  # G92 offset: machine = work + offset_now
    lines, moves, plane, incremental = ["G21 G90 G17 F200"], 0, "XY", False

    def coords(target: np.ndarray, axes) -> str:
        values = target - pos if incremental else target
        return " ".join(f"{_AXIS_LETTERS[k]}{values[k]:.4f}" for k in axes)

    for _ in range(n_blocks):
        kind = rng.choice(["straight", "straight", "arc", "arc", "arc", "plane", "distance", "g92", "feed"])
        if kind == "plane":
            plane = str(rng.choice(["XY", "ZX", "YZ"]))
            lines.append({"XY": "G17", "ZX": "G18", "YZ": "G19"}[plane])
        elif kind == "distance":
            incremental = not incremental
            lines.append("G91" if incremental else "G90")
        elif kind == "g92":
            if rng.random() < 0.3:
                lines.append("G92.1")  # work coordinates become machine ones again: re-read the position
                pos = pos + offset_now
                offset_now = np.zeros(3)
            else:
                new = np.round(rng.uniform(-20, 20, 3), 4)
                lines.append("G92 " + " ".join(f"{a}{v:.4f}" for a, v in zip(_AXIS_LETTERS, new)))
                offset_now = offset_now + pos - new
                pos = new
        elif kind == "feed":
            lines.append(f"F{rng.uniform(10, 3000):.1f}")
        elif kind == "straight":
            axes = sorted(rng.choice(3, size=rng.integers(1, 4), replace=False))
            target = pos.copy()
            target[axes] = np.round(pos[axes] + rng.uniform(-30, 30, len(axes)), 4)
            lines.append(f"{rng.choice(['G0', 'G1'])} {coords(target, axes)}")
            pos, moves = target, moves + 1
        else:
            a, b, n = PLANE_AXES[plane]
            radius = rng.uniform(0.5, 25)
            phi0, sweep = rng.uniform(0, 2 * np.pi), rng.uniform(0.2, 2 * np.pi - 0.2)
            centre = pos.copy()
            centre[a] -= radius * np.cos(phi0)
            centre[b] -= radius * np.sin(phi0)
            full = rng.random() < 0.1
            target = pos.copy()
            if not full:
                target[a] = round(centre[a] + radius * np.cos(phi0 + sweep), 4)
                target[b] = round(centre[b] + radius * np.sin(phi0 + sweep), 4)
            if rng.random() < 0.3:
                target[n] = round(pos[n] + rng.uniform(-5, 5), 4)  # helix
            code = rng.choice(["G2", "G3"])
            words = f"{code} {coords(target, (a, b, n))}"
            chord_over_diameter = np.hypot(target[a] - pos[a], target[b] - pos[b]) / (2 * radius)
            if not full and 0.05 < chord_over_diameter < 0.9 and rng.random() < 0.4:
                # R format: the sign picks the longer arc; rs274 computes the centre itself
                longer = (sweep > np.pi) == (code == "G3")
                words += f" R{-radius if longer else radius:.4f}"
            else:
                off = centre - pos
                words += f" {_CENTRE_LETTERS[a]}{off[a]:.4f} {_CENTRE_LETTERS[b]}{off[b]:.4f}"
                if rng.random() < 0.15:
                    words += f" P{rng.integers(2, 4)}"
            lines.append(words)
            pos, moves = target, moves + 1
    lines.append("M2")
    return "\n".join(lines) + "\n", moves


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_random_programs_match_rs274(seed: int, tmp_path: Path) -> None:
    require_rs274()
    text, n_moves = random_program(seed, 400)
    src = tmp_path / f"random{seed}.ngc"
    src.write_text(text)
    moves = canon_moves(run_rs274(src))
    assert len(moves) == n_moves
    problems = mismatches(moves, ipr.parse_file(src).entities)
    assert not problems, "\n".join(problems)


# One block after "G21 G90 G17": rs274 and vcnc must both accept it or both reject it.
AGREEMENT_BLOCKS = [
    "G2 X1 Y1", "G1 X1", "G1 X1 F0", "G0 X1 G1 Y1", "G1 X1 X2 F100", "G2 X10 Y0 R3 F100", "G2 X0 Y0 R5 F100",
    "G2 X5 Y0 I1 J0 F100", "G4", "G4 P-1", "M3 S-100", "G1 X1 F-10", "N10 N20 G0 X1", "G17 G18", "M3 M4 S100",
    "G2 X0 Y0 I1 J0 P0 F100", "G2 X0 Y0 I1 J0 P1.5 F100", "X1", "G91 G53 G0 X1", "G0 X1 R2", "G1 X1 F100 I2",
    "G0 X1 P2", "G80 X1", "G1 X1 E5 F100", "G2 X2 Y0 I1 J0 K1 F100", "G17 G2 X2 Y0 I1 F100",
    "G18 G2 X2 Z0 I1 J1 F100", "G2 X2 Y0 R1 I1 F100", "T1 M6", "T-1 M6", "G43 H-1", "G64 Q0.1", "M3", "S100 M3",
    "G92", "G92.1 X1", "G53 G1 X1 F100", "G0 X[1/0]", "#1=[SQRT[-1]]", "G0 X#<nope>", "#5400=1", "#0=1",
    "G0 X[ACOS[2]]", "G0 X[LN[0]]", "G0 X1.2.3", "M2 M30", "M0 M1", "G4 P1 G0 X1", "G21 G20", "G5.2 X1 Y1",
    "G90.1 G2 X2 Y0 I1 J0 F100", "G0X1Y2Z3", "g0 x1 (msg, hi) y2", "G0 X1 ;comment", "G0 X1 (a) (b)",
    "G0 X1 (unclosed", "G0 X1 )", "G01.0 X1", "G1.0 X1 F1", "G0 X+-1", "G0 X--1", "G0 X1.", "G0 X.", "G0 X",
    "G1 F100 X1 N5",  # N is only allowed at the start of a block
    "%",  # % only starts (first line) or ends a program; here it is neither
]
# Where vcnc rejects on purpose what rs274 accepts (the spec's dialect is narrower than LinuxCNC's).
VCNC_STRICTER = ["G0 X1 Y2 Z3 A1", "M6", "G64 P-1"]


def _accepts(src: Path) -> tuple[bool, str]:
    try:
        ipr.parse_file(src)
    except GCodeError as err:
        return False, str(err.diagnostics[0])
    return True, ""


@pytest.mark.slow
def test_accepts_and_rejects_like_rs274(tmp_path: Path) -> None:
    require_rs274()
    problems = []
    for i, block in enumerate(AGREEMENT_BLOCKS + VCNC_STRICTER):
        src = tmp_path / f"block{i}.ngc"
        src.write_text(f"G21 G90 G17\n{block}\nM2\n")
        try:
            run_rs274(src)
            rs274_ok, why = True, ""
        except RuntimeError as err:
            rs274_ok, why = False, str(err).splitlines()[-2:]
        vcnc_ok, vcnc_why = _accepts(src)
        expected = rs274_ok and block not in VCNC_STRICTER
        if vcnc_ok != expected:
            problems.append(f"{block!r}: rs274 {'accepts' if rs274_ok else f'rejects {why}'}, "
                            f"vcnc {'accepts' if vcnc_ok else 'rejects: ' + vcnc_why}")
    assert not problems, "\n".join(problems)
