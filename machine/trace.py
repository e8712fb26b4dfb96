"""The drive's trace: one row per interpolation period, in memory or streamed to a file.

Columns: t_s, pos_mm (N×3, commanded after quantisation), inc_blu (N×3 int64),
feed_mm_s, limit (LIMIT_* code), line, and with a servo model actual_mm (N×3) and
contour_um. A trace also carries the machine figures a plot needs (period, BLU,
axis limits) as metadata.

Writers are bounded in memory: CSV rows are appended batch by batch; an .npz is
built from one temporary raw file per column, streamed into the archive on close,
so a 7-minute program at 1 ms never sits whole in memory unless the caller asks
for the in-memory trace (`MemoryTrace`).
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# (name, dtype, columns per row); order is the CSV column order.
COLUMNS: tuple[tuple[str, str, int], ...] = (
    ("t_s", "<f8", 1),
    ("pos_mm", "<f8", 3),
    ("inc_blu", "<i8", 3),
    ("feed_mm_s", "<f8", 1),
    ("limit", "<i1", 1),
    ("line", "<i4", 1),
)
SERVO_COLUMNS: tuple[tuple[str, str, int], ...] = (
    ("actual_mm", "<f8", 3),
    ("contour_um", "<f8", 1),
)
_AXES = "xyz"


def _csv_names(name: str, width: int) -> list[str]:
    if width == 1:
        return [name]
    stem, _, unit = name.partition("_")
    return [f"{stem}_{_AXES[i]}_{unit}" for i in range(width)]


@dataclass(slots=True)
class Trace:
    """A whole trace loaded for plotting or analysis."""

    columns: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["t_s"])


class MemoryTrace:
    """Keeps every batch; the one trace sink whose memory grows with the periods."""

    def __init__(self, meta: dict):
        self.meta = meta
        self._parts: dict[str, list[np.ndarray]] = {}

    def write(self, rows: dict[str, np.ndarray]) -> None:
        for name, arr in rows.items():
            self._parts.setdefault(name, []).append(np.array(arr, copy=True))

    def close(self) -> Trace:
        """The trace; with no period written (nothing moved), the columns are there and empty."""
        empty = {name: [np.empty((0, w) if w > 1 else 0, dtype)] for name, dtype, w in COLUMNS}
        cols = {name: np.concatenate(parts) for name, parts in (empty | self._parts).items()}
        return Trace(cols, dict(self.meta))


class CsvTraceWriter:
    """Appends rows per batch; metadata goes in leading `# key=json` comment lines."""

    def __init__(self, path: str | Path, meta: dict, servo: bool):
        self.path = Path(path)
        self._spec = COLUMNS + (SERVO_COLUMNS if servo else ())
        self._fh = open(self.path, "w", encoding="ascii", newline="\n")
        for key, value in meta.items():
            self._fh.write(f"# {key}={json.dumps(value)}\n")
        names = [n for name, _, w in self._spec for n in _csv_names(name, w)]
        self._fh.write(",".join(names) + "\n")
        fmts = {"<f8": "%.9g", "<i8": "%d", "<i1": "%d", "<i4": "%d"}
        self._fmt = ",".join(fmts[dt] for _, dt, w in self._spec for _ in range(w))

    def write(self, rows: dict[str, np.ndarray]) -> None:
        n = len(rows["t_s"])
        table = np.empty((n, sum(w for _, _, w in self._spec)), dtype=object)
        col = 0
        for name, _, w in self._spec:
            table[:, col:col + w] = np.asarray(rows[name]).reshape(n, w)
            col += w
        np.savetxt(self._fh, table, fmt=self._fmt)

    def close(self) -> None:
        self._fh.close()


class NpzTraceWriter:
    """One raw temporary file per column; `close` streams them into an uncompressed .npz."""

    def __init__(self, path: str | Path, meta: dict, servo: bool):
        self.path = Path(path)
        self.meta = meta
        self._spec = COLUMNS + (SERVO_COLUMNS if servo else ())
        self._dir = tempfile.mkdtemp(prefix=".trace-", dir=self.path.parent)
        self._files = {name: open(os.path.join(self._dir, name), "wb") for name, _, _ in self._spec}
        self._rows = 0

    def write(self, rows: dict[str, np.ndarray]) -> None:
        for name, dtype, _ in self._spec:
            self._files[name].write(np.ascontiguousarray(rows[name], dtype=dtype).tobytes())
        self._rows += len(rows["t_s"])

    def close(self) -> None:
        for fh in self._files.values():
            fh.close()
        try:
            with zipfile.ZipFile(self.path, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
                for name, dtype, width in self._spec:
                    shape = (self._rows,) if width == 1 else (self._rows, width)
                    header = {"descr": np.dtype(dtype).str, "fortran_order": False, "shape": shape}
                    with zf.open(name + ".npy", "w", force_zip64=True) as out, \
                            open(os.path.join(self._dir, name), "rb") as src:
                        np.lib.format.write_array_header_1_0(out, header)
                        shutil.copyfileobj(src, out, 1 << 20)
                for key, value in self.meta.items():
                    with zf.open(f"meta_{key}.npy", "w") as out:
                        np.lib.format.write_array(out, np.asarray(value))
        finally:
            shutil.rmtree(self._dir, ignore_errors=True)


def open_writer(path: str | Path, meta: dict, servo: bool) -> CsvTraceWriter | NpzTraceWriter:
    """A file writer chosen by suffix: .npz or .csv; anything else is an error."""
    suffix = Path(path).suffix.lower()
    if suffix == ".npz":
        return NpzTraceWriter(path, meta, servo)
    if suffix == ".csv":
        return CsvTraceWriter(path, meta, servo)
    raise ValueError(f"trace file {path}: unknown format {suffix!r} (use .npz or .csv)")


def load_trace(path: str | Path) -> Trace:
    """Read a trace written by either writer."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        with np.load(path) as data:
            cols = {k: data[k] for k in data.files if not k.startswith("meta_")}
            meta = {k[5:]: data[k].tolist() for k in data.files if k.startswith("meta_")}
        missing = [name for name, _, _ in COLUMNS if name not in cols]
        if missing:
            raise ValueError(f"{path}: not a vcnc trace (missing {', '.join(missing)})")
        return Trace(cols, meta)
    if suffix == ".csv":
        return _load_csv(path)
    raise ValueError(f"trace file {path}: unknown format {suffix!r} (use .npz or .csv)")


def _load_csv(path: Path) -> Trace:
    meta: dict = {}
    with open(path, encoding="ascii") as fh:
        line = fh.readline()
        while line.startswith("#"):
            key, _, value = line[1:].strip().partition("=")
            meta[key] = json.loads(value)
            line = fh.readline()
        header = line.strip().split(",")
        table = np.loadtxt(fh, delimiter=",", ndmin=2)
    cols: dict[str, np.ndarray] = {}
    col = 0
    for name, dtype, width in COLUMNS + SERVO_COLUMNS:
        names = _csv_names(name, width)
        if header[col:col + width] != names:
            if name in {n for n, _, _ in SERVO_COLUMNS}:
                break
            raise ValueError(f"{path}: not a vcnc trace (expected column {names[0]!r})")
        block = table[:, col:col + width].astype(dtype)
        cols[name] = block[:, 0] if width == 1 else block
        col += width
    return Trace(cols, meta)
