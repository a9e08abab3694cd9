"""Compiled kernels of the front stages: the colour recogniser's bark look-up and the radius map's distance
transform (docs/localize-numba.md).

:func:`bark_lookup_rows` is the colour recogniser's bark test by :func:`segment.bark_lut_rows`' two-level
table (~0.2 MB, which stays in the cache between the stages; eleventh pass, speedS): the values of the
former ``kernels.bark_tiles`` (OpenCV's HSV thresholds, through :func:`segment.bark_lut`'s 2 MB table; the
seventh pass's ``bark_lookup`` read that table) at a fraction of its cost; the pixels of a run of flagged
tiles are read as one flat run per image row. Tests: tests/localize/test_kernels_front.py (equal to the
one-level table on all 2^24 colours, and to ``bark_tiles``).

:func:`distance_near` is the radius map's Euclidean distance transform, OpenCV's precise one
(``cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)``) at ~1/7 of its cost on branch
masks: the correctly rounded float32 root of the exact squared distance. OpenCV's (IPP's with one
thread) is that value or one unit in the last place off (~1e-6 px), and not always the same from
one call to the next; on the fixtures' masks they agree bit for bit, and the 60 scenes' results are
unchanged. Tests: tests/localize/test_kernels_front.py.

:func:`sample_every` is :func:`segment.sample_nearest` of a BGR image (OpenCV's nearest-neighbour resize by
a whole factor: the blocks' first pixels) as a plain strided copy, ~2/3 of ``cv2.resize``'s cost and
about 1/3 less on the image's first, cache-cold read in the pipeline (thirteenth pass, speedfront2).
Tests: tests/localize/test_kernels_front.py.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def distance_near(mask, out):
    """Euclidean distance (px) of each pixel of ``mask`` (H, W) uint8 to the nearest zero pixel of the
    image (pixels outside the image are not zero), float32 into ``out`` (H, W); returns ``out``.

    The squared distance along each column first (two passes over the rows), then per non-zero pixel
    the nearest columns of its row, out to the distance found so far: a cost per pixel of about its
    distance, little on thin branch masks, which are mostly zero (a mask with no zero pixel gets
    ``(H + W)^2`` squared distances; callers leave such masks to OpenCV).
    """
    h, w = mask.shape
    far = np.int64(h + w)
    g = np.empty((h, w), np.int64)                  # distance to the nearest zero pixel of the column
    for x in range(w):
        g[0, x] = 0 if mask[0, x] == 0 else far
    for y in range(1, h):
        for x in range(w):
            g[y, x] = 0 if mask[y, x] == 0 else min(g[y - 1, x] + 1, far)
    for y in range(h - 2, -1, -1):
        for x in range(w):
            g[y, x] = min(g[y, x], g[y + 1, x] + 1)
    for y in range(h):
        for x in range(w):
            g[y, x] = g[y, x] * g[y, x]             # (squared: far * far where the column has no zero)
    for y in range(h):
        gy = g[y]
        for x in range(w):
            best = gy[x]
            if best == 0:
                out[y, x] = 0.0
                continue
            k = 1
            while k * k < best and (x - k >= 0 or x + k < w):
                if x - k >= 0:
                    best = min(best, k * k + gy[x - k])
                if x + k < w:
                    best = min(best, k * k + gy[x + k])
                k += 1
            out[y, x] = np.sqrt(np.float32(best))
    return out


@numba.njit(**_JIT)
def tile_runs(tiles, tile_px, h, w):
    """The runs of consecutive flagged tiles of each tile row of ``tiles`` (TH, TW) (non-zero: flagged; each
    ``tile_px`` square, the last tile row and column reaching the bottom and right edges of an image ``h`` x
    ``w`` px) as pixel rectangles, row by row, left to right: (K, 4) int64 ``y0, y1, x0, x1`` (half-open)."""
    th, tw = tiles.shape
    out = np.empty((th * ((tw + 1) // 2), 4), np.int64)
    k = 0
    for ty in range(th):
        y0 = ty * tile_px
        y1 = h if ty == th - 1 else min(y0 + tile_px, h)
        tx = 0
        while tx < tw:
            if tiles[ty, tx] == 0:
                tx += 1
                continue
            t0 = tx
            while tx < tw and tiles[ty, tx] != 0:
                tx += 1
            out[k, 0], out[k, 1] = y0, y1
            out[k, 2], out[k, 3] = t0 * tile_px, (w if tx == tw else min(tx * tile_px, w))
            k += 1
    return out[:k]


@numba.njit(**_JIT)
def bark_lookup_rows(px, width, index, rows, tiles, tile_px, out):
    """The bark test of every pixel of the flagged tiles by a two-level colour table; the rest of ``out``
    untouched. Returns ``out``.

    ``px`` (H * W * 3,) uint8: a C-contiguous BGR image (H, W, 3), flat, ``width`` W px; ``index``
    (2^16,) uint16: per colour's ``b << 8 | g`` the number of its row of ``rows`` ((R * 32,) uint8: R
    distinct 256-bit rows, bit ``r & 7`` of byte ``r >> 3`` is the test of that ``(b, g, r)``;
    :func:`segment.bark_lut_rows` builds both from :func:`segment.bark_lut`'s table, ~1/9 of its size);
    ``tiles`` (TH, TW): non-zero = test that ``tile_px`` square tile (the last tile row and column reach
    the image's bottom and right edges); ``out`` (H * W,) uint8, the mask flat, gets 255 (bark) or 0.
    Consecutive flagged tiles of a tile row are read row by row as one run of pixels.
    """
    w = width
    h = out.size // w
    one = np.uint8(1)
    runs = tile_runs(tiles, tile_px, h, w)
    for k in range(runs.shape[0]):
        y0, y1, x0, x1 = runs[k, 0], runs[k, 1], runs[k, 2], runs[k, 3]
        for y in range(y0, y1):
            # (slices read from 0: numba then knows the indices are not negative, ~1.5x faster)
            src = px[3 * (y * w + x0):3 * (y * w + x1)]
            dst = out[y * w + x0:y * w + x1]
            for i in range(len(dst)):
                row = np.uint32(index[(np.uint32(src[3 * i]) << 8) | np.uint32(src[3 * i + 1])])
                r = np.uint32(src[3 * i + 2])
                dst[i] = np.uint8(0) - ((rows[(row << 5) | (r >> 3)] >> (r & 7)) & one)
    return out


@numba.njit(**_JIT)
def sample_every(img, factor, out):
    """Every ``factor``-th pixel of every ``factor``-th row of ``img`` (H, W, 3) uint8, C-contiguous, into
    ``out`` (hs, ws, 3) uint8 with hs <= H // factor, ws <= W // factor: ``out[i, j] = img[factor * i,
    factor * j]``; returns ``out``. Row by row (the source rows are read in order)."""
    hs, ws = out.shape[0], out.shape[1]
    for i in range(hs):
        src = img[i * factor]
        dst = out[i]
        for j in range(ws):
            k = np.uint64(j * factor)                   # (unsigned: no negative-index test)
            dst[j, 0] = src[k, 0]
            dst[j, 1] = src[k, 1]
            dst[j, 2] = src[k, 2]
    return out


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    distance_near(np.zeros((2, 2), np.uint8), np.zeros((2, 2), np.float32))
    index = np.zeros(1 << 16, np.uint16)
    rows = np.zeros(32, np.uint8)
    index.setflags(write=False)
    rows.setflags(write=False)                      # (segment.bark_lut_rows' tables are read-only)
    bark_lookup_rows(np.zeros(12, np.uint8), 2, index, rows, np.zeros((1, 1), np.uint8), 4, np.zeros(4, np.uint8))
    img = np.zeros((4, 4, 3), np.uint8)
    sample_every(img, 2, np.empty((2, 2, 3), np.uint8))
    img.setflags(write=False)                       # (read-only images: their own specialisation)
    sample_every(img, 2, np.empty((2, 2, 3), np.uint8))
