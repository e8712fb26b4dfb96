"""The PNG's columns and scales: exact extremes per column, a y range set by the data."""
import numpy as np
import pytest

from machine.plot import columns, envelope_line, y_top


def test_columns_keep_each_columns_exact_extremes_of_the_run():
    from test_report import _demo_run

    _, _, digest, trace = _demo_run()
    t0, t1, lo, hi, reason = columns(digest, n=10)
    assert len(t0) <= 10 and t0[0] == 0 and t1[-1] == pytest.approx(trace["t_s"][-1])
    feed, T = trace["feed_mm_s"], trace.meta["period_s"]
    for k in range(len(t0)):
        part = slice(int(round(t0[k] / T)), int(round(t1[k] / T)))
        assert lo[k, 0] == feed[part].min() and hi[k, 0] == feed[part].max()
        codes, counts = np.unique(trace["limit"][part], return_counts=True)
        assert reason[k] == codes[np.argmax(counts)]


def test_envelope_line_passes_through_every_extreme():
    x = np.linspace(0, 1, 100_001)
    y = np.sin(200 * x)
    y[12_345], y[67_890] = 7.0, -7.0
    xs, ys = envelope_line(x, y, n=50)
    assert len(xs) <= 200 and ys.max() == 7.0 and ys.min() == -7.0
    assert xs[np.argmax(ys)] == x[12_345] and np.all(np.diff(xs) >= 0)


def test_axis_scale_follows_the_data_and_draws_only_a_near_limit():
    top, shown = y_top(5.0, [200.0, 6.0, None])
    assert top == pytest.approx(6.0 * 1.04) and shown == [False, True, False]
    top, shown = y_top(5.0, [200.0, 200.0, 200.0])
    assert top == pytest.approx(5.4) and shown == [False] * 3
