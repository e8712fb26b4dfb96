"""LinuxCNC 2.9 measurements (tests/data/linuxcnc_twin) and the twin run the same way.

measured.csv holds, per machine (tests/data/linuxcnc_twin/ini/<machine>.ini, the INI file
LinuxCNC ran with) and program, the cycle time LinuxCNC's own simulator took (README.md
there says how it was measured). `twin_run` runs the same program through the LinuxCNC twin
with the settings read from that INI file and measures its cycle time as run_linuxcnc.sh
measures LinuxCNC's: from the first period that moves to the period that first commands the
final position. Used by tests/ipo/feed/linuxcnc_twin and bench/twins.py.
"""
from __future__ import annotations

import csv
import gzip
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from conftest import CORPUS_DIR, SHARED_DIR
from ipo.config import default_config
from ipo.contracts import LIMIT_DWELL, PeriodBatch
from ipo.linuxcnc_ini import load_ini
from ipo.feed.linuxcnc_twin.planner import plan_periods

DATA = Path(__file__).resolve().parent / "data" / "linuxcnc_twin"
REFERENCE_PROGRAMS = SHARED_DIR / "reference" / "linuxcnc-sim" / "programs"
NCFILES = Path("/usr/share/linuxcnc/ncfiles")  # LinuxCNC's examples, installed with linuxcnc-uspace
_SOURCES = {"reference": REFERENCE_PROGRAMS, "corpus": CORPUS_DIR, "ncfiles": NCFILES, "own": DATA / "programs"}


@dataclass(frozen=True)
class Measured:
    machine: str
    program: str
    source: str  # reference (../shared/reference/linuxcnc-sim), corpus (../shared/corpus), ncfiles, own (DATA)
    cycle_time_s: float
    path_length_mm: float
    note: str

    @property
    def path(self) -> Path:
        return _SOURCES[self.source] / f"{self.program}.ngc"

    @property
    def ini(self) -> Path:
        return DATA / "ini" / f"{self.machine}.ini"

    @property
    def id(self) -> str:
        return f"{self.machine}/{self.program}"

    @property
    def waits_dominate(self) -> bool:
        """A program written to measure task's waits (their spread, not the planner's)."""
        return self.note.startswith("task waits")


def measured() -> list[Measured]:
    with open(DATA / "measured.csv", newline="") as f:
        return [Measured(r["machine"], r["program"], r["source"], float(r["cycle_time_s"]),
                         float(r["path_length_mm"]), r["note"]) for r in csv.DictReader(f)]


@dataclass
class TwinRun:
    pos_mm: np.ndarray  # (N, 3) per period
    feed_mm_s: np.ndarray
    line: np.ndarray
    limit: np.ndarray
    period_s: float
    first_move: int  # index of the first period of the run cycle
    final: int  # index of its last period: the one that commands the final position

    @property
    def cycle_time_s(self) -> float:
        return (self.final - self.first_move + 1) * self.period_s

    @property
    def stood_s(self) -> float:
        """Standing time between the first and the last move (task waits, dwells)."""
        return float(np.count_nonzero(self.limit[self.first_move:self.final + 1] == LIMIT_DWELL)) * self.period_s


def twin_run(path: Path, ini: Path, *, feed_override: float = 1.0) -> TwinRun:
    import ipr

    settings = load_ini(ini)
    config = default_config()
    program = ipr.parse_file(str(path))
    batches = [b for b in plan_periods(program.entities, config, settings=settings, feed_override=feed_override)
               if isinstance(b, PeriodBatch)]
    limit = np.concatenate([b.limit for b in batches])
    # every period of the run cycle moves or brakes; standing ones (dwells, task waits) say so
    moving = np.nonzero(limit != LIMIT_DWELL)[0]
    return TwinRun(np.concatenate([b.pos_mm for b in batches]), np.concatenate([b.feed_mm_s for b in batches]),
                   np.concatenate([b.line for b in batches]), limit, settings.servo_period_s,
                   int(moving[0]) if len(moving) else 0, int(moving[-1]) if len(moving) else -1)


def profile(m: Measured) -> np.ndarray | None:
    """LinuxCNC's sampled periods of a program, decimated (columns period, x_mm, y_mm, z_mm,
    vel_mm_s, line; period 0 is the last one before the first move), or None."""
    f = DATA / "profiles" / f"{m.machine}__{m.program}.csv.gz"
    if not f.exists():
        return None
    with gzip.open(f, "rt") as fh:
        return np.loadtxt(fh, delimiter=",", skiprows=1)


def measured_waits() -> list[tuple[str, int, str, int]]:
    """waits.csv: (program, line, block, periods LinuxCNC stood after that block)."""
    with open(DATA / "waits.csv", newline="") as f:
        return [(r["program"], int(r["line"]), r["block"], int(r["stood_periods"])) for r in csv.DictReader(f)]


def percent_error(predicted: float, measured_s: float) -> float:
    return 100.0 * (predicted / measured_s - 1.0) if measured_s > 0 else math.nan
