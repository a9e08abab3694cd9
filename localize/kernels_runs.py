"""Compiled runs of a mask and their look-ups (:class:`edges.Runs`; docs/localize-numba.md).

:func:`mask_runs` is ``edges.find_runs``: each row's runs of a uint8 mask (read by 8-pixel words) with their
sub-pixel boundaries (``edges._soft_crossing``'s values); :func:`runs_find` and :func:`runs_between` are
``Runs.find`` (the run containing a pixel) and ``Runs.between`` (the runs whose centre lies in a range of
a row). The same values as the numpy steps they replace.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _readonly


@numba.njit(**_JIT)
def runs_find(keys, rows, x1, width, row, x):
    """``edges.Runs.find``: for each query (``row``, ``x``) the run containing pixel (row, rint(x)),
    -1 if none (or ``x`` not finite). ``keys``, ``rows``, ``x1``: the runs' start keys
    (``row * width + x0``), rows and last pixels, a sentinel first (``Runs._find_tables``)."""
    out = np.empty(len(row), np.int64)
    for k in range(len(row)):
        out[k] = -1
        if not np.isfinite(x[k]):
            continue
        xi = np.int64(np.rint(x[k]))
        i = np.searchsorted(keys, row[k] * width + xi, side="right") - 1
        if rows[i] == row[k] and x1[i] >= xi:
            out[k] = i - 1
    return out


@numba.njit(**_JIT)
def runs_between(keys, row, width, lo, hi):
    """``edges.Runs.between``: all pairs (query, run) with the run's centre key (``keys``, sorted:
    ``row * width + centre``) in [row * width + lo, row * width + hi] of each query."""
    n = len(row)
    a = np.empty(n, np.int64)
    b = np.empty(n, np.int64)
    total = 0
    for k in range(n):
        base = row[k] * width
        a[k] = np.searchsorted(keys, base + lo[k], side="left")
        b[k] = np.searchsorted(keys, base + hi[k], side="right")
        total += max(b[k] - a[k], 0)
    query = np.empty(total, np.int64)
    run = np.empty(total, np.int64)
    j = 0
    for k in range(n):
        for i in range(a[k], b[k]):
            query[j] = k
            run[j] = i
            j += 1
    return query, run


@numba.njit(**_JIT)
def _soft_edge(flat, p_out, p_in, outside, inside):
    """``edges._soft_crossing`` of one boundary: the coverage fraction in float32, then the position in
    float64 (numpy's promotion of float32 times int64), the same value."""
    a = np.float32(flat[p_out])
    b = np.float32(flat[p_in])
    frac = (np.float32(127.5) - a) / max(b - a, np.float32(1.0))
    frac = min(max(frac, np.float32(0.0)), np.float32(1.0))
    return float(outside) + float(frac) * float(inside - outside)


@numba.njit(**_JIT)
def _scan_runs(flat, words, w, above, rows, x0, x1):
    """:func:`mask_runs`' scan into ``rows``, ``x0``, ``x1`` (their length the most runs it takes): the
    number of runs, or -1 when there are more. (The reads index by ``np.uint64``: numba then drops its
    negative-index test on each, 0.165 -> 0.12 ms per full-size mask.)"""
    total = len(flat)
    n_words = len(words)
    cap = len(rows)
    n = 0
    inside = False
    row, row_start, row_end, start = 0, 0, w, 0
    p = 0
    high = np.uint64(0x8080808080808080)
    ones = np.uint64(0x0101010101010101)
    while p < total:
        if (p & 7) == 0:
            wd = words[np.uint64(p >> 3)]
            if not inside:                  # 8 pixels off at a time
                off_mask = high if above == 127 else ~np.uint64(0)
                if (wd & off_mask) == 0:
                    wi = (p >> 3) + 1
                    while wi + 4 <= n_words:
                        w0, w1, w2, w3 = np.uint64(wi), np.uint64(wi + 1), np.uint64(wi + 2), np.uint64(wi + 3)
                        if ((words[w0] | words[w1] | words[w2] | words[w3]) & off_mask) != 0:
                            break
                        wi += 4
                    while wi < n_words and (words[np.uint64(wi)] & off_mask) == 0:
                        wi += 1
                    p = wi << 3
                    continue
            elif p + 8 < row_end:           # 8 pixels on, the row going on after them
                if above == 127:
                    if (wd & high) == high:
                        p += 8
                        continue
                elif above == 0 and ((wd - ones) & ~wd & high) == 0:
                    p += 8
                    continue
        while p >= row_end:
            row += 1
            row_start = row_end
            row_end += w
        on = flat[np.uint64(p)] > above
        p += 1
        end = -1
        if on:
            if not inside:
                inside = True
                start = p - 1 - row_start
            if p == row_end:
                end = w - 1
        elif inside:
            end = p - 2 - row_start
        if end >= 0:
            inside = False
            if n == cap:
                return -1
            rows[n] = row
            x0[n] = start
            x1[n] = end
            n += 1
    return n


@numba.njit(**_JIT)
def mask_runs(flat, words, w, above, soft):
    """``edges.find_runs``' runs of a uint8 mask (``flat``: its pixels row-major, H W of them; ``words``
    the same bytes as uint64): rows, first and last columns (R,) int64 and sub-pixel left and right
    boundaries (R,) float64, row-major, the same values as the numpy steps (``_run_bounds`` and, with
    ``soft``, ``_soft_crossing``). Branch where ``flat > above``. Stretches of 8 pixels off (or, inside a
    run, on) are skipped a word at a time (``above`` 127: by the bytes' high bits; 0: zero bytes)."""
    cap = max(1024, len(flat) // 256)
    while True:
        rows, x0, x1 = np.empty(cap, np.int64), np.empty(cap, np.int64), np.empty(cap, np.int64)
        n = _scan_runs(flat, words, w, above, rows, x0, x1)
        if n >= 0:
            break
        cap *= 4
    left, right = np.empty(n), np.empty(n)
    for i in range(n):
        left[i] = x0[i] - 0.5
        right[i] = x1[i] + 0.5
        if soft:
            base = rows[i] * w
            if x0[i] > 0:
                left[i] = _soft_edge(flat, base + x0[i] - 1, base + x0[i], x0[i] - 1, x0[i])
            if x1[i] < w - 1:
                right[i] = _soft_edge(flat, base + x1[i] + 1, base + x1[i], x1[i] + 1, x1[i])
    return rows[:n].copy(), x0[:n].copy(), x1[:n].copy(), left, right


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    f, i = np.zeros(4), np.arange(4, dtype=np.int64)
    runs_find(_readonly(i.copy()), _readonly(i.copy()), _readonly(i.copy()), 4, i, f)
    runs_between(_readonly(f.copy()), i, 4, f, f)
    m = np.zeros(8, np.uint8)
    for soft in (True, False):
        mask_runs(m, m.view(np.uint64), 4, 127, soft)
