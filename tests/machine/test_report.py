"""`--report`: the digest against the drive and the program text, the page in a real browser."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import browser
from machine.cli import main

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "programs" / "demo.nc"
FINISH = ROOT / "programs" / "finish_nurbs.nc"
FINISH_MACHINE = ROOT / "programs" / "finish_machine.toml"


def vcnc(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    if result.exception and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def _demo_run():
    from ipo.config import default_config
    from machine.controller import Controller
    from machine.report.digest import DigestSink
    from machine.trace import MemoryTrace

    ctl = Controller(default_config())
    program = ctl.check(DEMO)
    meta = ctl.limits.meta()
    sink, memory = DigestSink(meta, max_buckets=64), MemoryTrace(meta)
    ctl.sinks = [sink, memory]
    result = ctl.run(program)
    return program, result, sink.finish(), memory.close()


def _source_line(path: Path, pattern: str) -> int:
    lines = path.read_text().splitlines()
    return next(i + 1 for i, text in enumerate(lines) if re.search(pattern, text))


def test_digest_extremes_are_the_drives_maxima_and_the_programmed_feed():
    _, result, digest, trace = _demo_run()
    env = digest.env
    assert env.width > 1  # 2512 periods in 64 buckets: merged
    peak = np.maximum(np.abs(env.lo), np.abs(env.hi)).max(axis=0)
    names = list(digest.signals)
    v = peak[names.index("vx"):names.index("vz") + 1]
    a = peak[names.index("ax"):names.index("az") + 1]
    np.testing.assert_allclose(v, result.max_axis_velocity_mm_s, atol=1e-3)
    np.testing.assert_allclose(a, result.max_axis_accel_mm_s2, atol=2e-3)
    assert env.hi[:, 0].max() == trace["feed_mm_s"].max() and env.lo[:, 0].min() == trace["feed_mm_s"].min()
    # each bucket's extremes sit at periods of the trace that carry exactly those values
    k = names.index("vx")
    vx = trace["inc_blu"][:, 0] * (trace.meta["blu_mm"] / trace.meta["period_s"])
    np.testing.assert_array_equal(vx[env.arg_hi[:, k]], env.hi[:, k])


def test_digest_knows_the_line_of_every_period_and_every_block_end():
    program, _, digest, trace = _demo_run()
    periods = np.arange(len(trace))
    lines = np.array([digest.line_at(p) for p in periods])
    np.testing.assert_array_equal(lines, trace["line"])
    # every G1/G3 end point written in the program is within one period's step of a vertex of the
    # 3-D path (a period ends where its step ends, the block's end lies inside the period)
    step = trace["feed_mm_s"].max() * trace.meta["period_s"] + trace.meta["blu_mm"]
    ends = []
    x = y = z = 0.0
    for text in DEMO.read_text().splitlines():
        words = dict(re.findall(r"([XYZ])(-?[\d.]+)", text))
        if re.match(r"G[0123]\b", text) and words:
            x, y, z = (float(words.get(c, v)) for c, v in zip("XYZ", (x, y, z)))
            ends.append((x, y, z))
    xyz = digest.path_rows[:, :3]
    for end in ends:
        assert np.min(np.linalg.norm(xyz - end, axis=1)) <= step, end


def test_run_report_is_one_file_without_network(tmp_path):
    out = tmp_path / "run.html"
    r = vcnc("run", DEMO, "--report", out)
    assert r.exit_code == 0, r.stderr
    text = out.read_text()
    assert not re.search(r"<script[^>]*\bsrc=|<link[^>]*\bhref=\"?https?:|<img[^>]*\bsrc=\"?https?:", text)
    assert "window.vcncReport" in text and "vcnc-blob" in text


def test_report_path_is_checked_before_the_run(tmp_path):
    out = tmp_path / "missing" / "run.html"
    r = vcnc("run", DEMO, "--report", out, "--json")
    assert r.exit_code == 2 and "--report" in r.stderr and "does not exist" in r.stderr
    assert r.stdout == "" and not out.parent.exists()


needs_chromium = pytest.mark.skipif(browser.CHROMIUM is None,
                                    reason="chromium is not installed (.ci/run installs Debian's chromium)")


def _open(page_path: Path, shot: Path):
    page = browser.Page(page_path.as_uri())
    page.wait_for("window.vcncReport && (window.vcncReport.ready || !!document.getElementById('error'))")
    assert page.evaluate("window.vcncReport.ready"), page.evaluate("document.getElementById('error').textContent")
    return page


def _plots(page) -> int:
    return page.evaluate("document.querySelectorAll('.js-plotly-plot').length")


def _not_blank(png: Path) -> float:
    """The share of pixels that are not the page's white."""
    import matplotlib.image

    img = matplotlib.image.imread(png)[..., :3]
    return float(np.mean(np.any(img < 0.95, axis=2)))


@needs_chromium
@pytest.mark.slow
def test_demo_report_in_chromium(tmp_path):
    out = tmp_path / "demo.html"
    assert vcnc("run", DEMO, "--report", out).exit_code == 0
    arc_line = _source_line(DEMO, r"^G3 X30 Y10")
    with _open(out, tmp_path / "demo.png") as page:
        assert _plots(page) == 3
        # the arc G3 X30 Y10 I0 J10 starts after 5 + 5 + 20 mm (rapid up, feed down, G1 X20) and is
        # a quarter circle of radius 10 about X20 Y10: its middle is at s = 30 + 2.5·pi
        pick = page.evaluate("window.vcncReport.selectDistance(30 + 2.5 * Math.PI)")[0]
        assert pick["line"] == arc_line and pick["text"].startswith("G3 X30 Y10")
        x, y, _ = pick["pos"]
        assert math.hypot(x - 20, y - 10) == pytest.approx(10, abs=0.01)
        assert page.evaluate("document.getElementById('pick').textContent").startswith(f"line {arc_line}: G3")
        # the same instant by time gives the same line
        again = page.evaluate(f"window.vcncReport.select({pick['t']})")
        assert again["line"] == arc_line
        shot = page.screenshot(tmp_path / "demo.png")
        assert page.errors == []
    assert _not_blank(shot) > 0.05


@needs_chromium
@pytest.mark.slow
def test_finishing_report_in_chromium_names_the_traced_line(tmp_path):
    out, trace = tmp_path / "finish.html", tmp_path / "finish.npz"
    r = vcnc("run", FINISH, "--machine", FINISH_MACHINE, "--report", out, "--trace", trace)
    assert r.exit_code == 0, r.stderr
    from machine.trace import load_trace

    tr = load_trace(trace)
    source = FINISH.read_text().splitlines()
    with _open(out, tmp_path / "finish.png") as page:
        assert _plots(page) == 3
        for p in np.linspace(0, len(tr) - 1, 17).astype(int)[1:]:
            pick = page.evaluate(f"window.vcncReport.select({float(tr['t_s'][p])!r})")
            assert pick["line"] == tr["line"][p]
            assert pick["text"] == source[pick["line"] - 1].rstrip()
            assert pick["period"] == p
            # the page keeps the position at block ends and every 16th period and interpolates between:
            # on this surface a chord of 16 periods is off by < 40 um
            np.testing.assert_allclose(pick["pos"], tr["pos_mm"][p], atol=0.04)
        page.evaluate("document.getElementById('colourby').value = 'reason'; "
                      "document.getElementById('colourby').dispatchEvent(new Event('change')); true")
        shot = page.screenshot(tmp_path / "finish.png")
        assert page.errors == []
    assert _not_blank(shot) > 0.05


@needs_chromium
@pytest.mark.slow
def test_compare_report_in_chromium_aligns_both_programs_by_distance(tmp_path):
    g2, nurbs = ROOT / "programs" / "circle_g2.nc", ROOT / "programs" / "circle_nurbs.nc"
    out = tmp_path / "cmp.html"
    r = vcnc("compare", g2, nurbs, "--report", out)
    assert r.exit_code == 0, r.stderr
    g2_line = _source_line(g2, r"^G2 X10 Y0 I-10")
    nurbs_lines = [i + 1 for i, text in enumerate(nurbs.read_text().splitlines()) if re.match(r"G06\.2|K", text)]
    with _open(out, tmp_path / "cmp.png") as page:
        assert _plots(page) == 2
        # both start with 5 mm of rapid up, 10 mm across and 5 mm down to the circle of radius 10
        # about X0 Y0 (from the G2's I-10): half way round it, both tools are on that circle
        picks = page.evaluate("window.vcncReport.selectDistance(20 + 10 * Math.PI)")
        assert [p["line"] for p in picks][0] == g2_line and picks[1]["line"] in nurbs_lines
        for p in picks:
            assert math.hypot(p["pos"][0], p["pos"][1]) == pytest.approx(10, abs=0.01)
            assert p["pos"][0] == pytest.approx(-10, abs=0.05)
        assert page.evaluate("document.getElementById('pick').textContent").count("line ") == 2
        shot = page.screenshot(tmp_path / "cmp.png")
        assert page.errors == []
    assert _not_blank(shot) > 0.05


def test_surface_grid_keeps_the_deepest_point_of_each_block():
    from machine.report.build import surface_grid

    x, y = np.linspace(0, 10, 1001), np.linspace(0, 5, 501)
    z = np.zeros((len(y), len(x)))
    z[123, 456] = -0.3  # a one-node gouge
    gx, gy, gz = surface_grid(x, y, z, nodes=100)
    assert gz.shape == (len(gy), len(gx)) and len(gx) <= 100 and len(gy) <= 100
    assert gz.min() == -0.3 and np.count_nonzero(gz) == 1
    j, i = np.argwhere(gz == -0.3)[0]
    assert gx[i] <= x[456] < gx[i] + (gx[1] - gx[0]) and gy[j] <= y[123] < gy[j] + (gy[1] - gy[0])


@needs_chromium
def test_workpiece_surface_is_drawn_when_the_run_has_one(tmp_path):
    from types import SimpleNamespace

    from machine.report.build import machine_info, run_report

    program, result, digest, _ = _demo_run()
    x, y = np.linspace(-5, 35, 81), np.linspace(-5, 35, 81)
    z = -0.01 * ((x[None, :] - 15) ** 2 + (y[:, None] - 15) ** 2) / 10
    out = run_report(tmp_path / "surface.html", digest, program=program, summary=result.summary(),
                     machine=machine_info(None), surface=SimpleNamespace(x_mm=x, y_mm=y, z_mm=z))
    with _open(out, tmp_path / "surface.png") as page:
        kinds = page.evaluate("document.getElementById('path3d').data.map(t => t.type)")
        assert "surface" in kinds
        zs = page.evaluate("document.getElementById('path3d').data.find(t => t.type === 'surface').z.flat()")
        assert min(zs) == pytest.approx(z.min(), abs=1e-6) and len(zs) == z.size
        assert page.errors == []


def test_run_with_a_workpiece_puts_its_surface_in_the_report(tmp_path):
    import json as json_

    out = tmp_path / "cut.html"
    r = vcnc("run", DEMO, "--machine", FINISH_MACHINE, "--stock=-5,-5,-2,35,35,1", "--grid-um", 250,
             "--report", out)
    assert r.exit_code == 0, r.stderr
    text = out.read_text()
    info = json_.loads(re.search(r'id="vcnc-info">(.*?)</script>', text).group(1))
    assert info["runs"][0]["surface"] is True
    dtype, _, size, shape = info["arrays"]["r0_surf_z"]
    # the stock is 40 x 40 mm at 250 um: 161 nodes a side, under the page's 300
    assert shape == [161, 161] and size == 161 * 161
