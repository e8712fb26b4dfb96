"""The `vcnc` command line: a thin dispatcher over library functions.

Each subcommand lives in its own module under machine/commands and is imported
only when it is invoked, so `vcnc parse` does not pay for numba or matplotlib.

Exit codes, the same for every subcommand: 0 done, 1 the program, the machine file or the
run failed (each reason printed, nothing moved past what was reported), 2 usage (a bad
option, a missing input file, an output path that cannot be written). A user never sees a
traceback: anything unexpected is reported in one line as a bug (exit 1); `--debug` shows it.
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
    "grbl": "machine.commands.grbl",
    "fit": "machine.commands.fit",
    "compare": "machine.commands.compare",
    "surface": "machine.commands.surface",
    "surface-report": "machine.commands.surface_report",
    "toolpath": "machine.commands.toolpath",
}


class _LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        module = COMMANDS.get(name)
        return importlib.import_module(module).command if module else None

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except (click.ClickException, click.exceptions.Exit, click.Abort, KeyboardInterrupt, SystemExit):
            raise
        except Exception as err:
            if ctx.params.get("debug"):
                raise
            raise click.ClickException(f"internal error (a bug in vcnc, please report it): "
                                       f"{type(err).__name__}: {err}; --debug shows the traceback") from None


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="vcnc", prog_name="vcnc")
@click.option("--debug", is_flag=True, help="Show the traceback of an internal error.")
def main(debug: bool) -> None:
    """vcnc: a virtual CNC controller with native NURBS interpolation.

    Exit codes: 0 done; 1 the program, machine file or run failed; 2 usage."""


if __name__ == "__main__":
    main()
