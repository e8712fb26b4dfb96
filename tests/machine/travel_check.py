"""travel_violations: the (line, reason) pairs of the motions that leave the travel, as
machine.check reports them (machine.extents.excursions_of), for tests of the extents."""
from __future__ import annotations

import numpy as np

from ipr.entities import group_by_type
from machine.extents import excursions_of


def travel_violations(motions, lo_mm: np.ndarray, hi_mm: np.ndarray) -> list[tuple[int, str]]:
    """(line, reason) for every motion that leaves the travel, one per axis and side, in line order."""
    return [(x.line, x.reason(lo_mm, hi_mm)) for x in excursions_of(group_by_type(list(motions)), lo_mm, hi_mm)]
