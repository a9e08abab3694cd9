"""The shared sums and order statistics (localize/kernels_stats.py) against numpy's."""

from __future__ import annotations

import numpy as np

from appliance.localize import kernels_stats


def test_segment_sums_are_numpys_reduceat_bit_for_bit():
    """The power sums of the fits: numpy's pairwise summation, all block sizes (< 8, <= 128, halved)."""
    rng = np.random.default_rng(1)
    for n in list(range(1, 40)) + [127, 128, 129, 130, 255, 256, 257, 600, 1031]:
        a = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 5, n)
        want = np.add.reduceat(np.concatenate([a, [0.0]]), [0, n])[0]
        assert kernels_stats._segment_sum(a, 0, n) == want
        assert kernels_stats._median(a) == np.median(a)
        ties = np.round(a[: n // 2 + 1] / 1e3)                     # (repeated values)
        assert kernels_stats._median(ties) == np.median(ties)


def test_pairwise_is_numpys_sum_bit_for_bit():
    """kernels_stats._pairwise (the line fits' sums, walked with a stack) against ndarray.sum on 1-400 random values."""
    rng = np.random.default_rng(17)
    for n in [*range(1, 400), 1000, 4097]:
        a = rng.normal(0, 100, n)
        assert kernels_stats._pairwise(a, 0, n) == a.sum()
