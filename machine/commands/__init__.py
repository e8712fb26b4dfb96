"""The `vcnc` subcommands, one module each, and what they share."""
from __future__ import annotations

import os

import click

# Our least-squares problems are many and small: BLAS threads only contend for the two cores.
# Set before numpy loads, which happens in the command modules, not at CLI start-up.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")


def load_machine(path: str | None):
    """The machine file, or the built-in default; a bad file names the key and exits."""
    from ipo.config import ConfigError, default_config, load_config

    try:
        return default_config() if path is None else load_config(path)
    except ConfigError as err:
        raise click.ClickException(f"machine file {path or '(default)'}: {err}") from None
    except OSError as err:
        raise click.ClickException(f"machine file {path}: {err.strerror or err}") from None


def check_output(path: str | None, option: str) -> None:
    """An output file's folder must exist and be writable before any work starts."""
    if path is None:
        return
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise click.BadParameter(f"{path}: the folder {folder} does not exist", param_hint=option)
    if os.path.isdir(path) or not os.access(folder, os.W_OK) or os.path.exists(path) and not os.access(path, os.W_OK):
        raise click.BadParameter(f"{path}: cannot be written", param_hint=option)
