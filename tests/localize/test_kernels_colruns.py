"""kernels_colruns.mask_col_runs against the code it replaces (find_runs of a transposed mask): the same runs."""

import cv2
import numpy as np

from appliance.localize import kernels_colruns, kernels_runs
from appliance.localize.edges import Runs, find_runs


def _transposed_runs(mask: np.ndarray, soft: bool) -> Runs:
    """``find_runs(mask.T)`` as it was (main 41599e4): OpenCV's transpose, then the row-major runs."""
    t = cv2.transpose(mask)
    flat = t.reshape(-1)
    return Runs(t.shape[1], *kernels_runs.mask_runs(flat, flat.view(np.uint64), t.shape[1], 127 if soft else 0, soft))


def _masks(rng):
    """Random masks (H, W multiple of 8): speckle, noise, blurred blobs (soft edges), nearly full and nearly
    empty, stripes along the rows and the columns, and single rows or columns."""
    for it in range(240):
        h, w = int(rng.integers(1, 70)), 8 * int(rng.integers(1, 14))
        kind = it % 6
        if kind == 0:
            m = (rng.random((h, w)) < rng.random()).astype(np.uint8) * 255
        elif kind == 1:
            m = rng.integers(0, 256, (h, w), dtype=np.uint8)
        elif kind == 2:
            m = cv2.GaussianBlur(((rng.random((h, w)) < 0.3) * 255).astype(np.uint8), (5, 5), 1.5)
        elif kind == 3:
            m = np.full((h, w), 255 if it % 12 == 3 else 0, np.uint8)
            m[rng.integers(0, h, 6), rng.integers(0, w, 6)] ^= 255
        elif kind == 4:
            m = np.zeros((h, w), np.uint8)
            m[:, rng.integers(0, w, 3)] = rng.integers(100, 256)      # whole columns (runs to the bottom row)
            m[rng.integers(0, h, 2), :] = 255                         # whole rows
        else:
            m = np.where(rng.random((h, w)) < 0.5, 127, 128).astype(np.uint8)   # at the threshold
        yield m


def test_mask_col_runs_equals_transposed_runs():
    rng = np.random.default_rng(20)
    n_runs = 0
    for m in _masks(rng):
        for soft in (True, False):
            ref = _transposed_runs(m, soft)
            flat = m.reshape(-1)
            got = kernels_colruns.mask_col_runs(flat, flat.view(np.uint64), m.shape[0], m.shape[1], 127 if soft else 0,
                                                soft)
            for name, a in zip(("row", "x0", "x1", "left_px", "right_px"), got):
                b = getattr(ref, name)
                assert a.dtype == b.dtype, name
                np.testing.assert_array_equal(a, b, err_msg=name)       # atol 0 px
            n_runs += len(got[0])
    assert n_runs > 50_000                                           # (the cases hold many runs)


def test_find_runs_of_transposed_view_agrees_with_transposing():
    rng = np.random.default_rng(21)
    m = cv2.GaussianBlur(((rng.random((240, 320)) < 0.05) * 255).astype(np.uint8), (9, 9), 3)
    m = cv2.threshold(m, 20, 255, cv2.THRESH_BINARY)[1]
    m = cv2.GaussianBlur(m, (3, 3), 0.8)                              # a soft mask, as the rectified ones
    for soft in (True, False):
        got, ref = find_runs(m.T, soft=soft), _transposed_runs(m, soft)
        assert got.width == ref.width == 240
        for name in ("row", "x0", "x1", "left_px", "right_px"):
            np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)
    assert len(got.row) > 100
    # a view that is not a plain transpose (a column slice) still takes the copying path, with the same runs
    part = m[:, 5:301].T
    got = find_runs(part, soft=True)
    ref = find_runs(np.ascontiguousarray(part), soft=True)
    np.testing.assert_array_equal(got.left_px, ref.left_px)
