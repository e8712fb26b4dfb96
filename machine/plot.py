"""Pictures of a trace: the path, the feed with its limiting reason, and the axes
against their limits. Matplotlib with the Agg backend, written straight to a PNG.

Long traces are reduced per time bucket to their minimum and maximum before
drawing, so a peak is never lost to decimation and a 500 000-period trace plots in
about the time of a short one.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

from ipo.contracts import LIMIT_NAMES  # noqa: E402
from machine.trace import Trace  # noqa: E402

MAX_POINTS = 4000
LIMIT_COLOURS = ("#c8e6c9", "#bbdefb", "#ffe0b2", "#f8bbd0", "#d1c4e9", "#fff59d", "#e0e0e0")
AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")


def _buckets(n: int) -> int:
    return max(1, int(np.ceil(n / MAX_POINTS)))


def _envelope(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-bucket start time, minimum and maximum of y."""
    b = _buckets(len(t))
    m = len(t) // b * b
    if m < len(t):
        pad = np.full(b - (len(t) - m), y[-1])
        y = np.concatenate((y, pad))
        t = np.concatenate((t, np.full(len(pad), t[-1])))
    yy = y.reshape(-1, b)
    return t[::b], yy.min(axis=1), yy.max(axis=1)


def axis_motion(trace: Trace) -> tuple[np.ndarray, np.ndarray, int]:
    """Per-period axis velocity (N,3) and the h-period stencil acceleration (N,3, NaN at the ends)."""
    meta = trace.meta
    blu, T = float(meta["blu_mm"]), float(meta["period_s"])
    h = int(meta.get("stencil_periods", 1))
    inc = trace["inc_blu"]
    vel = inc * (blu / T)
    x = np.vstack((np.zeros((1, 3), np.int64), np.cumsum(inc, axis=0)))[1:]
    acc = np.full(vel.shape, np.nan)
    if len(x) > 2 * h:
        acc[h:-h] = (x[2 * h:] - 2 * x[h:-h] + x[:-2 * h]) * (blu / (h * T) ** 2)
    return vel, acc, h


def _path(ax, horizontal: np.ndarray, vertical: np.ndarray, colour: np.ndarray | None, label: str):
    step = _buckets(len(horizontal))
    h, v = horizontal[::step], vertical[::step]
    if colour is None:
        ax.plot(h, v, lw=0.8, color="k")
        line = None
    else:
        seg = np.stack((np.column_stack((h[:-1], v[:-1])), np.column_stack((h[1:], v[1:]))), axis=1)
        line = LineCollection(seg, cmap="viridis", lw=0.9)
        line.set_array(colour[::step][:-1])
        ax.add_collection(line)
        ax.autoscale()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(label)
    return line


def plot_trace(trace: Trace, out: str | Path, title: str = "") -> Path:
    """Draw the four panels of a trace into `out` (PNG)."""
    if len(trace) == 0:
        raise ValueError("the trace is empty: nothing moved")
    meta = trace.meta
    t, pos, feed, limit = trace["t_s"], trace["pos_mm"], trace["feed_mm_s"], trace["limit"]
    vel, acc, h = axis_motion(trace)
    fig = plt.figure(figsize=(14, 12), layout="constrained")
    grid = fig.add_gridspec(3, 2, height_ratios=(1.3, 0.8, 1.0))
    ax_xy, ax_xz = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])
    ax_feed = fig.add_subplot(grid[1, :])
    ax_v, ax_a = fig.add_subplot(grid[2, 0]), fig.add_subplot(grid[2, 1])

    line = _path(ax_xy, pos[:, 0], pos[:, 1], pos[:, 2], "path XY (colour = Z)")
    ax_xy.set_xlabel("X mm")
    ax_xy.set_ylabel("Y mm")
    if line is not None:
        fig.colorbar(line, ax=ax_xy, label="Z mm", shrink=0.8)
    _path(ax_xz, pos[:, 0], pos[:, 2], None, "path XZ")
    ax_xz.set_xlabel("X mm")
    ax_xz.set_ylabel("Z mm")

    b = _buckets(len(t))
    tb, fmin, fmax = _envelope(t, feed)
    top = float(np.max(feed)) * 1.08 or 1.0
    codes = limit[::b][: len(tb)]
    for code, name in enumerate(LIMIT_NAMES):
        mask = codes == code
        if mask.any():
            ax_feed.fill_between(tb, 0, top, where=mask, step="post", color=LIMIT_COLOURS[code],
                                 label=f"limit: {name}", linewidth=0)
    ax_feed.fill_between(tb, fmin, fmax, color="k", step="post", linewidth=0.8)
    ax_feed.set_ylim(0, top)
    ax_feed.set_xlim(t[0], t[-1])
    ax_feed.set_xlabel("t s")
    ax_feed.set_ylabel("planned feed mm/s")
    ax_feed.set_title("feed and its limiting reason")
    handles, labels = ax_feed.get_legend_handles_labels()
    if "contour_um" in trace.columns:
        ax_err = ax_feed.twinx()
        tc, _, cmax = _envelope(t, trace["contour_um"])
        ax_err.plot(tc, cmax, color="tab:red", lw=0.8)
        ax_err.set_ylabel("contour error µm", color="tab:red")
        ax_err.set_ylim(bottom=0)
        handles.append(ax_err.lines[0])
        labels.append("contour error (servo)")
    ax_feed.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.06, 1.0), fontsize="small")

    for ax, data, key, what in ((ax_v, vel, "max_velocity_mm_s", "velocity mm/s"),
                                (ax_a, acc, "max_accel_mm_s2", f"acceleration mm/s² ({h}-period stencil)")):
        for i, name in enumerate("XYZ"):
            good = ~np.isnan(data[:, i])
            if not good.any():
                continue
            tt, lo, hi = _envelope(t[good], data[good, i])
            ax.fill_between(tt, lo, hi, color=AXIS_COLOURS[i], alpha=0.6, step="post", label=name, linewidth=0.6)
            if key in meta:
                lim = float(meta[key][i])
                ax.axhline(lim, color=AXIS_COLOURS[i], ls="--", lw=0.8)
                ax.axhline(-lim, color=AXIS_COLOURS[i], ls="--", lw=0.8)
        ax.set_xlim(t[0], t[-1])
        ax.set_xlabel("t s")
        ax.set_ylabel(what)
        ax.set_title(f"axis {what.split(' ')[0]} (dashed: limits)")
        ax.legend(loc="upper right", fontsize="small")
    if title:
        fig.suptitle(title)
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
