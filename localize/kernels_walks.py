"""Compiled walks and line reads on a mask, by bilinear reads (:mod:`ends`, :mod:`tips`; docs/localize-numba.md).

:func:`bilinear_u8` is ``cv2.remap``'s bilinear value of one point of a uint8 image (OpenCV's float32
interpolation, the same value), so the walks read the mask lazily, only where they go:
:func:`walk_edges` (the half-coverage crossing after a walk's last point), :func:`last_on` (where a line
last lies on the mask), :func:`child_outline_pairs` (a fork's child outline scan) and
:func:`near_points` (the points within a distance range of one point).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _readonly


@numba.njit(**_JIT)
def _fma32(a, b, c):
    """``a * b + c`` of float32 values rounded once (as a fused multiply-add; the float32 product is
    exact in float64)."""
    return np.float32(np.float64(a) * np.float64(b) + np.float64(c))


@numba.njit(**_JIT)
def bilinear_u8(img, x, y):
    """``cv2.remap(img, ..., INTER_LINEAR, BORDER_CONSTANT 0)`` of one point of a uint8 image: OpenCV 5's
    float32 interpolation (along the row, then between the rows, by fused multiply-adds, as its SIMD
    path on a CPU with FMA), rounded half to even: the same value (checked against cv2.remap on 4e6
    random points; without the fused rounding 6 of them differed by one level)."""
    h, w = img.shape
    if not (np.isfinite(x) and np.isfinite(y)):
        return np.float32(0.0)
    fx, fy = np.floor(x), np.floor(y)
    a, b = np.float32(x - fx), np.float32(y - fy)
    x0, y0 = int(fx), int(fy)
    # the four pixels (0 outside the image) as scalars: no array allocated per read (speed27)
    zero = np.float32(0.0)
    if 0 <= x0 and x0 + 1 < w and 0 <= y0 and y0 + 1 < h:
        p0, p1 = np.float32(img[y0, x0]), np.float32(img[y0, x0 + 1])
        p2, p3 = np.float32(img[y0 + 1, x0]), np.float32(img[y0 + 1, x0 + 1])
    else:
        in0, in1 = 0 <= y0 < h, 0 <= y0 + 1 < h
        l_in, r_in = 0 <= x0 < w, 0 <= x0 + 1 < w
        p0 = np.float32(img[y0, x0]) if in0 and l_in else zero
        p1 = np.float32(img[y0, x0 + 1]) if in0 and r_in else zero
        p2 = np.float32(img[y0 + 1, x0]) if in1 and l_in else zero
        p3 = np.float32(img[y0 + 1, x0 + 1]) if in1 and r_in else zero
    top = _fma32(a, p1 - p0, p0)
    bottom = _fma32(a, p3 - p2, p2)
    return min(max(np.rint(_fma32(b, bottom - top, top)), np.float32(0.0)), np.float32(255.0))


@numba.njit(**_JIT)
def walk_edges(mask, uv, bounds):
    """``ends.walk_edges``: per walk (points ``uv[bounds[i]:bounds[i + 1]]``) the fractional index
    of the half-coverage crossing after its last point on ``mask`` (bilinear, :func:`bilinear_u8`),
    and whether it has one. Each walk's points are read only up to its first off the mask (speedm2: the
    same values as reading them all)."""
    n = len(uv)
    v = np.empty(n, np.float32)
    nw = len(bounds) - 1
    idx = np.empty(nw)
    crosses = np.zeros(nw, np.bool_)
    half, tiny = np.float32(127.5), np.float32(1e-6)
    for i in range(nw):
        start, end = bounds[i], bounds[i + 1]
        first_off = end
        for j in range(start, end):
            v[j] = bilinear_u8(mask, np.float32(uv[j, 0]), np.float32(uv[j, 1]))
            if not v[j] >= half:
                first_off = j
                break
        crosses[i] = first_off < end and first_off > start
        if crosses[i]:
            k = max(first_off, start + 1)
            a, b = v[min(k - 1, n - 1)], v[min(k, n - 1)]
            frac = min(max((a - half) / max(a - b, tiny), np.float32(0.0)), np.float32(1.0))
            idx[i] = (k - 1 - start) + np.float64(frac)
        else:
            idx[i] = max(first_off - 1 - start, 0)
    return idx, crosses


@numba.njit(**_JIT)
def _interval_middle(mask, bx, by, ex, ey, start, stop, s_c, r_child, sin_t):
    """``ends.EndPlacer._interval_middle`` of ``_line_samples``' samples of one line ``(bx, by) + s (ex, ey)``:
    ``s`` is ``np.arange(start, stop, 1.0)`` (numpy's values: ``start + i * ((start + 1) - start)``), the
    mask read at each point by :func:`bilinear_u8` (``cv2.remap`` of the float32 points). Returns
    (found, middle)."""
    n = int(np.ceil(stop - start))
    if n < 2:
        return False, 0.0
    delta = (start + 1.0) - start
    ds = delta                                   # (s[1] - s[0])
    ic = int(np.rint((s_c - start) / ds))
    w = int(2 * r_child / sin_t / ds)
    lo_i, hi_i = max(ic - w, 0), min(ic + w + 1, n)
    if lo_i >= hi_i:
        return False, 0.0
    vals = np.full(n, -1.0)                      # (read when needed: each point's value is its own)

    def s_of(i):
        return start if i == 0 else start + 1.0 if i == 1 else start + i * delta
    c = min(max(ic, lo_i), hi_i - 1)
    k = -1
    for dd in range(max(c - lo_i, hi_i - 1 - c) + 1):
        for j in (c - dd, c + dd):               # nearest first, the lower side first
            if lo_i <= j < hi_i:
                if vals[j] < 0:
                    s = s_of(j)
                    vals[j] = bilinear_u8(mask, np.float32(bx + s * ex), np.float32(by + s * ey))
                if vals[j] >= 128:
                    k = j
                    break
        if k >= 0:
            break
    if k < 0:
        return False, 0.0
    a = k - 1
    while a >= 0:
        if vals[a] < 0:
            s = s_of(a)
            vals[a] = bilinear_u8(mask, np.float32(bx + s * ex), np.float32(by + s * ey))
        if vals[a] < 128:
            break
        a -= 1
    b = k + 1
    while b < n:
        if vals[b] < 0:
            s = s_of(b)
            vals[b] = bilinear_u8(mask, np.float32(bx + s * ex), np.float32(by + s * ey))
        if vals[b] < 128:
            break
        b += 1
    if a < 0 or b == n:
        return False, 0.0
    va, vb = vals[a], vals[b]
    lo = s_of(a) + ds * (128.0 - va) / max(vals[a + 1] - va, 1e-9)
    hi = s_of(b) - ds * (128.0 - vb) / max(vals[b - 1] - vb, 1e-9)
    if abs((hi - lo) * sin_t - 2 * r_child) > 0.8 * r_child + 2:
        return False, 0.0
    return True, 0.5 * (lo + hi)


@numba.njit(**_JIT)
def child_outline_pairs(mask, bases, s_c, e, reach, r_child, sin_t):
    """``ends.EndPlacer._fork_from_child_outline``'s scan of its two pairs of lines (``bases`` (4, 2),
    ``s_c`` (4,), direction ``e`` (2,), the samples ``s_c -/+ reach``): the first pair whose two
    interval middles are both found. Returns (pair index or -1, m1, m2)."""
    for i in range(2):
        ok1, m1 = _interval_middle(mask, bases[2 * i, 0], bases[2 * i, 1], e[0], e[1],
                                   s_c[2 * i] - reach, s_c[2 * i] + reach, s_c[2 * i], r_child, sin_t)
        if not ok1:
            continue
        ok2, m2 = _interval_middle(mask, bases[2 * i + 1, 0], bases[2 * i + 1, 1], e[0], e[1],
                                   s_c[2 * i + 1] - reach, s_c[2 * i + 1] + reach, s_c[2 * i + 1], r_child, sin_t)
        if ok2:
            return i, m1, m2
    return -1, 0.0, 0.0


@numba.njit(**_JIT)
def near_points(pts, px, py, lo, hi):
    """``ends.EndPlacer._near_points``' selection: the points ``pts`` (N, 2) whose distance (``np.hypot``)
    from (``px``, ``py``) lies in [``lo``, ``hi``], in order, and every point's distance (N,)."""
    n = len(pts)
    dist = np.empty(n)
    keep = np.zeros(n, np.bool_)
    m = 0
    for i in range(n):
        dist[i] = np.hypot(pts[i, 0] - px, pts[i, 1] - py)
        if dist[i] >= lo and dist[i] <= hi:
            keep[i] = True
            m += 1
    sel = np.empty((m, 2))
    j = 0
    for i in range(n):
        if keep[i]:
            sel[j, 0], sel[j, 1] = pts[i, 0], pts[i, 1]
            j += 1
    return sel, dist


@numba.njit(**_JIT)
def last_on(mask, starts, directions, s, n_s):
    """``tips._last_on``: where each line ``starts[k] + s directions[k]`` (float64 (K, 2); ``s`` (S,)
    float64, evenly spaced, whole or half values) last has ``mask`` (uint8) at or above 128, interpolated
    between samples (K,); NaN where the line starts off the mask or does not leave it within its first
    ``n_s[k]`` samples. The same values: the sample points in float32 (product, then sum), the reads
    :func:`bilinear_u8` (cv2.remap's), the crossing's fraction in float32 and its position in float64;
    each line read only up to its first sample off the mask."""
    n_lines = len(starts)
    out = np.empty(n_lines)
    step = s[1] - s[0]
    half, tiny = np.float32(127.5), np.float32(1e-6)
    for k in range(n_lines):
        sx, sy = np.float32(starts[k, 0]), np.float32(starts[k, 1])
        dx, dy = np.float32(directions[k, 0]), np.float32(directions[k, 1])
        first_off, prev, cur = -1, np.float32(0.0), np.float32(0.0)
        for j in range(n_s[k]):
            sj = np.float32(s[j])
            v = bilinear_u8(mask, sx + dx * sj, sy + dy * sj)
            if v < 128:
                first_off, cur = j, v
                break
            prev = v
        if first_off <= 0:
            out[k] = np.nan
        else:
            frac = (prev - half) / max(prev - cur, tiny)
            out[k] = s[first_off - 1] + float(frac) * step
    return out


@numba.njit(**_JIT)
def _crossing_at(row, t, i_off, i_on):
    """Where the coverage crosses 128 between samples ``i_off`` (off) and ``i_on`` (on) of ``row``
    (float32 values), in ``t`` (float64): ``forkalong._crossing``'s arithmetic, in float64."""
    v_off, v_on = np.float64(row[i_off]), np.float64(row[i_on])
    f = (v_on - 128.0) / max(v_on - v_off, 1e-9)
    return t[i_on] + f * (t[i_off] - t[i_on])


@numba.njit(**_JIT)
def _first_off(mask, row, bx, by, t, n, j0, j1, step):
    """The first ``j`` of ``range(j0, j1, step)`` whose sample ``(bx, by) + t[j] n`` (read into ``row[j]``)
    lies off ``mask`` (below 128); -1 when none does."""
    for j in range(j0, j1, step):
        row[j] = bilinear_u8(mask, np.float32(bx + t[j] * n[0]), np.float32(by + t[j] * n[1]))
        if not row[j] >= 128.0:
            return j
    return -1


@numba.njit(**_JIT)
def section_runs(mask, base, e, n, s, t, i0, gap_px):
    """``forkalong.sections``: per section ``s[i]`` (the samples ``base + s[i] e + t[j] n``, float64 (2,)
    vectors, ``t`` increasing with ``t[i0]`` its value nearest 0) the run through sample ``i0`` on ``mask``
    (uint8, at or above 128) and the next run beyond it. Returns ``ok``, ``lo``, ``hi``, ``child``, ``cl``,
    ``ch`` (S,) as ``sections``' dict: the run's ends and the further run's (sub-pixel crossings of 128, px
    along ``n``; NaN where none), the further run kept where it starts within ``gap_px`` of ``hi``. The same
    values: the sample points in float64 rounded to float32 (``_read``'s maps), the reads
    :func:`bilinear_u8` (cv2.remap's); each section read only from its first sample off the mask before
    ``i0`` to the further run's end, or to ``gap_px`` (+ 1) past the run's end where no further run starts
    within it."""
    ns, nt = len(s), len(t)
    ok = np.zeros(ns, np.bool_)
    child = np.zeros(ns, np.bool_)
    lo = np.full(ns, np.nan)
    hi = np.full(ns, np.nan)
    cl = np.full(ns, np.nan)
    ch = np.full(ns, np.nan)
    row = np.zeros(nt, np.float32)
    for i in range(ns):
        bx, by = base[0] + s[i] * e[0], base[1] + s[i] * e[1]
        row[i0] = bilinear_u8(mask, np.float32(bx + t[i0] * n[0]), np.float32(by + t[i0] * n[1]))
        if not row[i0] >= 128.0:
            continue
        lo_off = _first_off(mask, row, bx, by, t, n, i0 - 1, -1, -1)
        if lo_off < 0:
            continue
        hi_off = _first_off(mask, row, bx, by, t, n, i0 + 1, nt, 1)
        if hi_off < 0:
            continue
        ok[i] = True
        lo[i] = _crossing_at(row, t, lo_off, lo_off + 1)
        hi[i] = _crossing_at(row, t, hi_off, hi_off - 1)
        # the further run: its start's crossing lies past t[c_on - 1], so the scan stops where that is further
        # than gap_px (+ 1 px of margin for rounding) past hi: no run starting there could be kept
        c_on = nt
        far = hi[i] + gap_px + 1.0
        for j in range(hi_off + 1, nt):
            if t[j - 1] > far:
                break
            row[j] = bilinear_u8(mask, np.float32(bx + t[j] * n[0]), np.float32(by + t[j] * n[1]))
            if row[j] >= 128.0:
                c_on = j
                break
        if c_on >= nt:
            continue
        c_l = _crossing_at(row, t, c_on - 1, c_on)
        if not c_l - hi[i] <= gap_px:
            continue
        c_off = _first_off(mask, row, bx, by, t, n, c_on + 1, nt, 1)
        if c_off >= 0:
            child[i] = True
            cl[i] = c_l
            ch[i] = _crossing_at(row, t, c_off, c_off - 1)
    return ok, lo, hi, child, cl, ch


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    f = np.zeros(4)
    walk_edges(np.zeros((4, 4), np.uint8), np.zeros((2, 2)), np.array([0, 2], np.int64))
    child_outline_pairs(np.zeros((4, 4), np.uint8), np.zeros((4, 2)), f, f[:2], 5.0, 1.0, 1.0)
    near_points(_readonly(np.zeros((4, 2))), 0.0, 0.0, 1.0, 2.0)
    last_on(np.zeros((4, 4), np.uint8), np.zeros((1, 2)), np.zeros((1, 2)), np.arange(2.0), np.full(1, 2, np.int64))
    section_runs(np.zeros((4, 4), np.uint8), f[:2], f[:2], f[:2], f, f, 0, 1.0)
