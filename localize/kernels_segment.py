"""Compiled kernels of the segment stage, tenth pass (segspeed; docs/localize-numba.md).

:func:`open_close_tiles` is the colour recogniser's clean-up morphology, OpenCV's opening then closing
with the 3 x 3 cross (``cv2.morphologyEx(.., MORPH_OPEN / MORPH_CLOSE, getStructuringElement(
MORPH_ELLIPSE, (3, 3)))``), of a raw bark mask that is zero outside the tiles :func:`segment.bark_mask`
tested: only those tiles (and 5 px around them) are read and 1 px around them written, ~12 % of
fixture 00's image against the whole image for OpenCV's four passes. Erosion and dilation are exact
integer minima / maxima (the image's border ignored, as OpenCV's default border value does), so the
values are OpenCV's bit for bit.

:func:`gradient_tiles` is the outline unmixing's morphological gradient (3 x 3 square, ``cv2.morphologyEx(..,
MORPH_GRADIENT, np.ones((3, 3)))``) of the cleaned mask on the same tiles grown by 2 px, the same values.

Where the whole image was tested (most tiles flagged: fixture 03's grass) the callers keep OpenCV's calls.

Tests: tests/localize/test_kernels_segspeed.py.
"""
from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def _cross(src, s0, dst, d0, w, h, y0, y1, x0, x1, dilate):
    """``dst`` = minimum (``dilate`` False) or maximum of ``src`` over each pixel and its 4 neighbours inside
    the (h, w) image (those outside ignored, as OpenCV's default border does), on the image's rows [y0, y1)
    and columns [x0, x1). ``src``, ``dst``: flat uint8 row bands of width ``w`` whose first rows are
    the image's rows ``s0``, ``d0``. (Unsigned indices: no negative-index tests, the compiler vectorises
    the rows' loops.)"""
    one = np.uint64(1)
    for y in range(y0, y1):
        o = np.uint64((y - s0) * w)
        ou, od = np.uint64((max(y - 1, 0) - s0) * w), np.uint64((min(y + 1, h - 1) - s0) * w)
        q = np.uint64((y - d0) * w)
        xa, xb = max(x0, 1), min(x1, w - 1)
        for x_ in range(x0, xa):                            # (column 0: no left neighbour)
            x, r = np.uint64(x_), np.uint64(min(x_ + 1, w - 1))
            if dilate:
                dst[q + x] = max(max(src[o + x], src[o + r]), max(src[ou + x], src[od + x]))
            else:
                dst[q + x] = min(min(src[o + x], src[o + r]), min(src[ou + x], src[od + x]))
        if dilate:
            for x in range(np.uint64(xa), np.uint64(xb)):
                dst[q + x] = max(max(src[o + x - one], src[o + x + one]), max(max(src[o + x], src[ou + x]), src[od + x]))
        else:
            for x in range(np.uint64(xa), np.uint64(xb)):
                dst[q + x] = min(min(src[o + x - one], src[o + x + one]), min(min(src[o + x], src[ou + x]), src[od + x]))
        for x_ in range(max(xb, xa), x1):                   # (column w - 1: no right neighbour)
            x, lf = np.uint64(x_), np.uint64(max(x_ - 1, 0))
            if dilate:
                dst[q + x] = max(max(src[o + x], src[o + lf]), max(src[ou + x], src[od + x]))
            else:
                dst[q + x] = min(min(src[o + x], src[o + lf]), min(src[ou + x], src[od + x]))


@numba.njit(**_JIT)
def open_close_tiles(raw, tiles, tile_px, out):
    """Opening then closing of ``raw`` (H, W) uint8 with the 3 x 3 cross, into ``out`` (H, W) uint8 (zeros
    on entry: only pixels up to 1 px from a flagged tile are written). Returns ``out``.

    ``raw`` and ``out`` C-contiguous. ``raw`` must be zero outside the tiles flagged in ``tiles``
    (TH, TW) (non-zero: flagged), each ``tile_px`` square, the last tile row and column reaching the
    image's bottom and right edges (:func:`kernels_front.bark_lookup_rows`' tiles). The result is then zero
    farther than 1 px from them (the opening stays inside ``raw``, the closing grows it by at most 1 px),
    and each pixel depends on ``raw`` within 4 px. Per run of consecutive flagged tiles of a tile row
    (rectangle R): the erosion on R grown by 4 px (clipped to the image), the dilation on R + 3 px, the
    second dilation on R + 2 px, the last erosion on R + 1 px, written to ``out``: each pass reads only
    what the pass before wrote for this run, so every value written is the whole image's. The passes
    between go to two buffers of one tile row and 4 px above and below it (small: cached).
    """
    h, w = raw.shape
    th, tw = tiles.shape
    g = 4
    bh = max(tile_px, h - (th - 1) * tile_px) + 2 * g
    a = np.empty(bh * w, np.uint8)
    b = np.empty(bh * w, np.uint8)
    src, dst = raw.reshape(-1), out.reshape(-1)
    for ty in range(th):
        y0 = ty * tile_px
        y1 = h if ty == th - 1 else min(y0 + tile_px, h)
        base = y0 - g                                       # (the image row of the buffers' first row)
        tx = 0
        while tx < tw:
            if tiles[ty, tx] == 0:
                tx += 1
                continue
            t0 = tx
            while tx < tw and tiles[ty, tx] != 0:
                tx += 1
            x0 = t0 * tile_px
            x1 = w if tx == tw else min(tx * tile_px, w)
            _cross(src, 0, a, base, w, h, max(y0 - 4, 0), min(y1 + 4, h), max(x0 - 4, 0), min(x1 + 4, w), False)
            _cross(a, base, b, base, w, h, max(y0 - 3, 0), min(y1 + 3, h), max(x0 - 3, 0), min(x1 + 3, w), True)
            _cross(b, base, a, base, w, h, max(y0 - 2, 0), min(y1 + 2, h), max(x0 - 2, 0), min(x1 + 2, w), True)
            _cross(a, base, dst, 0, w, h, max(y0 - 1, 0), min(y1 + 1, h), max(x0 - 1, 0), min(x1 + 1, w), False)
    return out


@numba.njit(**_JIT)
def gradient_tiles(mask, tiles, tile_px, out):
    """Morphological gradient of ``mask`` (H, W) uint8 with the 3 x 3 square (maximum minus minimum over
    each pixel's 3 x 3 neighbourhood inside the image: ``cv2.morphologyEx(mask, MORPH_GRADIENT,
    np.ones((3, 3)))``), into ``out`` (H, W) uint8 on the flagged tiles grown by 2 px. Returns ``out``.

    ``mask`` must be zero farther than 1 px from the tiles flagged in ``tiles`` (TH, TW) (``tile_px``
    square, the last row and column reaching the image's edges: :func:`open_close_tiles`' result, or
    less): its gradient is then zero farther than 2 px from them, and ``out`` is right everywhere when
    zero there on entry (or non-zero only on the flagged tiles: ``segment.bark_mask``'s mask may be
    reused). Both C-contiguous.
    """
    h, w = mask.shape
    th, tw = tiles.shape
    g = 3
    bh = max(tile_px, h - (th - 1) * tile_px) + 2 * g
    hi = np.empty(bh * w, np.uint8)                       # each row's maximum over 3 columns
    lo = np.empty(bh * w, np.uint8)                       # ... minimum
    src, dst = mask.reshape(-1), out.reshape(-1)
    one = np.uint64(1)
    for ty in range(th):
        y0 = ty * tile_px
        y1 = h if ty == th - 1 else min(y0 + tile_px, h)
        base = y0 - g
        tx = 0
        while tx < tw:
            if tiles[ty, tx] == 0:
                tx += 1
                continue
            t0 = tx
            while tx < tw and tiles[ty, tx] != 0:
                tx += 1
            x0 = max(t0 * tile_px - 2, 0)
            x1 = min(w if tx == tw else tx * tile_px + 2, w)
            for y in range(max(y0 - 3, 0), min(y1 + 3, h)):
                o, q = np.uint64(y * w), np.uint64((y - base) * w)
                xa, xb = max(x0, 1), min(x1, w - 1)
                for x_ in (x0, x1 - 1):                      # (the image's first and last columns)
                    if xa <= x_ < xb or x_ < x0 or x_ >= x1:
                        continue
                    x = np.uint64(x_)
                    lf, rt = np.uint64(max(x_ - 1, 0)), np.uint64(min(x_ + 1, w - 1))
                    hi[q + x] = max(max(src[o + lf], src[o + x]), src[o + rt])
                    lo[q + x] = min(min(src[o + lf], src[o + x]), src[o + rt])
                for x in range(np.uint64(xa), np.uint64(xb)):
                    hi[q + x] = max(max(src[o + x - one], src[o + x]), src[o + x + one])
                for x in range(np.uint64(xa), np.uint64(xb)):
                    lo[q + x] = min(min(src[o + x - one], src[o + x]), src[o + x + one])
            for y in range(max(y0 - 2, 0), min(y1 + 2, h)):
                q = np.uint64((y - base) * w)
                qu, qd = np.uint64((max(y - 1, 0) - base) * w), np.uint64((min(y + 1, h - 1) - base) * w)
                o = np.uint64(y * w)
                for x in range(np.uint64(x0), np.uint64(x1)):
                    dst[o + x] = (max(max(hi[qu + x], hi[q + x]), hi[qd + x])
                                  - min(min(lo[qu + x], lo[q + x]), lo[qd + x]))
    return out


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    img, tiles = np.zeros((4, 4), np.uint8), np.ones((1, 1), np.uint8)
    open_close_tiles(img, tiles, 4, img.copy())
    gradient_tiles(img, tiles, 4, img.copy())
