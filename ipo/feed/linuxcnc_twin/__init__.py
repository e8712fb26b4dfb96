"""The LinuxCNC 2.9 twin: a program run as LinuxCNC 2.9's task and trajectory planner run it.

A port of LinuxCNC 2.9.0-pre1 (git f1270d6ed7: src/emc/task/emccanon.cc, src/emc/tp/tp.c,
tc.c, blendmath.c, spherical_arc.c, posemath), written anew in Python and numba; it
reproduces LinuxCNC's per-period trajectory, to the BLU, on the programs measured in
tests/data/linuxcnc_twin (docs/twins.md).

- `settings`: what the twin knows of the machine (ipo.linuxcnc_ini.LinuxcncSettings): the
  machine's LinuxCNC INI file (read at load by ipo.linuxcnc_ini), or the machine file's axes.
- `vec`, `geometry`: posemath's vectors, lines, circles (spiral, helix, the arc-length fit),
  spherical blend arcs.
- `canon`: the canon layer: naive-CAM merging, arcs, path modes; `biarcs`: G5.2 NURBS as
  LinuxCNC's biarcs.
- `segments`: one planner segment (TC_STRUCT) and tc.c's rules; `blendmath`: the blend arc of
  a G64 corner; `tp`: the planner queue (tangent joints, kinks, blend arcs, parabolic blends,
  the backward optimization pass).
- `columns`: queued segments as arrays; `cycle`: the compiled run cycle (one servo period per
  step: trapezoid or ramp, split cycles, parabolic blending).
- `planner`: `plan_periods`, the entry point (ipo.feed.planner's interface), and the stops
  task makes at spindle, coolant, message, tool and dwell blocks.

May import: ipo.config, ipo.linuxcnc_ini, ipo.contracts, ipo.errors, ipo.nurbs, ipo.interp, ipr.entities, numpy,
numba.
"""
