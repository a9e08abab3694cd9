"""The mask runs and their look-ups (localize/kernels_runs.py) against the numpy code they replace."""

from __future__ import annotations

import cv2
import numpy as np

from appliance.localize import edges, kernels_runs


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


def test_runs_find_and_between_are_the_numpy_lookups():
    """Runs.find / Runs.between (compiled) against the numpy formulas they replace, on a soft mask
    with queries off the image and non-finite columns."""
    import cv2
    from appliance.localize.edges import find_runs

    rng = np.random.default_rng(0)
    for _ in range(20):
        h, w = 60, int(rng.integers(20, 300))
        m = (cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 3) > 0.5).astype(np.uint8) * 255
        runs = find_runs(cv2.GaussianBlur(m, (3, 3), 0), soft=True)
        row = rng.integers(-2, h + 2, 300)
        x = rng.uniform(-3, w + 3, 300)
        x[::37] = np.nan
        xi = np.rint(np.nan_to_num(x, nan=-1e9)).astype(int)
        key, start = row * w + xi, runs.row * w + runs.x0
        i = np.searchsorted(start, key, side="right") - 1
        ok = np.isfinite(x) & (i >= 0) & (runs.row[np.maximum(i, 0)] == row) & (runs.x1[np.maximum(i, 0)] >= xi)
        np.testing.assert_array_equal(runs.find(row, x), np.where(ok, i, -1))
        lo = rng.uniform(-10, w, 300)
        hi = lo + rng.uniform(-5, 60, 300)
        q, r = runs.between(row, lo, hi)
        centre = runs.row * w + runs.centre_px
        want = [(k, j) for k in range(len(row)) for j in np.flatnonzero((centre >= row[k] * w + lo[k])
                                                                         & (centre <= row[k] * w + hi[k]))]
        assert list(zip(q.tolist(), r.tolist())) == want


def _runs_numpy(on: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, first and last columns of the runs of True of a bool image (row-major), by np.diff."""
    pad = np.zeros((on.shape[0], on.shape[1] + 2), np.int8)
    pad[:, 1:-1] = on
    d = np.diff(pad, axis=1)
    r0, c0 = np.nonzero(d == 1)
    _, c1 = np.nonzero(d == -1)
    return r0, c0, c1 - 1


def test_mask_runs_reads_by_unsigned_index():
    """kernels_runs.mask_runs (its scan now indexing by np.uint64) against np.diff's runs on masks with long
    stretches off and on (the word-at-a-time skips), runs at the rows' ends and soft edges, for both
    thresholds (above 127 and above 0), and a mask with more runs than the first buffer holds."""
    rng = np.random.default_rng(13)
    for h, w in ((40, 333), (7, 1280), (64, 64)):
        m = np.zeros((h, w), np.uint8)
        for _ in range(3 * h):
            y, x, n = rng.integers(0, h), rng.integers(0, w), rng.integers(1, 120)
            m[y, x:x + n] = 255
        m[rng.random((h, w)) < 0.02] = rng.integers(1, 255)                  # soft pixels and specks
        for above in (127, 0):
            flat = m.reshape(-1)
            rows, x0, x1, left, right = kernels_runs.mask_runs(flat, flat.view(np.uint64), w, above, above == 127)
            for got, want in zip((rows, x0, x1), _runs_numpy(m > above)):
                np.testing.assert_array_equal(got, want)
            assert len(rows) > h and (left <= x0).all() and (right >= x1).all()
    comb = np.zeros((64, 512), np.uint8)
    comb[:, ::2] = 255                                                       # 16384 runs (> the first 1024)
    flat = comb.reshape(-1)
    rows, x0, x1, _, _ = kernels_runs.mask_runs(flat, flat.view(np.uint64), 512, 0, False)
    assert len(rows) == 64 * 256 and (x1 == x0).all()
