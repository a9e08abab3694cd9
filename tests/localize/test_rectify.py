"""The sparse remap of masks gives exactly the full remap."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.calibrate.model import StereoCalibration
from appliance.localize import kernels_graph
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


@pytest.mark.parametrize("size", [(320, 240), (333, 251), (1280, 960)])
def test_tall_narrow_tiles_give_the_full_remap(size):
    w, h = size
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    assert rect.TILE_PX == (64, 16)
    rng = np.random.default_rng(w)
    for k in range(4):
        mask = np.zeros((h, w), np.uint8)
        for _ in range(max(1, w // 200)):                             # thick lines, soft edges
            a, b = rng.integers(0, w, 2), rng.integers(0, h, 2)
            cv2.line(mask, (int(a[0]), int(b[0])), (int(a[1]), int(b[1])), 255, int(rng.integers(2, 9)))
        mask = cv2.GaussianBlur(mask, (5, 5), 1.0) if k % 2 else mask
        cv2.circle(mask, (w - 2, h - 2), 5, 255, -1)                  # at the image corner
        mask[rng.integers(0, h, 5), rng.integers(0, w, 5)] = 1        # single faint pixels
        for side in (0, 1):
            full = cv2.remap(mask, *rect.float_maps(side), cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                             borderValue=0)
            need = rect._needed_tiles(mask, side)
            assert ((need[:, 1] - need[:, 0]) * (need[:, 3] - need[:, 2])).sum() < 0.7 * mask.size
            np.testing.assert_array_equal(rect.rectify(mask, side, fast=True), full)   # atol 0 (levels)


def _read_box_reference(map1: np.ndarray, y0: int, y1: int, x0: int, x1: int, h: int, w: int):
    """The box of the source pixels (ix, iy), (ix + 1, iy + 1) a fixed-point linear remap reads, by numpy."""
    m = map1[y0:y1, x0:x1].reshape(-1, 2).astype(np.int64)
    return (max(int(m[:, 1].min()), 0), min(int(m[:, 1].max()) + 2, h),
            max(int(m[:, 0].min()), 0), min(int(m[:, 0].max()) + 2, w))


@pytest.mark.parametrize("size", [(320, 240), (333, 251)])
def test_read_box_and_lazy_reads_of_exactly_those_pixels(size):
    w, h = size
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    rng = np.random.default_rng(w + h)
    bgr = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    for side in (0, 1):
        m1, m2 = rect.maps[side]
        full = cv2.remap(grey, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        for _ in range(150):
            y0, x0 = int(rng.integers(0, h)), int(rng.integers(0, w))
            y1, x1 = min(h, y0 + int(rng.integers(1, 40))), min(w, x0 + int(rng.integers(1, 90)))
            assert kernels_graph.read_box(m1, y0, y1, x0, x1, h, w) == _read_box_reference(m1, y0, y1, x0, x1, h, w)
            lazy = LazyRectified(rect, bgr, side)
            lazy._grey = np.full((h, w), 77, np.uint8)         # (a pixel read but not converted would show)
            np.testing.assert_array_equal(lazy[y0:y1, x0:x1], full[y0:y1, x0:x1])    # atol 0 (levels)
        for y0, y1, x0, x1 in ((0, 3, 0, 3), (h - 2, h, w - 5, w), (0, h, 0, w)):   # corners (outside), whole
            lazy = LazyRectified(rect, bgr, side)
            lazy._grey = np.full((h, w), 77, np.uint8)
            np.testing.assert_array_equal(lazy[y0:y1, x0:x1], full[y0:y1, x0:x1])
