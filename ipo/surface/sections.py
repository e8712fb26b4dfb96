"""Digitised points grouped into cross-sections (the input of 001's reverse-engineering chain).

Two layouts are read, as CSV (commas or semicolons) or XYZ text (whitespace):
- a header naming the columns `x`, `y`, `z` and optionally `section` (any order,
  case-insensitive; other columns are refused rather than guessed at);
- no header: three numbers per line, sections separated by one or more blank lines.
With a `section` column, blank lines mean nothing and each section's rows must be
contiguous. Lines starting with `#` are comments. Every error names the line.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ipo.errors import SURFACE_POINTS, IpoError

_SPLIT = re.compile(r"\s*[,;]\s*|\s+")
MAX_COORDINATE_MM = 1e5


class SectionsError(IpoError):
    """Bad digitised-point input (code E-IPO-SURFACE-POINTS); the message names the file and line."""

    def __init__(self, message: str):
        super().__init__(SURFACE_POINTS, message)


@dataclass(frozen=True, slots=True)
class Sections:
    """Cross-sections in file order: points[h] is (r_h, 3) in mm."""

    points: list[np.ndarray]
    labels: list[str]
    first_lines: list[int]  # 1-based line of each section's first point

    def __len__(self) -> int:
        return len(self.points)


def _fields(text: str) -> list[str]:
    return [f for f in _SPLIT.split(text.strip()) if f != ""]


def _number(token: str, where: str) -> float:
    try:
        value = float(token)
    except ValueError:
        raise SectionsError(f"{where}: '{token}' is not a number") from None
    if not math.isfinite(value):
        raise SectionsError(f"{where}: '{token}' is not a finite number (NaN or infinity)")
    if abs(value) > MAX_COORDINATE_MM:
        raise SectionsError(f"{where}: {value:g} mm is beyond {MAX_COORDINATE_MM:g} mm of the origin "
                            "(a digitised part within 100 m; the fits' least squares lose all precision beyond)")
    return value


def _header(fields: list[str], where: str) -> dict[str, int] | None:
    """Column index of x, y, z (and section) if the line is a header, else None."""
    try:
        [float(f) for f in fields]
        return None
    except ValueError:
        pass
    names = [f.strip().strip('"').lower() for f in fields]
    unknown = [n for n in names if n not in ("x", "y", "z", "section")]
    if unknown:
        raise SectionsError(f"{where}: unknown column(s) {unknown}; expected x, y, z and optionally section")
    if len(set(names)) != len(names):
        raise SectionsError(f"{where}: a column name repeats in {names}")
    missing = [a for a in "xyz" if a not in names]
    if missing:
        raise SectionsError(f"{where}: header lacks column(s) {missing}")
    return {n: i for i, n in enumerate(names)}


def parse_sections(text: str, file: str = "<string>", *, min_points: int = 2) -> Sections:
    """Sections from the text of a points file; each needs at least `min_points` points."""
    columns: dict[str, int] | None = None
    header_seen = False
    groups: list[tuple[str, int, list[tuple[float, float, float]]]] = []
    closed: set[str] = set()
    width = None
    blank_before = True
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.lstrip("\ufeff").strip()
        where = f"{file}:{n}"
        if line.startswith("#"):
            continue
        if not line:
            blank_before = True
            continue
        fields = _fields(line)
        if not header_seen and not groups:
            header_seen = True
            columns = _header(fields, where)
            if columns is not None:
                width = len(fields)
                continue
        if width is None:
            width = len(fields)
            if columns is None and width != 3:
                raise SectionsError(f"{where}: {width} values without a header; expected x y z "
                                    "(name the columns in a header line to use a section column)")
        if len(fields) != width:
            raise SectionsError(f"{where}: {len(fields)} values, but the file's rows have {width}")
        if columns is None:
            xyz = tuple(_number(f, where) for f in fields)
            if blank_before or not groups:
                groups.append((str(len(groups) + 1), n, []))
        else:
            xyz = tuple(_number(fields[columns[a]], where) for a in "xyz")
            label = fields[columns["section"]] if "section" in columns else "1"
            if not groups or groups[-1][0] != label:
                if label in closed:
                    raise SectionsError(f"{where}: section '{label}' resumes after another section began; "
                                        "each section's rows must be contiguous")
                if groups:
                    closed.add(groups[-1][0])
                groups.append((label, n, []))
        groups[-1][2].append(xyz)
        blank_before = False
    if not groups:
        raise SectionsError(f"{file}: no points")
    for label, line, pts in groups:
        if len(pts) < min_points:
            raise SectionsError(f"{file}:{line}: section '{label}' has {len(pts)} point(s); "
                                f"at least {min_points} are needed")
    return Sections([np.array(p, dtype=float) for _, _, p in groups],
                    [g[0] for g in groups], [g[1] for g in groups])


def read_sections(path: str | Path, *, min_points: int = 2) -> Sections:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise SectionsError(f"{path}: not a text file of points (not UTF-8 at byte {err.start})") from None
    return parse_sections(text, str(path), min_points=min_points)


def orient_like_first(sections: Sections) -> tuple[Sections, list[int]]:
    """The sections with every one that runs against the first (start-to-end direction, as a
    zig-zag digitisation gives) reversed, and the indices of those reversed. Skinning joins
    the sections' control points index by index, so they must all run the same way."""
    ref = sections.points[0][-1] - sections.points[0][0]
    flipped = [h for h, q in enumerate(sections.points) if np.dot(q[-1] - q[0], ref) < 0]
    points = [q[::-1].copy() if h in flipped else q for h, q in enumerate(sections.points)]
    return Sections(points, sections.labels, sections.first_lines), flipped
