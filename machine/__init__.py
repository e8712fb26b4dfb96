"""machine — the receivers of ipo's period stream, and the `vcnc` command line.

- `controller`: checks a whole program, then runs it through ipo.feed into the drive.
- `planners`: which planner a run uses (vcnc's or a controller twin, ipo.feed.profiles) and
  what machine hands a twin (the grbl twin: the grbl link's lines, machine.grbl.wire).
- `drive`, `servo`, `extents`: the simulated drive (limits, statistics, servo lag) and the
  travel check of the whole path.
- `realtime`: pacing at the interpolation period, with hold, override and stop.
- `trace`, `plot`, `report/`: per-period recording, its plots and the HTML report.
- `path_distance`: the exact distance from a path's periods to another path (`vcnc compare`).
- `grbl/`: the link to a grbl 1.1 board (NURBS sent as planned G1 segments).
- `increments/`: the increment protocol, its link and a receiver.
- `cli`, `commands/`: the `vcnc` command line, one module per subcommand.
- `client`, `server`: the `vcnc` entry point and `vcnc serve`, the fork server it hands offline
  commands to (start-up paid once; docs/server.md).

May import: ipo, ipr. Nothing imports machine.
"""
import ipo  # noqa: F401  (first: numba's cache directory, keyed by the kernels' source; ipo/kernel_cache.py)
