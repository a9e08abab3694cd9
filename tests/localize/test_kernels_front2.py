"""The thirteenth pass (speedfront2): the sample's strided copy against OpenCV's nearest-neighbour resize,
and the sparse remap's taller, narrower tiles against the full remap (float maps, the masks' path)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.localize import kernels_front
from appliance.localize.rectify import Rectifier
from appliance.localize.segment import sample_nearest

from tests.localize.test_rectify import distorted_rig


def _reference(img: np.ndarray, factor: int) -> np.ndarray:
    """sample_nearest before speedfront2: OpenCV's nearest-neighbour resize of the whole blocks."""
    h, w = img.shape[:2]
    hs, ws = h // factor, w // factor
    return cv2.resize(img[:hs * factor, :ws * factor], (ws, hs), interpolation=cv2.INTER_NEAREST)


@pytest.mark.parametrize("shape", [(960, 1280), (251, 333), (7, 9), (4, 4), (5, 1283)])
@pytest.mark.parametrize("factor", [1, 2, 3, 4, 5])
def test_sample_every_is_the_nearest_resize(shape, factor):
    rng = np.random.default_rng(shape[0] * 7 + factor)
    img = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    if shape[0] < factor or shape[1] < factor:
        pytest.skip("no whole block")
    got = sample_nearest(img, factor)
    assert got.dtype == np.uint8 and got.flags.c_contiguous
    np.testing.assert_array_equal(got, _reference(img, factor))       # atol 0 (levels)
    img.setflags(write=False)                                         # (a read-only image: the same)
    np.testing.assert_array_equal(sample_nearest(img, factor), _reference(img, factor))


def test_sample_every_constructed_and_fallbacks():
    img = np.zeros((12, 16, 3), np.uint8)
    img[4, 8] = (1, 2, 3)                                             # a block's first pixel: sampled
    img[5, 9] = (9, 9, 9)                                             # not a first pixel: not
    out = kernels_front.sample_every(img, 4, np.zeros((3, 4, 3), np.uint8))
    assert out[1, 2].tolist() == [1, 2, 3] and out.sum() == 6
    view = np.zeros((40, 60, 3), np.uint8)[::2, ::3]                  # not contiguous: OpenCV's path
    view[...] = np.arange(view.size, dtype=np.uint32).reshape(view.shape) % 251
    np.testing.assert_array_equal(sample_nearest(view, 4), _reference(view, 4))
    grey = np.arange(200, dtype=np.uint8).reshape(10, 20)             # one channel: OpenCV's path
    np.testing.assert_array_equal(sample_nearest(grey, 3), grey[:9:3, :18:3])


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
    from appliance.localize import kernels_graph
    from appliance.localize.rectify import LazyRectified
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
