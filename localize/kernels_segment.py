"""Compiled kernels of the segment stage: the colour recogniser's morphology on tiles, the outline
unmixing and the disc tests of its blocks (docs/localize-numba.md).

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

:func:`unmix_blocks` is the outline unmixing's per-block step (each outline pixel's coverage from its
colour between the block's bark and background colours). :func:`blocks_hold_disc` and
:func:`blocks_disc_colour` are ``segment.drop_small``'s disc test of the large components' blocks (which
pixels hold a whole disc of mask around them) and their colour sums.

Tests: tests/localize/test_kernels_segment.py (the unmixing, the morphology) and test_kernels_segclean.py
(the disc tests, within ``drop_small``).
"""
from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _readonly
from appliance.localize.kernels_front import tile_runs


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
    th = tiles.shape[0]
    g = 4
    bh = max(tile_px, h - (th - 1) * tile_px) + 2 * g
    a = np.empty(bh * w, np.uint8)
    b = np.empty(bh * w, np.uint8)
    src, dst = raw.reshape(-1), out.reshape(-1)
    runs = tile_runs(tiles, tile_px, h, w)
    for k in range(runs.shape[0]):
        y0, y1, x0, x1 = runs[k, 0], runs[k, 1], runs[k, 2], runs[k, 3]
        base = y0 - g                                       # (the image row of the buffers' first row)
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
    th = tiles.shape[0]
    g = 3
    bh = max(tile_px, h - (th - 1) * tile_px) + 2 * g
    hi = np.empty(bh * w, np.uint8)                       # each row's maximum over 3 columns
    lo = np.empty(bh * w, np.uint8)                       # ... minimum
    src, dst = mask.reshape(-1), out.reshape(-1)
    one = np.uint64(1)
    runs = tile_runs(tiles, tile_px, h, w)
    for k in range(runs.shape[0]):
        y0, y1 = runs[k, 0], runs[k, 1]
        base = y0 - g
        x0, x1 = max(runs[k, 2] - 2, 0), min(runs[k, 3] + 2, w)
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


@numba.njit(**_JIT)
def unmix_blocks(bgr, ring, blocks, n_o, s_o, chi, min_sin2, factor, out):
    """``segment.unmix_edges``' per-block unmixing and the coverage of its outline pixels, float32 in
    numpy's order of operations (the numpy steps' values bit for bit).

    For each block ``blocks[i]`` (row-major index into ``n_o`` (hs, ws) float32, the background's
    255-weighted sample count, and ``s_o`` (hs, ws, 3) float32, its colour sums): the background's
    mean colour ``c_o``, and where it has samples (n > 0.5) and is at least ``sqrt(min_sin2)`` off the
    bark's chromaticity ``chi`` (3,) float32, the vector ``v = (c_o - (c_o . chi) chi) / det``; each of
    the block's ``factor`` x ``factor`` pixels where ``ring`` (H, W) is non-zero then gets
    ``clip((1 - p . v) * 255 + 0.5, 0, 255)`` as uint8 in ``out`` (H, W), ``p`` its BGR colour. Returns
    the number of blocks unmixed.
    """
    ws = n_o.shape[1]
    one, scale, half = np.float32(1.0), np.float32(255.0), np.float32(0.5)
    inv255, lim = np.float32(1.0 / 255), np.float32(min_sin2)
    done = 0
    for i in range(len(blocks)):
        by, bx = blocks[i] // ws, blocks[i] % ws
        n = n_o[by, bx] * inv255
        nn = max(n, one)
        c0, c1, c2 = s_o[by, bx, 0] / nn, s_o[by, bx, 1] / nn, s_o[by, bx, 2] / nn
        c_chi = c0 * chi[0]
        c_chi += c1 * chi[1]
        c_chi += c2 * chi[2]
        c_c = c0 * c0
        c_c += c1 * c1
        c_c += c2 * c2
        det = c_c - c_chi * c_chi
        if not (n > half and det > lim * c_c):
            continue
        done += 1
        v0, v1, v2 = (c0 - c_chi * chi[0]) / det, (c1 - c_chi * chi[1]) / det, (c2 - c_chi * chi[2]) / det
        for y_ in range(by * factor, (by + 1) * factor):
            y = np.uint64(y_)                       # (unsigned indices: no negative-index tests)
            for x_ in range(bx * factor, (bx + 1) * factor):
                x = np.uint64(x_)
                if ring[y, x] == 0:
                    continue
                c = np.float32(bgr[y, x, 0]) * v0
                c += np.float32(bgr[y, x, 1]) * v1
                c += np.float32(bgr[y, x, 2]) * v2
                c = (one - c) * scale + half
                out[y, x] = np.uint8(min(max(c, np.float32(0.0)), np.float32(255.0)))
    return done


@numba.njit(**_JIT)
def _holds_disc(mask, y, x, dy, dx):
    """Whether every pixel at the offsets (``dy``, ``dx``) (M,) from (``y``, ``x``) is set in ``mask``
    (H, W) uint8 (inside it and non-zero); stops at the first unset one."""
    h, w = mask.shape
    for m in range(len(dy)):
        yy, xx = y + dy[m], x + dx[m]
        if yy < 0 or yy >= h or xx < 0 or xx >= w or mask[yy, xx] == 0:
            return False
    return True


@numba.njit(**_JIT)
def blocks_hold_disc(mask, gy, gx, comp, n_comp, factor, dy, dx):
    """Which components hold a disc: ``out[c]`` is True when some set pixel of the ``factor`` x
    ``factor`` blocks (``gy``, ``gx``) (K,) of component ``comp`` (K,) (0..``n_comp`` - 1) has every
    pixel at the offsets (``dy``, ``dx``) (M,) set too (:func:`_holds_disc`, inside ``mask`` (H, W)
    uint8). A component's test stops at its first such pixel."""
    h, w = mask.shape
    out = np.zeros(n_comp, np.bool_)
    for k in range(len(gy)):
        c = comp[k]
        if out[c]:
            continue
        y0, x0 = gy[k] * factor, gx[k] * factor
        for y in range(y0, min(y0 + factor, h)):
            for x in range(x0, min(x0 + factor, w)):
                if not out[c] and mask[y, x] != 0 and _holds_disc(mask, y, x, dy, dx):
                    out[c] = True
    return out


@numba.njit(**_JIT)
def blocks_disc_colour(mask, bgr, gy, gx, comp, n_comp, factor, dy, dx):
    """:func:`blocks_hold_disc`'s test over every set pixel of the blocks: per component the number of
    pixels whose disc offsets are all set (``count`` (n_comp,) int64) and the sum of their BGR colours
    in ``bgr`` (H, W, 3) uint8 (``sums`` (n_comp, 3) float64): the colour of its inside, free of the
    outline's mixed pixels."""
    h, w = mask.shape
    count = np.zeros(n_comp, np.int64)
    sums = np.zeros((n_comp, 3), np.float64)
    for k in range(len(gy)):
        c = comp[k]
        y0, x0 = gy[k] * factor, gx[k] * factor
        for y in range(y0, min(y0 + factor, h)):
            for x in range(x0, min(x0 + factor, w)):
                if mask[y, x] != 0 and _holds_disc(mask, y, x, dy, dx):
                    count[c] += 1
                    for ch in range(3):
                        sums[c, ch] += bgr[y, x, ch]
    return count, sums



def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    img, tiles = np.zeros((4, 4), np.uint8), np.ones((1, 1), np.uint8)
    open_close_tiles(img, tiles, 4, img.copy())
    gradient_tiles(img, tiles, 4, img.copy())
    i = np.zeros(1, np.int64)
    unmix_blocks(np.zeros((4, 4, 3), np.uint8), np.zeros((4, 4), np.uint8), i[:1], np.zeros((1, 1), np.float32),
                 np.zeros((1, 1, 3), np.float32), np.zeros(3, np.float32), 0.0025, 4, np.zeros((4, 4), np.uint8))
    ro = _readonly(np.zeros(1, np.int64))        # (the disc's offsets: segment._disc_offsets' cached, read-only)
    blocks_hold_disc(np.zeros((4, 4), np.uint8), i, i, i, 1, 4, ro, ro)
    blocks_disc_colour(np.zeros((4, 4), np.uint8), np.zeros((4, 4, 3), np.uint8), i, i, i, 1, 4, ro, ro)
