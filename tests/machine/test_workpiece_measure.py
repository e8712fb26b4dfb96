"""The surface measurements against profiles whose answers are known in closed form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from machine.workpiece.measure import classical_scallop_mm, detrend, period_mm, profile_figures


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
