"""Controller twins against the controllers they model: per program, the measured cycle time,
the twin's prediction and its error, and the naive estimate (length / feed) beside it.

LinuxCNC 2.9: bench/twins_linuxcnc.py (measurements in tests/data/linuxcnc_twin).

Usage: python bench/twins.py
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import twins_linuxcnc  # noqa: E402

if __name__ == "__main__":
    twins_linuxcnc.print_rows(twins_linuxcnc.rows())
