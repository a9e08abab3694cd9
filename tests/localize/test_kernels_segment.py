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


def _unmix_numpy(bgr, mask, window_px, band_px, factor=4):
    """The numpy steps unmix_blocks replaced (segment.unmix_edges before the kernel)."""
    import cv2

    from appliance.localize.segment import _K3, _MIN_SIN2, sample_nearest
    from appliance.localize.skeleton import block_mean
    h, w = mask.shape
    hs, ws = h // factor, w // factor
    ring = cv2.morphologyEx(mask, cv2.MORPH_GRADIENT, np.ones((2 * band_px + 1,) * 2, np.uint8))
    bi = np.flatnonzero(block_mean(ring[:hs * factor, :ws * factor], factor) != 0)
    out = mask.copy()
    small = sample_nearest(bgr, factor)
    ms = cv2.resize(mask[:hs * factor, :ws * factor], (ws, hs), interpolation=cv2.INTER_NEAREST)
    chi = np.array(cv2.mean(small, mask=cv2.erode(ms, _K3))[:3], np.float32)
    if not chi.any():
        chi = np.array(cv2.mean(small, mask=ms)[:3], np.float32)
    chi /= max(float(np.linalg.norm(chi)), 1e-6)
    away = cv2.bitwise_not(cv2.dilate(ms, _K3))
    win = (max(1, round(window_px / factor)),) * 2
    n_o = cv2.boxFilter(away, cv2.CV_32F, win, normalize=False)
    s_o = cv2.boxFilter(cv2.bitwise_and(small, small, mask=away), cv2.CV_32F, win, normalize=False)
    n = n_o.reshape(-1).take(bi) * (1.0 / 255)
    c_o = s_o.reshape(-1, 3).take(bi, axis=0) / np.maximum(n, 1.0)[:, None]
    c_chi = c_o @ chi
    c_c = np.einsum("ij,ij->i", c_o, c_o)
    det = c_c - c_chi * c_chi
    ok = (n > 0.5) & (det > _MIN_SIN2 * c_c)
    bi, v = bi[ok], (c_o[ok] - c_chi[ok, None] * chi) / det[ok, None]
    off = (np.arange(factor)[:, None] * w + np.arange(factor)).reshape(-1)
    fi = ((bi // ws) * (factor * w) + (bi % ws) * factor)[:, None] + off
    on = np.flatnonzero(ring.reshape(-1).take(fi) != 0)
    fi = fi.reshape(-1).take(on)
    v = v.take(on // (factor * factor), axis=0)
    p = bgr.reshape(-1, 3).take(fi, axis=0).astype(np.float32)
    cover = p[:, 0] * v[:, 0]
    cover += p[:, 1] * v[:, 1]
    cover += p[:, 2] * v[:, 2]
    cover = 1.0 - cover
    out.reshape(-1)[fi] = np.minimum(np.maximum(cover * 255.0 + 0.5, 0), 255).astype(np.uint8)
    return out


def test_unmix_blocks_gives_the_numpy_steps_coverage():
    """unmix_edges (its blocks and outline pixels compiled) equals the numpy steps it replaced, bit for
    bit, on a fixture scene's cleaned mask and on a noisy rendered disc (both outline bands)."""
    from pathlib import Path

    import cv2

    from appliance.config import load_config
    from appliance.localize.segment import bark_hsv, clean_mask, unmix_edges

    cfg = load_config().localize.segment
    img = cv2.imread(str(Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "left_00.png"))
    mask = clean_mask(bark_hsv(img, cfg)[1], cfg)
    rng = np.random.default_rng(7)
    disc = np.zeros((122, 161), np.uint8)
    cv2.circle(disc, (80, 60), 33, 255, -1)
    noisy = np.clip(np.where(disc[..., None] > 0, (60, 70, 90), (200, 160, 90)) + rng.normal(0, 12, (122, 161, 3)),
                    0, 255).astype(np.uint8)
    for bgr, m in ((img, mask), (cv2.GaussianBlur(noisy, (0, 0), 1.0), disc)):
        for band in (1, 2):
            want = _unmix_numpy(bgr, m, 20, band)
            assert np.count_nonzero((want > 0) & (want < 255)) > 100
            np.testing.assert_array_equal(unmix_edges(bgr, m, 20, band), want)
