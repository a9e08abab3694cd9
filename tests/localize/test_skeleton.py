"""The sparse Zhang-Suen thinning is OpenCV's, pixel for pixel."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize.skeleton import remove_corners, skeletonize, zhang_suen

from tests.localize.shapes import y_shape


def _blobs(seed: int, shape=(90, 120)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    m = (cv2.GaussianBlur(rng.random(shape), (0, 0), 3) > 0.5).astype(np.uint8) * 255
    m[0, rng.integers(0, shape[1], 30)] = 255           # foreground on the image border stays
    m[:, -1] = 255 * (rng.random(shape[0]) > 0.3)
    return m


def test_zhang_suen_is_opencv_thinning():
    masks = [y_shape(), np.full((20, 30), 255, np.uint8), np.zeros((10, 10), np.uint8)]
    masks += [_blobs(seed) for seed in range(20)]
    for m in masks:
        want = cv2.ximgproc.thinning(m, thinningType=cv2.ximgproc.THINNING_ZHANGSUEN) > 0
        got = zhang_suen(m)
        assert got.dtype == np.uint8 and got.shape == m.shape
        assert np.array_equal(got > 0, want)


def test_remove_corners_keeps_paths_connected_and_thin():
    skel = skeletonize(y_shape(), "thinning")
    thin = zhang_suen(y_shape())
    assert np.array_equal(skel.image, remove_corners(thin))
    assert skel.image.sum() < thin.sum()                              # staircase corners went
    n, _ = cv2.connectedComponents(skel.image, connectivity=8)
    assert n - 1 == 1
