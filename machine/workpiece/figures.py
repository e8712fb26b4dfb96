"""The figures of one machined surface, as a dict: what `vcnc surface-report`, `vcnc compare --stock` and
bench/workpiece.py print. Profiles are taken over the middle EVAL_FRACTION of the stock (away from the
entries and exits), along the feed on PROFILES rows spread across it, and across the passes on the
middle column; per-profile figures are reported as their median."""
from __future__ import annotations

import numpy as np

from machine.workpiece.measure import (classical_scallop_mm, gouge_report, gouges, profile,
                                       profile_figures)
from machine.workpiece.zmap import Surface

EVAL_FRACTION = 0.8
PROFILES = 9
# The figures along and across the passes describe a surface machined all over, as a finishing raster
# leaves it: where less of the middle of the stock was cut (a contour, a pocket, an engraving), its uncut
# top and the grooves' walls would be measured as scallops and facets, so those figures are left out.
MACHINED_MIN_PCT = 95.0
RASTER_KEYS = ("along_rz_um", "along_ra_um", "facet_spacing_mm", "facet_depth_um", "scallop_um",
               "pass_spacing_mm", "across_rz_um", "classical_pick_mm", "classical_scallop_um")


def inner(surface: Surface) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the columns and rows in the middle EVAL_FRACTION of the stock."""
    (x_lo, x_hi), (y_lo, y_hi) = _window(surface.x_mm), _window(surface.y_mm)
    return (surface.x_mm >= x_lo) & (surface.x_mm <= x_hi), (surface.y_mm >= y_lo) & (surface.y_mm <= y_hi)


def _window(values: np.ndarray) -> tuple[float, float]:
    lo, hi = float(values[0]), float(values[-1])
    margin = 0.5 * (1 - EVAL_FRACTION) * (hi - lo)
    return lo + margin, hi - margin


def surface_figures(surface: Surface, *, reference: np.ndarray | None = None, feed_axis: str = "x",
                    pick_mm: float | None = None, gouge_tol_mm: float = 1e-3) -> dict:
    cols, rows = inner(surface)
    machined_pct = float(np.mean(surface.line[np.ix_(rows, cols)] != 0) * 100) if cols.any() and rows.any() else 0.0
    out = {"grid_um": surface.grid_mm * 1e3, "nodes": int(surface.z_mm.size), "tool": surface.meta.get("tool"),
           "z_min_mm": float(np.min(surface.z_mm)), "z_max_mm": float(np.max(surface.z_mm)),
           "machined_pct": machined_pct}
    if machined_pct >= MACHINED_MIN_PCT:
        out.update(_raster_figures(surface, reference, feed_axis, pick_mm))
    else:
        out.update({key: None for key in RASTER_KEYS})
        out["note"] = (f"the middle {EVAL_FRACTION:.0%} of the stock is not machined all over ({machined_pct:.1f} % "
                       f"of its nodes cut, {MACHINED_MIN_PCT:g} % needed): no figures along and across the passes")
    if reference is not None:
        dev = surface.z_mm - reference
        out["deviation_min_um"] = float(np.nanmin(dev) * 1e3)
        out["deviation_max_um"] = float(np.nanmax(dev) * 1e3)
        gl = gouges(surface, np.nan_to_num(reference, nan=-np.inf), gouge_tol_mm)
        out["gouges"] = gouge_report(gl, surface, np.nan_to_num(reference, nan=-np.inf))
        out["_gouge_line"] = gl
    return out


def _raster_figures(surface: Surface, reference: np.ndarray | None, feed_axis: str, pick_mm: float | None) -> dict:
    """The figures along and across the passes (RASTER_KEYS)."""
    across_axis = "y" if feed_axis == "x" else "x"
    along_values = surface.x_mm if feed_axis == "x" else surface.y_mm
    across_values = surface.y_mm if feed_axis == "x" else surface.x_mm
    a_lo, a_hi = _window(along_values)
    c_lo, c_hi = _window(across_values)
    form_removed = reference is not None
    rows = [profile_figures(*profile(surface, feed_axis, at, a_lo, a_hi, reference), form_removed=form_removed)
            for at in np.linspace(c_lo, c_hi, PROFILES)]

    def median(key):
        vals = [getattr(r, key) for r in rows if getattr(r, key) is not None]
        return float(np.median(vals)) if vals else None

    across = profile_figures(*profile(surface, across_axis, 0.5 * (a_lo + a_hi), c_lo, c_hi, reference),
                             form_removed=form_removed, periodic=True)
    figures = {"along_rz_um": median("rz_um"), "along_ra_um": median("ra_um"),
               "facet_spacing_mm": median("facet_spacing_mm"), "facet_depth_um": median("facet_depth_um"),
               "scallop_um": across.facet_depth_um, "pass_spacing_mm": across.facet_spacing_mm,
               "across_rz_um": across.rz_um}
    r_mm = surface.meta.get("tool_corner_mm") if surface.meta.get("tool_shape") == "ball" else None
    spacing = pick_mm or surface.meta.get("pick_mm") or across.facet_spacing_mm
    figures["classical_pick_mm"] = spacing if r_mm else None
    figures["classical_scallop_um"] = classical_scallop_mm(r_mm, spacing) * 1e3 if r_mm and spacing else None
    return figures


ROWS = [("grid", "grid_um", "{:g} um"), ("nodes", "nodes", "{:,}"), ("Z min", "z_min_mm", "{:.4f} mm"),
        ("Z max", "z_max_mm", "{:.4f} mm"), ("machined (middle of the stock)", "machined_pct", "{:.1f} %"),
        ("along the feed Rz", "along_rz_um", "{:.3f} um"),
        ("along the feed Ra", "along_ra_um", "{:.3f} um"), ("facet spacing", "facet_spacing_mm", "{:.4f} mm"),
        ("facet depth", "facet_depth_um", "{:.3f} um"), ("scallop across the passes", "scallop_um", "{:.3f} um"),
        ("pass spacing", "pass_spacing_mm", "{:.4f} mm"),
        ("pick (classical scallop)", "classical_pick_mm", "{:.4f} mm"),
        ("classical scallop", "classical_scallop_um", "{:.3f} um"),
        ("deviation min", "deviation_min_um", "{:.3f} um"), ("deviation max", "deviation_max_um", "{:.3f} um")]


def format_rows(named: dict[str, dict]) -> str:
    """A table with one column per surface."""
    names = list(named)
    w = max([16] + [len(n) for n in names])
    lines = [f"{'':28s} " + " ".join(f"{n:>{w}s}" for n in names)]
    for label, key, fmt in ROWS:
        if all(key not in f for f in named.values()):
            continue
        cells = ["-" if f.get(key) is None else fmt.format(f[key]) for f in named.values()]
        lines.append(f"{label:28s} " + " ".join(f"{c:>{w}s}" for c in cells))
    for name, f in named.items():
        if f.get("note"):
            lines.append(f"note ({name}): {f['note']}")
        for g in f.get("gouges", [])[:10]:
            lines.append(f"gouge ({name}): line {g['line']}: {g['depth_um']:.3f} um deep at X{g['x_mm']:.3f} "
                         f"Y{g['y_mm']:.3f}, {g['nodes']} nodes")
    return "\n".join(lines)
