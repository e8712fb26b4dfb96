"""Corner blends the feed stage inserts under G64 besides the line/arc arcs of ipo.feed.pieces.

- `curve_corner`: a cubic blend where an arc or a NURBS meets another move at a corner, checked within P.
- `curvature_continuous`: quintic Bezier corners of continuous curvature between lines (S-curve mode).
- `g2_chains`: runs of small turns between short lines (CAM polylines) as one curvature-continuous
  curve of quintics from move midpoint to midpoint (S-curve mode).
- `chain_fit`: the smoothing fit of each chain's run within P (a discrete smoothing spline on the third
  derivative): the midpoints and tangents its quintics pass through.
- `g2_joints`: curvature-continuous joints next to arcs and NURBS, tangent or at a corner: both
  moves trimmed and joined by the quintic matching point, tangent and curvature (S-curve mode).
- `compiled`: numba arc-length tables, points and frames of the Bezier blends; point-to-polyline distances.

May import: ipo.segments, ipo.nurbs, ipr.entities, numpy, numba (not ipo.feed's other modules).
"""
