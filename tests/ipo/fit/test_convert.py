"""Program -> program conversion: G01 runs become G06.2 groups that start and end exactly where the
runs did and stay within tolerance of them; everything else passes through unchanged."""
from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from ipr import Setup, parse_text
from ipr.entities import GCodeError, Line, Nurbs
from ipo.nurbs.kernel import curve_points
from ipo.fit.convert import REFUSED, convert_text, count_blocks


def _ellipse_run(n=120, a=12.0, b=5.0, z=-1.0, digits=4, scale=1.0, sweep=np.pi):
    t = np.linspace(0, sweep, n + 1)
    pts = np.c_[a * np.cos(t), b * np.sin(t), z + 0.3 * np.sin(2 * t)] / scale
    return pts, [f"X{x:.{digits}f} Y{y:.{digits}f} Z{zz:.{digits}f}" for x, y, zz in pts]


def _program(words, head=("G21 G90 G17",), extra_after=("G2 X-12 Y-6 I0 J-3",)):
    first = words[0]
    return "\n".join([*head, "(a comment that must survive)", "S12500 M3", f"G0 {first}",
                      f"G1 {words[1]} F3000", *words[2:], *extra_after, "G0 Z5", "M5", "M2", ""])


def _polyline_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    a, ab = poly[:-1], np.diff(poly, axis=0)
    t = np.clip(np.einsum("psd,sd->ps", points[:, None] - a[None], ab) / np.einsum("sd,sd->s", ab, ab), 0, 1)
    return np.linalg.norm(points[:, None] - (a[None] + t[..., None] * ab[None]), axis=2).min(axis=1)


def _check_round_trip(src: str, out: str, tol_mm: float, setup=None):
    before = parse_text(src, setup=setup).entities
    after = parse_text(out, setup=setup).entities
    lines_before = [e for e in before if isinstance(e, Line)]
    nurbs = [e for e in after if isinstance(e, Nurbs)]
    assert nurbs, "the run should have been fitted"
    poly = np.array([lines_before[0].start] + [e.end for e in lines_before])
    for nb in nurbs:
        curve = curve_points(nb.degree, nb.knots, nb.weights, nb.points, np.linspace(nb.knots[0], nb.knots[-1], 3001))
        assert _polyline_distance(curve, poly).max() <= tol_mm * 1.0001
        # starts and ends exactly on a vertex of the G01 path
        for end in (nb.start, nb.end):
            assert np.min(np.linalg.norm(poly - np.array(end), axis=1)) < 1e-9
    # the fitted path is continuous and has the same two ends; everything that is not a G01 move is unchanged
    path_after = [e for e in after if isinstance(e, (Line, Nurbs))]
    assert path_after[0].start == lines_before[0].start
    assert np.allclose(path_after[-1].end, lines_before[-1].end, atol=1e-9, rtol=0)
    for a, b in zip(path_after, path_after[1:]):
        assert np.allclose(a.end, b.start, atol=1e-9, rtol=0)
    others_before = [e for e in before if not isinstance(e, (Line, Nurbs))]
    others_after = [e for e in after if not isinstance(e, (Line, Nurbs))]
    assert [type(e) for e in others_before] == [type(e) for e in others_after]
    for e0, e1 in zip(others_before, others_after):
        for attr in ("start", "end", "center", "rpm"):
            if hasattr(e0, attr):
                assert np.allclose(getattr(e0, attr), getattr(e1, attr), atol=1e-9, rtol=0)
    return before, after


@pytest.mark.parametrize("tol_mm", [0.001, 0.01])
def test_ellipse_run_becomes_g06_2_within_tolerance(tol_mm):
    pts, words = _ellipse_run()
    src = _program(words)
    out, rep = convert_text(src, tol_mm)
    before, after = _check_round_trip(src, out, tol_mm)
    assert rep.groups >= 1 and rep.max_deviation_mm <= tol_mm
    assert rep.blocks_after < rep.blocks_before / 2
    assert rep.blocks_before == count_blocks(src) and rep.blocks_after == count_blocks(out)
    # every group ends exactly on a vertex of the run (same number written, same float read)
    ends = {e.end for e in before if isinstance(e, Line)}
    assert all(nb.end in ends for nb in after if isinstance(nb, Nurbs))
    # the comment and the non-G01 lines pass through as text
    for keep in ("(a comment that must survive)", "S12500 M3", "G2 X-12 Y-6 I0 J-3", "G0 Z5", "M2"):
        assert keep in out.split("\n")
    assert "G06.2 P3" in out  # the default: rational quadratic spans


def test_inch_incremental_program_with_work_offset():
    pts, _ = _ellipse_run(scale=25.4, digits=5)
    inc = np.diff(pts, axis=0)
    words = [f"X{pts[0, 0]:.5f} Y{pts[0, 1]:.5f} Z{pts[0, 2]:.5f}"]
    words += [f"X{dx:.5f} Y{dy:.5f} Z{dz:.5f}" for dx, dy, dz in inc]
    head = ("G20 G17 G55",)
    src = "\n".join([*head, f"G0 {words[0]}", "G91", f"G1 {words[1]} F100", *words[2:], "G90", "G0 Z0.2", "M2", ""])
    setup = Setup(work_offsets_mm={"G55": (100.0, -50.0, 10.0)})
    out, rep = convert_text(src, 0.005, setup=setup)
    assert rep.groups >= 1
    before, after = _check_round_trip(src, out, 0.005, setup=setup)
    # the relative words of the groups (and of any move kept after them) add up to the same end
    end_before = [e for e in before if isinstance(e, Line)][-1].end
    end_after = [e for e in after if isinstance(e, (Line, Nurbs))][-1].end
    assert np.allclose(end_after, end_before, atol=1e-9, rtol=0)
    assert out.count("G06.2") == rep.groups


def test_modal_g1_after_a_group_is_restored():
    _, words = _ellipse_run()
    # after the run, a sharp corner and more modal G1 moves that were not fitted
    src = "\n".join(["G21 G90", f"G0 {words[0]}", f"G1 {words[1]} F3000", *words[2:],
                     "X-20 Y-20 Z-1", "X-30 Y-20 Z-1", "M2", ""])
    out, rep = convert_text(src, 0.01)
    after = parse_text(out).entities
    lines_after = [e for e in after if isinstance(e, Line)]
    assert [e.end for e in lines_after][-2:] == [(-20.0, -20.0, -1.0), (-30.0, -20.0, -1.0)]


def test_short_runs_and_other_blocks_stay_unchanged():
    src = "G21 G90\nG0 X0 Y0 Z0\nG1 X1 F100\nX2 Y0.5\nX3 Y0.3\n#1=2\nG1 X[#1*2] Y1\nG2 X6 Y1 I1 J0\nM2\n"
    out, rep = convert_text(src, 0.01)
    assert out == src
    assert rep.groups == 0 and rep.chains == 2  # G1 X1..X3, and G1 X[#1*2] with the G2 arc


def test_runs_break_at_feed_changes_and_corners():
    _, words = _ellipse_run(n=60)
    src = "\n".join(["G21 G90", f"G0 {words[0]}", f"G1 {words[1]} F3000", *words[2:30],
                     f"{words[30]} F2000", *words[31:], "M2", ""])
    out, rep = convert_text(src, 0.01)
    after = parse_text(out).entities
    feeds = sorted({round(e.feed_mm_s * 60) for e in after if isinstance(e, Nurbs)})
    assert rep.chains == 2 and feeds == [2000, 3000]


def test_feeds_beyond_the_machines_reach_share_a_group_and_the_programs_feed_comes_back():
    """The default machine's axes reach 173.2 mm/s together (100 mm/s each): F20000 and F30000 mm/min
    (333 and 500 mm/s) move it alike, so one group covers both, written with the lower F; the
    modal moves after the run get the program's own F30000 back. F3000 and F4000 stay apart."""
    _, words = _ellipse_run(n=60)
    tail = ["X-20 Y-20 Z-1", "X-30 Y-20 Z-1"]
    src = "\n".join(["G21 G90", f"G0 {words[0]}", f"G1 {words[1]} F20000", *words[2:30],
                     f"{words[30]} F30000", *words[31:], *tail, "M2", ""])
    out, rep = convert_text(src, 0.01)
    assert rep.chains == 1 and rep.groups == 1 and rep.feeds_merged == 1
    assert "F20000" in next(line for line in out.split("\n") if line.startswith("G06.2"))
    after = parse_text(out).entities
    assert [round(e.feed_mm_s * 60) for e in after if isinstance(e, Line)][-2:] == [30000, 30000]
    assert [e.end for e in after if isinstance(e, Line)][-2:] == [(-20.0, -20.0, -1.0), (-30.0, -20.0, -1.0)]
    slow = src.replace("F20000", "F3000").replace("F30000", "F4000")
    assert convert_text(slow, 0.01)[1].chains == 2
    assert convert_text(src, 0.01, reach_mm_s=0.0)[1].chains == 2  # merging off


def _six_runs() -> str:
    """Six half-ellipse runs at Z -1..-6 (around which Z wobbles by 0.3 mm); a feed change ends each."""
    runs = []
    for k in range(6):
        pts, words = _ellipse_run(n=60, z=-1.0 - k)
        runs += [f"G1 {words[0]} F{3000 + k}"] + words[1:]
    return "\n".join(["G21 G90 G17", "G0 X12 Y0 Z-1", *runs, "M2", ""])


def test_worker_processes_give_the_same_program():
    # several runs, fitted in two worker processes and in this one
    src = _six_runs()
    one, rep1 = convert_text(src, 0.01, jobs=1)
    two, rep2 = convert_text(src, 0.01, jobs=2)
    assert rep1.groups >= 6 and one == two and rep1.max_deviation_mm == rep2.max_deviation_mm
    with pytest.raises(ValueError):
        convert_text(src, 0.01, jobs=0)


def _refuse_below_z3(curve: Nurbs) -> str | None:
    """A stand-in for the controller's check (module level: the worker processes call it too)."""
    return "below Z-3.5" if curve.points[:, 2].max() < -3.5 else None


def test_controller_check_in_worker_processes_keeps_the_groups_it_refuses():
    # the check refuses the three lowest runs: planned again in halves (down to ipo.fit.convert.MIN_SPLIT moves) and
    # refused again, they stay G1 (the source's moves, or G1 lines each within tol of several of them), whether
    # the checks run in two worker processes or in this one
    src = _six_runs()
    one, rep1 = convert_text(src, 0.01, jobs=1, walkable=_refuse_below_z3)
    two, rep2 = convert_text(src, 0.01, jobs=2, walkable=_refuse_below_z3)
    assert one == two and rep1.kept_g01 == rep2.kept_g01
    assert rep2.groups == 3
    after = parse_text(two).entities
    z_nurbs = [e.points[:, 2] for e in after if isinstance(e, Nurbs)]
    assert len(z_nurbs) == 3 and min(z.max() for z in z_nurbs) > -3.5
    low = [e for e in after if isinstance(e, (Line, Nurbs)) and max(e.start[2], e.end[2]) < -3.4]
    assert low and all(isinstance(e, Line) for e in low)
    # every source vertex of the refused runs lies within tol of the G1 moves written for them
    poly = np.array([low[0].start] + [e.end for e in low])
    source = np.array([e.end for e in parse_text(src).entities if isinstance(e, Line) and e.end[2] < -3.4])
    assert _polyline_distance(source, poly).max() <= 0.01


def _refuse_over_24_points(curve: Nurbs) -> str | None:
    """A stand-in for the controller's check that refuses long groups (as its arc-length table refuses
    long groups whose weights spread, ipo.fit.weights)."""
    return "over 24 control points" if len(curve.points) > 24 else None


def test_a_refused_group_is_planned_again_in_halves_until_the_controller_takes_them():
    # one 200-move run: fitted alone it is one group of more than 24 points; refused, its moves are planned
    # again as halves (down to ipo.fit.convert.MIN_SPLIT moves), and every half the check takes is written
    _, words = _ellipse_run(n=200)
    src = _program(words, extra_after=())
    plain, _ = convert_text(src, 0.001, jobs=1)
    assert max(len(e.points) for e in parse_text(plain).entities if isinstance(e, Nurbs)) > 24
    out, rep = convert_text(src, 0.001, jobs=1, walkable=_refuse_over_24_points)
    written = [e for e in parse_text(out).entities if isinstance(e, Nurbs)]
    assert written and all(len(e.points) <= 24 for e in written)
    assert not [why for _, why in rep.kept_g01 if why.endswith("over 24 control points")]
    _check_round_trip(src, out, 0.001)


def _refuse_over_6_points(curve: Nurbs) -> str | None:
    return "over 6 control points" if len(curve.points) > 6 else None


def test_a_group_refused_after_three_halvings_is_halved_again():
    # the same run under a check that takes only groups of 6 points or fewer: halving the 200 moves three
    # times leaves pieces of 25 moves, still refused; they are halved again until the check takes each half
    # (or it is too short to halve), so none stays G1 because the check refused it (three halvings kept two)
    _, words = _ellipse_run(n=200)
    src = _program(words, extra_after=())
    out, rep = convert_text(src, 0.001, jobs=1, walkable=_refuse_over_6_points)
    written = [e for e in parse_text(out).entities if isinstance(e, Nurbs)]
    assert written and all(len(e.points) <= 6 for e in written)
    assert not [why for _, why in rep.kept_g01 if why.startswith(REFUSED)]
    _check_round_trip(src, out, 0.001)


def test_a_group_off_as_written_is_planned_again_in_halves(monkeypatch):
    # the same run with a stand-in for the check of the curve as written that finds every group of more than
    # 24 points off (as a long group's joined spans can drift past the tolerance): its moves are planned again
    # as halves, like a refused group's, and every half within the tolerance is written
    import ipo.fit.convert as convert

    real = convert.written_deviation_mm

    def off_when_long(curve, data, tol_mm):
        return 2.0 * tol_mm if len(curve.points) > 24 else real(curve, data, tol_mm)

    _, words = _ellipse_run(n=200)
    src = _program(words, extra_after=())
    monkeypatch.setattr(convert, "written_deviation_mm", off_when_long)
    out, rep = convert_text(src, 0.001, jobs=1)
    written = [e for e in parse_text(out).entities if isinstance(e, Nurbs)]
    assert len(written) >= 2 and all(len(e.points) <= 24 for e in written)
    assert not [why for _, why in rep.kept_g01 if why.startswith("rounded curve")]
    _check_round_trip(src, out, 0.001)


def test_bad_input():
    with pytest.raises(ValueError):
        convert_text("G1 X1 F100\n", 0.0)
    with pytest.raises(ValueError):
        convert_text("G1 X1 F100\n", 0.01, degree=7)
    with pytest.raises(GCodeError):
        convert_text("G1 X1 F100\nG33 X2 K1\n", 0.01)


def test_vcnc_fit_command(tmp_path):
    from machine.cli import main

    _, words = _ellipse_run()
    src = tmp_path / "in.nc"
    src.write_text(_program(words))
    dst = tmp_path / "out.nc"
    res = CliRunner().invoke(main, ["fit", str(src), "-o", str(dst), "--tol-mm", "0.01"])
    assert res.exit_code == 0, res.output
    assert "blocks" in res.output and "max deviation" in res.output and "fit time" in res.output
    parse_text(dst.read_text())
    bad = CliRunner().invoke(main, ["fit", str(src), "-o", str(dst), "--tol-mm", "-1"])
    assert bad.exit_code != 0


def test_split_runs_breaks_at_corners_feed_and_other_entities():
    from ipo.fit.g01_runs import split_runs
    from ipr.entities import Rapid

    def line(n, a, b, f=10.0):
        return Line(n, a, b, f)

    p = [(0.0, 0, 0), (1.0, 0, 0), (2.0, 0.2, 0), (3.0, 0.5, 0), (3.0, 1.5, 0), (3.0, 2.5, 0)]
    ents = [line(i + 1, p[i], p[i + 1]) for i in range(5)]  # turns: 11.3, 5.4, 73.3 (corner), 0 deg
    runs = split_runs(ents, corner_deg=30.0)
    assert [[e.line for e in r] for r in runs] == [[1, 2, 3], [4, 5]]
    assert len(split_runs(ents, corner_deg=80.0)) == 1
    ents2 = ents[:2] + [Rapid(9, p[2], p[2])] + [line(3, p[2], p[3], 20.0)] + ents[3:]
    assert [[e.line for e in r] for r in split_runs(ents2, corner_deg=80.0)] == [[1, 2], [3], [4, 5]]
    with pytest.raises(ValueError):
        split_runs(ents, corner_deg=200.0)


def test_vcnc_compare_circles_side_by_side(tmp_path):
    import json
    from pathlib import Path

    from machine.cli import main

    progs = Path(__file__).resolve().parents[3] / "programs"
    a, b = progs / "circle_g1_360.nc", progs / "circle_nurbs.nc"
    png = tmp_path / "cmp.png"
    res = CliRunner().invoke(main, ["compare", str(a), str(b), "--json", "--plot", str(png)])
    assert res.exit_code == 0, res.output
    figs = json.loads(res.output[res.output.index("{"):])
    assert figs["a"]["blocks"] == count_blocks(a.read_text()) and figs["b"]["bytes"] == len(b.read_bytes())
    for key in ("a", "b"):
        f = figs[key]
        # one circle of radius 10 at F1000 takes at least 2 pi 10 / (1000/60) s
        assert f["time_s"] > 2 * np.pi * 10 / (1000 / 60)
        assert 0 < f["min_feed_mm_min"] <= f["mean_feed_mm_min"] <= 1000 * 1.001
        assert f["rmax_max_um"] is None  # the default machine has no finishing section
    # the 360-gon lies within 0.4 um of the circle; both paths share the G64 corner blends (10 um)
    assert figs["a"]["path_distance_um"] < 15 and figs["b"]["path_distance_um"] < 15
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("target", ['"isotropic"', "3.3"])
def test_vcnc_compare_roughness_of_an_inclined_cut(tmp_path, target):
    import json
    import re
    from pathlib import Path

    from machine.cli import main

    # a straight cut inclined at atan(20/50) = 21.8 deg: the tool tip does not cut, so 002 eq. 2 holds,
    # R(f_i) = (f_p^2 + (f_i - f_p / 2 pi)^2) / 8r, smallest at f_i = f_p / 2 pi and (f_p^2 + (f_p / 2 pi)^2)
    # / 8r where the feed falls to 0 at the two ends. F2400 with S12500 and two flutes is f_i = 0.096 mm.
    toml = (Path(__file__).resolve().parents[3] / "programs" / "finish_machine.toml").read_text()
    machine = tmp_path / "m.toml"
    machine.write_text(re.sub(r"(?m)^roughness_target_um = .*$", f"roughness_target_um = {target}", toml))
    prog = tmp_path / "incline.nc"
    prog.write_text("G21 G90 G17 G64\nS12500 M3\nG0 X0 Y0 Z0\nG1 X50 Z-20 F2400\nM5\nM2\n")
    res = CliRunner().invoke(main, ["compare", str(prog), str(prog), "--machine", str(machine), "--json"])
    assert res.exit_code == 0, res.output
    figs = json.loads(res.output[res.output.index("{"):])["a"]
    r_mm, pick_mm, shift_mm = 3.0, 0.2, 0.2 / (2 * np.pi)

    def eq2_um(f_i):
        return (pick_mm**2 + (f_i - shift_mm) ** 2) / (8 * r_mm) * 1e3

    if target == "3.3":
        # eq. 5 allows f_i = p + sqrt(8 r R - f_p^2) = 0.23 mm: the cut runs at the programmed F, whose R is
        # the largest; the ramps pass through smaller ones
        assert figs["rmax_max_um"] == pytest.approx(eq2_um(0.096), rel=1e-3)
        assert eq2_um(0.0) < figs["rmax_mean_um"] < eq2_um(0.096)
    else:
        # the target is the cusp height across the feed, ~f_p^2 / 8r: the limiter holds f_i near f_p / 2 pi
        # at cruise, and the ends at rest are the largest
        cusp_um = (r_mm - np.sqrt(r_mm**2 - pick_mm**2 / 4)) * 1e3
        assert figs["rmax_max_um"] == pytest.approx(eq2_um(0.0), rel=1e-3)
        assert cusp_um * (1 - 1e-3) <= figs["rmax_mean_um"] <= cusp_um * 1.01


def test_vcnc_compare_roughness_needs_a_cut_that_moves_a_blu(tmp_path):
    from pathlib import Path

    from machine.cli import main

    # 2 um at F0.05 (0.8 nm a period): over the 11 periods of a slope chord the commanded position
    # moves by at most one BLU, mostly by none: the slope is taken from the nearest period that moved
    machine = Path(__file__).resolve().parents[3] / "programs" / "finish_machine.toml"
    prog = tmp_path / "crawl.nc"
    prog.write_text("G21 G90 G17 G64\nS12500 M3\nG0 X0 Y0 Z0\nG1 X0.002 Z-0.001 F0.05\nM5\nM2\n")
    res = CliRunner().invoke(main, ["compare", str(prog), str(prog), "--machine", str(machine), "--json"])
    assert res.exit_code == 0, res.output
    still = tmp_path / "still.nc"
    still.write_text("G21 G90 G17 G64\nS12500 M3\nG0 X0 Y0 Z0\nG1 X0.0004 F0.05\nM5\nM2\n")
    res = CliRunner().invoke(main, ["compare", str(still), str(still), "--machine", str(machine)])
    assert res.exit_code != 0 and "less than a BLU" in res.output


@pytest.mark.slow
def test_vcnc_fit_never_writes_a_group_the_controller_refuses(tmp_path):
    """LinuxCNC's lhchips4, lines 919-2700 (raster passes from line 920 on at F9991300 and F999800, both
    beyond the machine's reach, one chain), fitted at 10 um. Planned alone, that chain's group on line 502
    of the plain fit moves so unevenly in its parameter that the controller's arc-length table cannot hold
    it (at 20 um, with 3-decimal control points and tighter weight spreads, a group of lines 157-800 did:
    weights from 1.2e-6 to 1, E-NURBS-PATH, 0.1375 mm between u = 17054.906862 and 17054.906865). vcnc fit
    tables every group as the controller's check does and plans the moves of that one again in halves,
    checked again (a half still refused would stay G1): machine.check accepts the program it writes, and no
    move stays G1 for a refusal."""
    from conftest import require_corpus
    from ipo.config import default_config
    from ipo.feed.planner import nurbs_end_gap_mm
    from ipo.feed.split import planning_problem
    from machine.check import check_program
    from machine.cli import main

    path = require_corpus() / "g1_lhchips4.ngc"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    lines = path.read_text().split("\n")[918:2700]
    # where line 918 (a rapid) leaves the machine, and the modes in force there (lines 19 and 28 of the file)
    text = "\n".join(["G21 G64 P0.1 Q0.01", "G18", "G0 X-0.042 Y12.969 Z5.0 F9991300.0", *lines, "M2", ""])
    config = default_config()
    gap = nurbs_end_gap_mm(config)
    plain, _ = convert_text(text, 0.01, jobs=1)
    refused = [e.line for e in parse_text(plain).entities if isinstance(e, Nurbs) and planning_problem(e, gap)]
    if not refused:  # the fit's weights to the last bits depend on the CPU (numpy's BLAS and LAPACK)
        pytest.skip("this CPU's arithmetic fits that chain into groups the controller takes: the refusal does not "
                    "arise here (test_a_refused_group_is_planned_again_in_halves_until_the_controller_takes_them "
                    "holds the mechanism on every CPU)")
    src, dst = tmp_path / "in.ngc", tmp_path / "out.ngc"
    src.write_text(text)
    res = CliRunner().invoke(main, ["fit", str(src), "-o", str(dst), "--tol-mm", "0.01", "--jobs", "1"])
    assert res.exit_code == 0, res.output
    assert "the controller cannot follow the group" not in res.output
    out = dst.read_text()
    check_program(dst, config, np.array([a.min_mm for a in config.axes]), np.array([a.max_mm for a in config.axes]))
    written = [e for e in parse_text(out).entities if isinstance(e, Nurbs)]
    assert not any(planning_problem(e, gap) for e in written)
    assert len(written) > sum(isinstance(e, Nurbs) for e in parse_text(plain).entities)


@pytest.mark.parametrize("frame", [("G10 L2 P1 X10 Y5 Z0 R30", "G54"), ("G10 L1 P1 R2 Z0", "T1 M6", "G41 D1")])
def test_a_rotated_system_or_cutter_compensation_is_written_as_it_is(frame):
    """Program numbers in a rotated system (G10 L2 R) or under cutter compensation are not machine
    positions less an offset: a curve fitted to the machine path and written as program numbers would be
    rotated (or compensated) a second time. Such lines stay as written, and the report says why."""
    arc = [f"G1 X{20 * np.cos(a):.4f} Y{20 * np.sin(a):.4f}" for a in np.radians(np.arange(1, 181))]
    src = "\n".join(["G21 G90 G17", *frame, "G0 X20 Y0 Z1", "G1 Z-1 F600", *arc, "G1 X-25 Y0", "G40", "G0 Z5",
                     "M2", ""])
    out, rep = convert_text(src, 0.01)
    assert out == src
    assert any("rotated system" in why for _, why in rep.kept_g01)
    plain = src.replace("\n".join(frame) + "\n", "").replace("G40\n", "")
    out_plain, _ = convert_text(plain, 0.01)
    assert count_blocks(out_plain) < count_blocks(plain) / 10   # the same arc, unrotated, is fitted


def test_vcnc_fit_compare_on_every_planner(tmp_path):
    """`vcnc fit --compare` prints each planner's machining time before and after: the same figures as
    `vcnc compare --planner P`, each at least one circle of radius 10 at F1000 takes; with --stock both
    machined surfaces; a twin that cannot run the fitted program says why instead of a figure."""
    import json
    import re
    from pathlib import Path

    from machine.cli import main

    src = Path(__file__).resolve().parents[3] / "programs" / "circle_g1_360.nc"
    dst = tmp_path / "c.nc"
    res = CliRunner().invoke(main, ["fit", str(src), "-o", str(dst), "--tol-mm", "0.01", "--dialect", "g5.2",
                                    "--compare", "--stock=-14,-14,-3,14,14,0.5", "--grid-um", "200", "--tool", "1"])
    assert res.exit_code == 0, res.output
    assert "machined surfaces" in res.output and "difference B - A" in res.output
    rows = dict(re.findall(r"^(vcnc|grbl|linuxcnc) +([\d.]+ s -> +[\d.]+ s)", res.output, re.M))
    assert set(rows) == {"vcnc", "grbl", "linuxcnc"}, res.output
    for planner, cell in rows.items():
        before, after = (float(t) for t in re.findall(r"[\d.]+(?= s)", cell))
        assert min(before, after) > 2 * np.pi * 10 / (1000 / 60)
        cmp = CliRunner().invoke(main, ["compare", str(src), str(dst), "--planner", planner, "--json"])
        figs = json.loads(cmp.output[cmp.output.index("{"):])
        assert (round(figs["a"]["time_s"], 2), round(figs["b"]["time_s"], 2)) == (before, after), planner
    # a 3-D G06.2 group: LinuxCNC 2.9 runs only planar G5.2 curves
    helix = tmp_path / "helix.nc"
    moves = "\n".join(f"X{10 * np.cos(t):.4f} Y{10 * np.sin(t):.4f} Z{-t / 10:.4f}" for t in np.linspace(0, 3, 120))
    helix.write_text(f"G21 G17 G90 G94 G64\nG0 X10 Y0 Z5\nG1 Z0 F600\n{moves}\nG0 Z5\nM2\n")
    res = CliRunner().invoke(main, ["fit", str(helix), "-o", str(dst), "--tol-mm", "0.01", "--compare"])
    assert res.exit_code == 0, res.output
    assert re.search(r"^linuxcnc +not run: .*E-TWIN-UNSUPPORTED", res.output, re.M), res.output
    assert re.search(r"^grbl +[\d.]+ s ->", res.output, re.M), res.output
    bad = CliRunner().invoke(main, ["fit", str(src), "-o", str(dst), "--tol-mm", "0.01", "--stock=0,0,0,1,1,1"])
    assert bad.exit_code == 2 and "add --compare" in bad.output
