"""Saved surfaces: .npz (x_mm, y_mm, z_mm, line, gouge_line and the metadata) and .stl (a mesh of the
machined top over the grid, for any mesh viewer)."""
from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from machine.workpiece.zmap import Surface

# The heights are stored as float32, the Z-map's own precision (zmap.py): every value is exact. Deflate gains
# 15 % on them and took 2 s on finish_g01.nc's 2.5 M nodes as float64 (np.savez_compressed), 8x the removal:
# they are stored as they are; the lines and gouge lines (long runs of one value) are deflated at level 1.
HEIGHTS_DTYPE = np.float32
DEFLATE_LEVEL = 1


def save_npz(surface: Surface, path, gouge_line: np.ndarray | None = None) -> None:
    """An .npz that np.load reads: z_mm stored, the other arrays deflated."""
    gouge = np.zeros_like(surface.line) if gouge_line is None else gouge_line
    z = surface.z_mm.astype(HEIGHTS_DTYPE)
    if not np.array_equal(z, surface.z_mm, equal_nan=True):
        raise ValueError("the surface's heights are not the Z-map's float32 values")
    arrays = {"x_mm": surface.x_mm, "y_mm": surface.y_mm, "z_mm": z, "line": surface.line,
              "gouge_line": gouge, "meta": np.array(json.dumps(surface.meta))}
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=DEFLATE_LEVEL) as archive:
        for name, array in arrays.items():
            member = f"{name}.npy"
            if name == "z_mm":
                member = zipfile.ZipInfo(member)
                member.compress_type = zipfile.ZIP_STORED
            with archive.open(member, "w", force_zip64=True) as out:
                np.lib.format.write_array(out, np.asanyarray(array), allow_pickle=False)


def load_npz(path) -> tuple[Surface, np.ndarray]:
    """The surface and its gouge_line array; ValueError if the file is not a saved surface."""
    with np.load(path) as data:
        missing = [k for k in ("x_mm", "y_mm", "z_mm") if k not in data.files]
        if missing:
            raise ValueError(f"{path}: not a vcnc surface (missing {', '.join(missing)})")
        z = data["z_mm"].astype(np.float64)
        line = data["line"] if "line" in data.files else np.zeros(z.shape, np.int32)
        gouge = data["gouge_line"] if "gouge_line" in data.files else np.zeros(z.shape, np.int32)
        meta = json.loads(str(data["meta"])) if "meta" in data.files else {}
        return Surface(data["x_mm"], data["y_mm"], z, line, meta), gouge


def save_stl(surface: Surface, path) -> None:
    """Binary STL of the top surface: two triangles per grid cell, normals up."""
    x, y, z = surface.x_mm, surface.y_mm, surface.z_mm.astype(np.float32)
    X, Y = np.meshgrid(x.astype(np.float32), y.astype(np.float32))
    p = np.stack((X, Y, z), axis=-1)
    a, b, c, d = p[:-1, :-1], p[:-1, 1:], p[1:, 1:], p[1:, :-1]
    tri = np.concatenate((np.stack((a, b, c), axis=-2).reshape(-1, 3, 3),
                          np.stack((a, c, d), axis=-2).reshape(-1, 3, 3)))
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    rec = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["n"], rec["v"] = n, tri
    with open(Path(path), "wb") as fh:
        fh.write(b"vcnc machined surface".ljust(80, b" "))
        fh.write(np.uint32(len(tri)).tobytes())
        fh.write(rec.tobytes())
