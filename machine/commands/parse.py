"""`vcnc parse FILE [--json] [--all-errors] [--machine TOML]`: check a part program and show
its entities, with the work offsets and tool lengths of the machine file (default: built in).

Exit 0 when the program is valid, 1 when it has errors (printed on stderr as
`file:line:col: error[CODE]: message`). Warnings and notices go to stderr too.
"""
from __future__ import annotations

import json
import math
import sys

import click

from machine.commands import INPUT_FILE

_KINDS = {"Rapid": "rapid", "Line": "line", "Arc": "arc", "Nurbs": "nurbs", "Dwell": "dwell"}


def _arc_length_mm(arc) -> float:
    from ipr.entities import PLANE_AXES

    _, _, n = PLANE_AXES[arc.plane]
    return math.hypot(arc.radius_mm * arc.sweep_rad, arc.end[n] - arc.start[n])


def _nurbs_length_mm(nurbs) -> float:
    from ipo.nurbs.kernel import arc_length

    return arc_length(nurbs.degree, nurbs.knots, nurbs.weights, nurbs.points, rel_tol=1e-6)


def path_length_mm(entity) -> float:
    kind = type(entity).__name__
    if kind in ("Rapid", "Line"):
        return math.dist(entity.start, entity.end)
    if kind == "Arc":
        return _arc_length_mm(entity)
    if kind == "Nurbs":
        return _nurbs_length_mm(entity)
    return 0.0


def entity_json(entity, position) -> dict:
    """One entity as issue 2 item 6 describes it; `position` stands in for a dwell's place."""
    kind = _KINDS[type(entity).__name__]
    feed = getattr(entity, "feed_mm_s", None)
    start = list(getattr(entity, "start", position))
    end = list(getattr(entity, "end", position))
    obj = {"line": entity.line, "kind": kind, "start": start, "end": end,
           "feed_mm_min": None if feed is None else feed * 60.0}
    if kind == "arc":
        obj.update(center=list(entity.center), plane=entity.plane, ccw=entity.ccw)
    elif kind == "nurbs":
        obj.update(degree=entity.degree, knots=entity.knots.tolist(), weights=entity.weights.tolist(),
                   points=entity.points.tolist())
    return obj


def _straight_summary(moves):
    """Length and corner points of the straight moves, vectorised (the bulk of a CAM program)."""
    import numpy as np
    from itertools import chain

    n = len(moves)
    starts = np.fromiter(chain.from_iterable(e.start for e in moves), float, 3 * n).reshape(n, 3)
    ends = np.fromiter(chain.from_iterable(e.end for e in moves), float, 3 * n).reshape(n, 3)
    return float(np.linalg.norm(ends - starts, axis=1).sum()), [starts, ends]


def _arc_summary(arcs):
    """Length and sampled points of arcs, vectorised per plane (ipr.entities.Arc.sweep_rad's rule)."""
    import numpy as np
    from ipr.entities import PLANE_AXES

    length, corners = 0.0, []
    for plane, (a, b, c) in PLANE_AXES.items():
        group = [e for e in arcs if e.plane == plane]
        if not group:
            continue
        start, end, center = (np.array([getattr(e, k) for e in group]) for k in ("start", "end", "center"))
        ccw = np.array([e.ccw for e in group])
        turns = np.array([e.turns for e in group], float)
        radius = np.hypot(start[:, a] - center[:, a], start[:, b] - center[:, b])
        a0 = np.arctan2(start[:, b] - center[:, b], start[:, a] - center[:, a])
        a1 = np.arctan2(end[:, b] - center[:, b], end[:, a] - center[:, a])
        up = np.mod(a1 - a0, 2 * np.pi)
        down = -np.mod(a0 - a1, 2 * np.pi)
        sweep = np.where(ccw, np.where(up > 1e-12, up, 2 * np.pi), np.where(down < -1e-12, down, -2 * np.pi))
        sweep += np.copysign(2 * np.pi * turns, sweep)
        length += float(np.hypot(radius * sweep, end[:, c] - start[:, c]).sum())
        t = np.linspace(0.0, 1.0, 65)
        ang = a0[:, None] + t * sweep[:, None]
        pts = np.empty((len(group), len(t), 3))
        pts[:, :, a] = center[:, a, None] + radius[:, None] * np.cos(ang)
        pts[:, :, b] = center[:, b, None] + radius[:, None] * np.sin(ang)
        pts[:, :, c] = start[:, c, None] + t * (end[:, c] - start[:, c])[:, None]
        corners.append(pts.reshape(-1, 3))
    return length, corners


def _summary(program) -> None:
    import numpy as np
    from rich.console import Console
    from rich.table import Table

    by_kind: dict[str, list] = {kind: [] for kind in _KINDS.values()}
    for e in program.entities:
        kind = _KINDS.get(type(e).__name__)
        if kind is not None:
            by_kind[kind].append(e)
    straight = by_kind["rapid"] + by_kind["line"]
    length, corners = _straight_summary(straight) if straight else (0.0, [])
    if by_kind["arc"]:
        arc_length, arc_corners = _arc_summary(by_kind["arc"])
        length += arc_length
        corners += arc_corners
    for e in by_kind["nurbs"]:
        length += path_length_mm(e)
        corners.append(e.points)
    table = Table(title=f"vcnc parse {program.file}", show_header=False)
    table.add_column("figure", style="bold")
    table.add_column("value", justify="right")
    for kind in ("rapid", "line", "arc", "nurbs", "dwell"):
        table.add_row(f"{kind} entities", str(len(by_kind[kind])))
    table.add_row("path length", f"{length:.3f} mm")
    if corners:
        pts = np.vstack(corners)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        table.add_row("bounding box min", "  ".join(f"{v:.3f}" for v in lo) + " mm")
        table.add_row("bounding box max", "  ".join(f"{v:.3f}" for v in hi) + " mm")
    Console().print(table)


def _setup(machine_file: str | None):
    """Work offsets and tool lengths of the machine file (default: the built-in machine)."""
    from ipr import Setup
    from machine.commands import load_machine

    return Setup.from_machine(load_machine(machine_file))


@click.command("parse")
@click.argument("file", type=INPUT_FILE)
@click.option("--json", "as_json", is_flag=True, help="print the entities as a JSON array")
@click.option("--all-errors", is_flag=True, help="report every error, not just the first")
@click.option("--machine", "machine_file", type=INPUT_FILE,
              help="machine TOML for work offsets and tool lengths (default: built in)")
def command(file: str, as_json: bool, all_errors: bool, machine_file: str | None) -> None:
    """Check FILE and print its motion entities (or a summary)."""
    from ipr import GCodeError, parse_file

    setup = _setup(machine_file)
    try:
        program = parse_file(file, setup=setup, all_errors=all_errors)
    except GCodeError as err:
        for diag in err.diagnostics:
            click.echo(str(diag), err=True)
        sys.exit(1)
    for diag in program.warnings:
        click.echo(str(diag), err=True)
    if as_json:
        items, position = [], (0.0, 0.0, 0.0)
        for e in program.entities:
            if type(e).__name__ in _KINDS:
                items.append(entity_json(e, position))
                position = tuple(items[-1]["end"])
        click.echo(json.dumps(items))
    else:
        _summary(program)
