"""Compiled numpy-equal sums and order statistics, shared by the other kernels (docs/localize-numba.md).

:func:`_pairwise` is numpy's pairwise summation (blocks of 8 partial sums below 128 terms, halves above),
so a kernel's sums equal ``np.sum`` / ``np.add.reduceat`` bit for bit (:func:`_segment_sum`: the first term
plus the pairwise sum of the rest, as ``reduceat``). :func:`_sorted`, :func:`_select` and :func:`_median`
are a sort, a quickselect and ``np.median``'s value (the mean of the two middle values for an even count).
Called only from other kernels (compiled with them).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def _pairwise_block(a, lo, n):
    """numpy's pairwise sum of ``a[lo:lo + n]``, n <= 128 (one block: 8 accumulators)."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    m = n - n % 8
    i = 8
    while i < m:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@numba.njit(**_JIT)
def _pairwise(a, lo, n):
    """numpy's pairwise sum of ``a[lo:lo + n]`` (float64 reduce inner loop: blocks of 8 accumulators, halves
    rounded down to 8 above 128), the same value bit for bit; walked with a stack, not recursion: numba does
    not link a recursive kernel into a cached one of another module, nor reload it reliably."""
    if n <= 128:                                # (one block: no stack)
        return _pairwise_block(a, lo, n)
    seg_lo, seg_n, state = np.empty(64, np.int64), np.empty(64, np.int64), np.empty(64, np.int64)
    vals = np.empty(64)
    sp, vp = 1, 0
    seg_lo[0], seg_n[0], state[0] = lo, n, 0
    while sp > 0:
        l0, n0, st = seg_lo[sp - 1], seg_n[sp - 1], state[sp - 1]
        if n0 <= 128:
            sp -= 1
            vals[vp] = _pairwise_block(a, l0, n0)
            vp += 1
            continue
        n2 = n0 // 2
        n2 -= n2 % 8
        if st == 0:                             # the first half
            state[sp - 1] = 1
            seg_lo[sp], seg_n[sp], state[sp] = l0, n2, 0
            sp += 1
        elif st == 1:                           # then the second
            state[sp - 1] = 2
            seg_lo[sp], seg_n[sp], state[sp] = l0 + n2, n0 - n2, 0
            sp += 1
        else:                                   # their sum
            sp -= 1
            vp -= 1
            vals[vp - 1] = vals[vp - 1] + vals[vp]
    return vals[0]


@numba.njit(**_JIT)
def _segment_sum(a, lo, n):
    """``np.add.reduceat``'s sum of a segment ``a[lo:lo + n]`` (n >= 1): its first value plus the
    pairwise sum of the rest."""
    return a[lo] + _pairwise(a, lo + 1, n - 1)


@numba.njit(**_JIT)
def _partition(p, lo, hi):
    """Hoare's partition of ``p[lo:hi + 1]`` in place about the median of three: ``(i, j)`` with
    ``p[lo:j + 1]`` at most the pivot, ``p[i:hi + 1]`` at least it (and equal to it between)."""
    mid = (lo + hi) // 2
    if p[mid] < p[lo]:
        p[mid], p[lo] = p[lo], p[mid]
    if p[hi] < p[lo]:
        p[hi], p[lo] = p[lo], p[hi]
    if p[hi] < p[mid]:
        p[hi], p[mid] = p[mid], p[hi]
    pivot = p[mid]
    i, j = lo, hi
    while i <= j:
        while p[i] < pivot:
            i += 1
        while pivot < p[j]:
            j -= 1
        if i <= j:
            p[i], p[j] = p[j], p[i]
            i += 1
            j -= 1
    return i, j


@numba.njit(**_JIT)
def _sorted(a):
    """A sorted copy of a 1-D float array (quicksort, insertion sort below 16; NaN not expected).
    Its own few lines rather than ``np.sort``: a tenth of the compile time."""
    p = a.copy()
    stack = np.empty(128, np.int64)
    top = 0
    stack[0], stack[1] = 0, len(p) - 1
    top = 2
    while top:
        top -= 2
        lo, hi = stack[top], stack[top + 1]
        while hi - lo >= 16:
            i, j = _partition(p, lo, hi)
            if j - lo < hi - i:                 # the smaller part first (the stack stays shallow)
                stack[top], stack[top + 1] = i, hi
                hi = j
            else:
                stack[top], stack[top + 1] = lo, j
                lo = i
            top += 2
        for i in range(lo + 1, hi + 1):         # insertion sort of the short rest
            v = p[i]
            j = i - 1
            while j >= lo and p[j] > v:
                p[j + 1] = p[j]
                j -= 1
            p[j + 1] = v
    return p


@numba.njit(**_JIT)
def _select(p, k):
    """Reorder ``p`` in place so that ``p[k]`` is its k-th smallest value, none larger before it and
    none smaller after it (quickselect, Hoare's partition); returns ``p[k]``."""
    lo, hi = 0, len(p) - 1
    while hi > lo:
        i, j = _partition(p, lo, hi)
        if k <= j:                              # (between j and i: all equal to the pivot)
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return p[k]


@numba.njit(**_JIT)
def _median(a):
    """``np.median`` of a 1-D float array, NaN-free (the same value: the middle order statistic(s),
    by selection in a copy)."""
    n = len(a)
    if n == 0:
        return np.nan
    p = a.copy()
    k = n // 2
    hi = _select(p, k)
    if n % 2:
        return hi
    lo = p[0]
    for i in range(1, k):
        lo = max(lo, p[i])
    return (lo + hi) / 2
