"""The `vcnc` command line: a thin dispatcher over library functions.

Each subcommand lives in its own module under machine/commands and is imported
only when it is invoked, so `vcnc parse` does not pay for numba or matplotlib.
"""
from __future__ import annotations

import importlib

import click

COMMANDS = {
    "parse": "machine.commands.parse",
    "interp": "machine.commands.interp",
    "run": "machine.commands.run",
    "plot": "machine.commands.plot",
    "stream": "machine.commands.stream",
    "fit": "machine.commands.fit",
    "compare": "machine.commands.compare",
    "surface": "machine.commands.surface",
    "toolpath": "machine.commands.toolpath",
}


class _LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        module = COMMANDS.get(name)
        return importlib.import_module(module).command if module else None


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
def main() -> None:
    """vcnc: a virtual CNC controller with native NURBS interpolation."""
