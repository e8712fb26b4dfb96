"""G01 runs -> rational B-spline G06.2 groups (paper 001 §2, Appendix I).

- `rational`: 001's rational least-squares approximation (eq. 1–11): alternating control
  points, weights and parameter correction.
- `compiled`: the compiled closest-point (foot) search of the parameter correction.
- `tolerance`: the fewest control points that keep a polyline within a tolerance.
- `g01_runs`: the runs of consecutive G01 moves between corners (the bench's corpus runs).
- `chains`: the chains of G1/G2/G3 moves a fit may replace, and which of their corners stay sharp.
- `groups`: one chain -> the fewest blocks: sections between sharp corners, pieces fitted or kept,
  joined into G06.2 groups with a knot of multiplicity = degree at each corner (G5.2, and
  G06.2 of degree 3..5).
- G06.2's default, rational quadratic (conic) spans with their own knots and weights:
  `conic` (one span between two junctions and its test), `conic_plan` (one chain -> the fewest
  written blocks, a shortest path over the junctions, compiled), `weights` (the spans' weights
  and knots joined into one rational quadratic B-spline), `quadratic` (the plan walked back into
  groups and kept moves).
- `arcs`: a run of G1 moves as one G1 line or G2/G3 arc (in the principal plane the run lies in)
  within the tolerance (exact test), the block that writes it and its path as written; the conic
  plan weighs it against groups.
- `move_runs`: a stretch of G1 moves outside groups as the fewest such moves, their junctions
  anywhere on its segments (a shortest path over points at 1/32 of each).
- `distance`: the two-way distance between a written curve and the path it replaces, bounded
  from above (the check of the curve as written).
- `convert`: `vcnc fit`'s program rewriting (chains found, planned in parallel, written back).
- `modal_text`: the motion code, feed and plane a block after a group or written arc relies on, restored.
- `written`: a fit as the G06.2 or G5.2 blocks that write it, and the curve exactly as written.

May import: ipo.errors, ipo.numpy_kernels, ipo.nurbs, ipr, numpy, numba.
"""
