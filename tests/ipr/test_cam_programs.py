"""CAM-style programs (tests/cam/, written for these tests in the styles of Fusion 360/HSM,
generic Fanuc, Mastercam, Mach3 wizards, Haas, FreeCAD, Estlcam, CamBam, VCarve, SheetCam,
PyCAM and F-Engrave posts) run in `vcnc run` with the dialect each was written for (the last
part of its name): every one completes at its last programmed point with 0 limit violations.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

import ipr
from ipr.entities import Line, Rapid
from machine.cli import main

ROOT = Path(__file__).resolve().parents[2]
CAM = ROOT / "tests" / "cam"
PROGRAMS = sorted(p for p in CAM.iterdir() if p.suffix in (".nc", ".ngc", ".tap"))
TOOLS = {1: (0.0, 3.0), 2: (20.0, 2.5), 3: (30.0, 1.5)}   # tool -> (length, radius) mm


def machine_file(tmp_path: Path, dialect: str) -> Path:
    text = (ROOT / "ipo" / "machine.toml").read_text()
    # tool 1 of the default machine is a 6 mm ball: cutter radius 3 mm
    tools = "".join(f"\n[tools.{t}]\nlength_mm = {length}\ndiameter_mm = {2 * radius}\n"
                    for t, (length, radius) in TOOLS.items() if t != 1)
    path = tmp_path / f"{dialect}.toml"
    path.write_text(f'dialect = "{dialect}"\n' + text + tools)
    return path


def dialect_of(path: Path) -> str:
    return path.stem.rsplit("_", 1)[1]


@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: p.name)
def test_cam_program_runs_to_completion(tmp_path, path: Path) -> None:
    result = CliRunner().invoke(main, ["run", str(path), "--machine", str(machine_file(tmp_path, dialect_of(path))),
                                       "--json"])
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["state"] == "completed"
    assert summary["limit_violations"] == 0
    setup = ipr.Setup(tool_lengths_mm={t: v[0] for t, v in TOOLS.items()}, dialect=dialect_of(path))
    last = [e for e in ipr.parse_file(path, setup=setup).entities if isinstance(e, (Line, Rapid))][-1]
    assert summary["position_mm"] == pytest.approx(list(last.end), abs=1e-3)


def test_the_programs_cover_the_styles() -> None:
    assert len(PROGRAMS) >= 14
    assert {dialect_of(p) for p in PROGRAMS} == {"linuxcnc", "fanuc", "haas", "mach3", "grbl"}


def test_dialect_codes_are_refused_in_linuxcnc() -> None:
    """What the Haas, FreeCAD-grbl and Fanuc programs need is not LinuxCNC: rs274 refuses it too."""
    for path, code in ((CAM / "fusion_haas.nc", "E-GCODE-UNSUPPORTED"), (CAM / "freecad_grbl.nc", "E-ARC-FORMAT")):
        with pytest.raises(ipr.GCodeError) as err:
            ipr.parse_file(path)
        assert err.value.diagnostics[0].code == code
