"""Constant-chord interpolation: one motion entity stepped period by period at given chords.

- `recursive`: 000's recursive parameter update (eq. 8–14, the start-up of §2.2.1).
- `taylor`: the Taylor update (002 eq. 7), first and second order.
- `constant_du`: the naive baseline of 000 Fig. 7.
- `line_arc`: exact stepping along lines, arcs and helices.
- `steppers`: `make_stepper`, the one way to get a stepper for an entity (the contract is
  `ipo.contracts.Steps`).
- `reference_word`: per-period positions quantised to BLU (000 §2.3); the production
  quantiser of the period stream.
- `reference_pulse`: unit pulses by the 0.5 BLU rule (000 §2.4).
- `chord_study`: `vcnc interp`'s study at a constant chord (000 §3, Fig. 7–9).

May import: ipo.contracts, ipo.errors, ipo.segments, ipo.nurbs, ipr.entities, numpy, numba.
"""
