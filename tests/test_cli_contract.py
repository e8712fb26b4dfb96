"""The CLI contract: every subcommand on every class of bad input gives a clear message and an
exit code of the documented convention (0 done, 1 the program/machine/run failed, 2 usage),
never a traceback, and checks its output paths before any work.

Classes: a missing file, a folder, an empty file, binary bytes, a huge value or line, a
program without motion, and an output path in a folder that does not exist. Each subcommand
gets each class in the argument it reads; the run counts as clean when it exits 0, 1 or 2 as
the class demands and prints neither a traceback nor vcnc's "internal error" line (which the
CLI prints instead of a traceback for an unexpected exception: here it would be a bug).
Then the issue's reproducers, one by one.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from surface_cases import bump, csv_text

from machine.cli import main

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "programs" / "demo.nc"
BINARY = bytes(range(256)) * 8
HUGE_PROGRAM = "G0 X0 Y0 Z0\nG1 X" + "9" * 400 + " F100\n" + "(" + "x" * 100_000 + ")\nM2\n"
NO_MOTION = "G21 G90\nM3 S1000\nM5\nM2\n"


def vcnc(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def assert_clean(result, codes):
    text = (result.stdout or "") + (result.stderr or "")
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise AssertionError(f"traceback: {result.exception!r}\n{text}") from result.exception
    assert "Traceback" not in text and "internal error" not in text, text
    assert result.exit_code in codes, (result.exit_code, text)
    return text


@pytest.fixture()
def inputs(tmp_path):
    """name -> (path, exit codes allowed) for each class of bad input, as a program."""
    def write(name, data):
        p = tmp_path / name
        p.write_bytes(data) if isinstance(data, bytes) else p.write_text(data)
        return p
    folder = tmp_path / "folder.nc"
    folder.mkdir()
    return {
        "missing": (tmp_path / "missing.nc", {2}),
        "folder": (folder, {2}),
        "empty": (write("empty.nc", ""), {0, 1}),
        "binary": (write("binary.nc", BINARY), {1}),
        "huge": (write("huge.nc", HUGE_PROGRAM), {1}),
        "no_motion": (write("none.nc", NO_MOTION), {0, 1}),
    }


def _iges(tmp_path) -> Path:
    points = tmp_path / "bump.csv"
    points.write_text(csv_text(bump(n_sections=5, n_points=12).sections))
    out = tmp_path / "bump.igs"
    assert vcnc("surface", points, "-o", out, "--tol-mm", "0.05").exit_code == 0
    return out


def _commands(path, tmp_path):
    """Each subcommand with `path` as the file it reads (argument lists)."""
    out = tmp_path / "out"
    return {
        "parse": ["parse", path],
        "run": ["run", path],
        "run-plot": ["run", path, "--plot", out.with_suffix(".png")],
        "interp": ["interp", path, "--step-um", "100"],
        "plot": ["plot", path, "--out", out.with_suffix(".png")],
        "stream": ["stream", path, "--dry-run"],
        "fit": ["fit", path, "-o", out.with_suffix(".nc"), "--tol-mm", "0.01"],
        "compare-a": ["compare", path, DEMO],
        "compare-b": ["compare", DEMO, path],
        "surface": ["surface", path, "-o", out.with_suffix(".igs")],
        "toolpath": ["toolpath", path, "--ball-mm", "3", "--pick-mm", "0.5", "-o", out.with_suffix(".nc")],
    }


@pytest.mark.parametrize("command", ["parse", "run", "run-plot", "interp", "plot", "stream", "fit", "compare-a",
                                     "compare-b", "surface", "toolpath"])
@pytest.mark.parametrize("kind", ["missing", "folder", "empty", "binary", "huge", "no_motion"])
def test_every_subcommand_on_every_class_of_bad_input(tmp_path, inputs, command, kind):
    path, codes = inputs[kind]
    if command in ("plot", "surface", "toolpath") and kind in ("huge", "no_motion"):
        codes = {1}  # a program is not a trace, a points file or an IGES file
    assert_clean(vcnc(*_commands(path, tmp_path)[command]), codes)


@pytest.mark.parametrize("args", [
    ["run", DEMO, "--plot", "{missing}/x.png"], ["run", DEMO, "--trace", "{missing}/x.npz"],
    ["run", DEMO, "--trace", "{tmp}/x.txt"], ["run", DEMO, "--plot", "{tmp}"],
    ["plot", "{trace}", "--out", "{missing}/x.png"], ["interp", DEMO, "--out", "{missing}/x.npz"],
    ["fit", DEMO, "-o", "{missing}/out.nc", "--tol-mm", "0.01"],
    ["compare", DEMO, DEMO, "--plot", "{missing}/c.png"],
    ["surface", "{points}", "-o", "{missing}/s.igs"], ["surface", "{points}", "-o", "{tmp}/s.txt"],
    ["toolpath", "{iges}", "--ball-mm", "3", "--pick-mm", "0.5", "-o", "{missing}/f.nc"],
], ids=lambda a: " ".join(str(x) for x in a[:1] + a[2:4]))
def test_an_output_path_that_cannot_be_written_is_a_usage_error_before_any_work(tmp_path, args):
    trace = tmp_path / "t.npz"
    trace.write_bytes(b"not read: the output path is refused first")
    points = tmp_path / "p.csv"
    points.write_text(csv_text(bump(n_sections=5, n_points=12).sections))
    fill = {"missing": tmp_path / "no" / "such", "tmp": tmp_path, "trace": trace, "points": points,
            "iges": points}
    text = assert_clean(vcnc(*[str(a).format(**fill) for a in args]), {2})
    assert "Invalid value" in text and not list(tmp_path.glob("*.png"))


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_an_output_folder_without_write_permission_is_a_usage_error(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    assert "cannot be written" in assert_clean(vcnc("run", DEMO, "--plot", locked / "x.png"), {2})


def test_version_and_debug():
    text = assert_clean(vcnc("--version"), {0})
    assert text.startswith("vcnc, version ")


def test_python_m_machine_cli_runs_the_cli(tmp_path):
    """A process skips Python's teardown (machine.cli): what the command wrote is all there, and
    the exit code is the command's, as CliRunner sees them in this process."""
    import subprocess
    program = ROOT / "programs" / "demo.nc"
    for args in (["parse", str(program), "--json"], ["parse", str(tmp_path / "nope.nc")], ["--version"]):
        done = subprocess.run([sys.executable, "-m", "machine.cli", *args], capture_output=True, text=True,
                              timeout=60)
        inside = CliRunner().invoke(main, args, prog_name="python -m machine.cli")
        assert (done.returncode, done.stdout) == (inside.exit_code, inside.stdout), args
        assert done.stderr.strip().splitlines()[-1:] == inside.stderr.strip().splitlines()[-1:], args
    assert done.stdout.startswith("vcnc, version")


def test_parse_and_run_agree_on_a_missing_file(tmp_path):
    codes = {vcnc(cmd, tmp_path / "nope.nc").exit_code for cmd in ("parse", "run", "stream", "interp")}
    assert codes == {2}


def test_an_empty_program_says_nothing_moved_with_plot_and_compare(tmp_path):
    empty = tmp_path / "empty.nc"
    empty.write_text(NO_MOTION)
    text = assert_clean(vcnc("run", empty, "--plot", tmp_path / "x.png"), {0})
    assert "nothing moved" in text and not (tmp_path / "x.png").exists()
    text = assert_clean(vcnc("compare", DEMO, empty), {1})
    assert "nothing moved" in text


def test_huge_arc_turns_are_refused_by_the_interpreter(tmp_path):
    for p in ("1000000000", "[10**30]"):
        prog = tmp_path / "p.nc"
        prog.write_text(f"G0 X1 Y0\nG2 X1 Y0 I-1 P{p} F100\nM2\n")
        text = assert_clean(vcnc("run", prog), {1})
        assert ":2:" in text and "error[E-VALUE]: arc turns" in text and "from 1 to 1000" in text


def test_exponent_notation_is_named(tmp_path):
    prog = tmp_path / "p.nc"
    prog.write_text("G0 X1e5\nG0 X0 E5\n")
    text = assert_clean(vcnc("parse", "--all-errors", prog), {1})
    first, second = [line for line in text.splitlines() if "error[" in line]
    assert ":1:6:" in first and "exponent notation is not G-code" in first
    assert "exponent notation" not in second  # an E word after a space is just an E word


def test_interp_bounds_the_number_of_steps():
    text = assert_clean(vcnc("interp", DEMO, "--step-um", "1e-300"), {2})
    assert "at most 20,000,000" in text
    assert_clean(vcnc("interp", DEMO, "--step-um", "nan"), {2})


@pytest.mark.parametrize("content,words", [
    ("x,y,z,section\n" + "".join(f"{i},0,{i % 2},1\n" for i in range(6)), "two or more sections"),
    (BINARY, "not a text file"),
    ("x,y,z,section\n0,0,0,1\n1e300,0,0,1\n2,0,0,1\n3,0,0,1\n0,1,0,2\n1,1,0,2\n2,1,0,2\n3,1,0,2\n", ":3: error[E-IPO-SURFACE-POINTS]: 1e+300 mm"),
])
def test_surface_on_bad_points(tmp_path, content, words):
    points = tmp_path / "p.csv"
    points.write_bytes(content) if isinstance(content, bytes) else points.write_text(content)
    text = assert_clean(vcnc("surface", points, "-o", tmp_path / "s.igs"), {1})
    assert words in text and str(points) in text


def test_stream_increments_dry_run_refuses_a_terminal(monkeypatch):
    from machine.commands import stream
    monkeypatch.setattr(stream, "_stdout_is_terminal", lambda: True)
    result = CliRunner().invoke(stream.command, [str(DEMO), "--protocol", "increments", "--dry-run"])
    text = (result.stdout or "") + (result.stderr or "")
    assert result.exit_code == 2 and "redirect stdout" in text


def test_trapezoid_mode_counts_jerk_and_says_it_is_not_limited(tmp_path):
    """Trapezoid mode steps the acceleration: the periods over the jerk limit are counted (the
    drive's stencil of h periods, recomputed here from the trace) and kept out of the total."""
    import json
    trace = tmp_path / "demo.npz"
    summary = json.loads(assert_clean(vcnc("run", DEMO, "--json", "--trace", trace), {0}).strip().splitlines()[-1])
    assert summary["limits_checked"] == ("100 100 100 mm/s; 1000 1000 1000 mm/s^2; 100000 100000 100000 mm/s^3 "
                                         "(jerk counted, not limited in trapezoid mode)")
    h, blu, period = summary["accel_stencil_periods"], 1e-3, 1e-3
    pos = np.load(trace)["pos_mm"]
    pos = np.vstack([np.repeat(pos[:1], 3 * h, axis=0), pos])  # standing still before the start
    jerk = np.abs(pos[3 * h:] - 3 * pos[2 * h:-h] + 3 * pos[h:-2 * h] - pos[:-3 * h]) / (h * period) ** 3
    over = int(np.sum(np.any(jerk > 1e5 + 4 * blu / (h * period) ** 3 + 1e-9, axis=1)))
    assert over > 0 and summary["limit_violations_by_kind"]["jerk"] == over
    assert summary["limit_violations"] == 0
    assert np.max(summary["max_axis_jerk_mm_s3"]) > 1e5  # measured above the configured 1e5: not a violation
