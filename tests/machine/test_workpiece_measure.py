"""The surface measurements against profiles whose answers are known in closed form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from machine.workpiece.measure import chord_facets, classical_scallop_mm, detrend, period_mm, profile_figures
from machine.workpiece.zmap import Surface


def test_the_mean_line_follows_a_curved_form():
    """A dome of radius 150 mm with a 1 um, 0.8 mm ripple: the residual is the ripple alone. ISO 16610-21's
    plain Gaussian mean line would sag by sigma^2 / 2R = 0.73 um under the dome (sigma = alpha cut-off /
    sqrt(2 pi) = 0.468 mm at 2.5 mm)."""
    x = np.arange(-30.0, 30.0, 0.01)
    ripple = 0.5e-3 * np.cos(2 * math.pi * x / 0.8)
    r = detrend(x, np.sqrt(150.0**2 - x**2) + ripple)
    inner = np.isfinite(r)
    assert inner.sum() > 0.8 * len(x)
    # the ripple passes with the regression filter's gain at 0.8 mm (near 1), and no offset
    assert abs(np.mean(r[inner])) < 2e-6
    gain = np.ptp(r[inner]) / np.ptp(ripple[inner])
    assert 0.97 < gain <= 1.0 + 1e-6


@pytest.mark.parametrize("samples_per_period", [4.0, 4.3, 10.0])
def test_the_pass_spacing_is_the_dominant_wavelength(samples_per_period):
    """Scallops of a 3 mm ball at 0.2 mm picks sampled by 4 to 10 nodes each: the spacing within 1 %, and
    every arch found (not every other one, where the sampling makes some cusps low)."""
    pick = 0.2
    y = np.arange(0.0, 20.0, pick / samples_per_period)
    phase = (y + 0.5 * pick) % pick - 0.5 * pick  # distance to the nearest pass centre
    z = 3.0 - np.sqrt(9.0 - phase**2)
    assert period_mm(y, z - z.mean()) == pytest.approx(pick, rel=0.01)
    fig = profile_figures(y, z, form_removed=False, periodic=True)
    assert fig.facet_spacing_mm == pytest.approx(pick, rel=0.02)
    # the arch tops are cusps sampled within half a node of their peak
    h = classical_scallop_mm(3.0, pick)
    assert h - (pick / 2) / 3.0 * (pick / samples_per_period) / 2 - 1e-9 <= fig.facet_depth_um / 1e3 <= h + 1e-9


def test_a_flat_floor_has_no_pass_spacing():
    """Across a 4 mm slot 1 mm deep, over the middle 8 mm of a 10 mm stock at 80 um nodes (what
    `vcnc surface-report` measures on a slot): the floor between the walls has no arches, so no pass
    spacing (the walls' steps alone put a peak in the spectrum)."""
    y = 1.04 + 0.08 * np.arange(100)
    fig = profile_figures(y, np.where((y > 3.0) & (y < 7.0), -1.0, 0.0), form_removed=False, periodic=True)
    assert fig.facet_spacing_mm is None and fig.facet_depth_um == 0.0


def test_chord_facets_are_the_pieces_each_straight_block_cut():
    """A row cut by blocks 1 mm long (lines 10, 11, ...), each leaving a parabolic arch sinking `sag` below
    the chord of its ends, at the first of its nodes of 20 um: the facets found by the lines are the whole
    blocks inside the window (not the two it cuts short, not the arc on line 99), 1 mm long, sag deep,
    however low the arches against a ripple the shape-found facets would need to stand out of."""
    step, sag = 0.02, np.array([0.3, 0.5, 0.4, 0.6, 0.2, 0.5]) * 1e-3
    x = np.arange(0, 300) * step  # 0 .. 5.98 mm: six blocks of 50 nodes
    block = np.arange(300) // 50
    t = (np.arange(300) % 50) / 49.0
    dev = -sag[block] * 4 * t * (1 - t) + 1e-4 * (block % 2)  # each block at its own level
    line = (10 + block).astype(np.int32)
    line[block == 3] = 99  # not a straight block
    y = np.array([0.0, 1.0])
    z = np.vstack([dev, dev]).astype(np.float64)
    surf = Surface(x, y, z, np.vstack([line, line]))
    lengths, depths = chord_facets(surf, "x", 0.0, 0.5, 5.5, np.zeros_like(z), {10, 11, 12, 13, 14, 15})
    # window 0.5 .. 5.5 cuts blocks 0 and 5 short; block 3 is line 99: blocks 1, 2, 4 remain
    assert lengths == pytest.approx([1.0, 1.0, 1.0], abs=1e-12)
    # the arch's lowest node: t = 24/49 or 25/49, 4 t (1 - t) = 2400/2401
    assert depths == pytest.approx(sag[[1, 2, 4]] * 2400 / 2401, rel=1e-9)
