"""The match stage's kernels of the fifth numba pass (localize/kernels.py, block "speedm2") against the
numpy code they replace."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize import curves, edges, kernels, tips


def _runs_by_numpy(mask, soft):
    """edges.find_runs' former numpy steps: the run bounds by the xor of the padded mask, the soft crossings."""
    w = mask.shape[1]
    sr, x0, x1 = edges._run_bounds(mask, 127 if soft else 0)
    left, right = x0 - 0.5, x1 + 0.5
    if soft and len(sr):
        flat, start = mask.reshape(-1), sr * w
        left = np.where(x0 > 0, edges._soft_crossing(flat, start, np.maximum(x0 - 1, 0), x0), left)
        right = np.where(x1 < w - 1, edges._soft_crossing(flat, start, np.minimum(x1 + 1, w - 1), x1), right)
    return sr, x0, x1, left, right


def test_mask_runs_is_the_numpy_runs_bit_for_bit():
    """Random binary and soft masks (runs touching both image borders, single pixels, odd widths, a
    transposed view, more runs than the first buffer holds): the same rows, columns and sub-pixel
    boundaries, bit for bit and in the same dtypes."""
    rng = np.random.default_rng(0)
    masks = []
    for trial in range(300):
        h, w = int(rng.integers(1, 40)), int(rng.integers(1, 70)) * 8
        m = (rng.random((h, w)) < rng.uniform(0, 1)).astype(np.uint8) * 255
        if trial % 2 and min(h, w) > 2:
            m = cv2.GaussianBlur(m, (3, 3), 0)
            m[rng.random((h, w)) < 0.05] = rng.integers(0, 256)
        masks.append(m)
    big = (rng.random((64, 400)) < 0.5).astype(np.uint8) * 200      # ~13 000 runs (> the first buffer's 1024)
    masks += [big, np.full((3, 8), 255, np.uint8), np.zeros((2, 8), np.uint8)]
    n_kernel = 0
    for m in masks:
        for view in (m, m.T):
            for soft in (True, False):
                got = edges.find_runs(view, soft)
                want = _runs_by_numpy(np.ascontiguousarray(view), soft)
                for a, b in zip((got.row, got.x0, got.x1, got.left_px, got.right_px), want):
                    assert a.dtype == b.dtype and np.array_equal(a, b)
                c = np.ascontiguousarray(view)
                n_kernel += c.size % 8 == 0
    assert n_kernel > 600                       # most masks went through the kernel


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
        got = kernels.end_slopes_groups(t, y, g.astype(np.intp), n_groups, 60.0)
        want = curves._end_slopes_groups_np(t, y, g, n_groups, 60.0)
        assert np.array_equal(got, want)
    assert np.array_equal(curves.end_slopes_groups(np.zeros(0), np.zeros(0), np.zeros(0, int), 3), np.zeros((3, 2)))
    t = np.arange(100.0)
    assert np.allclose(curves.end_slopes_groups(t, 2 * t + 1, np.zeros(100, int), 1), 2.0)


def test_last_on_is_the_remap_of_all_lines():
    """Lines from inside and outside blurred discs, in all directions, with and without their own sample
    counts: the same crossings (NaN included) as one cv2.remap of every line, bit for bit."""
    rng = np.random.default_rng(2)
    n_lines = n_found = 0
    for trial in range(200):
        h, w = int(rng.integers(20, 80)), int(rng.integers(20, 80))
        m = np.zeros((h, w), np.uint8)
        centres = rng.integers(0, (w, h), (3, 2))
        for x, y in centres:
            cv2.circle(m, (int(x), int(y)), int(rng.integers(3, 20)), 255, -1)
        m = cv2.GaussianBlur(m, (5, 5), 1.0)
        k = int(rng.integers(1, 12))
        starts = rng.uniform(-2, max(h, w) + 2, (k, 2))
        starts[: k // 2] = centres[rng.integers(0, 3, k // 2)] + rng.normal(0, 1, (k // 2, 2))
        ang = rng.uniform(0, 2 * np.pi, k)
        dirs = np.column_stack([np.cos(ang), np.sin(ang)])
        s = np.arange(0.0, rng.uniform(1.5, 40), 0.5)
        n_s = rng.integers(1, len(s) + 1, k) if trial % 2 else None
        got = tips._last_on(m, starts, dirs, s, n_s)
        want = tips._last_on_np(m, starts, dirs, s, n_s)
        assert got.dtype == want.dtype and np.array_equal(got, want, equal_nan=True)
        n_lines += k
        n_found += int(np.isfinite(got).sum())
    assert n_found > 0.2 * n_lines                 # many lines do cross the outline


def test_nearest_per_query_is_lexsorts_pick():
    """Sorted query ids with ties and NaN residuals: the same picks as lexsort at each id's first place."""
    rng = np.random.default_rng(3)
    for trial in range(1000):
        n = int(rng.integers(1, 60))
        q = np.sort(rng.integers(0, max(n // 2, 1), n)).astype(np.int64)
        res = np.round(rng.uniform(0, 3, n), 1)            # (ties)
        if trial % 4 == 0:
            res[rng.random(n) < 0.3] = np.nan
        order = np.lexsort((res, q))
        want = order[np.concatenate([[True], q[order][1:] != q[order][:-1]])]
        assert np.array_equal(kernels.nearest_per_query(q, res), want)


def test_near_junctions_is_the_numpy_test():
    """Samples near pieces' end nodes (junction or not, thresholds per end): the same as the former numpy
    steps (the differences to each end's node, np.hypot, the threshold per piece)."""
    rng = np.random.default_rng(4)
    for _ in range(300):
        n_pieces, n = int(rng.integers(1, 8)), int(rng.integers(1, 200))
        g = np.sort(rng.integers(0, n_pieces, n)).astype(np.int64)
        xc, rows = rng.uniform(0, 100, n), np.round(rng.uniform(0, 100, n))
        junction = rng.random((n_pieces, 2)) < 0.6
        nxy = rng.uniform(0, 100, (n_pieces, 2, 2))
        thr = rng.uniform(1, 40, (n_pieces, 2))
        want = np.zeros(n, bool)
        for k in range(2):
            d = np.column_stack([xc, rows]) - nxy[:, k][g]
            want |= junction[:, k][g] & (np.hypot(d[:, 0], d[:, 1]) < thr[:, k][g])
        assert np.array_equal(kernels.near_junctions(xc, rows, g, junction, nxy, thr), want)


def test_warm_up_compiles_the_signatures_these_kernels_get():
    """After a Localizer is built, localizing (colour and exact masks) compiles none of these kernels again."""
    from pathlib import Path

    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer
    from appliance.synth.truth import load_truth

    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    loc = Localizer(load_calibration(fixtures / "rig.yaml"), load_config().localize)
    mine = [kernels.end_slopes_groups, kernels.mask_runs, kernels.last_on,
            kernels.nearest_per_query, kernels.near_junctions]
    before = [len(f.signatures) for f in mine]
    left, right = (cv2.imread(str(fixtures / "scenes" / f"{s}_03.png")) for s in ("left", "right"))
    truth = load_truth(fixtures / "scenes" / "truth_03.json")
    loc.localize(left, right)
    loc.localize(left, right, mask_left=truth.mask_left, mask_right=truth.mask_right)
    assert [len(f.signatures) for f in mine] == before and all(before)
