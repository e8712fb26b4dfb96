"""G01 runs -> rational B-spline G06.2 groups (paper 001 §2, Appendix I).

- `rational`: 001's rational least-squares approximation (eq. 1–11): alternating control
  points, weights and parameter correction.
- `compiled`: the compiled closest-point (foot) search of the parameter correction.
- `tolerance`: the fewest control points that keep a polyline within a tolerance.
- `g01_runs`: the runs of consecutive G01 moves a fit may replace.
- `convert`: `vcnc fit`'s program rewriting (runs found, fitted in parallel, written back).

May import: ipo.nurbs, ipr, numpy, numba.
"""
