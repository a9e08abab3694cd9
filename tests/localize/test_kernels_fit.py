"""The polynomial fits and their evaluation (localize/kernels_fit.py) against the numpy steps they replace."""

from __future__ import annotations

import numpy as np

from appliance.localize import curves, kernels_fit
from appliance.localize.curves import fit_groups


def test_fit_groups_is_least_squares_per_group():
    """Each group's polynomial is the least-squares one (np.polyfit in the scaled parameter), its
    degree lowered to what its distinct parameters support; an empty group gets a constant 0."""
    rng = np.random.default_rng(2)
    ts = [np.sort(rng.choice(np.arange(500.0), 60, replace=False)), np.zeros(0), np.repeat([3.0, 9.0], 5),
          np.sort(rng.uniform(0, 80, 30))]
    degrees = np.array([3, 2, 3, 2])
    ys = [0.002 * t ** 2 - 0.3 * t + rng.normal(0, 0.5, len(t)) for t in ts]
    g = np.repeat(np.arange(len(ts)), [len(t) for t in ts])
    fit = fit_groups(np.concatenate(ts), np.concatenate(ys), g, len(ts), degrees)
    np.testing.assert_array_equal(fit.degree, [3, 0, 1, 2])
    assert not fit.coef[1].any()
    for k in (0, 2, 3):
        t, y, d = ts[k], ys[k], int(fit.degree[k])
        assert fit.t0[k] == np.add.reduceat(t, [0])[0] / len(t)
        want = np.polyfit((t - fit.t0[k]) / fit.ts[k], y, d)
        np.testing.assert_allclose(fit.coef[k, 3 - d:], want, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(fit(np.full(len(t), k), t), np.polyval(want, (t - fit.t0[k]) / fit.ts[k]),
                                   rtol=1e-12, atol=1e-9)


def test_end_slopes_groups_is_the_numpy_steps_bit_for_bit():
    """Random groups (in order and shuffled, few samples, short spans, empty groups): the same slopes
    as the numpy steps (bincounts and ufunc.at), bit for bit."""
    rng = np.random.default_rng(1)
    for trial in range(500):
        n_groups, n = int(rng.integers(1, 12)), int(rng.integers(1, 300))
        g = rng.integers(0, n_groups, n)
        if trial % 2:
            g = np.sort(g)
        t = np.round(rng.uniform(0, 400, n)) if trial % 3 else rng.uniform(0, 8, n)
        y = rng.normal(20, 5, n)
        got = kernels_fit.end_slopes_groups(t, y, g.astype(np.intp), n_groups, 60.0)
        want = curves._end_slopes_groups_np(t, y, g, n_groups, 60.0)
        assert np.array_equal(got, want)
    assert np.array_equal(curves.end_slopes_groups(np.zeros(0), np.zeros(0), np.zeros(0, int), 3), np.zeros((3, 2)))
    t = np.arange(100.0)
    assert np.allclose(curves.end_slopes_groups(t, 2 * t + 1, np.zeros(100, int), 1), 2.0)
