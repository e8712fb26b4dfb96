"""Two machined surfaces of the same stock (`vcnc compare A B --stock …`): their figures side by side,
their difference, and the plot of both with the difference map."""
from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from machine.workpiece.figures import EVAL_FRACTION, format_rows, inner, surface_figures
from machine.workpiece.cli_run import check_stock_and_grid
from machine.workpiece.zmap import Surface


def cut_options(stock_text, tool, grid_um, surface_plot) -> dict | None:
    """build_workpiece's keywords from the command line, checked before any run; None without --stock."""
    if stock_text is None:
        if tool is not None or grid_um is not None or surface_plot:
            raise click.UsageError("--tool, --grid-um and --surface-plot cut a workpiece: add --stock")
        return None
    check_stock_and_grid(stock_text, grid_um)
    return {"stock_text": stock_text, "tool": tool, "grid_um": grid_um}


def compare_surfaces(a: Surface, b: Surface) -> dict:
    """Both surfaces' figures and their difference over the middle of the stock (figures.inner: at the
    stock's edges the tool enters and leaves, and a wall between two nodes differs by its height for a
    path a micrometre apart)."""
    figs = {"a": surface_figures(a), "b": surface_figures(b)}
    cols, rows = inner(a)
    diff = (b.z_mm - a.z_mm)[np.ix_(rows, cols)]
    figs["difference_um"] = {"max_abs": float(np.max(np.abs(diff)) * 1e3),
                             "rms": float(np.sqrt(np.mean(diff**2)) * 1e3)}
    return figs


def format_surfaces(figs: dict, files) -> str:
    name_a, name_b = (Path(f).name for f in files)
    d = figs["difference_um"]
    return ("\nmachined surfaces\n" + format_rows({name_a: figs["a"], name_b: figs["b"]})
            + f"\ndifference B - A over the middle {EVAL_FRACTION:.0%} of the stock: max |dz| {d['max_abs']:.3f} um, "
              f"rms {d['rms']:.3f} um")


def plot_pair(a: Surface, b: Surface, out, files) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from machine.workpiece.measure import detrend
    from machine.workpiece.plot import shaded

    extent = (a.x_mm[0], a.x_mm[-1], a.y_mm[0], a.y_mm[-1])
    fig, axes = plt.subplots(1, 3, figsize=(18, 5.5))
    for ax, s, name in ((axes[0], a, files[0]), (axes[1], b, files[1])):
        rough = np.vstack([detrend(s.x_mm, row) for row in s.z_mm]) * 1e3
        cols, rows = inner(s)
        mid = rough[np.ix_(rows, cols)]
        lim = float(np.nanpercentile(np.abs(mid), 99)) if np.isfinite(mid).any() else 1.0
        rgb = shaded(np.nan_to_num(rough), cmap="RdBu_r", vmin=-lim, vmax=lim, blend="soft")
        ax.imshow(rgb, origin="lower", extent=extent, aspect="equal")
        ax.set_title(f"{Path(name).name}\nshaded, less its mean line along X (+-{lim:.2f} um)")
    diff = (b.z_mm - a.z_mm) * 1e3
    lim = float(np.percentile(np.abs(diff), 99.5)) or 1.0
    im = axes[2].imshow(diff, origin="lower", extent=extent, aspect="equal", cmap="RdBu_r", vmin=-lim, vmax=lim)
    fig.colorbar(im, ax=axes[2], label="um")
    axes[2].set_title("B - A, um")
    for ax in axes:
        ax.set_xlabel("X mm")
        ax.set_ylabel("Y mm")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
