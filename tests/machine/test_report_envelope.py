"""The report's min/max envelopes keep every extreme exactly, however the periods arrive."""
import numpy as np
import pytest

from machine.report.envelope import Envelope, column_envelope


def _signal(n: int, seed: int = 3) -> np.ndarray:
    """A chirp with noise and isolated one-period spikes (what a plain decimation loses)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / n
    y = np.sin(2 * np.pi * (3 + 400 * t) * t) + 0.01 * rng.standard_normal(n)
    k = min(25, n)
    spikes = rng.choice(n, k, replace=False)
    y[spikes] += rng.choice([-5.0, 5.0], k) * rng.uniform(1, 2, k)
    return y


@pytest.mark.parametrize("n,columns", [(1, 4), (7, 4), (4096, 1000), (100_003, 1000), (262_144, 512)])
def test_every_bucket_keeps_its_exact_minimum_and_maximum(n, columns):
    y = _signal(n)
    lo, hi, arg_lo, arg_hi = column_envelope(y, columns)
    width = -(-n // len(lo))
    assert len(lo) <= 2 * columns and (len(lo) > columns // 2 or n < columns)
    # brute force over the same buckets of `width` periods
    for b in range(len(lo)):
        part = y[b * width:(b + 1) * width]
        assert lo[b] == part.min() and hi[b] == part.max()
        assert y[arg_lo[b]] == lo[b] and y[arg_hi[b]] == hi[b]
        assert b * width <= arg_lo[b] < (b + 1) * width and b * width <= arg_hi[b] < (b + 1) * width
    assert lo.min() == y.min() and hi.max() == y.max()
    assert np.argmin(y) in arg_lo and np.argmax(y) in arg_hi
    # every one-period spike is kept at its own period (none shares a bucket with a bigger one here)
    kept = set(arg_lo.tolist()) | set(arg_hi.tolist())
    spikes = np.flatnonzero(np.abs(y) > 4)
    alone = [i for i in spikes if np.sum((spikes // width) == i // width) == 1]
    assert all(int(i) in kept for i in alone)


def test_batches_of_any_size_give_the_same_envelope_as_one_batch():
    y = _signal(50_000, seed=9)
    whole = Envelope(1, max_buckets=256)
    whole.add(y[:, None])
    pieces = Envelope(1, max_buckets=256)
    rng = np.random.default_rng(1)
    i = 0
    while i < len(y):
        k = int(rng.integers(1, 3000))
        pieces.add(y[i:i + k, None])
        i += k
    a, b = whole.finish(), pieces.finish()
    assert a.width == b.width
    for name in ("lo", "hi", "arg_lo", "arg_hi"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_undefined_values_are_skipped_and_rows_and_counts_follow_the_merges():
    n = 1000
    y = np.arange(n, dtype=float)
    y[:5] = np.nan
    env = Envelope(1, max_buckets=8, row_width=1, categories=3)
    env.add(y[:, None], rows=lambda idx: idx.astype(float)[:, None], category=np.arange(n) % 3)
    d = env.finish()
    assert d.width == 128 and len(d) == 8
    assert d.lo[0, 0] == 5 and d.arg_lo[0, 0] == 5 and d.hi[-1, 0] == n - 1
    np.testing.assert_array_equal(d.first_rows[:, 0], np.arange(8) * 128)
    assert d.counts.sum() == n
    np.testing.assert_array_equal(d.counts.sum(axis=1), [128] * 7 + [n - 7 * 128])
