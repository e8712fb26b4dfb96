"""The `vcnc` command line: a thin dispatcher over library functions.

Each subcommand lives in its own module under machine/commands and is imported
only when it is invoked, so `vcnc parse` does not pay for numba or matplotlib.

Exit codes, the same for every subcommand: 0 done, 1 the program, the machine file or the
run failed (each reason printed, nothing moved past what was reported), 2 usage (a bad
option, a missing input file, an output path that cannot be written). A user never sees a
traceback: anything unexpected is reported in one line as a bug (exit 1); `--debug` shows it.

A `vcnc` process ends without Python's teardown: once its command has finished (its files
closed, its exit code set) and the exit handlers have run, the process flushes stdout and
stderr and exits. The teardown would free the objects of numpy, numba and LLVM and of every
loaded kernel one by one: 50-100 ms of CPU in every `vcnc run` or `vcnc interp`, more than
its own work on a short program. Called with an argument list (CliRunner, a script's
`main([...])`), the group returns or raises as click's does.
"""
from __future__ import annotations

import atexit
import importlib
import os
import sys

import click

COMMANDS = {
    "parse": "machine.commands.parse",
    "interp": "machine.commands.interp",
    "run": "machine.commands.run",
    "serve": "machine.commands.serve",
    "plot": "machine.commands.plot",
    "stream": "machine.commands.stream",
    "grbl": "machine.commands.grbl",
    "fit": "machine.commands.fit",
    "compare": "machine.commands.compare",
    "surface": "machine.commands.surface",
    "surface-report": "machine.commands.surface_report",
    "toolpath": "machine.commands.toolpath",
    "warmup": "machine.commands.warmup",
}

# Each command's one-line help, so `vcnc --help` lists the commands without importing their
# modules (numpy, ipo, numba: 0.1 s of CPU, 0.3-0.5 s of wall time on a busy machine).
# tests/test_cli_startup.py checks every line against the command's own docstring; a command
# missing here is imported to ask it.
SHORT_HELP = {
    "parse": "Check FILE and print its motion entities (or a summary).",
    "interp": "Interpolate every motion entity of FILE at a constant chord D (no feed planning).",
    "run": "Check FILE, then run it in the virtual controller and print what the machine did.",
    "plot": "Plot the path, the feed with its limiting reason, and the axes against their limits.",
    "serve": "Keep vcnc loaded and run offline commands for `vcnc` (start-up paid once).",
    "stream": "Stream FILE to a grbl 1.1 board or an increment-protocol drive.",
    "grbl": "Sender features for a grbl 1.1 board (streaming is `vcnc stream`).",
    "fit": "Replace G01 runs by rational B-spline G06.2 groups within a tolerance.",
    "compare": "Run two programs (or one on two controllers) and compare them (002 Table 1).",
    "surface": "Fit digitised cross-sections, skin them into a rational surface and write IGES.",
    "surface-report": "Measure a machined surface saved by `vcnc run --surface OUT.npz`.",
    "toolpath": "Write ball-end finishing passes over an IGES surface as G06.2 groups.",
    "warmup": "Compile the numba kernels of a run now (once per install), so the first run does not wait.",
}


class _LazyGroup(click.Group):
    def main(self, args=None, **extra):
        if args is not None or extra.get("standalone_mode") is False:
            return super().main(args, **extra)
        # the process's own command line: end it as the module docstring says. Registered
        # before the commands load their libraries, the exit runs after their exit handlers.
        ending = _Ending()
        atexit.register(ending.exit_now)
        try:
            return super().main(args, **extra)
        except SystemExit as done:
            ending.ended, ending.code = True, done.code
            raise

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """click's listing (same layout and truncation), from SHORT_HELP instead of imports."""
        names = self.list_commands(ctx)
        limit = formatter.width - 6 - max(len(name) for name in names)
        rows = [(name, (click.Command(name, help=SHORT_HELP[name]) if name in SHORT_HELP
                        else self.get_command(ctx, name)).get_short_help_str(limit)) for name in names]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

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


class _Ending:
    """How the command ended: `code` once it raised SystemExit (`ended`); otherwise (an
    exception on its way out) the process tears down as usual."""

    def __init__(self):
        self.ended = False
        self.code = None

    def exit_now(self) -> None:
        if not self.ended:
            return
        code = self.code
        if code is None:
            code = 0
        elif not isinstance(code, int):   # sys.exit("text"): Python has printed it already
            code = 1
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):   # a closed pipe or stream: Python's own exit would lose it too
                pass
        os._exit(code & 0xFF)


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="vcnc", prog_name="vcnc")
@click.option("--debug", is_flag=True, help="Show the traceback of an internal error.")
def main(debug: bool) -> None:
    """vcnc: a virtual CNC controller with native NURBS interpolation.

    Exit codes: 0 done; 1 the program, machine file or run failed; 2 usage."""


if __name__ == "__main__":
    main()
