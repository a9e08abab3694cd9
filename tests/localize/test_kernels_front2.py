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
