"""kernels_front.bark_lookup_rows (eleventh pass, speedS) against the one-level table (segment.bark_lut) it
replaced, read in numpy."""

import numpy as np

from appliance.commands.common import effective_config
from appliance.localize import kernels_front
from appliance.localize.segment import bark_lut, bark_lut_rows


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
