"""Programs whose machined surface is known in closed form, for the tests and bench/workpiece.py.

- raster: a ball-end zig-zag over a plane at step-over s: cusps h = r - sqrt(r^2 - (s/2)^2);
- bowl: the lower 60 degrees of a circle of radius BOWL_RHO_MM in the XZ plane, followed by the ball's
  tip, as a G01 polygon of n chords (facets of depth = the chords' sagitta) or as one rational quadratic
  G06.2 (no facets): the ball's centres run on the same circle BOWL r higher, so the exact surface is the
  circle of radius rho + r about that centre, and a node's radial distance inside it is its deviation.
"""
from __future__ import annotations

import math

import numpy as np

BOWL_RHO_MM = 20.0
BOWL_TIP_CENTRE = (10.0, 3.0, 18.0)
BOWL_STOCK = "0,0,-6,20,6,0"
BOWL_SPAN_RAD = math.pi / 3


def raster_program(pick_mm: float, passes: int, length_mm: float, depth_mm: float, feed_mm_min: float,
                   y0_mm: float = 1.0) -> str:
    lines = ["G21 G90 G94 G64 T1 M6 S10000 M3", f"G0 X0 Y{y0_mm:g} Z1", f"G1 Z{-depth_mm:g} F{feed_mm_min:g}"]
    for k in range(passes):
        y = y0_mm + k * pick_mm
        lines.append(f"G1 X{length_mm:g} Y{y:.6f}" if k % 2 == 0 else f"G1 X0 Y{y:.6f}")
        if k < passes - 1:
            lines.append(f"G1 Y{y + pick_mm:.6f}")
    return "\n".join(lines + ["G0 Z5", "M2", ""])


def bowl_sagitta_mm(chords: int) -> float:
    return BOWL_RHO_MM * (1 - math.cos(BOWL_SPAN_RAD / chords / 2))


def bowl_polygon_program(chords: int, feed_mm_min: float = 1200.0) -> str:
    a = np.linspace(-math.pi / 2 - BOWL_SPAN_RAD / 2, -math.pi / 2 + BOWL_SPAN_RAD / 2, chords + 1)
    cx, y, cz = BOWL_TIP_CENTRE
    pts = [f"X{cx + BOWL_RHO_MM * math.cos(t):.6f} Z{cz + BOWL_RHO_MM * math.sin(t):.6f}" for t in a]
    return "\n".join(["G21 G90 G94 G64 T1 M6 S10000 M3", f"G0 {pts[0]} Y{y:g}", f"G1 F{feed_mm_min:g} " + pts[0]]
                     + [f"G1 {p}" for p in pts[1:]] + ["G0 Z25", "M2", ""])


def bowl_nurbs_program(feed_mm_min: float = 1200.0) -> str:
    """The same arc as a rational quadratic: the middle control point at the tangents' crossing, weight
    cos(span/2)."""
    cx, y, cz = BOWL_TIP_CENTRE
    half = BOWL_SPAN_RAD / 2
    x0, x1 = cx - BOWL_RHO_MM * math.sin(half), cx + BOWL_RHO_MM * math.sin(half)
    end_z = cz - BOWL_RHO_MM * math.cos(half)
    mid_z = cz - BOWL_RHO_MM / math.cos(half)
    return "\n".join(["G21 G90 G94 G64 T1 M6 S10000 M3", f"G0 X{x0:.6f} Y{y:g} Z{end_z:.6f}",
                      f"G06.2 P3 K0 X{x0:.6f} Y{y:g} Z{end_z:.6f} R1 F{feed_mm_min:g}",
                      f"K0 X{cx:g} Z{mid_z:.6f} R{math.cos(half):.9f}",
                      f"K0 X{x1:.6f} Z{end_z:.6f} R1", "K1", "K1", "K1", "G0 Z25", "M2", ""])


def bowl_deviation(surface, r_mm: float, margin_mm: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """(x_mm, deviation_mm) along y = the bowl's plane: radial distance of the machined profile inside the
    exact surface (positive: material left), away from the arc's ends by margin_mm."""
    cx, y, cz = BOWL_TIP_CENTRE
    j = int(np.argmin(np.abs(surface.y_mm - y)))
    half_x = BOWL_RHO_MM * math.sin(BOWL_SPAN_RAD / 2)
    keep = np.abs(surface.x_mm - cx) < half_x - margin_mm
    x, z = surface.x_mm[keep], surface.z_mm[j, keep]
    return x, (BOWL_RHO_MM + r_mm) - np.hypot(x - cx, z - (cz + r_mm))
