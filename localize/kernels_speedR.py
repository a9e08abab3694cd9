"""Compiled kernels of the front stages, ninth pass (speedR; docs/localize-numba.md).

:func:`needed_tiles` is :meth:`Rectifier.rectify`'s choice of the output tiles to remap of a mostly
empty mask: the tiles whose source box (rounded out to 8 px cells) holds a non-zero pixel, joined into
runs along each tile row. The same runs as the former threshold, block mean (three halvings) and
integral image, from one scan of the mask by 8-pixel words (~0.03 against 0.11 ms per 1280x960 mask).

Tests: tests/localize/test_kernels_speedR.py.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def needed_tiles(words, cell_box, tile_box, out):
    """The output tiles of a sparse remap whose source cells hold a non-zero pixel, as runs along a tile row.

    Parameters
    ----------
    words : ndarray (H, W / 8) uint64
        The source image (uint8, width a multiple of 8) read as 8-pixel words: a cell is 8 x 8 px.
    cell_box : ndarray (T, 4) int64
        Each tile's source cells ``cy0, cy1, cx0, cx1`` (end exclusive; an empty range: nothing read).
    tile_box : ndarray (T, 4) int64
        Each tile ``y0, y1, x0, x1`` in the output (row-major tile order).
    out : ndarray (T, 4) int64
        Receives the runs ``y0, y1, x0, x1``: neighbouring needed tiles of one tile row joined.

    Returns
    -------
    int
        The number of runs written to ``out``.
    """
    h, wb = words.shape
    cells = np.zeros((-(-h // 8), wb), np.uint8)
    acc = np.zeros(wb, np.uint64)
    for y0 in range(0, h, 8):
        acc[:] = 0
        for y in range(y0, min(y0 + 8, h)):
            for c in range(wb):
                acc[c] |= words[y, c]
        for c in range(wb):
            cells[y0 // 8, c] = acc[c] != 0
    n = 0
    for t in range(len(tile_box)):
        cy0, cy1, cx0, cx1 = cell_box[t, 0], cell_box[t, 1], cell_box[t, 2], cell_box[t, 3]
        hit = False
        for cy in range(cy0, cy1):
            for cx in range(cx0, cx1):
                if cells[cy, cx]:
                    hit = True
                    break
            if hit:
                break
        if not hit:
            continue
        if n > 0 and out[n - 1, 0] == tile_box[t, 0] and out[n - 1, 3] == tile_box[t, 2]:
            out[n - 1, 3] = tile_box[t, 3]                  # (continues the run)
        else:
            out[n, 0], out[n, 1], out[n, 2], out[n, 3] = tile_box[t, 0], tile_box[t, 1], tile_box[t, 2], tile_box[t, 3]
            n += 1
    return n


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    box = np.zeros((1, 4), np.int64)
    needed_tiles(np.zeros((8, 1), np.uint64), box, box, box.copy())
