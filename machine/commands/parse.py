"""`vcnc parse FILE [--json] [--all-errors] [--machine TOML]`: check a part program and show
its entities, with the work offsets and tool lengths of the machine file (default: built in).

Exit 0 when the program is valid, 1 when it has errors (printed on stderr as
`file:line:col: error[CODE]: message`). Warnings and notices go to stderr too.
"""
from __future__ import annotations

import json
import sys

import click

from machine.commands import INPUT_FILE

KINDS = {"Rapid": "rapid", "Line": "line", "Arc": "arc", "Nurbs": "nurbs", "Dwell": "dwell"}


def entity_json(entity, position) -> dict:
    """One entity as `--json` prints it: line, kind, start and end (mm, machine coordinates),
    feed_mm_min (null for rapids and dwells); an arc adds center, plane and ccw, a NURBS degree,
    knots, weights and points. `position` stands in for a dwell's start and end."""
    kind = KINDS[type(entity).__name__]
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
    from ipr import GCodeError, ProgramText
    from machine.program_summary import Summary

    setup = _setup(machine_file)
    run = ProgramText.read(file).interpret(setup, all_errors)
    items, position = [], (0.0, 0.0, 0.0)
    summary = Summary()
    try:
        for batch in run:   # the entities a batch at a time: only the summary or the JSON is kept
            if not as_json:
                summary.add(batch)
                continue
            for e in batch:
                if type(e).__name__ in KINDS:
                    items.append(entity_json(e, position))
                    position = tuple(items[-1]["end"])
    except GCodeError as err:
        for diag in err.diagnostics:
            click.echo(str(diag), err=True)
        sys.exit(1)
    for diag in run.warnings:
        click.echo(str(diag), err=True)
    if as_json:
        click.echo(json.dumps(items))
    else:
        summary.print(file)
