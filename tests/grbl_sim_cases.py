"""The grbl-sim measurements (tests/data/grbl_sim/measured.json) as the twin's inputs, for the
twin's tests and bench/twins.py: each case's program as `vcnc stream --dry-run` sends it to a
board at machine zero (the built-in machine file), the board's `$$`, and the wire it measured on.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from ipo.config import default_config
from ipo.grbl_settings import GrblSettings, read_dump
from ipr import parse_text

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "grbl_sim"
SHARED = ROOT.parent / "shared"
MEASURED = json.loads((DATA / "measured.json").read_text())
SIM_BYTE_S = 66 / 16e6  # grbl-sim's own byte period at 115200: 2*UBRR0+1 ticks, doubled by U2X0
SIM_CLIENT_S = 1e-4  # grbl's `ok` to the client's next line: grbl-sim writes answers with no wire time,
# and the measuring client answers in about 1 ms of wall time, 0.1 ms at -t 0.1


@dataclass(frozen=True)
class Case:
    label: str
    text: str | None  # None: a corpus program and ../shared is absent
    settings: GrblSettings
    baud: float
    motion_s: float
    raw: dict

    def entities(self):
        return parse_text(self.text, self.raw["program"]).entities

    def wire(self):
        from machine.grbl.wire import wire_lines
        from machine.planners import grbl_groups

        return wire_lines(grbl_groups(self.entities(), default_config()))


def _text(case: dict) -> str | None:
    name = case["program"]
    path = SHARED / name if name.startswith("corpus/") else ROOT / name if name.startswith("programs/") \
        else DATA / name
    if not path.exists():
        return None
    text = path.read_text()
    if "head_lines" in case:
        text = "".join(text.splitlines(keepends=True)[:case["head_lines"]]) + "M2\n"
    return text


def cases() -> list[Case]:
    out = []
    for raw in MEASURED["cases"]:
        wire = raw["wire_baud"]
        label = (f"{Path(raw['program']).name}{'[:%d]' % raw['head_lines'] if 'head_lines' in raw else ''} "
                 f"{Path(raw['settings']).stem.removeprefix('settings_')} "
                 + (f"{wire:.0f} baud" if wire else "sim wire"))
        out.append(Case(label, _text(raw), read_dump(DATA / raw["settings"]), wire or 10.0 / SIM_BYTE_S,
                        raw["motion_s"], raw))
    return out
