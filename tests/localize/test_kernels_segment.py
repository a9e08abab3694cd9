"""The segment stage's kernels (localize/kernels_segment.py, segspeed) against the OpenCV calls they replace."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from appliance.commands.common import effective_config
from appliance.localize import kernels_segment
from appliance.localize.segment import _bark_tiles, _kernel, clean_mask, sample_nearest, segment_mask, unmix_edges

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
CROSS = _kernel(3)                                  # (MORPH_ELLIPSE 3 x 3: the cross)


def _open_close(raw: np.ndarray) -> np.ndarray:
    """The replaced code: OpenCV's opening then closing of the whole image."""
    return cv2.morphologyEx(cv2.morphologyEx(raw, cv2.MORPH_OPEN, CROSS), cv2.MORPH_CLOSE, CROSS)


def _gradient(mask: np.ndarray) -> np.ndarray:
    return cv2.morphologyEx(mask, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8))


def _tiled(rng, h: int, w: int, tile_px: int, share: float, dense: float):
    """A random 0/255 mask confined to random ``tile_px`` tiles (the last row and column reaching the edges)."""
    th, tw = max(1, h // tile_px), max(1, w // tile_px)
    tiles = (rng.random((th, tw)) < share).astype(np.uint8)
    ys = np.minimum(np.arange(h) // tile_px, th - 1)
    xs = np.minimum(np.arange(w) // tile_px, tw - 1)
    inside = tiles[ys][:, xs] != 0
    blobs = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 2.0)
    raw = np.where(inside & (blobs > np.quantile(blobs, 1 - dense)), 255, 0).astype(np.uint8)
    return raw, tiles


@pytest.mark.parametrize("h, w", [(96, 128), (101, 77), (37, 19), (16, 16), (50, 3), (3, 40)])
def test_open_close_tiles_random(h, w):
    """Exact (atol 0 px) against OpenCV on random masks of random tiles: sizes not multiples of the tile,
    a last tile row taller than a tile, images narrower than the 4 px reach, all tiles flagged."""
    rng = np.random.default_rng(h * 1000 + w)
    for share in (0.0, 0.3, 0.7, 1.0):
        for dense in (0.3, 0.6, 0.95):
            raw, tiles = _tiled(rng, h, w, 16, share, dense)
            got = kernels_segment.open_close_tiles(raw, tiles, 16, np.zeros_like(raw))
            np.testing.assert_array_equal(got, _open_close(raw))
            got = kernels_segment.gradient_tiles(_open_close(raw), tiles, 16, raw.copy())   # (raw: off tiles zero)
            np.testing.assert_array_equal(got, _gradient(_open_close(raw)))


def test_kernels_constructed():
    """Pixels on the tiles' corners and the image's edges; a one-pixel speck (opened away); a 1 px gap
    (closed); a soft mask's gradient (any values: maximum minus minimum)."""
    raw = np.zeros((48, 48), np.uint8)
    tiles = np.zeros((3, 3), np.uint8)
    tiles[0, 0] = tiles[2, 2] = tiles[1, 1] = 1
    raw[0:16, 0:16] = 255                         # a whole corner tile at the image's corner
    raw[5, 5] = 0                                 # a hole (closed)
    raw[32:48, 32:48] = 255
    raw[32:48, 40] = 0                            # a 1 px gap (closed)
    raw[20, 20] = 255                             # a speck (opened away)
    raw[16:32, 31] = 255                          # a line on the tile's right edge (opened away)
    want = _open_close(raw)
    got = kernels_segment.open_close_tiles(raw, tiles, 16, np.zeros_like(raw))
    np.testing.assert_array_equal(got, want)
    assert got[20, 20] == 0 and got[5, 5] == 255 and got[40, 40] == 255
    soft = want.copy()
    soft[want > 0] = np.random.default_rng(1).integers(1, 256, int((want > 0).sum()))
    np.testing.assert_array_equal(kernels_segment.gradient_tiles(soft, tiles, 16, np.zeros_like(soft)), _gradient(soft))


@pytest.mark.parametrize("name", ["00", "03"])
def test_segment_mask_unchanged(name):
    """segment_mask (the kernels on the tested tiles) equals the OpenCV path bit for bit on the fixtures
    (fixture 03: most tiles flagged, the whole image tested: the kernels over one tile of the image's size)."""
    cfg = effective_config(None).localize.segment
    for side in ("left", "right"):
        bgr = cv2.imread(str(FIXTURES / f"{side}_{name}.png"))
        small = sample_nearest(bgr, 4)
        raw, tiles = _bark_tiles(bgr, cfg, small=small)
        assert (tiles is None) == (name == "03")
        m = clean_mask(raw.copy(), cfg, bgr, small)                    # (no tiles: OpenCV's morphology)
        want = unmix_edges(bgr, m, cfg.edge_window_px, cfg.edge_band_px, small=small)
        np.testing.assert_array_equal(segment_mask(bgr, cfg), want)
