"""The feed stage: motion entities -> one arc-length path -> planned feed -> period batches.

Pipeline (`planner.FeedPlanner`, per look-ahead window), three owners with the planner
as the loop between them: the intake (motions read -> pieces), the window (pieces,
samples and caps, events) and the output side (`emission`: the period grid, where the
machine stands).
- `intake`: motions read but not yet built (each NURBS as its parts, with its driver),
  built into pieces and handed on with their drivers; where an event read now happens.
- `split`: a NURBS with C0 corners inside it, as its parts (and the check that refuses a
  curve the planner cannot follow); `table_verdict`: whether sampling's table holds a degree-2
  part, compiled, for that check on the thousands of groups `vcnc fit` writes.
- `pieces`: lines, arcs and G64 corner blends on one arc-length parameter; `blends/` holds
  the corners next to arcs and NURBS (`curve_corner`), the curvature-continuous corners of S-curve mode
  (`curvature_continuous` between lines, `g2_chains` through runs of short lines, `g2_joints` next
  to arcs and NURBS) and their compiled kernels (`compiled`); `arc_corners`: the cubic corners where
  an arc meets a line or an arc, all of a build's in one compiled pass (curve_corner's rule, to the bit).
- `nurbs_driver`: one NURBS walked by its stepper along the planned arc lengths; a corner
  blend's curve and table (`BlendCurve`), which emission walks without a stepper.
- `analytic`: the analytic pieces' points, tangents and curvature by arc length, compiled;
  `arcs`: G2/G3 arcs laid out as such pieces (and trimmed by their blends), compiled.
- `sampling`: where along the path the limits are evaluated.
- `limits`: caps on v^2 at the samples, each with its reason, 002's roughness limiter
  among them (the model, eq. 1–6, is ipo.roughness: the machine-file check reads it too);
  `cap_kernels`: the per-sample caps, compiled.
- `merge`: G64 Q, G1 runs within Q of one line joined before the pieces (LinuxCNC's rule).
- `lookahead`: the phase-plane profile and its time parameterisation; `interval_lp`: the
  two-variable programme of one interval that its backward pass solves per sample.
- `scurve`: S-curve mode's window: jerk-limited segments committed and put out by period;
  `jerk_plan` finds them (passes, the checks of `jerk_checks`, limits raised where the checks
  allow, staircases merged by `jerk_runs`) from the anchors of `jerk_anchors`, `jerk_profile`
  holds the double-S closed forms and the time line of a chain of segments.
- `window`: the look-ahead window (pieces, drivers, samples and caps, pending events),
  one object with one owner, the planner; `driver_changes`: what one build made.
- `emission`: a refined profile -> the period grid -> quantised positions -> `PeriodBatch`;
  owns where the machine stands and the S-curve filter; reads the window.
- `planner`: the look-ahead plan over the window and the loop between the owners;
  `plan_periods`, the stage's entry point.
- `grbl_twin/`, `linuxcnc_twin/`: the controller twins (a grbl 1.1 board, LinuxCNC 2.9) behind
  the same interface; `profiles`: the machine file's `planner` -> its plan_periods
  (ipo.config.PLANNERS).

May import: ipo.config, ipo.config_values, ipo.contracts, ipo.errors, ipo.grbl_settings, ipo.roughness, ipo.segments, ipo.numpy_kernels, ipo.nurbs, ipo.interp, ipr.entities, numpy, numba.
"""
