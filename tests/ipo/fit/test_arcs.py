"""Runs of G1 chords written as one G2/G3 arc or G1 line (ipo.fit.arcs): within the tolerance both ways by
brute force (the arc sampled by its angle, every point's distance to the polyline), in the program's frame
(plane, units, G90/G91, offsets, arc-distance mode) as vcnc and LinuxCNC's rs274 read the written blocks,
and never a full circle, an arc over 180 degrees or a helix."""
from __future__ import annotations


import numpy as np
import pytest
from test_fit_chains import _both_ways

from ipr import Setup, parse_text
from ipr.entities import PLANE_AXES, Arc, Line, Nurbs
from ipo.fit.arcs import ARC, NONE, STRAIGHT, one_move
from ipo.fit.convert import convert_text, count_blocks


def _segment_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    a, ab = poly[:-1], np.diff(poly, axis=0)
    t = np.clip(np.einsum("psd,sd->ps", points[:, None] - a[None], ab) / np.einsum("sd,sd->s", ab, ab), 0, 1)
    return np.linalg.norm(points[:, None] - (a[None] + t[..., None] * ab[None]), axis=2).min(axis=1)


def _dense(poly: np.ndarray, parts: int = 10) -> np.ndarray:
    t = np.linspace(0.0, 1.0, parts, endpoint=False)
    return np.vstack([(poly[:-1, None] + t[None, :, None] * np.diff(poly, axis=0)[:, None]).reshape(-1, 3), poly[-1:]])


def _noisy_run(rng, plane: str, tol: float) -> np.ndarray:
    """Chords of a circle (or of a line) in the plane, their sagitta up to 1.5 tol, vertices moved off it
    radially by up to 0, 0.5 or 1.5 tol."""
    a, b, n = PLANE_AXES[plane]
    radius = rng.choice([rng.uniform(0.5, 30.0), rng.uniform(500.0, 5000.0), 1e7])
    sweep = min(rng.uniform(0.05, 3.0), rng.uniform(1.0, 50.0) / radius) * rng.choice([-1.0, 1.0])
    step = 2.0 * np.arccos(1.0 - rng.uniform(0.05, 1.5) * tol / radius)
    count = int(np.clip(np.ceil(abs(sweep) / step), 2, 40))
    ang = rng.uniform(0, 2 * np.pi) + sweep * np.linspace(0.0, 1.0, count + 1)
    ang[1:-1] += rng.uniform(-0.2, 0.2, count - 1) * sweep / count
    r = radius + rng.uniform(-1.0, 1.0, len(ang)) * rng.choice([0.0, 0.5, 1.5]) * tol
    r[0] = r[-1] = radius
    pts = np.zeros((len(ang), 3))
    pts[:, a], pts[:, b], pts[:, n] = r * np.cos(ang), r * np.sin(ang), 1.25
    return pts - pts[0]  # near the origin: a line's radius 1e7 is only how it was made


@pytest.mark.parametrize("plane", ["XY", "ZX", "YZ"])
def test_one_move_is_within_tolerance_both_ways_by_brute_force(plane):
    tol = 0.01
    rng = np.random.default_rng({"XY": 1, "ZX": 2, "YZ": 3}[plane])
    a, b, n = PLANE_AXES[plane]
    found = {NONE: 0, STRAIGHT: 0, ARC: 0}
    for _ in range(100):
        q = _noisy_run(rng, plane, tol)
        centre = np.full(3, np.nan)
        kind = one_move(q, 0, len(q) - 1, a, b, n, tol, centre)
        found[kind] += 1
        if kind == NONE:
            continue
        if kind == STRAIGHT:
            curve = q[0] + np.linspace(0.0, 1.0, 1001)[:, None] * (q[-1] - q[0])
        else:
            r = np.hypot(q[0, a] - centre[a], q[0, b] - centre[b])
            assert abs(np.hypot(q[-1, a] - centre[a], q[-1, b] - centre[b]) - r) < 1e-9
            a0 = np.arctan2(q[0, b] - centre[b], q[0, a] - centre[a])
            sweep = (np.arctan2(q[-1, b] - centre[b], q[-1, a] - centre[a]) - a0 + np.pi) % (2 * np.pi) - np.pi
            assert abs(sweep) < np.radians(150.0) + 1e-12  # the short arc, never past 180 degrees
            t = a0 + sweep * np.linspace(0.0, 1.0, 1001)
            curve = np.empty((len(t), 3))
            curve[:, a], curve[:, b], curve[:, n] = centre[a] + r * np.cos(t), centre[b] + r * np.sin(t), q[0, n]
        both = max(_segment_distance(curve, q).max(), _segment_distance(_dense(q), curve).max())
        # the arc's 1000 chords (at most 3 rad, radius 30 mm; or 50 mm long) miss it by less than 0.05 um
        assert both <= tol + 5e-5, (kind, both)
    assert min(found.values()) >= 10, found


def test_the_minimax_is_skipped_only_where_no_circle_of_its_range_fits():
    # arcs._may_fit against a brute-force scan of the curvatures _minimax_offset searches: where it says no,
    # no circle through the run's ends keeps every inner vertex within tol radially
    from ipo.fit.arcs import _kappa_range, _may_fit

    tol = 0.01
    rng = np.random.default_rng(7)
    skipped = 0
    for _ in range(300):
        q = _noisy_run(rng, "XY", tol)
        q[1:-1, :2] += rng.normal(0.0, rng.choice([0.2, 1.0, 4.0]) * tol, (len(q) - 2, 2))
        half = 0.5 * np.hypot(*(q[-1, :2] - q[0, :2]))
        m = 0.5 * (q[0, :2] + q[-1, :2])
        u = (q[-1, :2] - q[0, :2]) / (2.0 * half)
        nrm = np.array([-u[1], u[0]])
        t = rng.uniform(-3.0, 3.0) * half * rng.choice([1.0, 10.0, 100.0])
        if _may_fit(q, 0, len(q) - 1, 0, 1, m[0], m[1], nrm[0], nrm[1], half, t, tol):
            continue
        skipped += 1
        lo, hi = _kappa_range(half, t, tol)
        kappa = np.linspace(lo, hi, 4001)
        r = np.maximum(1.0 / np.abs(kappa), half)
        centres = m + np.copysign(np.sqrt(r * r - half * half), kappa)[:, None] * nrm
        err = np.abs(np.linalg.norm(q[None, 1:-1, :2] - centres[:, None], axis=2) - r[:, None]).max(axis=1)
        assert err.min() > tol
    assert skipped >= 30


def _fillet_profile(plane: str, n_chord: int = 12) -> np.ndarray:
    """A profile in the plane: a line, a 90 degree fillet R5 as chords, a line, a 60 degree fillet R8."""
    a, b, n = PLANE_AXES[plane]
    pts = [(0.0, 0.0), (10.0, 0.0)]
    t = np.linspace(-np.pi / 2, 0.0, n_chord + 1)[1:]
    pts += [(10.0 + 5.0 * np.cos(u), 5.0 + 5.0 * np.sin(u)) for u in t]
    pts += [(15.0, 12.0)]
    t = np.linspace(0.0, np.pi / 3, n_chord + 1)[1:]
    pts += [(7.0 + 8.0 * np.cos(u), 12.0 + 8.0 * np.sin(u)) for u in t]
    out = np.zeros((len(pts), 3))
    out[:, a], out[:, b] = np.array(pts).T
    out[:, n] = -2.0
    return out


CASES = {
    # plane, units and distance modes, arc-centre mode, work offset
    "G18 mm G90 G91.1 G55": ("ZX", "G21 G18 G90 G91.1 G55", 1.0, False),
    "G17 inch G91 G90.1 G55": ("XY", "G20 G17 G90.1 G55", 25.4, True),
    "G19 mm G91 G91.1": ("YZ", "G21 G19 G91.1", 1.0, True),
}


def _profile_program(case: str) -> tuple[str, Setup]:
    plane, head, unit, relative = CASES[case]
    offset = np.array([100.0, -50.0, 10.0])
    pts = (_fillet_profile(plane) - offset) / unit if "G55" in head else _fillet_profile(plane) / unit
    digits = 5 if unit != 1.0 else 4
    steps = np.diff(pts, axis=0) if relative else pts[1:]
    words = [" ".join(f"{c}{v:.{digits}f}" for c, v in zip("XYZ", p)) for p in steps]
    first = " ".join(f"{c}{v:.{digits}f}" for c, v in zip("XYZ", pts[0]))
    body = ["G91"] if relative else []
    # after the run (which ends in a fillet), a modal G1 move that cannot join it (a comment)
    after = "X0.1" if relative else f"X{pts[-1, 0] + 0.1:.{digits}f}"
    src = "\n".join([head, f"G0 {first}", *body, f"G1 {words[0]} F300", *words[1:], f"{after} (after the run)",
                      "M2", ""])
    return src, Setup(work_offsets_mm={"G55": tuple(offset)})


@pytest.mark.parametrize("case", list(CASES))
def test_arcs_are_written_in_the_programs_frame_within_tolerance(case):
    tol = 0.01
    src, setup = _profile_program(case)
    out, rep = convert_text(src, tol, jobs=1, setup=setup)
    before, after = parse_text(src, setup=setup).entities, parse_text(out, setup=setup).entities
    arcs = [e for e in after if isinstance(e, Arc)]
    assert rep.arcs == len(arcs) == 2 and rep.groups == 0 and not any(isinstance(e, Nurbs) for e in after)
    assert all(e.plane == CASES[case][0] for e in arcs)
    assert rep.blocks_after == count_blocks(out) < rep.blocks_before - 20
    assert _both_ways(before, after) <= tol * 1.001
    # the same end; the move after the run is still G1 at the run's feed
    moves, lines = [e for e in after if isinstance(e, (Line, Arc))], [e for e in before if isinstance(e, Line)]
    assert isinstance(moves[-2], Arc) and np.allclose(moves[-2].end, lines[-2].end, atol=1e-9, rtol=0)
    assert isinstance(moves[-1], Line) and np.allclose(moves[-1].end, lines[-1].end, atol=1e-9, rtol=0)
    assert moves[-1].feed_mm_s == lines[-1].feed_mm_s == pytest.approx(300.0 * CASES[case][2] / 60.0)


def test_linuxcnc_reads_the_arcs_as_vcnc_does(tmp_path):
    from rs274 import canon_moves, require_rs274, run_rs274

    require_rs274()
    for case in CASES:
        src, setup = _profile_program(case)
        if "G55" in src:  # rs274 reads work offsets from its own var file: the program sets them instead
            src = "G10 L2 P2 X100 Y-50 Z10\n" + src
            setup = Setup()
        out, rep = convert_text(src, 0.01, jobs=1, setup=setup)
        assert rep.arcs == 2
        path = tmp_path / "fitted.ngc"
        path.write_text(out)
        theirs = [m for m in canon_moves(run_rs274(path)) if m.kind != "rapid"]
        ours = [e for e in parse_text(out, setup=setup).entities if isinstance(e, (Line, Arc))]
        assert [m.kind for m in theirs] == ["arc" if isinstance(e, Arc) else "line" for e in ours], case
        for m, e in zip(theirs, ours):
            # rs274 prints the position and the work offset each to 4 decimals
            assert np.allclose(m.end_mm, e.end, atol=2 * m.tol_mm, rtol=0), case
            if isinstance(e, Arc):
                a, b, _ = PLANE_AXES[e.plane]
                assert m.plane == e.plane and m.rotation == (1 if e.ccw else -1)
                assert np.allclose(np.array(m.center_mm)[[a, b]], np.array(e.center)[[a, b]], atol=2 * m.tol_mm,
                                   rtol=0)


def _cross_plane_program(program_plane: str, run_plane: str) -> str:
    """A program in program_plane whose run of G1 chords lies in run_plane (a raster pass in a vertical
    plane), then a comment line and an arc of the program's own plane that needs it in force."""
    pts = _fillet_profile(run_plane)
    words = [f"X{p[0]:.4f} Y{p[1]:.4f} Z{p[2]:.4f}" for p in pts]
    a, b, _ = PLANE_AXES[program_plane]
    end = pts[-1].copy()
    end[a] += 2.0
    centre = {"XY": "I1 J0", "ZX": "K1 I0", "YZ": "J1 K0"}[program_plane]
    code = {"XY": "G17", "ZX": "G18", "YZ": "G19"}[program_plane]
    return "\n".join([f"G21 G90 {code}", f"G0 {words[0]}", f"G1 {words[1]} F600", *words[2:], "(a comment)",
                      f"N90 G2 X{end[0]:.4f} Y{end[1]:.4f} Z{end[2]:.4f} {centre}", "M2", ""])


@pytest.mark.parametrize("program_plane, run_plane", [("XY", "ZX"), ("XY", "YZ"), ("ZX", "XY")])
def test_a_run_in_another_plane_is_an_arc_in_that_plane_and_the_programs_plane_comes_back(program_plane,
                                                                                         run_plane):
    # the fillets are arcs in the run's plane (written with its code), within tol both ways by brute force; the
    # program's own arc after them is read in the program's plane again, the same arc as in the source
    src = _cross_plane_program(program_plane, run_plane)
    out, rep = convert_text(src, 0.01, jobs=1)
    before, after = parse_text(src).entities, parse_text(out).entities
    fitted = [e for e in after if isinstance(e, Arc)][:-1]
    assert rep.arcs == len(fitted) == 2 and all(e.plane == run_plane for e in fitted)
    assert rep.blocks_after == count_blocks(out) < rep.blocks_before - 20
    assert _both_ways(before, after) <= 0.01 * 1.001
    theirs, ours = before[-2], after[-2]
    assert isinstance(ours, Arc) and ours.plane == theirs.plane == program_plane
    assert ours.start == theirs.start and ours.end == theirs.end and ours.center == theirs.center
    assert ours.ccw == theirs.ccw


def test_linuxcnc_reads_arcs_in_another_plane_as_vcnc_does(tmp_path):
    from rs274 import canon_moves, require_rs274, run_rs274

    require_rs274()
    for planes in (("XY", "ZX"), ("XY", "YZ"), ("ZX", "XY")):
        out, rep = convert_text(_cross_plane_program(*planes), 0.01, jobs=1)
        assert rep.arcs == 2
        path = tmp_path / "fitted.ngc"
        path.write_text(out)
        theirs = [m for m in canon_moves(run_rs274(path)) if m.kind != "rapid"]
        ours = [e for e in parse_text(out).entities if isinstance(e, (Line, Arc))]
        assert [m.kind for m in theirs] == ["arc" if isinstance(e, Arc) else "line" for e in ours], planes
        for m, e in zip(theirs, ours):
            assert np.allclose(m.end_mm, e.end, atol=2 * m.tol_mm, rtol=0), planes
            if isinstance(e, Arc):
                a, b, _ = PLANE_AXES[e.plane]
                assert m.plane == e.plane and m.rotation == (1 if e.ccw else -1), planes
                assert np.allclose(np.array(m.center_mm)[[a, b]], np.array(e.center)[[a, b]], atol=2 * m.tol_mm,
                                   rtol=0)


@pytest.mark.parametrize("sweep_deg, helix", [(300.0, False), (360.0, False), (120.0, True)])
def test_no_full_circle_no_arc_over_180_degrees_no_helix(sweep_deg, helix):
    t = np.radians(np.linspace(0.0, sweep_deg, 121))
    z = np.linspace(0.0, 1.0, len(t)) if helix else np.zeros(len(t))
    words = [f"X{10 * np.cos(u):.4f} Y{10 * np.sin(u):.4f} Z{zz:.4f}" for u, zz in zip(t, z)]
    src = "\n".join(["G21 G90 G17", f"G0 {words[0]}", f"G1 {words[1]} F600", *words[2:], "M2", ""])
    out, rep = convert_text(src, 0.01, jobs=1)
    before, after = parse_text(src).entities, parse_text(out).entities
    arcs = [e for e in after if isinstance(e, Arc)]
    if helix:
        assert not arcs
    else:
        assert len(arcs) >= 2 and all(abs(e.sweep_rad) < np.pi for e in arcs)
    assert _both_ways(before, after) <= 0.01 * 1.001



def _mixed_feed_program(tail: bool) -> tuple[str, np.ndarray, list[float]]:
    """The XY fillet profile with its feed switching between two beyond the machine's reach every 3 moves;
    tail: then a zig-zag of single moves (kept as written); a modal G1 move after the chain."""
    pts = _fillet_profile("XY")
    if tail:
        pts = np.vstack([pts, pts[-1] + [-6.0, 0.0, 0.0], pts[-1] + [-6.0, -4.0, 0.0], pts[-1] + [-10.0, -4.5, 0.0]])
    feeds = [600000.0 if (i // 3) % 2 else 900000.0 for i in range(len(pts) - 1)]
    words, prev = [], None
    for p, f in zip(pts[1:], feeds):
        words.append(f"X{p[0]:.4f} Y{p[1]:.4f} Z{p[2]:.4f}" + (f" F{f:.0f}" if f != prev else ""))
        prev = f
    src = "\n".join(["G21 G17 G90", f"G0 X{pts[0, 0]:.4f} Y{pts[0, 1]:.4f} Z{pts[0, 2]:.4f}", f"G1 {words[0]}",
                     *words[1:], "X0 (after the run)", "M2", ""])
    return src, pts, feeds


def _position(p: np.ndarray, pts: np.ndarray) -> float:
    """Where p lies on the polyline pts: vertex index + fraction of the segment after it."""
    best, at = np.inf, 0.0
    for i in range(len(pts) - 1):
        d = pts[i + 1] - pts[i]
        f = float(np.clip(np.dot(p - pts[i], d) / np.dot(d, d), 0.0, 1.0))
        gap = np.linalg.norm(pts[i] + f * d - p)
        if gap < best - 1e-9:
            best, at = gap, i + f
    assert best < 1e-3
    return float(round(at)) if abs(at - round(at)) < 1e-6 else at


@pytest.mark.parametrize("tail", [True, False])
def test_a_run_crosses_feeds_beyond_the_machines_reach_at_the_lowest(tail):
    """Feeds a chain merges (all beyond the machine's reach) do not split a run: each written move takes
    the lowest feed of the source moves it covers, and every move after it gets the program's own back."""
    src, pts, feeds = _mixed_feed_program(tail)
    out, rep = convert_text(src, 0.01, jobs=1)
    before, after = parse_text(src).entities, parse_text(out).entities
    assert rep.arcs == 2 and rep.groups == 0 and rep.feeds_merged > 0
    assert _both_ways(before, after) <= 0.01 * 1.001
    moves = [e for e in after if isinstance(e, (Line, Arc))]
    for e in moves[:-1]:  # the source moves it covers: those ending past its start, starting before its end
        lo, hi = _position(np.array(e.start), pts), _position(np.array(e.end), pts)
        covered = feeds[int(np.floor(lo)):int(np.ceil(hi))]
        assert e.feed_mm_s == pytest.approx(min(covered) / 60.0), e
    assert moves[-1].feed_mm_s == pytest.approx(feeds[-1] / 60.0)  # the modal move after the chain
