"""`vcnc fit` through corners (issue 23): chains of G1/G2/G3 moves become G06.2 groups that round
what can be rounded, keep sharp corners exactly, leave G61 alone, and stay within the tolerance both
ways. The written file is checked with scipy's BSpline (rational: the homogeneous curve divided by its
weight) and brute-force distances to the original path, never with the fit's own evaluator."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

from ipr import parse_text
from ipr.entities import PLANE_AXES, Arc, Line, Nurbs
from ipo.fit.chains import rounding_radius_mm
from ipo.fit.convert import convert_text, count_blocks
from ipo.fit.written import coordinate_digits, rounding_bound_mm



SPACING_MM = 0.002


def _scipy_points(nb: Nurbs, per_span: int = 2000, spacing_mm: float = SPACING_MM) -> np.ndarray:
    """The written NURBS evaluated by scipy: C(u) = sum N_i w_i P_i / sum N_i w_i, at most spacing_mm
    apart (a rational span can run fast through part of its parameter range: each knot span is first
    sampled evenly in u, then again evenly along its length)."""
    hom = np.c_[nb.points * nb.weights[:, None], nb.weights]
    spl = BSpline(np.asarray(nb.knots), hom, nb.degree)

    def at(u):
        h = spl(u)
        return h[:, :3] / h[:, 3:]

    out = []
    for a, b in zip(nb.knots[:-1], nb.knots[1:]):
        if b > a:
            u = np.linspace(a, b, per_span)
            s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(at(u), axis=0), axis=1))])
            out.append(at(np.interp(np.linspace(0.0, s[-1], max(2, int(s[-1] / spacing_mm) + 2)), s, u)))
    return np.vstack(out)


def _arc_points(a: Arc, n: int = 400) -> np.ndarray:
    i, j, k = PLANE_AXES[a.plane]
    t = np.linspace(0.0, 1.0, n)
    a0 = np.arctan2(a.start[j] - a.center[j], a.start[i] - a.center[i])
    out = np.empty((n, 3))
    out[:, i] = a.center[i] + a.radius_mm * np.cos(a0 + a.sweep_rad * t)
    out[:, j] = a.center[j] + a.radius_mm * np.sin(a0 + a.sweep_rad * t)
    out[:, k] = a.start[k] + (a.end[k] - a.start[k]) * t
    return out


def _path(entities, spacing_mm: float = SPACING_MM) -> np.ndarray:
    """Points along every feed move at most spacing_mm apart, each move on its own (no point on the
    gap between two moves that do not meet, as across a rapid)."""
    pts = []
    for e in entities:
        if isinstance(e, Line):
            pts.append(_densified(np.array([e.start, e.end]), spacing_mm))
        elif isinstance(e, Arc):
            normal = PLANE_AXES[e.plane][2]
            length = np.hypot(e.radius_mm * e.sweep_rad, e.end[normal] - e.start[normal])
            pts.append(_arc_points(e, int(length / spacing_mm) + 2))
        elif isinstance(e, Nurbs):
            pts.append(_scipy_points(e, spacing_mm=spacing_mm))
    return np.vstack(pts)


def _densified(poly: np.ndarray, step_mm: float) -> np.ndarray:
    seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    parts = np.maximum(np.ceil(seg / step_mm).astype(int), 1)
    t = np.concatenate([np.arange(k) / k for k in parts])
    owner = np.repeat(np.arange(len(seg)), parts)
    return np.vstack([poly[owner] + t[:, None] * (poly[owner + 1] - poly[owner]), poly[-1:]])


def _both_ways(before, after) -> float:
    """Largest distance original path -> written path and written path -> original path (feed moves),
    both taken as points at most 2 um apart: a point's distance to the nearest point of the other
    overstates its distance to that path by at most sqrt(d^2 + (1 um)^2) - d (0.05 um at d = 10 um)."""
    feed = (Line, Arc, Nurbs)
    a = _path([e for e in before if isinstance(e, feed)])
    b = _path([e for e in after if isinstance(e, feed)])
    return float(max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max()))


def _random_corner_program(seed: int, n_pieces: int = 16) -> tuple[str, list[tuple[np.ndarray, float]]]:
    """A planar path of smooth stretches (polylined arcs of random radius) meeting at corners that turn
    by every angle from 0 to 170 degrees, written to 4 decimals; and each corner's vertex and turn."""
    rng = np.random.default_rng(seed)
    p = np.zeros(2)
    heading = 0.0
    pts = [p.copy()]
    corners = []
    turns = np.linspace(0.0, np.radians(170.0), n_pieces)
    rng.shuffle(turns)
    for turn in turns:
        heading += turn * rng.choice([-1.0, 1.0])
        if pts:
            corners.append((np.array([p[0], p[1], 0.0]), float(turn)))
        radius = rng.uniform(3.0, 30.0) * rng.choice([-1.0, 1.0])
        length = rng.uniform(2.0, 8.0)
        n = int(rng.integers(6, 30))
        for _ in range(n):
            heading += length / n / radius
            p = p + length / n * np.array([np.cos(heading), np.sin(heading)])
            pts.append(p.copy())
    words = [f"X{x:.4f} Y{y:.4f}" for x, y in pts]
    text = "\n".join(["G21 G90 G17 G64", "G0 X0 Y0 Z0", f"G1 {words[1]} F1200", *words[2:], "M2", ""])
    return text, corners[1:]


@pytest.mark.parametrize("seed", [1, 2])
def test_random_corners_within_tolerance_both_ways_and_sharp_ones_exact(seed):
    tol = 0.01
    src, corners = _random_corner_program(seed)
    out, rep = convert_text(src, tol, jobs=1)
    before, after = parse_text(src).entities, parse_text(out).entities
    # the polylined arcs come back as curves: G06.2 groups, or G2/G3 arcs (the source has none)
    assert any(isinstance(e, (Nurbs, Arc)) for e in after)
    assert rep.blocks_after < rep.blocks_before / 2
    assert rep.blocks_after == count_blocks(out)
    dev = _both_ways(before, after)
    assert dev <= tol * 1.001, dev
    assert rep.max_deviation_mm <= tol
    # corners that must stay sharp (a rounding within tol would be too tight for F1200 at 1000 mm/s^2)
    written = _path([e for e in after if isinstance(e, (Line, Arc, Nurbs))])
    slack = rounding_bound_mm(3, 1.0) + 1e-6
    sharp = [(v, t) for v, t in corners if t > np.radians(30.0)
             and (1200 / 60) ** 2 > 1000.0 * rounding_radius_mm(np.array(t), 0.00913)]
    assert sharp
    ctrl = np.vstack([e.points for e in after if isinstance(e, Nurbs)] + [np.array([e.end]) for e in after
                                                                          if isinstance(e, (Line, Arc))])
    for vertex, _ in sharp:
        # the curve passes through the vertex, up to the rounding of the written control point
        assert np.min(np.linalg.norm(written - vertex, axis=1)) <= slack
        # as a corner: the vertex is a control point (a knot of multiplicity = degree), or ends a G1/G2/G3
        assert np.min(np.linalg.norm(ctrl - vertex, axis=1)) <= slack


def test_raster_step_overs_stay_corners():
    """A zig-zag raster at F5000: the 0.2 mm step-overs turn 90 degrees twice, which no rounding within
    10 um allows at 83 mm/s and 1000 mm/s^2 (radius 24 um, 289,000 mm/s^2). Each pass's end and the next
    one's start are control points of the group (knots of multiplicity 2): the curve turns there, not in
    a tiny turn beside them (G2/G3 arcs for runs of chords off: the passes lie in XZ planes, and with them
    each pass is a few G18 arcs, test_arcs)."""
    x = np.linspace(0.0, 40.0, 81)
    lines = ["G21 G90 G17 G64", "G0 X0 Y0 Z0"]
    corners = []
    for k in range(4):
        xs = x if k % 2 == 0 else x[::-1]
        zs = 0.5 * np.sin(xs / 6.0 + k * 0.1)
        words = [f"X{a:.4f} Y{0.2 * k:.4f} Z{b:.4f}" for a, b in zip(xs, zs)]
        if k == 0:
            lines += [f"G1 {words[0]} F5000", *words[1:]]
        else:
            lines += words
            corners.append(np.round([xs[0], 0.2 * k, zs[0]], 4))
        corners.append(np.round([xs[-1], 0.2 * k, zs[-1]], 4))
    src = "\n".join(lines + ["M2", ""])
    out, rep = convert_text(src, 0.01, jobs=1, arcs=False)
    before, after = parse_text(src).entities, parse_text(out).entities
    assert rep.groups == 1 and rep.blocks_after < rep.blocks_before / 5
    assert _both_ways(before, after) <= 0.01 * 1.001
    nb = next(e for e in after if isinstance(e, Nurbs))
    slack = rounding_bound_mm(coordinate_digits(0.01, 1.0), 1.0) + 1e-9  # a control point as written
    for vertex in corners[:-1]:
        assert np.min(np.linalg.norm(nb.points - vertex, axis=1)) <= slack
    # the report tells the six step-over corners (the passes are smooth: no other corner) from the knots
    # where only the weights restart (the curve stays tangent there); together they are the written
    # group's inner knots of multiplicity 2
    knots, counts = np.unique(nb.knots[nb.degree + 1:-nb.degree - 1], return_counts=True)
    assert rep.sharp_vertices == rep.sharp_corners == 6
    assert rep.sharp_corners + rep.double_knots == int(np.sum(counts == 2))


def test_an_arc_inside_a_smooth_path_joins_the_group():
    """A circle R20 written as G1 chords, then one G3 quarter of the same circle, then chords again:
    the chain runs through the arc and one group replaces all of it, within tolerance of the arc
    (with G2/G3 arcs for runs of chords off: with them, each quarter of chords is one arc, below)."""
    tol = 0.01
    r = 20.0

    def chords(a0, a1, n):
        return [f"X{r * np.cos(t):.4f} Y{r * np.sin(t):.4f}" for t in np.linspace(a0, a1, n + 1)[1:]]

    q = np.pi / 2
    first = chords(0, q, 40)
    lines = ["G21 G90 G17 G64", f"G0 X{r:.4f} Y0 Z0", f"G1 {first[0]} F1500", *first[1:],
             f"G3 X{-r:.4f} Y0 I0 J{-r:.4f}", *chords(2 * q, 3 * q, 40)]
    lines[43] = "G1 " + lines[43]
    src = "\n".join(lines + ["M2", ""])
    out, rep = convert_text(src, tol, jobs=1, arcs=False)
    before, after = parse_text(src).entities, parse_text(out).entities
    assert any(isinstance(e, Arc) for e in before)
    assert not any(isinstance(e, Arc) for e in after), "the arc is inside the group"
    assert _both_ways(before, after) <= tol * 1.001
    assert rep.groups == 1 and rep.blocks_after < rep.blocks_before / 4
    out, rep = convert_text(src, tol, jobs=1)
    after = parse_text(out).entities
    assert [e.line for e in after if isinstance(e, Arc)] == [3, 4, 5] and rep.arcs == 2 and rep.groups == 0
    assert _both_ways(before, after) <= tol * 1.001


def test_g61_region_is_not_rounded():
    zig = [f"X{0.5 * i:.4f} Y{0.2 * np.sin(0.3 * i):.4f}" for i in range(1, 80)]
    src = "\n".join(["G21 G90 G17", "G0 X0 Y0 Z0", "G61", "G1 X0.1 Y0 F1000", *zig, "G64",
                     *[f"X{40 + 0.5 * i:.4f} Y{0.2 * np.sin(0.3 * i):.4f}" for i in range(80)], "M2", ""])
    out, rep = convert_text(src, 0.01, jobs=1)
    src_lines, out_lines = src.split("\n"), out.split("\n")
    g61 = src_lines[2:src_lines.index("G64")]
    assert out_lines[2:2 + len(g61)] == g61, "every G61 block is kept as written"
    assert rep.groups + rep.arcs >= 1 and out_lines[2 + len(g61):] != src_lines[2 + len(g61):]


def test_fitted_program_runs_without_limit_violations(tmp_path):
    from ipo.config import default_config
    from machine.controller import Controller

    src, _ = _random_corner_program(4, n_pieces=10)
    out, rep = convert_text(src, 0.01, jobs=1)
    path = tmp_path / "fitted.nc"
    path.write_text(out)
    ctl = Controller(default_config())
    result = ctl.run(ctl.check(path))
    assert result.state == "completed"
    assert result.limit_violations == 0, result.limit_violations_by_kind


@pytest.mark.parametrize("name", ["g1_lhchips4.ngc"])
def test_corpus_chains_within_tolerance(name):
    from conftest import require_corpus

    path = require_corpus() / name
    if not path.exists():
        pytest.skip(f"{path} is absent")
    text = "\n".join(path.read_text().split("\n")[:160]) + "\nM2\n"
    out, rep = convert_text(text, 0.01, jobs=1)
    before, after = parse_text(text).entities, parse_text(out).entities
    assert rep.arcs >= 10 and rep.lines >= 3  # G18 fillets and lines written as G1 chords
    assert _both_ways(before, after) <= 0.01 * 1.001
    # some of them join inside a segment of the source (ipo.fit.move_runs), not on a vertex
    vertices = np.array([e.end for e in before if isinstance(e, (Line, Arc))])
    ends = np.array([e.end for e in after if isinstance(e, (Line, Arc))])
    assert np.sum(cKDTree(vertices).query(ends)[0] > 1e-6) >= 3


def test_g5_2_output_parses_in_vcnc_and_in_linuxcnc_rs274(tmp_path):
    from rs274 import run_rs274

    src, _ = _random_corner_program(2, n_pieces=10)
    out, rep = convert_text(src, 0.01, jobs=1, dialect="g5.2")
    assert rep.groups >= 3 and out.count("G5.2") == rep.groups == out.count("G5.3")
    before, after = parse_text(src).entities, parse_text(out).entities
    assert _both_ways(before, after) <= 0.01 * 1.001
    path = tmp_path / "fitted.ngc"
    path.write_text(out)
    canon = run_rs274(path)
    assert canon.count("NURBS_FEED(") == rep.groups
    # the control-point counts rs274 read are the ones vcnc read
    counts = [int(line.split("NURBS_FEED(")[1].split(",")[0]) for line in canon.splitlines() if "NURBS_FEED(" in line]
    assert counts == [len(e.points) for e in after if isinstance(e, Nurbs)]


def test_g5_2_leaves_paths_that_leave_the_xy_plane():
    words = [f"X{0.5 * i:.4f} Y{np.sin(0.1 * i):.4f} Z{0.01 * i:.4f}" for i in range(1, 60)]
    src = "\n".join(["G21 G90 G17", "G0 X0 Y0 Z0", f"G1 {words[0]} F1000", *words[1:], "M2", ""])
    out, rep = convert_text(src, 0.01, jobs=1, dialect="g5.2")
    assert out == src and rep.groups == 0
    assert "XY plane" in rep.kept_g01[0][1]


def test_fitted_corpus_program_passes_the_controllers_check(tmp_path):
    """Every G06.2 group vcnc fit writes for LinuxCNC's lhchips4 (CAM output; its first 1400 lines)
    at 5 um can be followed: the controller's whole-program check (machine.check) accepts the program,
    and the knots as the feed stage evens the speed at C0 knots (ipo.feed.split.even_speed) keep
    intervals double precision resolves. Before, spans changed their end weights 1e9-fold (refused:
    E-NURBS-PATH) and the evened knots of one group ran to 1e-25 of its length (the run faulted)."""
    from conftest import require_corpus
    from ipo.config import default_config
    from ipo.feed.split import even_speed
    from machine.check import check_program

    path = require_corpus() / "g1_lhchips4.ngc"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    text = "\n".join(path.read_text().split("\n")[:1400]) + "\nM2\n"
    out, rep = convert_text(text, 0.005, jobs=1)
    assert rep.groups >= 1 and rep.arcs >= 50
    fitted = tmp_path / "fitted.ngc"
    fitted.write_text(out)
    config = default_config()
    check_program(fitted, config, np.array([a.min_mm for a in config.axes]),
                  np.array([a.max_mm for a in config.axes]))
    for e in parse_text(out).entities:
        if isinstance(e, Nurbs):
            knots = np.asarray(even_speed(e).knots)
            steps = np.diff(knots)
            assert steps[steps > 0].min() >= 1e-11 * (knots[-1] - knots[0]), e.line


@pytest.mark.parametrize("first, last", [(0, 3), (2, 5), (3, 7), (1, 7)])
def test_sub_chain_is_the_chain_of_its_moves(first, last):
    # a refused group's moves are planned again as chains of their own (ipo.fit.convert): the slice of a
    # chain is what split_chains finds for those moves alone, arcs' points and tangents included
    from ipo.fit.chains import split_chains, sub_chain

    src = "\n".join(["G21 G90 G17", "G0 X0 Y0 Z0", "G1 X2 Y0.1 F600", "X4 Y0.5", "G3 X6 Y2.5 I0 J2",
                     "G1 X6.5 Y4", "G2 X8.5 Y6 I2 J0", "G1 X10 Y6.2", "X12 Y6", "M2", ""])
    moves = [e for e in parse_text(src).entities if isinstance(e, (Line, Arc)) and e.line > 2]
    (chain,) = split_chains(moves, 0.01)
    (alone,) = split_chains(moves[first:last], 0.01)
    part = sub_chain(chain, first, last)
    assert part.moves == alone.moves and part.sag_mm == alone.sag_mm
    for name in ("points", "ends", "tan_in", "tan_out", "on_arc"):
        np.testing.assert_array_equal(getattr(part, name), getattr(alone, name), err_msg=name)
