"""The front stages' kernels (localize/kernels_front.py, speed02) against the OpenCV calls they replace."""

from __future__ import annotations
from dataclasses import replace
from pathlib import Path

import cv2
import numba
import numpy as np
import pytest

from appliance.commands.common import effective_config
from appliance.localize import kernels_front
from appliance.localize.radius import NEAR_MAX_SHARE, ridge_radius_map
from appliance.localize.segment import (
    _hsv_threshold, bark_hsv, bark_lut, bark_lut_rows, bark_mask, sample_nearest, segment_mask,
)
from appliance.localize.skeleton import binary, skeletonize

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"


@numba.njit(cache=False)
def bark_tiles(bgr, lut, tiles, tile_px, out):
    """The reference for bark_lookup_rows (kernels.bark_tiles until speedG, which bark_lookup replaced):
    the bark test of every pixel of the flagged tiles, by a colour lookup table, in one pass; the
    rest of ``out`` untouched.

    ``bgr`` (H, W, 3) uint8; ``lut`` (2^21,) uint8: bit ``k & 7`` of byte ``k >> 3`` is the test of the
    colour ``k = b << 16 | g << 8 | r``; ``tiles`` (TH, TW): non-zero = test that ``tile_px`` square
    tile (the last tile row and column reach the image's bottom and right edges); ``out`` (H, W)
    uint8 gets 255 (bark) or 0.
    """
    h, w = out.shape
    th, tw = tiles.shape
    for ty in range(th):
        y0 = ty * tile_px
        y1 = h if ty == th - 1 else min(y0 + tile_px, h)
        for tx in range(tw):
            if tiles[ty, tx] == 0:
                continue
            x0 = tx * tile_px
            x1 = w if tx == tw - 1 else min(x0 + tile_px, w)
            for y in range(y0, y1):
                for x in range(x0, x1):
                    k = (np.int64(bgr[y, x, 0]) << 16) | (np.int64(bgr[y, x, 1]) << 8) | np.int64(bgr[y, x, 2])
                    out[y, x] = 255 if (lut[k >> 3] >> (k & 7)) & 1 else 0
    return out


def test_bark_tiles_is_opencvs_hsv_threshold_in_the_tiles():
    """bark_tiles with bark_lut's table gives OpenCV's HSV thresholds (bark_hsv) pixel for pixel in the
    flagged tiles (edge tiles reaching the image's edges) and leaves the rest, for a hue range wrapping
    through red, one not wrapping and one wrapping without containing 120; the table is bark_hsv's test
    of every colour."""
    base = effective_config(None).localize.segment
    rng = np.random.default_rng(6)
    img = rng.integers(0, 256, (70, 90, 3), np.uint8)
    img[:35] = cv2.GaussianBlur(img[:35], (0, 0), 3)           # (smooth colours too)
    for hues in ((base.hue_min, base.hue_max), (5, 40), (175, 130)):
        cfg = replace(base, hue_min=hues[0], hue_max=hues[1])
        want = bark_hsv(img, cfg)[1]
        assert 0 < cv2.countNonZero(want) < want.size
        tiles = (rng.random((5, 6)) < 0.6).astype(np.uint8)
        got = bark_tiles(img, bark_lut(cfg), tiles, 16, np.full(want.shape, 7, np.uint8))
        inside = np.kron(tiles, np.ones((16, 16), np.uint8))[:70, :90].astype(bool)
        np.testing.assert_array_equal(got[inside], want[inside])
        assert (got[~inside] == 7).all()
        every = np.unpackbits(bark_lut(cfg), bitorder="little").reshape(4096, 4096)    # all 2^24 colours
        k = np.arange(1 << 24, dtype=np.int64)
        colours = np.stack([k >> 16, (k >> 8) & 255, k & 255], 1).astype(np.uint8).reshape(4096, 4096, 3)
        np.testing.assert_array_equal(every * 255, bark_hsv(colours, cfg)[1])


def _cv_distance(mask: np.ndarray) -> np.ndarray:
    """What ridge_radius_map took before (OpenCV's square roots can be one unit in the last place
    off, and differ with the mask's non-zero value: the masks are made 0/1 first, as there)."""
    return cv2.distanceTransform(binary(mask), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def _exact(ref: np.ndarray) -> np.ndarray:
    """The correctly rounded float32 roots of OpenCV's squared distances (integers)."""
    return np.sqrt(np.rint(ref.astype(np.float64) ** 2)).astype(np.float32)


def _near(mask: np.ndarray) -> np.ndarray:
    return kernels_front.distance_near(mask, np.empty(mask.shape, np.float32))


def test_distance_near_is_opencvs_on_the_fixtures_masks():
    """The skeleton's 4x smaller masks of the four fixture pairs (the radius map's input): the exact
    distances bit for bit, OpenCV's to its last bit (with one OpenCV thread its IPP transform may
    return a root one ulp off, not the same on every call)."""
    cfg = effective_config(None).localize.segment
    for n in range(4):
        for side in ("left", "right"):
            bgr = cv2.imread(str(FIXTURES / f"{side}_{n:02d}.png"))
            small = skeletonize(segment_mask(bgr, cfg), "fast", 4).mask
            assert 0 < cv2.countNonZero(small) <= NEAR_MAX_SHARE * small.size
            ref = _cv_distance(small)
            np.testing.assert_array_equal(_near(small), _exact(ref))
            np.testing.assert_allclose(_near(small), ref, rtol=2e-7, atol=0)
            assert ref.max() > 5.0


def test_distance_near_constructed_shapes():
    """Thick lines, discs, a disc cut by the image's corner (outside is not zero), a single pixel,
    a column without a zero pixel: OpenCV's distances to rounding (atol 1e-5 px), the exact ones bit
    for bit."""
    img = np.zeros((90, 130), np.uint8)
    cv2.line(img, (5, 80), (120, 10), 255, 9)
    cv2.line(img, (0, 45), (129, 50), 255, 3)
    cv2.circle(img, (30, 30), 14, 255, -1)
    cv2.circle(img, (125, 85), 12, 255, -1)                 # cut by the bottom-right corner
    img[:, 70] = 255                                        # a column without a zero
    img[2, 100] = 255
    ref = _cv_distance(img)
    np.testing.assert_allclose(_near(img), ref, rtol=0, atol=1e-5)
    np.testing.assert_array_equal(_near(img), _exact(ref))
    assert _near(img)[2, 100] == 1.0 and _near(img)[89, 129] > 3.0
    np.testing.assert_array_equal(_near(np.zeros((3, 4), np.uint8)), np.zeros((3, 4), np.float32))
    one = np.zeros((1, 9), np.uint8)
    one[0, 3:7] = 1
    np.testing.assert_array_equal(_near(one), np.array([[0, 0, 0, 1, 2, 2, 1, 0, 0]], np.float32))


def test_distance_near_random_masks():
    """Random masks from sparse to nearly full (at least one zero pixel): OpenCV's values to rounding
    (its square root may be one unit in the last place off: atol 1e-5 px); the exact distances (the
    squared ones are integers) bit for bit."""
    rng = np.random.default_rng(2)
    for t in range(150):
        h, w = (int(v) for v in rng.integers(1, 80, 2))
        m = (rng.random((h, w)) < rng.choice([0.02, 0.3, 0.7, 0.95])).astype(np.uint8) * 255
        if t % 2:
            m = cv2.dilate(m, np.ones((5, 5), np.uint8))
        m.flat[rng.integers(m.size)] = 0
        ref = _cv_distance(m)
        got = _near(m)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-5)
        np.testing.assert_array_equal(got, _exact(ref))


def test_ridge_radius_map_full_masks_take_opencvs_path():
    """A mask fuller than NEAR_MAX_SHARE (and one without any zero pixel) goes to OpenCV: its map (to
    rounding: OpenCV's precise distances differ by an ulp from one call to the next)."""
    full = np.full((40, 50), 255, np.uint8)
    full[20, 25] = 0
    ref = cv2.max(cv2.subtract(_cv_distance(full), 0.5), 0.0)
    np.testing.assert_allclose(ridge_radius_map(full).image, ref, rtol=1e-6, atol=0)
    ones = np.full((10, 12), 255, np.uint8)
    ref = cv2.max(cv2.subtract(_cv_distance(ones), 0.5), 0.0)
    assert ref.min() > 1e6                                  # (no zero pixel: OpenCV's "far")
    np.testing.assert_allclose(ridge_radius_map(ones).image, ref, rtol=1e-6, atol=0)


def test_ridge_radius_map_branch_mask():
    """The radius map of a 4x smaller branch mask (window 3, scale 4), as the localizer takes it: the
    distances less half a pixel, max-filtered, times the scale."""
    img = np.zeros((60, 80), np.uint8)
    cv2.line(img, (5, 50), (75, 8), 255, 7)
    ref = cv2.max(cv2.subtract(cv2.dilate(_cv_distance(img), np.ones((3, 3), np.uint8)), 0.5), 0.0) * np.float32(4)
    got = ridge_radius_map(img, 3, 4)
    assert got.scale == 4 and got.image.dtype == np.float32
    np.testing.assert_allclose(got.image, ref, rtol=0, atol=4e-5)
    assert 10.0 < got.image.max() < 16.0                    # (7 px wide: radius ~3.5 small px)


def _lookup(img: np.ndarray, cfg, tiles: np.ndarray, tile_px: int, fill: int = 7) -> np.ndarray:
    out = np.full(img.shape[:2], fill, np.uint8)
    kernels_front.bark_lookup_rows(np.ascontiguousarray(img).reshape(-1), img.shape[1], *bark_lut_rows(cfg), tiles,
                                   tile_px, out.reshape(-1))
    return out


def test_bark_lookup_is_bark_tiles():
    """bark_lookup_rows (bark_lookup until speedS) against the kernel it replaces (bark_tiles) for random tile flags (runs of
    tiles, single tiles, the last row and column reaching the image's edges), tile sizes and hue
    ranges (wrapping through red, not wrapping), on random and smooth colours: bit for bit, pixels
    outside the flagged tiles untouched."""
    base = effective_config(None).localize.segment
    rng = np.random.default_rng(7)
    img = rng.integers(0, 256, (75, 101, 3), np.uint8)
    img[:40] = cv2.GaussianBlur(img[:40], (0, 0), 3)
    for hues, tile_px, p in (((base.hue_min, base.hue_max), 16, 0.5), ((5, 40), 8, 0.3), ((base.hue_min, base.hue_max),
                                                                                          32, 0.9)):
        cfg = replace(base, hue_min=hues[0], hue_max=hues[1])
        lut = bark_lut(cfg)
        tiles = (rng.random((-(-75 // tile_px), -(-101 // tile_px))) < p).astype(np.uint8) * 255
        want = bark_tiles(img, lut, tiles, tile_px, np.full(img.shape[:2], 7, np.uint8))
        got = _lookup(img, cfg, tiles, tile_px)
        np.testing.assert_array_equal(got, want)
        assert (got == 7).any() and (got == 255).any() and (got == 0).any()
    small_tiles = np.ones((2, 3), np.uint8)                     # (fewer tiles than the image: the last reach its edges)
    np.testing.assert_array_equal(_lookup(img, cfg, small_tiles, 16),
                                  bark_tiles(img, lut, small_tiles, 16, np.full(img.shape[:2], 7, np.uint8)))


def test_bark_mask_is_opencvs_test_where_flagged():
    """bark_mask through bark_lookup_rows: on a fixture (tiles) and a speckled image (the whole image,
    FULL_SHARE), OpenCV's HSV thresholds (_hsv_threshold) wherever it tests, everywhere on the speckled one."""
    cfg = effective_config(None).localize.segment
    bgr = cv2.imread(str(FIXTURES / "left_00.png"))
    got, want = bark_mask(bgr, cfg), _hsv_threshold(bgr, cfg)
    assert cv2.countNonZero(got) > 0.9 * cv2.countNonZero(want)
    assert not (got & ~want).any()                              # (tested pixels exact; the rest 0)
    rng = np.random.default_rng(3)
    speckled = np.where(rng.random((96, 128, 1)) < 0.3, np.uint8([40, 60, 90]), np.uint8([40, 200, 90]))
    speckled = np.ascontiguousarray(speckled.astype(np.uint8))
    want = _hsv_threshold(speckled, cfg)
    assert 0 < cv2.countNonZero(want) < want.size
    np.testing.assert_array_equal(bark_mask(speckled, cfg), want)


def _one_level(px, width, lut, tiles, tile_px, out):
    """The test by the one-level table (bit ``k & 7`` of byte ``k >> 3``, ``k = b << 16 | g << 8 | r``) of
    the pixels of the flagged tiles (the last tile row and column reach the image's edges), in numpy."""
    bgr = px.reshape(-1, 3).astype(np.uint32)
    k = bgr[:, 0] << 16 | bgr[:, 1] << 8 | bgr[:, 2]
    test = ((lut[k >> 3] >> (k & 7)) & 1).astype(np.uint8) * 255
    h = out.size // width
    ty = np.minimum(np.arange(h) // tile_px, tiles.shape[0] - 1)
    tx = np.minimum(np.arange(width) // tile_px, tiles.shape[1] - 1)
    flagged = (tiles[ty[:, None], tx[None, :]] != 0).reshape(-1)
    out[flagged] = test[flagged]
    return out


def _both(px, width, tiles, tile_px, cfg, n):
    old = np.full(n, 7, np.uint8)
    new = np.full(n, 7, np.uint8)
    _one_level(px, width, bark_lut(cfg), tiles, tile_px, old)
    index, rows = bark_lut_rows(cfg)
    kernels_front.bark_lookup_rows(px, width, index, rows, tiles, tile_px, new)
    return old, new


def test_every_colour_same_test():
    """All 2^24 BGR colours, one image 4096 x 4096: the same 0/255 values (exact: no tolerance)."""
    cfg = effective_config(None).localize.segment
    k = np.arange(1 << 24, dtype=np.uint32)
    px = np.empty((1 << 24, 3), np.uint8)
    px[:, 0], px[:, 1], px[:, 2] = k >> 16, (k >> 8) & 255, k & 255
    old, new = _both(px.reshape(-1), 4096, np.ones((1, 1), np.uint8), 4096, cfg, 1 << 24)
    np.testing.assert_array_equal(new, old)
    assert 0 < np.count_nonzero(new) < new.size            # (some bark colours, not all)
    index, rows = bark_lut_rows(cfg)
    assert index.nbytes + rows.nbytes < 0.25 * bark_lut(cfg).nbytes


def test_tiles_and_ragged_edges_untouched_elsewhere():
    """Random image 37 x 53 px, random 5 px tiles (the last row/column ragged): flagged tiles the same
    values, the rest of ``out`` left as it was (7)."""
    rng = np.random.default_rng(5)
    cfg = effective_config(None).localize.segment
    h, w, t = 37, 53, 5
    img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    img[::3, ::2] = (40, 70, 110)                            # (a brown: some bark pixels)
    tiles = (rng.random((h // t, w // t)) < 0.5).astype(np.uint8)
    old, new = _both(img.reshape(-1), w, tiles, t, cfg, h * w)
    np.testing.assert_array_equal(new, old)
    assert (new == 7).any() and (new == 255).any()


def _reference(img: np.ndarray, factor: int) -> np.ndarray:
    """sample_nearest before speedfront2: OpenCV's nearest-neighbour resize of the whole blocks."""
    h, w = img.shape[:2]
    hs, ws = h // factor, w // factor
    return cv2.resize(img[:hs * factor, :ws * factor], (ws, hs), interpolation=cv2.INTER_NEAREST)


@pytest.mark.parametrize("shape, factor", [(s, f) for s in [(960, 1280), (251, 333), (7, 9), (4, 4), (5, 1283)]
                                           for f in [1, 2, 3, 4, 5] if min(s) >= f])   # (at least one whole block)
def test_sample_every_is_the_nearest_resize(shape, factor):
    rng = np.random.default_rng(shape[0] * 7 + factor)
    img = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
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
