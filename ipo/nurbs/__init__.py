"""The NURBS kernel (000 eq. 1–4): the one geometry of a rational B-spline curve.

- `kernel`: vectorised evaluation over many parameters (A2.3 compiled) (basis functions, spans,
  points, derivatives); the reference the compiled form and the tests are held to.
- `compiled`: scalar numba evaluation for the per-period loops (one u at a time), in the
  de Boor form and as per-span polynomials.
- `subcurve`: the part of a curve between two parameters, by knot insertion.

May import: numpy, numba, ipr.entities. Nothing else of ipo.
"""
