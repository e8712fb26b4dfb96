"""The feed stage with each NURBS interpolator a machine file may name.

A Taylor update (002 eq. 7) misses the planned chord by an amount that changes from period to
period, and that change is an acceleration error: on these random rational cubics taylor1 went
up to 3.2x and taylor2 up to 1.11x over the axis acceleration limit. Under the feed stage every
method's chord is solved to the driver's tolerance, with the method's du as the first guess.
Constant du cannot follow a feed at all and is refused before anything moves.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ipo.config import ConfigError, load_config
from ipo.feed.planner import plan_periods
from ipo.contracts import PeriodBatch
from tests.ipo.feed.test_nurbs_blend import CFG, assert_forward_to_the_end, assert_within_limits
from tests.ipo.feed.test_nurbs_corners import random_cubic


@pytest.mark.parametrize("method, seed", [("taylor1", 1), ("taylor1", 20), ("taylor2", 15), ("taylor2", 18),
                                          ("recursive", 20)])
def test_every_feed_stage_method_keeps_the_axis_limits(method, seed):
    e = random_cubic(seed)
    cfg = dataclasses.replace(CFG, method=method)
    pos = np.concatenate([b.pos_mm for b in plan_periods([e], cfg, start_mm=e.start) if isinstance(b, PeriodBatch)])
    assert_within_limits(pos, e.start)
    assert_forward_to_the_end(pos, e.start, e.end)


def test_constant_du_is_refused_by_the_feed_stage(tmp_path):
    import re
    from pathlib import Path

    e = random_cubic(1)
    with pytest.raises(ValueError, match="cannot follow a feed profile"):
        list(plan_periods([e], dataclasses.replace(CFG, method="constant-du"), start_mm=e.start))
    toml = tmp_path / "m.toml"
    default = (Path(__file__).resolve().parents[3] / "ipo" / "machine.toml").read_text()
    toml.write_text(re.sub(r'(?m)^method = "recursive"', 'method = "constant-du"', default))
    with pytest.raises(ConfigError, match="^method: "):
        load_config(toml)
