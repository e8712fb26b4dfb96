"""G01 runs -> rational B-spline G06.2 groups (paper 001 §2, Appendix I).

- `rational`: 001's rational least-squares approximation (eq. 1–11): alternating control
  points, weights and parameter correction.
- `compiled`: the compiled closest-point (foot) search of the parameter correction.
- `tolerance`: the fewest control points that keep a polyline within a tolerance.
- `g01_runs`: the runs of consecutive G01 moves between corners (the bench's corpus runs).
- `chains`: the chains of G1/G2/G3 moves a fit may replace, and which of their corners stay sharp.
- `groups`: one chain -> the fewest blocks: sections between sharp corners, pieces fitted or kept,
  joined into G06.2 groups with a knot of multiplicity = degree at each corner.
- `convert`: `vcnc fit`'s program rewriting (chains found, planned in parallel, written back).

May import: ipo.errors, ipo.nurbs, ipr, numpy, numba.
"""
