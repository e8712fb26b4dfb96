"""The grbl 1.1 twin: a program as a grbl 1.1 board (gnea/grbl 1.1h) runs it, behind the same
interface as vcnc's own planner (`twin.plan_periods`, the PeriodBatch stream).

- `wire`: what grbl receives, one WireLine per line on the serial link (machine hands in
  the grbl link's lines; `from_entities` for a program without NURBS and no link).
- `arcs`: G2/G3 cut into chords by the arc tolerance $12 (mc_arc).
- `planner`: the 16-block ring, junction speeds from $11, the two-pass re-planning.
- `stepper`: the segment generator (ACCELERATION_TICKS_PER_SECOND, AMASS) and step timing.
- `board`: the serial link, the main loop, the planner and the stepper on grbl's clock.
- `twin`: the board's segments sampled at the machine's period; `plan_periods`.
The `$$` settings are ipo.grbl_settings (the machine file's loader reads them).

May import: ipo.config, ipo.contracts, ipo.errors, ipo.grbl_settings, ipo.interp, ipr.entities, numpy.
"""
