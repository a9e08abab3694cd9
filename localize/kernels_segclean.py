"""Compiled kernels of the segment stage's component clean-up (docs/localize-numba.md).

``segment.drop_small`` (the colour recogniser's removal of small components) keeps OpenCV's blocks' means
(``skeleton.block_mean``) and ``cv2.connectedComponents`` of them; the numpy steps that followed on the
blocks (``flatnonzero`` / ``take`` / ``bincount`` for the areas, ``unique`` / ``divmod`` for the small
components' blocks, ``compare`` / ``erode`` / ``mean`` for the large components' bark colour, a copy of
the image and a fancy-indexed clearing) are these kernels, each one pass over the non-empty blocks
only. The decisions (areas against ``min_area_px``, the disc test, the chromaticity) stay in
``drop_small`` in the same float steps, so the mask is the same bit for bit.

- :func:`component_areas`: the components' areas (px), ``bincount``'s weighted sums.
- :func:`component_blocks`: the blocks of chosen components (``np.unique``'s compact numbering).
- :func:`whole_block_sums`: the colour sums and counts of the sample over the large components' whole
  blocks, eroded (3 x 3, outside the grid = 0) and not: ``cv2.mean``'s operands (it returns sum * (1 / n)).
- :func:`clear_blocks`: zero the blocks of the dropped components.

Tests: tests/localize/test_kernels_segclean.py.
"""
from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def component_areas(idx, labels, cover, count_of, n):
    """Area (px) of each component: ``area`` (n,) float64, the sum of ``count_of[cover[i]]`` over the
    non-empty blocks ``idx`` (K,) (flat, row-major) of label ``labels[idx]`` (``cover``, ``labels``: the
    block image and its labels, flat). ``np.bincount``'s weighted sums (exact integers), in one pass."""
    area = np.zeros(n, np.float64)
    for k in range(len(idx)):
        i = idx[k]
        area[labels[i]] += count_of[cover[i]]
    return area


@numba.njit(**_JIT)
def component_blocks(idx, labels, comp_of, ws):
    """The blocks of ``idx`` (K,) (flat, row-major, row length ``ws``) whose component ``labels[i]`` has
    ``comp_of`` >= 0: their rows ``gy``, columns ``gx`` and ``comp_of`` values ``comp``, each (M,) int64,
    in ``idx``'s order."""
    m = 0
    for k in range(len(idx)):
        if comp_of[labels[idx[k]]] >= 0:
            m += 1
    gy, gx, comp = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m, np.int64)
    m = 0
    for k in range(len(idx)):
        i = idx[k]
        c = comp_of[labels[i]]
        if c >= 0:
            gy[m], gx[m], comp[m] = i // ws, i % ws, c
            m += 1
    return gy, gx, comp


@numba.njit(**_JIT)
def whole_block_sums(idx, labels, cover, skip, small, hs, ws):
    """Colour sums of the sample ``small`` (HS', WS', 3) uint8 over the whole blocks (``cover`` 255) among
    ``idx`` (K,) (flat indices into the (``hs``, ``ws``) block grid, row-major) whose component
    ``labels[i]`` is not flagged in ``skip``: ``(n_inner, s_inner, n_all, s_all)`` over those blocks whose
    8 neighbour blocks are such blocks too (none on the grid's border: ``cv2.erode`` with a border of 0)
    and over all of them. Each ``n`` is (2,) int64: the number of such blocks on the whole grid, and
    inside the sample (the first HS' rows and WS' columns: ``segment._bark_chroma``'s ``cv2.mean``
    over the common part); each ``s`` (3,) float64 the sums inside the sample (exact integers):
    ``cv2.mean``'s operands (it returns sum * (1 / n))."""
    hr, wr = small.shape[0], small.shape[1]
    use = np.zeros(hs * ws, np.bool_)
    for k in range(len(idx)):
        i = idx[k]
        use[i] = cover[i] == 255 and not skip[labels[i]]
    s_in, s_all = np.zeros(3, np.int64), np.zeros(3, np.int64)
    n_in, n_all = np.zeros(2, np.int64), np.zeros(2, np.int64)
    for k in range(len(idx)):
        i = idx[k]
        if not use[i]:
            continue
        y, x = i // ws, i % ws
        inside = y < hr and x < wr
        n_all[0] += 1
        if inside:
            n_all[1] += 1
            for c in range(3):
                s_all[c] += small[y, x, c]
        if y == 0 or x == 0 or y == hs - 1 or x == ws - 1:
            continue
        if (use[i - ws - 1] and use[i - ws] and use[i - ws + 1] and use[i - 1] and use[i + 1]
                and use[i + ws - 1] and use[i + ws] and use[i + ws + 1]):
            n_in[0] += 1
            if inside:
                n_in[1] += 1
                for c in range(3):
                    s_in[c] += small[y, x, c]
    return n_in, s_in.astype(np.float64), n_all, s_all.astype(np.float64)


@numba.njit(**_JIT)
def clear_blocks(mask, idx, labels, drop, ws, factor):
    """Zero, in ``mask`` (H, W) uint8, the ``factor`` square blocks among ``idx`` (K,) (flat, row-major,
    row length ``ws``) whose component ``labels[i]`` is flagged in ``drop``. Returns ``mask``."""
    for k in range(len(idx)):
        i = idx[k]
        if drop[labels[i]]:
            y0, x0 = (i // ws) * factor, (i % ws) * factor
            for y in range(y0, y0 + factor):
                for x in range(x0, x0 + factor):
                    mask[y, x] = 0
    return mask


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    idx = np.zeros(1, np.int64)
    labels, cover = np.zeros(1, np.int32), np.zeros(1, np.uint8)
    count_of = np.zeros(256)
    count_of.setflags(write=False)              # (segment's table of counts: cached, read-only)
    component_areas(idx, labels, cover, count_of, 1)
    component_blocks(idx, labels, np.full(1, -1, np.int64), 1)
    skip = np.zeros(1, np.bool_)
    whole_block_sums(idx, labels, cover, skip, np.zeros((1, 1, 3), np.uint8), 1, 1)
    clear_blocks(np.zeros((4, 4), np.uint8), idx, labels, skip, 1, 4)
