"""The virtual workpiece: the stock cut by the motion the controller actually made.

A receiver of the drive's per-period rows (beside the trace writers); it owns the height field and hands
back a Surface, and nothing in the drive or the controller depends on it.

- tool.py: the cutter from the tool table (flat, ball, bull) as a solid of revolution (core, corner).
- stock.py: the stock box (--stock or the machine file's [stock]) and the grid, with the spacing rule.
- envelope.py: numba: the exact envelope of a tool swept along one segment (and a bull's lower bound).
- chains.py: numba: runs of period positions within a thin sleeve around one straight line.
- bounds.py: numba: lower bounds of a run's envelope (a dilated tool on its line, its tangent planes).
- tiles.py: numba: the update of one tile of nodes from the runs that reach it.
- search.py: numba: the exact envelopes of a run's segments at a tile's nodes, per node or all at once.
- removal.py: the update of the Z-map by a batch of periods (runs, blocks, threads).
- teeth.py: numba: the update by the flutes' edges at the spindle angle, period by period (--teeth).
- zmap.py: Workpiece (the receiver: heights, the line that cut each node, tool changes) and Surface.
- build.py: a Workpiece for a checked program (which tool, which stock, which grid).
- surface_file.py: saved surfaces (.npz, .stl).
- measure.py, figures.py, plot.py, pair.py: what a surface shows, its figures, its plot, two surfaces.
- analytic.py: programs whose machined surface is known in closed form (tests, bench).
- cli_run.py: the workpiece's part of `vcnc run` (--stock, --tool, --grid-um, --surface).
"""
