"""The fitting and surface chain refuses bad input with ipo's typed errors: each code of
ipo.errors that `vcnc fit`, `vcnc surface`, `vcnc toolpath` and `vcnc interp` report, met through the CLI
(exit 1, `WHERE: error[CODE]: message`), and every ipo code documented in docs/gcode-errors.md."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from ipo import errors
from ipo.surface.iges import write_iges
from ipo.surface.section_fit import fit_shared
from ipo.surface.skinning import skin
from machine.cli import main
from surface_cases import cylinder

DOCS = Path(__file__).resolve().parents[2] / "docs" / "gcode-errors.md"


def refused(code: str, *args) -> str:
    """Run `vcnc ARGS`, expect exit 1 with the code; the message's text."""
    result = CliRunner().invoke(main, [str(a) for a in args])
    assert result.exit_code == 1, result.output
    assert f"error[{code}]: " in result.output and "internal error" not in result.output, result.output
    return result.output


def _csv(path: Path, sections: list[np.ndarray]) -> Path:
    path.write_text("x,y,z,section\n" + "".join(f"{float(x)!r},{float(y)!r},{float(z)!r},{h}\n"
                                                  for h, q in enumerate(sections, 1) for x, y, z in q))
    return path


def _iges(path: Path, surf) -> Path:
    write_iges(path, [surf])
    return path


def test_surface_points(tmp_path):
    pts = tmp_path / "p.csv"
    pts.write_text("x,y,z\n0,0,0\n1,zero,0\n")
    out = refused(errors.SURFACE_POINTS, "surface", pts, "-o", tmp_path / "s.igs")
    assert f"{pts}:3: error[E-IPO-SURFACE-POINTS]: 'zero' is not a number" in out


def test_fit_settings_control_points_out_of_range(tmp_path):
    pts = _csv(tmp_path / "p.csv", cylinder().sections)
    out = refused(errors.FIT_SETTINGS, "surface", pts, "-o", tmp_path / "s.igs", "--ctrl", "3")
    assert "control-point count 3 must be in 4..14" in out  # order 4; 14 points per section


def test_fit_data_a_section_at_one_place(tmp_path):
    secs = cylinder().sections
    secs[2] = np.repeat(secs[2][:1], len(secs[2]), axis=0)
    out = refused(errors.FIT_DATA, "surface", _csv(tmp_path / "p.csv", secs), "-o", tmp_path / "s.igs")
    assert "all identical" in out


def test_fit_tolerance_out_of_reach(tmp_path):
    # four points fit any cubic exactly; the shared count of four cannot follow the wavy 20-point section
    x = np.linspace(0.0, 10.0, 20)
    secs = [np.c_[x[::6][:4], np.zeros(4), np.zeros(4)], np.c_[x, np.full(20, 5.0), np.sin(3 * x)]]
    out = refused(errors.FIT_TOLERANCE, "surface", _csv(tmp_path / "p.csv", secs), "-o", tmp_path / "s.igs",
                  "--tol-mm", "0.001")
    assert "no control-point count up to 4 fits every section within 0.001 mm" in out


def test_skin_needs_two_sections(tmp_path):
    out = refused(errors.SKIN, "surface", _csv(tmp_path / "p.csv", cylinder().sections[:1]), "-o", tmp_path / "s.igs")
    assert "two or more sections" in out


def test_iges_reader(tmp_path):
    bad = tmp_path / "bad.igs"
    bad.write_text("not an IGES file\n")
    out = refused(errors.IGES, "toolpath", bad, "--ball-mm", "3", "--pick-mm", "1", "-o", tmp_path / "f.nc")
    assert f"{bad}:1: error[E-IPO-IGES]: not an 80-column IGES record" in out


def test_surface_data_a_zero_weight(tmp_path):
    surf, _ = skin(fit_shared(cylinder().sections, 6).fits)
    surf.weights[2, 3] = 0.0  # written as the file would hold it; the reader's surface refuses it
    igs = _iges(tmp_path / "w0.igs", surf)
    out = refused(errors.SURFACE_DATA, "toolpath", igs, "--ball-mm", "3", "--pick-mm", "1", "-o", tmp_path / "f.nc")
    assert "weights must all be > 0" in out


def test_toolpath_settings(tmp_path):
    igs = _iges(tmp_path / "cyl.igs", skin(fit_shared(cylinder().sections, 6).fits)[0])
    out = refused(errors.TOOLPATH_SETTINGS, "toolpath", igs, "--ball-mm", "0", "--pick-mm", "1",
                  "-o", tmp_path / "f.nc")
    assert "ball radius must be > 0 mm, got 0.0" in out


def test_toolpath_surface_gouge(tmp_path):
    # a concave valley of radius 2 mm: a 3 mm ball's centre path folds back
    flipped = [q * np.array([1.0, 1.0, -1.0]) for q in cylinder(radius=2.0, length=6.0, sweep_deg=90.0).sections]
    igs = _iges(tmp_path / "valley.igs", skin(fit_shared(flipped, 6).fits)[0])
    out = refused(errors.TOOLPATH_SURFACE, "toolpath", igs, "--ball-mm", "3", "--pick-mm", "1",
                  "-o", tmp_path / "f.nc")
    assert "folds back (gouge)" in out


def test_interp_study_without_motion(tmp_path):
    prog = tmp_path / "dwell.nc"
    prog.write_text("G21 G90\nG4 P0.5\nM2\n")
    assert f"{prog}: error[{errors.STUDY}]: no motion to interpolate" in refused(errors.STUDY, "interp", prog)


@pytest.mark.parametrize("code", errors.CODES)
def test_every_ipo_code_is_documented(code):
    assert f"`{code}`" in DOCS.read_text()
