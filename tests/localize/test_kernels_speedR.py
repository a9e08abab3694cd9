"""The rectification's and the graph stages' kernels (localize/kernels_speedR.py, speedR) against the code
they replace (kept here as the reference)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.localize import kernels_speedR
from appliance.localize.rectify import Rectifier
from appliance.localize.skeleton import block_mean

from tests.localize.test_rectify import distorted_rig


def needed_tiles_reference(rect: Rectifier, image: np.ndarray, side: int) -> np.ndarray:
    """Rectifier._needed_tiles before speedR: 8 px cells by an OpenCV block mean, tiles by an integral image."""
    b = rect.BLOCK_PX
    h, w = image.shape
    hb, wb = -(-h // b), -(-w // b)
    any_px = cv2.threshold(image, 0, 255, cv2.THRESH_BINARY)[1]
    if (hb * b, wb * b) != (h, w):
        any_px = cv2.copyMakeBorder(any_px, 0, hb * b - h, 0, wb * b - w, cv2.BORDER_CONSTANT, value=0)
    cells = cv2.integral(block_mean(any_px, b))
    t = rect.tiles[side]
    by0, bx0 = t[:, 4] // b, t[:, 6] // b
    by1, bx1 = np.maximum(-(-t[:, 5] // b), by0), np.maximum(-(-t[:, 7] // b), bx0)
    count = cells[by1, bx1] - cells[by0, bx1] - cells[by1, bx0] + cells[by0, bx0]
    need = t[count > 0, :4]
    if len(need) == 0:
        return need
    start = np.flatnonzero(np.concatenate([[True], (need[1:, 0] != need[:-1, 0]) | (need[1:, 2] != need[:-1, 3])]))
    end = np.concatenate([start[1:], [len(need)]]) - 1
    return np.column_stack([need[start, :3], need[end, 3]])


@pytest.mark.parametrize("size", [(320, 240), (336, 251)])
def test_needed_tiles_are_the_block_mean_tiles(size):
    w, h = size                                         # (251 rows: a last cell row of 3 px)
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    rng = np.random.default_rng(11)
    masks = [np.zeros((h, w), np.uint8), np.full((h, w), 255, np.uint8)]
    for k in range(40):
        m = np.zeros((h, w), np.uint8)
        for _ in range(k % 5):
            cv2.line(m, tuple(int(v) for v in rng.integers(0, (w, h))), tuple(int(v) for v in rng.integers(0, (w, h))),
                     255, int(rng.integers(1, 12)))
        ys, xs = rng.integers(0, h, k), rng.integers(0, w, k)
        m[ys, xs] = rng.integers(1, 256, k)                 # single (faint) pixels anywhere, the corners too
        m[[0, h - 1][k % 2], [0, w - 1][(k // 2) % 2]] = k % 3
        masks.append(m)
    for m in masks:
        for side in (0, 1):
            got = rect._needed_tiles(m, side)
            assert got.dtype == np.int64 and got.shape[1] == 4
            np.testing.assert_array_equal(got, needed_tiles_reference(rect, m, side))
    # a view (not C-contiguous) takes the numpy path, with the same runs
    wide = np.zeros((h, 2 * w), np.uint8)
    wide[:, :w] = masks[5]
    np.testing.assert_array_equal(rect._needed_tiles(wide[:, :w], 0), needed_tiles_reference(rect, masks[5], 0))


def test_needed_tiles_kernel_joins_runs_of_one_tile_row_only():
    # four tiles in a 2 x 2 grid, each reading its own cell; cells 0, 1 and 3 set
    words = np.zeros((16, 2), np.uint64)
    words[0, 0], words[3, 1], words[12, 1] = 1, 1 << 63, 5
    cells = np.array([[0, 1, 0, 1], [0, 1, 1, 2], [1, 2, 0, 1], [1, 2, 1, 2]], np.int64)
    tiles = np.array([[0, 4, 0, 4], [0, 4, 4, 8], [4, 8, 0, 4], [4, 8, 4, 8]], np.int64)
    out = np.zeros((4, 4), np.int64)
    n = kernels_speedR.needed_tiles(words, cells, tiles, out)
    np.testing.assert_array_equal(out[:n], [[0, 4, 0, 8], [4, 8, 4, 8]])
    empty = cells.copy()
    empty[:, 1] = empty[:, 0]                               # no source cells: never needed
    assert kernels_speedR.needed_tiles(words, empty, tiles, out) == 0
