"""The sparse remap of masks gives exactly the full remap."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.calibrate.model import StereoCalibration
from appliance.localize.rectify import LazyRectified, Rectifier


def distorted_rig(width: int, height: int) -> StereoCalibration:
    K = np.array([[520.0, 0, width / 2 + 7], [0, 515.0, height / 2 - 5], [0, 0, 1]])
    D = np.array([-0.12, 0.05, 0.001, -0.002, 0.0])
    R = cv2.Rodrigues(np.array([0.01, -0.03, 0.02]))[0]
    return StereoCalibration.from_pose((width, height), K, D, K, D, R, [-120.0, 1.0, 2.0])


@pytest.mark.parametrize("size", [(320, 240), (333, 251)])
def test_sparse_remap_of_a_mask_is_the_full_remap(size):
    w, h = size
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    rng = np.random.default_rng(3)
    mask = np.zeros((h, w), np.uint8)
    cv2.line(mask, (40, 10), (90, h - 20), 255, 7)
    cv2.circle(mask, (w - 3, h - 2), 4, 255, -1)          # at the image corner
    mask[rng.integers(0, h, 5), rng.integers(0, w, 5)] = 1  # single faint pixels count too
    for side in (0, 1):
        m1, m2 = rect.maps[side]
        full = cv2.remap(mask, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        need = rect._needed_tiles(mask, side)
        assert ((need[:, 1] - need[:, 0]) * (need[:, 3] - need[:, 2])).sum() < 0.7 * mask.size   # sparse path
        assert np.array_equal(rect.rectify(mask, side), full)
        assert np.array_equal(rect.rectify(np.zeros_like(mask), side), np.zeros_like(mask))
        grey = rng.integers(0, 256, (h, w), dtype=np.uint8)                         # dense: full remap
        assert np.array_equal(rect.rectify(grey, side), cv2.remap(grey, m1, m2, cv2.INTER_LINEAR))


def test_lazy_rectified_bgr_gives_the_grey_rectified_image():
    w, h = 333, 251
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    bgr = np.random.default_rng(5).integers(0, 256, (h, w, 3), dtype=np.uint8)
    for side in (0, 1):
        want = rect.rectify(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), side)
        lazy, lazy_grey = LazyRectified(rect, bgr, side, (32, 64)), LazyRectified(rect, cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), side)
        for ys, xs in ((slice(0, h), slice(0, w)), (slice(40, 90), slice(100, 230)), (slice(h - 5, h), slice(0, 7))):
            assert np.array_equal(lazy[ys, xs], want[ys, xs])
            assert np.array_equal(lazy_grey[ys, xs], want[ys, xs])


def test_lazy_rectified_reads_anywhere_are_the_full_rectified_image():
    w, h = 333, 251
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    rng = np.random.default_rng(9)
    bgr = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    for side in (0, 1):
        want = rect.rectify(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), side)
        lazy = LazyRectified(rect, bgr, side)
        for _ in range(200):                 # strips and patches, crossing tiles, at and past the borders
            y0, x0 = rng.integers(-5, h), rng.integers(-5, w)
            ys, xs = slice(max(y0, 0), y0 + rng.integers(1, 40)), slice(max(x0, 0), x0 + rng.integers(1, 300))
            assert np.array_equal(lazy[ys, xs], want[ys, xs])
