"""Compiled kernels of the runs' sub-pixel refinement, :func:`subpixel.refine_runs` (docs/localize-numba.md).

:func:`subpixel.refine_runs` moves the runs' boundaries to the grey image's outline. Its numpy glue
(concatenations, fancy indexing, ``np.where`` over all 2R boundaries, a few dozen calls of 10-30 us on
~5000 runs) is replaced by two loops, with the same values bit for bit; the grey step itself
(:func:`subpixel.refine_boundaries`: OpenCV's remap of the queried pixels, then
:func:`refine_steps`, below) stays between them:

- :func:`remap_tables`: :func:`subpixel.gather`'s look-up of the queried pixels' entries in the
  view's remap tables (the remap itself stays OpenCV's);
- :func:`refine_todo`: which boundaries are refined (``only``; :func:`subpixel.steep_boundaries`'s test
  on the soft mask), with their rows and columns;
- :func:`refine_stats`: the moved boundaries, the mask's bias (``np.median``'s value),
  :func:`subpixel.whole_pixel_share` and :func:`subpixel.grey_weight`'s median deviation (its square stays
  in Python: CPython's ``x ** 2`` is libm's ``pow``, which differs from ``x * x`` in the last bit about
  once in a thousand);
- :func:`refine_apply`: the rest of :func:`subpixel.refine_runs`: the bias, the mix, the clamp to the
  run's middle and the pixels taken into the run.

Tests: tests/localize/test_kernels_refine.py (against the numpy code it replaced).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _readonly
from appliance.localize.kernels_stats import _median


@numba.njit(**_JIT)
def refine_todo(row, left_px, right_px, only, use_only, mask, use_mask, max_tan):
    """The boundaries :func:`subpixel.refine_runs` refines, in its order (all left boundaries, then all
    right ones).

    Parameters
    ----------
    row : ndarray (R,) int64
        The runs' rows.
    left_px, right_px : ndarray (R,) float64
        Their boundaries, px.
    only : ndarray (R,) bool
        Runs to refine (read only when ``use_only``).
    mask : ndarray (H, W) uint8
        Soft mask (read only when ``use_mask``): a boundary counts where the outline runs within
        ``atan(max_tan)`` of the vertical (:func:`subpixel.steep_boundaries`' central differences).

    Returns
    -------
    todo : ndarray (K,) int64
        Boundary indices into ``concatenate([left_px, right_px])``.
    rows : ndarray (K,) int64
    x : ndarray (K,) float64
    """
    n = len(row)
    h, w = mask.shape
    todo = np.empty(2 * n, np.int64)
    k = 0
    for i in range(2 * n):
        j = i if i < n else i - n
        if use_only and not only[j]:
            continue
        if use_mask:
            x = left_px[j] if i < n else right_px[j]
            r = min(max(row[j], 1), h - 2)
            c = min(max(np.int64(np.rint(x)), 1), w - 2)
            gx = abs(np.int32(mask[r, c + 1]) - np.int32(mask[r, c - 1]))
            gy = abs(np.int32(mask[r + 1, c]) - np.int32(mask[r - 1, c]))
            if not float(gy) <= max_tan * float(gx):
                continue
        todo[k] = i
        k += 1
    todo = todo[:k].copy()
    rows = np.empty(k, np.int64)
    xs = np.empty(k)
    for i in range(k):
        j = todo[i] if todo[i] < n else todo[i] - n
        rows[i] = row[j]
        xs[i] = left_px[j] if todo[i] < n else right_px[j]
    return todo, rows, xs


@numba.njit(**_JIT)
def _remainder1(a):
    """``np.remainder(a, 1.0)`` (numpy's ``divmod`` steps: ``fmod``, then the divisor's sign)."""
    mod = np.fmod(a, 1.0)
    if mod != 0.0:
        if mod < 0.0:
            mod += 1.0
    else:
        mod = 0.0
    return mod


@numba.njit(**_JIT)
def refine_stats(row, left_px, right_px, todo, xr, mx, has_map, min_moved, max_samples):
    """:func:`subpixel.refine_runs`' statistics of the grey steps ``xr`` (K,) of the boundaries ``todo``
    (K,) (:func:`refine_todo`'s, float64 px), with numpy's values.

    ``mx`` (H, W) float32 is the view's x remap table (``Rectifier.float_maps``; read only when
    ``has_map``, else the boundaries are taken as the original image's own, as
    :func:`subpixel.whole_pixel_share` does with an ndarray). ``max_samples``: that function's.

    Returns
    -------
    sel : ndarray (M,) int64
        The entries of ``todo`` the grey step moved.
    bias : float
        The median inward shift of those, px (NaN unless ``M >= min_moved``).
    share : float
        :func:`subpixel.whole_pixel_share` of the moved boundaries (NaN unless ``M >= min_moved``).
    mad : float
        :func:`subpixel.grey_weight`'s median absolute deviation of the shifts less ``bias``, px (NaN
        unless ``M >= min_moved``); the caller squares it in Python (libm's ``pow``, as before).
    """
    n = len(row)
    sel = np.empty(len(todo), np.int64)
    m = 0
    for i in range(len(todo)):
        t = todo[i]
        if xr[i] != (left_px[t] if t < n else right_px[t - n]):
            sel[m] = i
            m += 1
    sel = sel[:m].copy()
    if m < min_moved:
        return sel, np.nan, np.nan, np.nan
    dev = np.empty(m)
    for i in range(m):
        t = todo[sel[i]]
        dev[i] = (xr[sel[i]] - left_px[t]) if t < n else -(xr[sel[i]] - right_px[t - n])
    bias = _median(dev)
    share = 0.0
    if m:
        step = -(-m // max_samples)
        cnt, tot = 0, 0
        for i in range(0, m, step):
            t = todo[sel[i]]
            j = t if t < n else t - n
            xs = left_px[j] if t < n else right_px[j]
            sx = xs
            if has_map:
                xi = min(max(np.int64(math.floor(xs)), 0), mx.shape[1] - 2)
                f = xs - xi
                sx = float(mx[row[j], xi]) * (1.0 - f) + float(mx[row[j], xi + 1]) * f
            frac = _remainder1(sx + 0.5)
            cnt += min(frac, 1.0 - frac) < 0.1
            tot += 1
        share = cnt / tot
    d2 = dev - bias
    med = _median(d2)
    for i in range(m):
        d2[i] = abs(d2[i] - med)
    return sel, bias, share, _median(d2)


@numba.njit(**_JIT)
def refine_apply(row, x0, x1, left_px, right_px, width, todo, xr, sel, bias, use_bias, weight, max_dev_px):
    """:func:`subpixel.refine_runs`' new runs: every boundary shifted by ``bias`` (inward, px) if
    ``use_bias``, the moved ones ``todo[sel]`` (grey steps ``xr[sel]``) towards their grey step (at most
    ``max_dev_px`` from it) by ``weight``, clamped to the run's middle, and a pixel taken into the run
    where its boundary moved out into it and 2+ background pixels stay before the next run.

    Returns
    -------
    x0, x1 : ndarray (R,) int64
    left, right : ndarray (R,) float64
        px.
    """
    n = len(row)
    x = np.empty(2 * n)
    x[:n] = left_px
    x[n:] = right_px
    if use_bias:
        for i in range(n):
            x[i] += bias
            x[n + i] -= bias
    for i in range(len(sel)):
        t = todo[sel[i]]
        xt = x[t]
        xg = min(max(xr[sel[i]], xt - max_dev_px), xt + max_dev_px)
        x[t] = xg if weight == 1.0 else xt + weight * (xg - xt)
    left, right = np.empty(n), np.empty(n)
    nx0, nx1 = x0.copy(), x1.copy()
    big = np.int64(1) << 40
    for i in range(n):                              # never across the run's own middle
        centre = 0.5 * (left_px[i] + right_px[i])
        left[i] = min(x[i], centre)
        right[i] = max(x[n + i], centre)
    for i in range(n):
        gap_lo = big if i == 0 or row[i] != row[i - 1] else x0[i] - x1[i - 1]
        gap_hi = big if i == n - 1 or row[i + 1] != row[i] else x0[i + 1] - x1[i]
        if gap_lo >= 3 and x0[i] > 0 and left[i] < x0[i] - 0.5:
            nx0[i] = x0[i] - 1
        if gap_hi >= 3 and x1[i] < width - 1 and right[i] > x1[i] + 0.5:
            nx1[i] = x1[i] + 1
    return nx0, nx1, left, right


@numba.njit(**_JIT)
def remap_tables(m1, m2, row, col, w, width):
    """:func:`subpixel.gather`'s remap tables of the queried pixels of a lazily rectified view: the
    entries of its fixed-point maps at ``(row[k], clip(col[k, j], 0, w - 1))`` in row-major order, padded
    with entry 0 to whole rows of ``width`` (remap's output stays under 32767 rows).

    Parameters
    ----------
    m1 : ndarray (H * W,) int32
        The view's CV_16SC2 map, each (x, y) int16 pair read as one int32.
    m2 : ndarray (H * W,) uint16
        Its CV_16UC1 interpolation table.
    row : ndarray (K,) int64
    col : ndarray (K, n) int64
    w : int
        Image width, px.

    Returns
    -------
    map1 : ndarray (rows, width) int32 (view as int16 (rows, width, 2) for cv2.remap)
    map2 : ndarray (rows, width) uint16
    """
    k, m = col.shape
    n = k * m
    size = -(-n // width) * width
    map1 = np.empty(size, np.int32)
    map2 = np.empty(size, np.uint16)
    j = 0
    for i in range(k):
        base = row[i] * w
        for o in range(m):
            at = base + min(max(col[i, o], 0), w - 1)
            map1[j] = m1[at]
            map2[j] = m2[at]
            j += 1
    for j in range(n, size):
        map1[j] = m1[0]
        map2[j] = m2[0]
    return map1.reshape(size // width, width), map2.reshape(size // width, width)


@numba.njit(**_JIT)
def refine_steps(p, x_px, xi, log_tab, min_step, min_share, max_shift_px):
    """``subpixel.refine_boundaries`` after its gather: each boundary ``x_px`` (K,) (pixel ``xi`` (K,) int64)
    moved to the grey step along its row from the 7 pixels ``p`` (K, 7) float32 (whole grey levels
    0-255) centred on ``xi``, with numpy's float32 / float64 steps in the same order (the same values).
    ``log_tab`` (256,) float32: numpy's float32 ``log`` of ``max(v, 1e-3)`` for the steps' values ``v``
    (whole levels: index ``max(v, 0)``), so the logs are numpy's own."""
    n = len(x_px)
    out = np.empty(n)
    f0, half, neg = np.float32(0.0), np.float32(0.5), np.float32(-1e-6)
    two = np.float32(2.0)
    lim = np.float32(0.5 * min_share)
    for i in range(n):
        out[i] = x_px[i]
        raw = p[i, 5] + p[i, 6] - p[i, 0] - p[i, 1]
        sg = np.float32(1.0) if raw > f0 else np.float32(-1.0) if raw < f0 else f0
        d = np.float32(x_px[i] - xi[i])
        best, k = -np.inf, 0
        for j in range(1, 5):
            v = (p[i, j + 1] - p[i, j]) * sg
            if (j == 1 and d > f0) or (j == 4 and d < f0):
                continue
            if v > best:
                best, k = v, j
        if k == 0:                      # (every candidate -inf: numpy's argmax takes the first)
            k = 2 if d > f0 else 1
        a = (p[i, k] - p[i, k - 1]) * sg
        b = (p[i, k + 1] - p[i, k]) * sg
        c = (p[i, k + 2] - p[i, k + 1]) * sg
        if not (b >= np.float32(min_step) and b >= lim * abs(raw) and b > a and b >= c):
            continue
        if a > f0 and c > f0:
            la = log_tab[int(a)] if a >= np.float32(1.0) else log_tab[0]
            lb = log_tab[int(b)] if b >= np.float32(1.0) else log_tab[0]
            lc = log_tab[int(c)] if c >= np.float32(1.0) else log_tab[0]
            frac = half * (la - lc) / min(la - two * lb + lc, neg)
        else:
            frac = half * (a - c) / min(a - two * b + c, neg)
        shift = (float(k) - 2.5 - float(d)) + float(frac)
        if abs(shift) <= max_shift_px:
            out[i] = x_px[i] + shift
    return out



def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    i2, f2, b2 = np.zeros(2, np.int64), np.zeros(2), np.zeros(2, np.bool_)
    remap_tables(np.zeros(4, np.int32), np.zeros(4, np.uint16), i2, np.zeros((2, 7), np.int64), 2, 1024)
    todo, rows, xs = refine_todo(i2, f2, f2, b2, False, np.zeros((4, 4), np.uint8), True, 1.0)   # (find_runs'
    sel, bias, share, mad = refine_stats(i2, f2, f2, todo, xs, np.zeros((4, 4), np.float32), True, 50, 256)  # runs:
    refine_apply(i2, i2, i2, f2, f2, 4, todo, xs, sel, bias, True, 1.0, 0.6)                      # writable)
    refine_steps(np.zeros((1, 7), np.float32), np.zeros(1), np.ones(1, np.int64), _readonly(np.zeros(256, np.float32)),
                 12.0, 0.25, 1.5)
