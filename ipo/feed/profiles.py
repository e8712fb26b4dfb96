"""Planner profiles: the machine file's `planner` (ipo.config.PLANNERS) -> its plan_periods.

vcnc's own planner (ipo.feed.planner) and the controller twins (ipo.feed.grbl_twin, ...)
share one interface: `plan_periods(entities, config, *, method, feed_override, start_mm,
batch_periods)` yielding PeriodBatch runs and the program's events. A twin may take more
keywords (the grbl twin: `wire`, the lines the grbl link sends), which machine supplies.
"""
from __future__ import annotations

import importlib
from typing import Callable

from ipo.config import PLANNERS


def plan_function(name: str) -> Callable:
    """The plan_periods of planner profile `name` (a key of ipo.config.PLANNERS)."""
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; choose one of {', '.join(PLANNERS)}")
    return importlib.import_module(PLANNERS[name]).plan_periods
