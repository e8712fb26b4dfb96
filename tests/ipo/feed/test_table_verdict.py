"""ipo.feed.table_verdict against the table it stands for (ipo.feed.sampling.nurbs_table): the same
parameters to the bit where it is sure, never sure where nurbs_table refuses, and
planning_problem's answer (with nurbs_table's message) unchanged."""
from __future__ import annotations

import numpy as np

from ipr import parse_text
from ipr.entities import Nurbs
from ipo.errors import IpoError
from ipo.feed.sampling import nurbs_table
from ipo.feed.split import corner_parts, planning_problem
from ipo.feed.table_verdict import table_parameters, tabled
from ipo.fit.convert import convert_text
from tests.ipo.feed.test_steep_weights import PROGRAM as STEEP_PROGRAM

GAP_MM = 0.05


def _relief_raster() -> str:
    """A height-map finishing raster as CAM systems write it: 0.75 mm steps along X over a relief with
    ridges (turns of 5-40 degrees), 90-degree step-overs between passes, 3 decimals."""
    x = np.arange(0.0, 45.0, 0.75)
    words = []
    for row, y in enumerate(np.arange(0.0, 8.0, 0.5)):  # 16 passes: >= 30 parts (12 gave 26)
        xs = x if row % 2 == 0 else x[::-1]
        z = -1.0 + 0.8 * np.sin(xs / 3.0 + y) + 0.6 * np.abs(np.sin(xs / 7.0))
        words += [f"X{a:.3f} Y{y:.3f} Z{c:.3f}" for a, c in zip(xs, z)]
    return "\n".join(["G21 G90 G17 G64", "G0 X0 Y0 Z5", f"G1 {words[0]} F1200", *words[1:], "M2", ""])


def _arrays(part: Nurbs):
    return (np.array(part.knots, dtype=float), np.array(part.weights, dtype=float),
            np.array(part.points, dtype=float), GAP_MM)


def _degree2_parts() -> list[Nurbs]:
    # groups only: the passes lie in XZ planes, which the fit would otherwise write as G18 arcs
    fitted, _ = convert_text(_relief_raster(), 0.01, jobs=1, arcs=False)
    groups = [e for text in (fitted, STEEP_PROGRAM) for e in parse_text(text).entities if isinstance(e, Nurbs)]
    assert len(groups) >= 2
    return [p for g in groups for p in corner_parts(g) if isinstance(p, Nurbs) and p.degree == 2]


def test_parameters_are_nurbs_tables_to_the_bit():
    """Real fitted groups (a relief raster fitted at 10 um, cut at their corners) and the steep-weights
    group of CAMotics' bear.nc (weights 8.7e-6 to 2.5e-2): every part nurbs_table tables gets the same
    parameters from table_parameters, and those it is sure of are all of them but a few."""
    parts = _degree2_parts()
    sure = 0
    for part in parts:
        table = nurbs_table(part, GAP_MM)  # all of these are tabled (the fit kept only those)
        u = table_parameters(*_arrays(part))
        if len(u):
            assert np.array_equal(u, table.u), part.line
        sure += tabled(*_arrays(part))
    assert len(parts) >= 30 and sure >= 0.9 * len(parts)


def test_a_curve_nurbs_table_refuses_is_left_to_it():
    """Two control points that coincide inside a quadratic: |C'| vanishes at the knot between them
    (nurbs_table's E-NURBS-PATH). The verdict is not sure, and planning_problem says what
    nurbs_table says."""
    e = Nurbs(7, 2, np.array([0.0, 0.0, 0.0, 1.0, 2.0, 2.0, 2.0]), np.ones(4),
              np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 1.0, 0.0]]), 50.0)
    assert not tabled(*_arrays(e))
    try:
        nurbs_table(e, GAP_MM)
        raise AssertionError("nurbs_table should refuse this curve")
    except IpoError as err:
        assert planning_problem(e, GAP_MM) == err.message
        assert "vanishing derivative at u = 1" in err.message


def test_uneven_weights_are_not_sure():
    """Weights 1 and 1e-9 side by side: nurbs_table still tables the curve (1709 samples, measured), but
    the arc length needs many rounds of halving there; the verdict leaves it to nurbs_table and
    planning_problem accepts it as before."""
    e = Nurbs(3, 2, np.array([0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 3.0, 3.0]), np.array([1.0, 1e-9, 1.0, 1e-9, 1.0]),
              np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [2, 1, 0], [2, 2, 0]]), 50.0)
    assert not tabled(*_arrays(e))
    assert len(nurbs_table(e, GAP_MM).u) > 1000
    assert planning_problem(e, GAP_MM) is None
