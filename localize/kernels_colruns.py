"""Compiled runs of a mask along its columns, read row by row (fourteenth pass, speed20; docs/localize-numba.md).

:func:`mask_col_runs` is :func:`kernels_runs.mask_runs` of the transposed mask (``edges.find_runs(mask.T)``,
the flat pieces' runs) without the transpose: the mask is read in its own row-major order, 8 pixels at a
time where nothing changes, and each column's run is closed where the column turns off. The same runs,
order and sub-pixel boundaries as transposing first (~0.15-0.2 ms less per 1280x960 mask, which is read
cold once instead of being copied and read again).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_runs import _soft_edge


@numba.njit(**_JIT)
def _scan_columns(flat, words, h, w, above, col, y0, y1):
    """:func:`mask_col_runs`' scan: every run of ``flat > above`` along a column, in the order the runs end
    (row by row), into ``col``, ``y0``, ``y1`` (their length the most runs it takes). Returns the number of
    runs, or -1 when there are more. A word (8 columns of a row, ``w`` a multiple of 8) whose pixels are on
    and off as in the row above (by the bytes' high bits for ``above`` 127, by zero bytes for 0) starts and
    ends no run, and is skipped (four at a time where they can be)."""
    cap = len(col)
    n = 0
    start = np.full(w, -1, np.int64)             # the open run's first row per column, -1: none
    high = np.uint64(0x8080808080808080)
    ones = np.uint64(0x0101010101010101)
    wpr = w // 8
    for y in range(h):
        base = y * w
        row0 = np.uint64(y * wpr)
        prev0 = np.uint64((y - 1) * wpr) if y > 0 else np.uint64(0)
        wi = 0
        while wi < wpr:
            if y > 0 and wi + 4 <= wpr and (above == 127 or above == 0):    # four words as the row above
                diff = np.uint64(0)
                for q in range(4):
                    a = words[row0 + np.uint64(wi + q)]
                    b = words[prev0 + np.uint64(wi + q)]
                    if above == 127:
                        diff |= (a ^ b) & high
                    else:
                        diff |= ((a - ones) & ~a & high) ^ ((b - ones) & ~b & high)
                if diff == 0:
                    wi += 4
                    continue
            a = words[row0 + np.uint64(wi)]
            if above == 127:
                pa = a & high
                pb = words[prev0 + np.uint64(wi)] & high if y > 0 else np.uint64(0)
                same = pa == pb
            elif above == 0:
                za = (a - ones) & ~a & high      # the zero bytes' high bits
                if y > 0:
                    b = words[prev0 + np.uint64(wi)]
                    same = za == ((b - ones) & ~b & high)
                else:
                    same = za == high
            else:
                same = False
            if not same:
                for j in range(8):
                    x = wi * 8 + j
                    on = flat[np.uint64(base + x)] > above
                    s = start[x]
                    if on:
                        if s < 0:
                            start[x] = y
                    elif s >= 0:
                        if n == cap:
                            return -1
                        col[n] = x
                        y0[n] = s
                        y1[n] = y - 1
                        n += 1
                        start[x] = -1
            wi += 1
    for x in range(w):                            # runs reaching the bottom row
        if start[x] >= 0:
            if n == cap:
                return -1
            col[n] = x
            y0[n] = start[x]
            y1[n] = h - 1
            n += 1
    return n


@numba.njit(**_JIT)
def mask_col_runs(flat, words, h, w, above, soft):
    """The runs of the transposed mask, as :func:`kernels_runs.mask_runs` gives them for
    ``mask.T.copy()``: ``flat`` (H * W,) uint8 the mask (H, W) row-major (``words``: the same bytes as
    uint64; W a multiple of 8); branch where ``flat > above`` (127 or 0). Returns the runs' columns
    (the transposed mask's rows), first and last rows (R,) int64, sorted by column then row, and their
    sub-pixel boundaries (R,) float64 along the column (with ``soft``: where the coverage crosses 127.5
    between the pixel outside and the one inside, :func:`kernels_runs._soft_edge`'s value; else half a
    pixel outside)."""
    cap = max(1024, len(flat) // 256)
    while True:
        col, y0, y1 = np.empty(cap, np.int64), np.empty(cap, np.int64), np.empty(cap, np.int64)
        n = _scan_columns(flat, words, h, w, above, col, y0, y1)
        if n >= 0:
            break
        cap *= 4
    first = np.zeros(w + 1, np.int64)            # a stable counting sort by column (a column's runs end in order)
    for i in range(n):
        first[col[i] + 1] += 1
    for x in range(w):
        first[x + 1] += first[x]
    rows, a, z = np.empty(n, np.int64), np.empty(n, np.int64), np.empty(n, np.int64)
    for i in range(n):
        k = first[col[i]]
        first[col[i]] += 1
        rows[k], a[k], z[k] = col[i], y0[i], y1[i]
    left, right = np.empty(n), np.empty(n)
    for i in range(n):
        left[i] = a[i] - 0.5
        right[i] = z[i] + 0.5
        if soft:
            x = rows[i]
            if a[i] > 0:
                left[i] = _soft_edge(flat, (a[i] - 1) * w + x, a[i] * w + x, a[i] - 1, a[i])
            if z[i] < h - 1:
                right[i] = _soft_edge(flat, (z[i] + 1) * w + x, z[i] * w + x, z[i] + 1, z[i])
    return rows, a, z, left, right


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernel for the argument types callers pass."""
    m = np.zeros(16, np.uint8)
    for soft in (True, False):
        mask_col_runs(m, m.view(np.uint64), 2, 8, 127, soft)
