"""The surface plot: shaded height, the deviation map in um with its colour bar, and one profile across
and one along the passes through the middle of the stock (short windows, so that scallops and facets
show), as deviation from the reference or from the mean line (measure.detrend)."""
from __future__ import annotations

import numpy as np

from machine.workpiece.measure import CUTOFF_MM, detrend, profile
from machine.workpiece.zmap import Surface

PROFILE_ACROSS_MM = 2.0  # a few passes
PROFILE_ALONG_MM = 10.0  # a few chords of a finishing program
# Shaded maps are blended at most this many pixels along a side: the panel shows about 650, and
# blending finish_g01.nc's 2581 x 961 nodes took 1.1 s of the figure's 3 s. The slopes are taken at every node
# first, so that the scallops still shade the averaged pixels.
SHADE_MAX_PX = 1400


def _block_mean(a: np.ndarray, f: int) -> np.ndarray:
    """Means over f x f blocks of the first two axes (the last blocks of each axis may be smaller)."""
    rows, cols = np.arange(0, a.shape[0], f), np.arange(0, a.shape[1], f)
    sums = np.add.reduceat(np.add.reduceat(a, rows, axis=0), cols, axis=1)
    counts = np.outer(np.diff(np.append(rows, a.shape[0])), np.diff(np.append(cols, a.shape[1])))
    return sums / counts.reshape(counts.shape + (1,) * (a.ndim - 2))


def shaded(data: np.ndarray, *, cmap: str = "gray", vmin: float | None = None, vmax: float | None = None,
           blend: str = "hsv", spacing: float = 1.0, vert_exag: float = 1.0) -> np.ndarray:
    """RGB of data in the colour map, shaded by the light from the north-west: LightSource.shade, with the
    slopes taken at every node and the blend at most SHADE_MAX_PX a side."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LightSource, Normalize

    light = LightSource(azdeg=315, altdeg=35)
    intensity = light.hillshade(data, vert_exag=vert_exag, dx=spacing, dy=spacing)
    rgb = plt.get_cmap(cmap)(Normalize(vmin, vmax)(data))[..., :3]
    f = -(-max(data.shape) // SHADE_MAX_PX)
    if f > 1:
        rgb, intensity = _block_mean(rgb, f), _block_mean(intensity, f)
    mix = light.blend_hsv if blend == "hsv" else light.blend_soft_light
    return mix(rgb, intensity[..., None])


def plot_surface(surface: Surface, out, *, title: str = "", reference: np.ndarray | None = None,
                 feed_axis: str = "x") -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x, y, z = surface.x_mm, surface.y_mm, surface.z_mm
    extent = (x[0], x[-1], y[0], y[-1])
    fig, ((ax_h, ax_d), (ax_across, ax_along)) = plt.subplots(2, 2, figsize=(14, 9))
    ax_h.imshow(shaded(z, spacing=surface.grid_mm, vert_exag=20.0), origin="lower", extent=extent, aspect="equal")
    ax_h.set_title("machined surface (shaded height)")
    if reference is not None:
        dev_um, label = (z - reference) * 1e3, "deviation from the reference, um (+ material left)"
    else:
        dev_um = np.vstack([detrend(x, row) for row in z]) * 1e3 if feed_axis == "x" else \
            np.column_stack([detrend(y, col) for col in z.T]) * 1e3
        label = "height less its mean line along the feed (ISO 16610-31 Gaussian regression), um"
    inner = dev_um[len(y) // 10:len(y) - len(y) // 10, len(x) // 10:len(x) - len(x) // 10]
    lim = float(np.nanpercentile(np.abs(inner), 99.5)) if np.isfinite(inner).any() else 1.0
    im = ax_d.imshow(dev_um, origin="lower", extent=extent, aspect="equal", cmap="RdBu_r", vmin=-lim, vmax=lim)
    fig.colorbar(im, ax=ax_d, label="um")
    ax_d.set_title(label)
    across = "y" if feed_axis == "x" else "x"
    mid = {"x": 0.5 * (x[0] + x[-1]), "y": 0.5 * (y[0] + y[-1])}
    for ax, along, name, half in ((ax_across, across, "across", PROFILE_ACROSS_MM / 2),
                                  (ax_along, feed_axis, "along", PROFILE_ALONG_MM / 2)):
        c = mid[along]
        s_mm, d = profile(surface, along, mid["y" if along == "x" else "x"], c - half - CUTOFF_MM,
                          c + half + CUTOFF_MM, reference)
        r = d if reference is not None else detrend(s_mm, d)
        keep = np.abs(s_mm - c) <= half
        ax.plot(s_mm[keep], r[keep] * 1e3, lw=0.8)
        ax.set_xlabel(f"{along.upper()} mm")
        ax.set_ylabel("um")
        at = "Y" if along == "x" else "X"
        ax.set_title(f"profile {name} the passes ({at} = {mid['y' if along == 'x' else 'x']:.3f} mm)")
    for ax in (ax_h, ax_d):
        ax.set_xlabel("X mm")
        ax.set_ylabel("Y mm")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
