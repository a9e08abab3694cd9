"""Compiled per-point steps that were a handful of small numpy operations each: rounding points, the boxes
they read, counts and look-ups at them (fourteenth pass, speed20; docs/localize-numba.md). Each gives the
values of the numpy steps it replaces (integers, or numpy's floating-point operations in numpy's order).

:func:`search_boxes` is ``texture._search``'s numpy steps before its reads (the patches' rounded
centres and the boxes both images are read over) in one call instead of ~10 small numpy operations;
:func:`inside_fractions` is ``patchmask.inside_fraction``'s counts, patch by patch instead of a summed-area
table of the patches' bounding box; :func:`skeleton_to_full` is ``SkeletonGraph.to_full`` in one pass (no
temporary arrays); :func:`radius_lookup` is ``radius.radius_at``'s rounding, clamping and read.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _readonly


@numba.njit(**_JIT)
def search_boxes(uv_px, hh, hw, lo, hi, h, w):
    """``texture._search``'s patch centres and read boxes: ``uv`` (N, 2) int64, ``np.rint(uv_px)`` of the
    centres ``uv_px`` (N >= 1, 2) float64, and the boxes ``(by0, by1, lx0, lx1, rx0, rx1)`` (half-open, clipped
    to the image of ``h`` rows and ``w`` columns) over which the left patches (half heights ``hh`` (N,) int64,
    half width ``hw``) and the right strips (disparities ``lo``..``hi``) lie: the same integers as the numpy
    steps (``(uv[:, 1] - hh).min()``, ``uv[:, 0].max()``, ...). ``uv`` None when a centre is not finite
    (the caller's numpy steps then)."""
    n = len(uv_px)
    for i in range(n):
        if not (np.isfinite(uv_px[i, 0]) and np.isfinite(uv_px[i, 1])):
            return None, 0, 0, 0, 0, 0, 0
    uv = np.empty((n, 2), np.int64)
    top, bottom = np.int64(1) << 62, -(np.int64(1) << 62)
    u_min, u_max = np.int64(1) << 62, -(np.int64(1) << 62)
    for i in range(n):
        u, v = np.int64(np.rint(uv_px[i, 0])), np.int64(np.rint(uv_px[i, 1]))
        uv[i, 0], uv[i, 1] = u, v
        top, bottom = min(top, v - hh[i]), max(bottom, v + hh[i])
        u_min, u_max = min(u_min, u), max(u_max, u)
    by0, by1 = max(top, 0), min(bottom + 1, h)
    lx0, lx1 = max(u_min - hw, 0), min(u_max + hw + 1, w)
    rx0, rx1 = max(u_min - hi - hw, 0), min(u_max - lo + hw + 1, w)
    return uv, by0, by1, lx0, lx1, rx0, rx1


@numba.njit(**_JIT)
def inside_fractions(mask, uv, hh, hw):
    """``patchmask.inside_fraction``: the fraction (N,) of each (2 ``hh`` + 1) x (2 ``hw`` + 1) patch centred
    on ``uv`` (N, 2) float64 px (rounded half to even) that lies where ``mask`` (H, W) uint8 is >= 128, the
    part outside the image counting as outside; 0 for a non-finite centre. The counts are exact integers,
    each divided by the patch's area as numpy divides them (float64)."""
    h, w = mask.shape
    area = float((2 * hh + 1) * (2 * hw + 1))
    out = np.zeros(len(uv))
    for i in range(len(uv)):
        if not (np.isfinite(uv[i, 0]) and np.isfinite(uv[i, 1])):
            continue
        cx, cy = np.int64(np.rint(uv[i, 0])), np.int64(np.rint(uv[i, 1]))
        n = 0
        for y in range(max(cy - hh, 0), min(cy + hh + 1, h)):
            row = mask[y]
            for x in range(max(cx - hw, 0), min(cx + hw + 1, w)):
                if row[x] >= 128:
                    n += 1
        out[i] = float(n) / area
    return out


@numba.njit(**_JIT)
def skeleton_to_full(yx, scale):
    """``SkeletonGraph.to_full``: skeleton (row, col) ``yx`` (N, 2) int64 or float64 -> full-resolution (x, y)
    (N, 2) float64, ``(col + 0.5) * scale - 0.5`` and ``(row + 0.5) * scale - 0.5``: numpy's operations in its
    order (the integers converted to float64 first), so the same values."""
    out = np.empty((len(yx), 2))
    s = float(scale)
    for i in range(len(yx)):
        out[i, 0] = (float(yx[i, 1]) + 0.5) * s - 0.5
        out[i, 1] = (float(yx[i, 0]) + 0.5) * s - 0.5
    return out


@numba.njit(**_JIT)
def radius_lookup(img, scale, xy):
    """``radius.radius_at``: the map ``img`` (H, W) float32 (``scale`` full-resolution px per map pixel) at
    the nearest map pixel of each full-resolution point ``xy`` (N, 2) float64 (x, y), clamped into the map:
    (N,) float64, ``np.rint((xy + 0.5) / scale - 0.5)``'s pixel as numpy rounds it. None when a point is
    not finite (the caller's numpy steps then: numpy's conversion of NaN to an integer is its own)."""
    h, w = img.shape
    s = float(scale)
    out = np.empty(len(xy))
    for i in range(len(xy)):
        if not (np.isfinite(xy[i, 0]) and np.isfinite(xy[i, 1])):
            return None
        x = np.int64(np.rint((xy[i, 0] + 0.5) / s - 0.5))
        y = np.int64(np.rint((xy[i, 1] + 0.5) / s - 0.5))
        out[i] = img[min(max(y, 0), h - 1), min(max(x, 0), w - 1)]
    return out


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    img, i = np.zeros((8, 16), np.uint8), np.ones(1, np.int64)
    search_boxes(np.zeros((1, 2)), i, 1, 0, 2, 8, 16)
    inside_fractions(img, np.zeros((1, 2)), 1, 1)
    radius_lookup(np.zeros((2, 2), np.float32), 2.0, np.zeros((1, 2)))
    for dtype in (np.int64, np.float64):            # (the graph's arrays, some read-only)
        skeleton_to_full(np.zeros((1, 2), dtype), 4.0)
        skeleton_to_full(_readonly(np.zeros((1, 2), dtype)), 4.0)
