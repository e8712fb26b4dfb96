"""Corner blends the feed stage inserts under G64 besides the line/arc arcs of ipo.feed.pieces.

- `nurbs_corner`: a blend where a NURBS meets a line, an arc or another NURBS.
- `curvature_continuous`: quintic Bezier corners of continuous curvature (S-curve mode).
- `compiled`: numba arc-length tables and points of the Bezier blends.

May import: ipo.nurbs, ipr.entities, numpy, numba (not ipo.feed's other modules).
"""
