"""Write the example programs of issue 7 (run from the repo root: `python programs/make_programs.py`).

- circle_g2.nc: a circle of radius 10 mm as one G2;
- circle_g1_360.nc: the same circle as 360 G1 chords;
- circle_nurbs.nc: the same circle as a rational quadratic G06.2 (9 control points, weights 1 and sqrt(2)/2);
- finish_g01.nc: ball-end finishing (r = 3 mm, pick feed 0.2 mm, F5000, S12500, two flutes) of a
  120 x 40 mm mould panel: a sphere of radius 150 mm with a broad bulge,
  z = sqrt(150^2 - (x-60)^2 - (y-20)^2) - 150 + 6 exp(-((x-85)^2 + (y-25)^2) / 3200),
  raster passes along X (zig-zag), chords within 1 um of the exact tool-tip path: our version of
  002 Fig. 7 (002's part is larger still: 210,522 G01 lines);
- finish_nurbs.nc: finish_g01.nc with its G01 runs fitted by `vcnc fit` at 5 um (002 Fig. 8).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
R_CIRCLE_MM = 10.0
BALL_R_MM = 3.0
PICK_MM = 0.2
CHORD_TOL_MM = 0.001
PATCH_X_MM, PATCH_Y_MM = 120.0, 40.0
FIT_TOL_MM = 0.005
SPHERE_R_MM = 150.0
SPHERE_CENTRE_MM = (60.0, 20.0)
BULGE_MM, BULGE_CENTRE_MM, BULGE_WIDTH_MM2 = 6.0, (85.0, 25.0), 3200.0


def surface(x, y):
    """Height z(x, y) and its gradient: the sphere's cap with the bulge on it (slopes up to 29 deg)."""
    dx, dy = x - SPHERE_CENTRE_MM[0], y - SPHERE_CENTRE_MM[1]
    root = np.sqrt(SPHERE_R_MM**2 - dx**2 - dy**2)
    bx, by = x - BULGE_CENTRE_MM[0], y - BULGE_CENTRE_MM[1]
    e = BULGE_MM * np.exp(-(bx**2 + by**2) / BULGE_WIDTH_MM2)
    k = 2.0 / BULGE_WIDTH_MM2
    return root - SPHERE_R_MM + e, -dx / root - k * e * bx, -dy / root - k * e * by


def tool_tip(xc, y0):
    """Tool-tip points of a ball of radius r touching the surface, tool centre on the plane y = y0.

    The centre is the contact point plus r times the unit normal; for each contact x the contact y
    is found by Newton so that the centre lies on y = y0 (no gouging: the surface's concave radii
    exceed r)."""
    yc = np.full_like(xc, y0)
    for _ in range(30):
        def centre_y(yy):
            _, zx, zy = surface(xc, yy)
            return yy - BALL_R_MM * zy / np.sqrt(1 + zx**2 + zy**2)
        f = centre_y(yc) - y0
        h = 1e-7
        yc = yc - f / ((centre_y(yc + h) - centre_y(yc - h)) / (2 * h))
    z, zx, zy = surface(xc, yc)
    norm = np.sqrt(1 + zx**2 + zy**2)
    return np.c_[xc - BALL_R_MM * zx / norm, np.full_like(xc, y0), z + BALL_R_MM / norm - BALL_R_MM]


def chord_vertices(dense: np.ndarray, tol_mm: float) -> np.ndarray:
    """Indices of a polyline through `dense` whose chords stay within tol of every dense point
    (greedy: each chord as long as possible, found by doubling then bisection)."""
    def ok(i, j):
        a, b = dense[i], dense[j]
        ab = b - a
        t = np.clip((dense[i:j + 1] - a) @ ab / (ab @ ab), 0, 1)
        return np.max(np.linalg.norm(dense[i:j + 1] - (a + t[:, None] * ab), axis=1)) <= tol_mm

    out, i, n = [0], 0, len(dense)
    while i < n - 1:
        step = 1
        while i + 2 * step < n and ok(i, i + 2 * step):
            step *= 2
        lo, hi = i + step, min(i + 2 * step, n - 1)
        if ok(i, hi):
            lo = hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (mid, hi) if ok(i, mid) else (lo, mid)
        i = lo
        out.append(i)
    return np.array(out)


def fmt(v: float, digits: int = 4) -> str:
    s = f"{v:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0") else s


def circle_programs() -> dict[str, str]:
    r = R_CIRCLE_MM
    head = ["G21 G17 G90 G94 G64", "G0 X0 Y0 Z5", f"G0 X{fmt(r)} Y0", "G1 Z0 F600"]
    tail = ["G0 Z5", "M2", ""]
    g2 = [f"(circle of radius {fmt(r)} mm about X0 Y0 as one clockwise G2)"] + head + \
        [f"G2 X{fmt(r)} Y0 I{fmt(-r)} J0 F1000"] + tail
    ang = -np.arange(1, 361) * 2 * np.pi / 360
    g1 = [f"(the same circle as 360 G1 chords, chord error {r * (1 - math.cos(math.pi / 360)) * 1e3:.2f} um)"] + \
        head + [f"G1 X{fmt(r * math.cos(a))} Y{fmt(r * math.sin(a))}" + (" F1000" if k == 0 else "")
                for k, a in enumerate(ang)] + tail
    # clockwise full circle: four quarter arcs, corners weighted sqrt(2)/2, double interior knots
    pts = [(r, 0), (r, -r), (0, -r), (-r, -r), (-r, 0), (-r, r), (0, r), (r, r), (r, 0)]
    knots = [0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4]
    w = [1.0 if k % 2 == 0 else math.sqrt(0.5) for k in range(9)]
    nurbs = [f"(the same circle as a rational quadratic G06.2: 9 control points, weights 1 and sqrt[2]/2)"] + head
    nurbs.append(f"G06.2 P3 K{knots[0]} X{fmt(pts[0][0])} Y0 Z0 R1 F1000")
    for k in range(1, 9):
        nurbs.append(f"K{knots[k]} X{fmt(pts[k][0])} Y{fmt(pts[k][1])} R{fmt(w[k], 8)}")
    nurbs += [f"K{k}" for k in knots[9:]]
    nurbs += tail
    return {"circle_g2.nc": "\n".join(g2), "circle_g1_360.nc": "\n".join(g1), "circle_nurbs.nc": "\n".join(nurbs)}


def finishing_program() -> str:
    lines = [
        "(finish_g01: ball-end finishing, r = 3 mm, two flutes, pick feed 0.2 mm, F5000, S12500)",
        "(mould panel over X0..120 Y0..40: sphere R150 about X60 Y20 with a bulge 6 exp[-r^2/3200] at X85 Y25)",
        "(tool-tip coordinates)",
        f"(raster along X, zig-zag; G01 chords within {CHORD_TOL_MM * 1e3:g} um of the exact tool path)",
        "G21 G17 G90 G94 G64",
        "S12500 M3",
        "G0 Z15",
    ]
    xc = np.linspace(0.0, PATCH_X_MM, int(round(PATCH_X_MM / 0.01)) + 1)  # dense enough: sagitta << 1 nm
    n_pass = int(round(PATCH_Y_MM / PICK_MM)) + 1
    for k in range(n_pass):
        y0 = k * PICK_MM
        dense = tool_tip(xc, y0)
        if k % 2:
            dense = dense[::-1]
        verts = dense[chord_vertices(dense, CHORD_TOL_MM)]
        if k == 0:
            lines += [f"G0 X{fmt(verts[0, 0])} Y{fmt(y0)}", f"G1 Z{fmt(verts[0, 2])} F5000"]
        else:
            lines.append(f"G1 X{fmt(verts[0, 0])} Y{fmt(y0)} Z{fmt(verts[0, 2])}")
        lines += [f"X{fmt(x)} Z{fmt(z)}" for x, _, z in verts[1:]]
    lines += ["G0 Z15", "M5", "M2", ""]
    return "\n".join(lines)


def main() -> None:
    for name, text in circle_programs().items():
        (HERE / name).write_text(text)
    g01 = finishing_program()
    (HERE / "finish_g01.nc").write_text(g01)
    sys.path.insert(0, str(HERE.parent))
    from ipo.fit.convert import convert_text

    nurbs, report = convert_text(g01, FIT_TOL_MM, file="finish_g01.nc")
    header = (f"(finish_nurbs: finish_g01.nc with its G01 runs fitted by vcnc fit --tol-mm {FIT_TOL_MM:g}:"
              f" {report.groups} G06.2 groups, max deviation {report.max_deviation_mm * 1e3:.3f} um)\n")
    (HERE / "finish_nurbs.nc").write_text(header + nurbs)
    print(f"finish_g01.nc {report.blocks_before} blocks -> finish_nurbs.nc {report.blocks_after} blocks,"
          f" max deviation {report.max_deviation_mm * 1e3:.3f} um, fit {report.fit_time_s:.1f} s")


if __name__ == "__main__":
    main()
