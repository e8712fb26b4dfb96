"""What `vcnc parse` prints about a program: entity counts, path length and bounding box,
gathered a batch of entities at a time (machine.commands.parse)."""
from __future__ import annotations

import math

import numpy as np

from ipo.nurbs.kernel import arc_length
from ipr.arc_arrays import arc_sweeps, coordinates
from ipr.entities import PLANE_AXES, Arc, Dwell, Line, Nurbs, Rapid, group_by_type
from machine.extents import arc_boxes


def _arc_length_mm(arc) -> float:
    _, _, n = PLANE_AXES[arc.plane]
    return math.hypot(arc.radius_mm * arc.sweep_rad, arc.end[n] - arc.start[n])


def _nurbs_length_mm(nurbs) -> float:
    return arc_length(nurbs.degree, nurbs.knots, nurbs.weights, nurbs.points, rel_tol=1e-6)


def path_length_mm(entity) -> float:
    kind = type(entity).__name__
    if kind in ("Rapid", "Line"):
        return math.dist(entity.start, entity.end)
    if kind == "Arc":
        return _arc_length_mm(entity)
    if kind == "Nurbs":
        return _nurbs_length_mm(entity)
    return 0.0


class Summary:
    """Entity counts, path length and bounding box of a program, added a batch of entities at a
    time (vectorised per batch, nothing kept: memory does not grow with the program). Arcs are
    boxed exactly (machine.extents.arc_boxes), a NURBS by its control points (its convex hull)."""

    def __init__(self):
        self.counts = dict.fromkeys(("rapid", "line", "arc", "nurbs", "dwell"), 0)
        self.length_mm = 0.0
        self.lo, self.hi = np.full(3, np.inf), np.full(3, -np.inf)

    def _extend(self, points) -> None:
        if len(points):
            self.lo = np.minimum(self.lo, points.min(axis=0))
            self.hi = np.maximum(self.hi, points.max(axis=0))

    def add(self, batch: list) -> None:
        groups = group_by_type(batch)
        for cls, kind in ((Rapid, "rapid"), (Line, "line"), (Arc, "arc"), (Nurbs, "nurbs"), (Dwell, "dwell")):
            self.counts[kind] += len(groups.get(cls, ()))
        straight = groups.get(Line, []) + groups.get(Rapid, [])
        if straight:
            starts, ends = coordinates(straight, "start"), coordinates(straight, "end")
            self.length_mm += float(np.linalg.norm(ends - starts, axis=1).sum())
            self._extend(starts)
            self._extend(ends)
        if Arc in groups:
            self._add_arcs(groups[Arc])
        for e in groups.get(Nurbs, ()):
            self.length_mm += path_length_mm(e)
            self._extend(e.points)

    def _add_arcs(self, arcs: list) -> None:
        g = arc_sweeps(arcs)
        rows = np.arange(len(arcs))
        rise = g.end[rows, g.axes[:, 2]] - g.start[rows, g.axes[:, 2]]
        self.length_mm += float(np.hypot(g.r_start_mm * g.sweep_rad, rise).sum())
        lo, hi = arc_boxes(arcs)
        self._extend(lo)
        self._extend(hi)

    def print(self, file: str) -> None:
        from rich.console import Console  # here: `vcnc interp` imports this module for path_length_mm alone
        from rich.table import Table

        table = Table(title=f"vcnc parse {file}", show_header=False)
        table.add_column("figure", style="bold")
        table.add_column("value", justify="right")
        for kind in ("rapid", "line", "arc", "nurbs", "dwell"):
            table.add_row(f"{kind} entities", str(self.counts[kind]))
        table.add_row("path length", f"{self.length_mm:.3f} mm")
        if self.lo[0] <= self.hi[0]:
            table.add_row("bounding box min", "  ".join(f"{v:.3f}" for v in self.lo) + " mm")
            table.add_row("bounding box max", "  ".join(f"{v:.3f}" for v in self.hi) + " mm")
        Console().print(table)
