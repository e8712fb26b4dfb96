"""The `vcnc` subcommands, one module each, and what they share."""
from __future__ import annotations

import os
from pathlib import Path

import click

# Our least-squares problems are many and small: BLAS threads only contend for the two cores.
# Set before numpy loads, which happens in the command modules, not at CLI start-up.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")


# an input file: exists, is a file, may be read (a missing one is a usage error, exit 2)
INPUT_FILE = click.Path(exists=True, dir_okay=False, readable=True)


def load_machine(path: str | None):
    """The machine file, or the built-in default; a bad file names the key and exits."""
    from ipo.config import ConfigError, default_config, load_config

    try:
        return default_config() if path is None else load_config(path)
    except ConfigError as err:
        raise click.ClickException(f"machine file {path or '(default)'}: {err}") from None
    except OSError as err:
        raise click.ClickException(f"machine file {path}: {err.strerror or err}") from None


def refusal(err, where: str) -> click.ClickException:
    """An ipo.errors.IpoError refusing the user's input, as the commands report it (exit 1):
    `WHERE: error[CODE]: message`, or the message's own `file:line:` where it starts with WHERE."""
    location, sep, text = err.message.partition(": ")
    if not (sep and location.startswith(where)):
        location, text = where, err.message
    return click.ClickException(f"{location}: error[{err.code}]: {text}")


def linuxcnc_ini_option(fn):
    return click.option("--linuxcnc-ini", "linuxcnc_ini", type=INPUT_FILE,
                        help="The machine's LinuxCNC INI file for the LinuxCNC twin: its [AXIS_*] limits, "
                             "[TRAJ] keys and servo period (default: the machine file's [linuxcnc] ini, "
                             "else its axes).")(fn)


def planner_options(fn):
    """--planner, --grbl-settings and --linuxcnc-ini, shared by the commands that run a program."""
    from ipo.config import PLANNERS

    fn = linuxcnc_ini_option(fn)
    fn = click.option("--grbl-settings", "grbl_settings", type=INPUT_FILE,
                      help="grbl's `$$` printout (`$110=6000.000` lines) for the grbl twin "
                           "(default: the machine file's [grbl] settings, else its axes).")(fn)
    return click.option("--planner", type=click.Choice(list(PLANNERS)), default=None,
                        help="Whose motion planning to reproduce: vcnc's own, or a controller twin "
                             "(default: the machine file's `planner`).")(fn)


def apply_planner(config, planner: str | None, grbl_settings: str | None, linuxcnc_ini: str | None = None):
    """The machine configuration with --planner, --grbl-settings and --linuxcnc-ini applied (a bad
    dump or INI file: usage error naming the line or the key)."""
    from ipo.grbl_settings import GrblSettingsError, read_dump
    from ipo.linuxcnc_ini import IniError, load_ini
    from machine.planners import with_planner

    settings = ini = None
    if grbl_settings is not None:
        try:
            settings = read_dump(grbl_settings)
        except GrblSettingsError as err:
            raise click.BadParameter(str(err), param_hint="--grbl-settings") from None
    if linuxcnc_ini is not None:
        try:
            ini = load_ini(linuxcnc_ini)
        except IniError as err:
            raise click.BadParameter(str(err), param_hint="--linuxcnc-ini") from None
    return with_planner(config, planner, settings, ini)


class OutputPath(click.ParamType):
    """A file the command will write, checked when the command line is read, before any work:
    a known suffix, not a folder, in a folder that exists and may be written. A bad one is a
    usage error (exit 2), so a long run is never lost at its end to a typo in a path."""

    name = "path"

    def __init__(self, suffixes: tuple[str, ...] = ()):
        self.suffixes = suffixes

    def convert(self, value, param, ctx):
        path = Path(value)
        if self.suffixes and path.suffix.lower() not in self.suffixes:
            self.fail(f"{value}: must end in {' or '.join(self.suffixes)}", param, ctx)
        if path.is_dir():
            self.fail(f"{value} is a folder", param, ctx)
        folder = path.parent
        if not folder.is_dir():
            self.fail(f"{value}: the folder {folder} does not exist", param, ctx)
        if not os.access(folder, os.W_OK | os.X_OK) or path.exists() and not os.access(path, os.W_OK):
            self.fail(f"{value} cannot be written (permission denied)", param, ctx)
        return str(value)



