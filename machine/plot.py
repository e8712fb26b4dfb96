"""Pictures of a run: the path, the feed with its limiting reason, and the axes against their
limits. Matplotlib with the Agg backend, written straight to a PNG.

Everything is drawn from a run's digest (machine.report.digest): per column of the picture
the exact minimum and maximum of each signal, so a peak is never lost and a 48-minute
program draws in the time of a short one, from memory that does not grow with its periods.
The feed is an envelope (its maxima and minima per column, the band between them light), the
axes are each axis's largest magnitude per column against its limit, on a scale set by the
data: a run at 5 mm/s on a 200 mm/s axis is not a flat line at the bottom.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

from ipo.contracts import LIMIT_NAMES  # noqa: E402
from machine.report.build import LIMIT_COLOURS  # noqa: E402
from machine.report.digest import ROW, Digest, digest_trace  # noqa: E402
from machine.trace import Trace  # noqa: E402

COLUMNS = 1500  # about the panels' width in pixels
AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")
LIMIT_IN_VIEW = 1.5  # a limit up to this multiple of the data's peak is drawn in the panel, else named


def columns(digest: Digest, n: int = COLUMNS):
    """The digest's buckets merged into at most n columns: (t0, t1, lo, hi, reason) per column,
    lo/hi the exact extremes of every signal, reason the one holding most periods."""
    env, T = digest.env, digest.period_s
    group = max(1, -(-len(env) // n))
    starts = np.arange(0, len(env), group)
    lo = np.minimum.reduceat(env.lo, starts, axis=0)
    hi = np.maximum.reduceat(env.hi, starts, axis=0)
    counts = np.add.reduceat(env.counts, starts, axis=0)
    t0 = starts * env.width * T
    t1 = np.minimum((starts + group) * env.width, env.periods) * T
    return t0, t1, lo, hi, np.argmax(counts, axis=1)


def envelope_line(x: np.ndarray, y: np.ndarray, n: int = COLUMNS) -> tuple[np.ndarray, np.ndarray]:
    """A polyline through each column's minimum and maximum of y, in order: at n columns it draws
    what the whole line would, every extreme included, from 2n points."""
    from machine.report.envelope import column_envelope

    lo, hi, arg_lo, arg_hi = column_envelope(y, n)
    idx = np.sort(np.column_stack((arg_lo, arg_hi)), axis=1).ravel()
    return x[idx], y[idx]


def y_top(peak: float, limits) -> tuple[float, list[bool]]:
    """The y range's top, set by the data; which limits are near enough to be drawn in it."""
    shown = [lim is not None and lim <= LIMIT_IN_VIEW * peak for lim in limits]
    top = max([peak * 1.08 or 1.0] + [lim * 1.04 for lim, s in zip(limits, shown) if s])
    return top, shown


def _path(ax, digest: Digest, i: int, j: int, rapid_lines) -> LineCollection:
    rows = digest.path_rows
    h, v, z = rows[:, i], rows[:, j], rows[:, 2]
    rapid = np.isin(rows[:, ROW.index("line")].astype(np.int64), np.fromiter(rapid_lines, dtype=np.int64))
    seg = np.stack((np.column_stack((h[:-1], v[:-1])), np.column_stack((h[1:], v[1:]))), axis=1)
    cut = LineCollection(seg[~rapid[1:]], cmap="viridis", lw=0.8)
    cut.set_array(z[1:][~rapid[1:]])
    ax.add_collection(cut)
    ax.add_collection(LineCollection(seg[rapid[1:]], colors="0.5", lw=0.7, linestyles="--"))
    ax.autoscale()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("XYZ"[i] + " mm")
    ax.set_ylabel("XYZ"[j] + " mm")
    return cut


def plot_digest(digest: Digest, out: str | Path, title: str = "", rapid_lines=()) -> Path:
    """Draw a run's digest into `out` (PNG): paths XY and XZ, feed, axis velocity/acceleration/jerk."""
    if digest.periods == 0:
        raise ValueError("the trace is empty: nothing moved")
    meta, names = digest.meta, list(digest.signals)
    t0, t1, lo, hi, reason = columns(digest)
    edges = np.append(t0, t1[-1])
    fig = plt.figure(figsize=(14, 15), layout="constrained")
    grid = fig.add_gridspec(4, 2, height_ratios=(1.3, 0.8, 0.8, 0.8))
    ax_xy, ax_xz = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])
    ax_feed = fig.add_subplot(grid[1, :])
    ax_v, ax_a, ax_j = fig.add_subplot(grid[2, 0]), fig.add_subplot(grid[2, 1]), fig.add_subplot(grid[3, :])

    cut = _path(ax_xy, digest, 0, 1, rapid_lines)
    ax_xy.set_title("path XY (colour = Z; rapids dashed)")
    fig.colorbar(cut, ax=ax_xy, label="Z mm", shrink=0.8)
    _path(ax_xz, digest, 0, 2, rapid_lines)
    ax_xz.set_title("path XZ")

    f = names.index("feed")
    top = float(hi[:, f].max()) * 1.08 or 1.0
    for code, name in enumerate(LIMIT_NAMES):
        mask = reason == code
        if mask.any():
            ax_feed.fill_between(edges, 0, top, where=np.append(mask, mask[-1]), step="post",
                                 color=LIMIT_COLOURS[code], alpha=0.35, label=f"limit: {name}", linewidth=0)
    ax_feed.fill_between(edges, np.append(lo[:, f], lo[-1, f]), np.append(hi[:, f], hi[-1, f]), step="post",
                         color="0.55", alpha=0.5, linewidth=0, label="feed: min…max per column")
    ax_feed.stairs(hi[:, f], edges, color="k", lw=0.7, label="feed: max per column")
    ax_feed.set_ylim(0, top)
    ax_feed.set_xlim(edges[0], edges[-1])
    ax_feed.set_xlabel("t s")
    ax_feed.set_ylabel("planned feed mm/s")
    ax_feed.set_title("feed and its limiting reason (the reason holding most of each column)")
    handles, labels = ax_feed.get_legend_handles_labels()
    if "contour_um" in names:
        ax_err = ax_feed.twinx()
        c = names.index("contour_um")
        ax_err.stairs(hi[:, c], edges, color="tab:red", lw=0.8)
        ax_err.set_ylabel("contour error µm", color="tab:red")
        ax_err.set_ylim(bottom=0)
        handles.append(ax_err.patches[0])
        labels.append("contour error (servo), max per column")
    ax_feed.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")

    h = int(meta.get("stencil_periods", 1))
    panels = ((ax_v, "v", "max_velocity_mm_s", "velocity mm/s"),
              (ax_a, "a", "max_accel_mm_s2", f"acceleration mm/s² ({h}-period stencil)"),
              (ax_j, "j", "max_jerk_mm_s3", f"jerk mm/s³ ({h}-period stencil)"))
    for ax, kind, key, what in panels:
        c0, c1, alo, ahi, _ = columns(digest, COLUMNS if ax is ax_j else COLUMNS // 3)  # segments 2-3 px long
        cols = [names.index(kind + c) for c in "xyz"]
        mag = np.maximum(np.abs(alo[:, cols]), np.abs(ahi[:, cols]))
        mag[~np.isfinite(mag)] = 0.0
        limits = [float(v) for v in meta[key]] if key in meta else [None] * 3
        top, shown = y_top(float(mag.max()), limits)
        for i, name in enumerate("XYZ"):
            label = f"|{name}|" if limits[i] is None or shown[i] else f"|{name}| (limit {limits[i]:g} off scale)"
            # one level per column and no risers: an axis that stops in every other column (a raster's
            # step-over axis) would otherwise be a solid block of vertical strokes
            ax.hlines(mag[:, i], c0, c1, colors=AXIS_COLOURS[i], lw=1.4, label=label)
            if shown[i]:
                ax.axhline(limits[i], color=AXIS_COLOURS[i], ls="--", lw=0.8)
        ax.set_ylim(0, top)
        ax.set_xlim(edges[0], edges[-1])
        ax.set_xlabel("t s")
        ax.set_ylabel(what)
        ax.set_title(f"axis {what.split(' ')[0]}: largest magnitude per column (dashed: limits)")
        ax.legend(loc="upper right", fontsize="small")
    if title:
        fig.suptitle(title)
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_trace(trace: Trace, out: str | Path, title: str = "") -> Path:
    """Draw a loaded trace (a file written by `vcnc run --trace`) into `out` (PNG)."""
    if len(trace) == 0:
        raise ValueError("the trace is empty: nothing moved")
    return plot_digest(digest_trace(trace), out, title)
