"""The virtual workpiece: the stock cut by the motion the controller actually made.

A receiver of the drive's per-period rows (beside the trace writers); it owns the height field and hands
back a Surface, and nothing in the drive or the controller depends on it.

- tool.py: the cutter from the tool table (flat, ball, bull) as a solid of revolution (core, corner).
- stock.py: the stock box (--stock or the machine file's [stock]) and the grid, with the spacing rule.
- kernels.py: numba kernels: the exact envelope of a tool swept along one segment, and the tiled update.
- zmap.py: Workpiece (the receiver: heights, the line that cut each node, tool changes) and Surface.
- build.py: a Workpiece for a checked program (which tool, which stock, which grid).
- surface_file.py: saved surfaces (.npz, .stl).
- cli_run.py: the workpiece's part of `vcnc run` (--stock, --tool, --grid-um, --surface).
"""
