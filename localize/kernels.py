"""Compiled loops (numba): for the match stage the per-piece fits, the run look-ups, the ends' walks
and the curves' evaluation; for the skeleton the thinning, corner removal and graph's pixel work;
for the colour recogniser the bark test of the tiles near bark by a lookup table (docs/localize-numba.md).

Each kernel replaces a stretch of small numpy calls (10-40 per piece or end, ~1-3 us each) by one
compiled loop over the pieces, queries or points: the same rules and, where the arithmetic allows,
the same values. Sums are numpy's pairwise sums (:func:`_pairwise`), so the power sums of the fits are
those of ``np.add.reduceat`` bit for bit; the small normal-equation systems are solved by Gaussian
elimination with partial pivoting instead of LAPACK's ``dgesv`` (equal up to rounding); the walks'
mask reads are OpenCV's bilinear values (:func:`bilinear_u8`).

Compiled on first use (~10 s for all of them) and cached on disk: under ``NUMBA_CACHE_DIR`` if set,
else beside this file in ``__pycache__``, else in the user's cache directory (``~/.cache/numba``);
later processes load the cache (~0.1 s). Where none is writable, in memory in each process
(:func:`_cacheable`).
"""

from __future__ import annotations

import warnings

import numba
import numpy as np

def _probe():
    """(A function of this file for :func:`_cacheable`.)"""


def _cacheable() -> bool:
    """Whether numba has a writable place for this file's compiled code (``NUMBA_CACHE_DIR``, else
    beside the file, else the user's cache directory). Where it has none (a read-only install, an
    unwritable home) ``cache=True`` would raise at import: the kernels then compile in memory in each
    process (~10 s on first use), with a warning."""
    try:
        numba.njit(cache=True)(_probe)
        return True
    except RuntimeError:
        warnings.warn(f"numba has no writable cache directory for {__file__} (set NUMBA_CACHE_DIR to one): "
                      "the localizer's kernels compile in memory in each process (~10 s on first use)",
                      RuntimeWarning, stacklevel=2)
        return False


_JIT = dict(cache=_cacheable(), nogil=True)


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


@numba.njit(**_JIT)
def _fit_one(t, y, degree, coef, last):
    """``curves.fit_groups`` of one group's samples ``t``, ``y`` (n,) into ``coef`` (4,) (highest power
    first, zero-padded); returns (t0, ts, degree used). The power sums are numpy's ``fit_groups``' bit
    for bit (the ``last`` group's sums, as its ``reduceat`` segment, end with a padding zero);
    degrees 2 and 3 solved by Gaussian elimination with partial pivoting (LAPACK's up to rounding)."""
    n = len(t)
    e = n + 1 if last else n            # summed length (the padding sample: zeros)
    coef[:] = 0.0
    if n == 0:                          # (meaningless, as fit_groups' empty groups)
        return 0.0, 1.0, 0
    deg = degree
    if deg > 0:
        increasing = True
        for i in range(1, n):
            if not t[i] > t[i - 1]:
                increasing = False
                break
        if not increasing:              # distinct values limit the degree
            st = _sorted(t)
            distinct = 1
            for i in range(1, n):
                if st[i] != st[i - 1]:
                    distinct += 1
            deg = min(deg, distinct - 1)
    deg = max(min(deg, n - 1), 0)
    if last:
        tp = np.zeros(e)
        tp[:n] = t
        t0 = _segment_sum(tp, 0, e) / n
    else:
        t0 = _segment_sum(t, 0, n) / n
    t_lo, t_hi = t[0], t[0]
    for i in range(1, n):
        t_lo = min(t_lo, t[i])
        t_hi = max(t_hi, t[i])
    ts = max(max(t_hi - t0, t0 - t_lo), 1.0)
    sy0 = 2 * deg + 1
    p = np.empty((3 * deg + 2, e))      # rows x^0 .. x^2deg, y x^0 .. y x^deg (as fit_groups)
    if last:
        p[:, n] = 0.0
    for i in range(n):
        p[1, i] = (t[i] - t0) / ts
        p[sy0, i] = y[i]                # (y x^0: 1.0 * y)
    for k in range(2, 2 * deg + 1):
        for i in range(n):
            p[k, i] = p[k - 1, i] * p[1, i]
    for k in range(1, deg + 1):
        for i in range(n):
            p[sy0 + k, i] = p[k, i] * y[i]
    s = np.empty(3 * deg + 2)
    s[0] = float(n)                     # (a sum of ones: exact)
    for k in range(1, 3 * deg + 2):
        s[k] = _segment_sum(p[k], 0, e)
    if deg == 0:
        coef[3] = s[sy0] / n
        return t0, ts, deg
    if deg == 1:
        nn, sx, sy, sxx, sxy = float(n), s[1], s[sy0], s[2], s[sy0 + 1]
        det = nn * sxx - sx * sx
        coef[2] = (nn * sxy - sx * sy) / det
        coef[3] = (sxx * sy - sx * sxy) / det
        return t0, ts, deg
    m = deg + 1                         # normal equations a c = b (c highest power first)
    a = np.empty((m, m))
    b = np.empty(m)
    for i in range(m):
        for j in range(m):
            a[i, j] = s[2 * deg - i - j]
        b[i] = s[sy0 + deg - i]
    for j in range(m):                  # elimination with partial pivoting
        piv = j
        for i in range(j + 1, m):
            if abs(a[i, j]) > abs(a[piv, j]):
                piv = i
        if piv != j:
            for c in range(m):
                a[j, c], a[piv, c] = a[piv, c], a[j, c]
            b[j], b[piv] = b[piv], b[j]
        for i in range(j + 1, m):
            f = a[i, j] / a[j, j]
            for c in range(j + 1, m):
                a[i, c] -= f * a[j, c]
            b[i] -= f * b[j]
    for i in range(m - 1, -1, -1):
        v = b[i]
        for c in range(i + 1, m):
            v -= a[i, c] * b[c]
        b[i] = v / a[i, i]
    for i in range(m):
        coef[4 - m + i] = b[i]
    return t0, ts, deg


@numba.njit(**_JIT)
def _group_polys(ng):
    """Empty per-group polynomials: coef (G, 4) zeros, t0 (G,) zeros, ts (G,) ones, degree (G,) int64 zeros."""
    return np.zeros((ng, 4)), np.zeros(ng), np.ones(ng), np.zeros(ng, np.int64)


@numba.njit(**_JIT)
def fit_groups(t, y, starts, degree):
    """``curves.fit_groups`` of every group (group k: samples ``starts[k]:starts[k + 1]``).

    Returns coef (G, 4), t0 (G,), ts (G,), degree (G,) int64."""
    ng = len(starts) - 1
    coef, t0, ts, deg = _group_polys(ng)
    for k in range(ng):
        a, b = starts[k], starts[k + 1]
        t0[k], ts[k], deg[k] = _fit_one(t[a:b], y[a:b], degree[k], coef[k], k == ng - 1)
    return coef, t0, ts, deg


@numba.njit(**_JIT)
def robust_fit_groups(t, y, starts, degree, rounds, k_mad):
    """``curves.robust_fit_groups``: per group (samples ``starts[k]:starts[k + 1]``, ``rounds[k]``
    rounds) a least-squares polynomial refitted without residuals beyond ``k_mad`` MADs.

    Returns coef (G, 4), t0 (G,), ts (G,), degree (G,) int64, inliers bool (N,)."""
    ng = len(starts) - 1
    coef, t0, ts, deg = _group_polys(ng)
    keep = np.ones(len(t), np.bool_)
    trial = np.zeros(4)
    for k in range(ng):
        a, b = starts[k], starts[k + 1]
        n = b - a
        tk, yk, kk = t[a:b], y[a:b], keep[a:b]
        t0[k], ts[k], deg[k] = _fit_one(tk, yk, degree[k], coef[k], k == ng - 1)
        if n == 0:
            continue
        res = np.empty(n)
        new = np.empty(n, np.bool_)
        for _ in range(rounds[k]):
            c0, c1, c2, c3 = coef[k, 0], coef[k, 1], coef[k, 2], coef[k, 3]
            nk = 0
            for i in range(n):          # residuals (GroupPolys' Horner over the padded coefficients)
                x = (tk[i] - t0[k]) / ts[k]
                res[i] = yk[i] - (((x * c0 + c1) * x + c2) * x + c3)
                if kk[i]:
                    nk += 1
            r = np.empty(nk)
            j = 0
            for i in range(n):
                if kk[i]:
                    r[j] = res[i]
                    j += 1
            med = _median(r)
            for i in range(nk):
                r[i] = abs(r[i] - med)
            thr = k_mad * (1.4826 * _median(r) + 1e-3) + 0.05
            count = 0
            changed = False
            for i in range(n):
                new[i] = abs(res[i]) <= thr
                count += new[i]
                changed |= new[i] != kk[i]
            if not (count > degree[k] + 1 and changed):
                break
            kk[:] = new
            ts_, ys_ = np.empty(count), np.empty(count)
            j = 0
            for i in range(n):
                if new[i]:
                    ts_[j], ys_[j] = tk[i], yk[i]
                    j += 1
            t0[k], ts[k], deg[k] = _fit_one(ts_, ys_, degree[k], trial, k == ng - 1)
            coef[k] = trial
    return coef, t0, ts, deg, keep


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
def consensus_lines(t, d, bounds, live, ij, tol_px):
    """``dense._consensus_lines``: per live piece ``live[m]`` (candidates ``bounds[k]:bounds[k + 1]``)
    the line d(t) through the most candidates among the hypotheses ``ij[:, m]`` (pairs of candidate
    indices; pairs less than 3 rows apart do not count), fitted to its inliers (:func:`fit_groups`
    of degree 1); without a pair 3 rows apart, the candidates' median. Other pieces: a constant 0.

    Returns coef (G, 4), t0 (G,), ts (G,), degree (G,) int64."""
    ng = len(bounds) - 1
    coef, t0, ts, deg = _group_polys(ng)
    n_hyp = ij.shape[2]
    for m in range(len(live)):
        k = live[m]
        lo, hi = bounds[k], bounds[k + 1]
        best, best_count = -1, -2
        for h in range(n_hyp):
            i, j = ij[0, m, h], ij[1, m, h]
            dt = t[j] - t[i]
            if not abs(dt) >= 3:
                if best_count < -1:
                    best, best_count = h, -1
                continue
            slope = (d[j] - d[i]) / dt
            count = 0
            for s in range(lo, hi):
                if abs(d[s] - ((t[s] - t[i]) * slope + d[i])) <= tol_px:
                    count += 1
            if count > best_count:
                best, best_count = h, count
        if best_count < 0:              # no pair 3 rows apart: the median
            coef[k, 3] = _median(d[lo:hi])
            continue
        i, j = ij[0, m, best], ij[1, m, best]
        slope = (d[j] - d[i]) / (t[j] - t[i])
        tk = np.empty(best_count)
        dk = np.empty(best_count)
        c = 0
        for s in range(lo, hi):
            if abs(d[s] - ((t[s] - t[i]) * slope + d[i])) <= tol_px:
                tk[c], dk[c] = t[s], d[s]
                c += 1
        t0[k], ts[k], deg[k] = _fit_one(tk, dk, 1, coef[k], m == len(live) - 1)
    return coef, t0, ts, deg


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
    p = np.zeros(4, np.float32)
    for k in range(4):
        yy, xx = y0 + k // 2, x0 + k % 2
        if 0 <= yy < h and 0 <= xx < w:
            p[k] = np.float32(img[yy, xx])
    top = _fma32(a, p[1] - p[0], p[0])
    bottom = _fma32(a, p[3] - p[2], p[2])
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
def _horner(c, x):
    """``Poly.at``'s sum of coefficients ``c`` (highest power first) at the scaled parameter ``x``."""
    if len(c) == 1:
        return c[0]
    y = x * c[0] + c[1]
    for k in range(2, len(c)):
        y = y * x + c[k]
    return y


@numba.njit(**_JIT)
def eval_clamped(coef, dcoef, t0, ts, lo, hi, slopes, own_slopes, t):
    """``curves.BranchCurve._eval`` of a :class:`curves.Poly` (coefficients ``coef``, its derivative's
    ``dcoef``, scaling ``t0``, ``ts``) at parameters ``t`` (N >= 2,): the polynomial inside the span
    [lo, hi], beyond it the value at the span's end plus the slope (the derivative's there when
    ``own_slopes``, else ``slopes`` (2,)) times the distance; the same sums as ``_eval``'s numpy paths."""
    n = len(t)
    out = np.empty(n)
    mn, mx = np.inf, -np.inf
    nan = False
    for i in range(n):
        if np.isnan(t[i]):
            nan = True
        mn = min(mn, t[i])
        mx = max(mx, t[i])
    if not nan and mn >= lo and mx <= hi:          # inside: the polynomial (Poly.__call__)
        for i in range(n):
            out[i] = _horner(coef, (t[i] - t0) / ts)
        return out
    s_lo = _horner(dcoef, (lo - t0) / ts) if own_slopes else slopes[0]
    s_hi = _horner(dcoef, (hi - t0) / ts) if own_slopes else slopes[1]
    if not nan and mn >= hi:                       # all beyond the high end
        v = _horner(coef, (hi - t0) / ts)
        for i in range(n):
            out[i] = v + s_hi * (t[i] - hi)
        return out
    if not nan and mx <= lo:
        v = _horner(coef, (lo - t0) / ts)
        for i in range(n):
            out[i] = v + s_lo * (t[i] - lo)
        return out
    for i in range(n):                             # the general path: clamped, carried on beyond
        if np.isnan(t[i]):
            out[i] = np.nan
            continue
        tc = min(max(t[i], lo), hi)
        out[i] = _horner(coef, (tc - t0) / ts) + (s_lo if t[i] < lo else s_hi) * (t[i] - tc)
    return out


@numba.njit(**_JIT)
def _code(flat, p, off):
    """Neighbour code of the padded flat pixel ``p``: bit k = neighbour k (``off[k]`` away) set."""
    c = 0
    for k in range(8):
        if flat[np.uint64(p + off[k])] != 0:        # (unsigned: numba drops its negative-index test)
            c |= 1 << k
    return c


@numba.njit(**_JIT)
def zhang_suen_flat(flat, live, start, off, tab0, tab1):
    """Zhang-Suen thinning in place on a zero-padded flat 0/1 image (``skeleton.zhang_suen``'s loop).

    ``live`` (uint8, same size; modified): the pixels that may still go; ``start``: the first
    sub-iteration's candidates (flat indices); ``off`` (8,): flat steps to the neighbours; ``tab0`` /
    ``tab1`` (256,) bool: the sub-iterations' deletion tables. Each sub-iteration decides on the image
    as the previous one left it, then deletes; later candidates are the live pixels next to a deletion
    in the last two sub-iterations; stops after two sub-iterations without a deletion. Returns the
    number of sub-iterations.
    """
    n = flat.size
    near = (np.empty(n, np.int64), np.empty(n, np.int64))
    n_near = np.zeros(2, np.int64)
    for k in range(len(start)):
        near[0][k] = start[k]
        near[1][k] = start[k]
    n_near[0] = n_near[1] = len(start)
    seen = np.full(n, -1, np.int64)
    cand = np.empty(n, np.int64)
    gone = np.empty(n, np.int64)
    i, quiet = 0, 0
    while quiet < 2:
        nc = 0
        if i == 0:
            for k in range(len(start)):
                cand[nc] = start[k]
                nc += 1
        else:
            for par in range(2):
                lst = near[par]
                for k in range(n_near[par]):
                    p = lst[k]
                    if live[p] != 0 and seen[p] != i:
                        seen[p] = i
                        cand[nc] = p
                        nc += 1
        tab = tab0 if (i & 1) == 0 else tab1
        ng = 0
        for k in range(nc):
            p = cand[k]
            if tab[_code(flat, p, off)]:
                gone[ng] = p
                ng += 1
        for k in range(ng):
            flat[gone[k]] = 0
            live[gone[k]] = 0
        lst = near[i & 1]
        m = 0
        for k in range(ng):
            for j in range(8):
                q = gone[k] + off[j]
                if live[q] != 0 and seen[q] != -2 - i:      # (each neighbour once per list)
                    seen[q] = -2 - i
                    lst[m] = q
                    m += 1
        n_near[i & 1] = m
        quiet = 0 if ng else quiet + 1
        i += 1
    return i


@numba.njit(**_JIT)
def remove_corners_flat(flat, idx, w2, corner):
    """``skeleton.remove_corners``' two passes in place on a zero-padded flat 0/1 image of row length
    ``w2``: the set pixels ``idx`` (row-major flat indices) of parity 0, then of parity 1, each pass
    deciding on the image as the previous pass left it (all its pixels first, then the deletions)."""
    off = np.array([-w2, -w2 + 1, 1, w2 + 1, w2, w2 - 1, -1, -w2 - 1], np.int64)
    gone = np.empty(len(idx), np.int64)
    for par in range(2):
        ng = 0
        for k in range(len(idx)):
            p = idx[k]
            if ((p // w2 + p % w2) & 1) == par and corner[_code(flat, p, off)]:
                gone[ng] = p
                ng += 1
        for k in range(ng):
            flat[gone[k]] = 0


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
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(**_JIT)
def _components(idx, pos, on, w2, w):
    """8-connected components of the pixels ``idx[on]`` (``idx``: row-major flat indices into a
    zero-padded image of row length ``w2``): labels 1..n per pixel (0 where not ``on``) numbered as
    ``cv2.connectedComponents`` numbers them, by the first 2 x 2 block of each (blocks row-major; the
    block-based scan's order, checked on random images), and n. ``pos``: each flat pixel's index into
    ``idx``, -1 where none."""
    m = len(idx)
    parent = np.arange(m)
    for i in range(m):
        if not on[i]:
            continue
        p = idx[i]
        for q in (p - 1, p - w2 - 1, p - w2, p - w2 + 1):        # (neighbours scanned before p)
            j = pos[q]
            if j >= 0 and on[j]:
                a, b = _find(parent, i), _find(parent, j)
                if a != b:
                    parent[max(a, b)] = min(a, b)
    wb = (w + 1) // 2
    first = np.full(m, np.iinfo(np.int64).max)
    n_roots = 0
    for i in range(m):
        if on[i]:
            r = _find(parent, i)
            y, x = idx[i] // w2 - 1, idx[i] % w2 - 1
            first[r] = min(first[r], (y // 2) * wb + x // 2)
            n_roots += parent[i] == i
    key = np.empty(n_roots, np.int64)                          # (first block, root) in one sortable key
    c = 0
    for i in range(m):
        if on[i] and parent[i] == i:
            key[c] = first[i] * m + i
            c += 1
    key = _sorted(key)                                         # (not np.argsort: its compile time)
    rank = np.zeros(m, np.int64)
    for k in range(n_roots):
        rank[key[k] % m] = k + 1
    lab = np.zeros(m, np.int64)
    for i in range(m):
        if on[i]:
            lab[i] = rank[_find(parent, i)]
    return lab, n_roots


@numba.njit(**_JIT)
def _unique_pairs(a, b, n):
    """Distinct pairs (a[k], b[k]) of the first ``n``, sorted, as (K, 2) int64."""
    key = np.empty(n, np.int64)
    for k in range(n):
        key[k] = (a[k] << 32) | b[k]
    key = _sorted(key)
    out = np.empty((n, 2), np.int64)
    c = 0
    for k in range(n):
        if k == 0 or key[k] != key[k - 1]:
            out[c, 0], out[c, 1] = key[k] >> 32, key[k] & 0xFFFFFFFF
            c += 1
    return out[:c]


@numba.njit(**_JIT)
def graph_core(flat, idx, w2, w, count):
    """``graph.build_graph``'s pixel work on a zero-padded flat 0/1 skeleton (row length ``w2``, image
    width ``w``; ``idx`` its set pixels, row-major): each pixel's neighbour count (``count`` table), the
    junction (>= 3) and path (2) pixels' 8-connected component labels (as ``cv2.connectedComponents``
    numbers them), the segment-node contacts (segment, node) and node-node contacts (node, node),
    1-based, distinct and sorted, and per segment the steps to its E, SE, S, SW neighbours (4, S + 1).
    Node ids: junctions 1..J by label, then the endpoints (1 neighbour) in row-major order."""
    m = len(idx)
    off = np.array([-w2, -w2 + 1, 1, w2 + 1, w2, w2 - 1, -1, -w2 - 1], np.int64)
    pos = np.full(len(flat), -1, np.int32)
    for i in range(m):
        pos[idx[i]] = i
    n = np.empty(m, np.int64)
    for i in range(m):
        c = 0
        for k in range(8):
            if flat[idx[i] + off[k]] != 0:
                c |= 1 << k
        n[i] = count[c]
    jlab, n_j = _components(idx, pos, n >= 3, w2, w)
    slab, n_s = _components(idx, pos, n == 2, w2, w)
    node = jlab.copy()
    e = n_j
    for i in range(m):
        if n[i] == 1:
            e += 1
            node[i] = e
    ps, pn, c = np.empty(8 * m, np.int64), np.empty(8 * m, np.int64), 0
    steps = np.zeros((4, n_s + 1), np.int64)
    for i in range(m):
        if n[i] != 2:
            continue
        for k in range(8):
            j = pos[idx[i] + off[k]]
            if j >= 0:
                if node[j] > 0:
                    ps[c], pn[c] = slab[i], node[j]
                    c += 1
                if 2 <= k <= 5 and slab[j] == slab[i]:
                    steps[k - 2, slab[i]] += 1
    sn = _unique_pairs(ps, pn, c)
    a, b, c = np.empty(8 * m, np.int64), np.empty(8 * m, np.int64), 0
    for i in range(m):
        if node[i] == 0:
            continue
        for k in range(8):
            j = pos[idx[i] + off[k]]
            if j >= 0 and node[j] > 0 and node[j] != node[i]:
                a[c], b[c] = min(node[i], node[j]), max(node[i], node[j])
                c += 1
    return n, jlab, n_j, slab, n_s, sn, _unique_pairs(a, b, c), steps


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def warm_up() -> None:
    """Compile (or load from the disk cache) every kernel for the argument types the localizer
    passes, on tiny inputs: ~10 s the first time without a cache, ~0.1 s from the cache, then
    nothing. :class:`~appliance.localize.Localizer` calls it when built, so that no frame waits
    for a compile (a live stream, a worker process)."""
    f, i = np.zeros(4), np.arange(4, dtype=np.int64)
    bounds = np.array([0, 4], np.int64)
    fit_groups(np.arange(4.0), f, bounds, np.ones(1, np.int64))
    robust_fit_groups(np.arange(4.0), f, bounds, np.ones(1, np.int64), np.ones(1, np.int64), 3.5)
    consensus_lines(np.arange(4.0), f, bounds, np.zeros(1, np.int64), np.zeros((2, 1, 2), np.int64), 1.5)
    runs_find(_readonly(i.copy()), _readonly(i.copy()), _readonly(i.copy()), 4, i, f)
    runs_between(_readonly(f.copy()), i, 4, f, f)
    walk_edges(np.zeros((4, 4), np.uint8), np.zeros((2, 2)), np.array([0, 2], np.int64))
    child_outline_pairs(np.zeros((4, 4), np.uint8), np.zeros((4, 2)), f, f[:2], 5.0, 1.0, 1.0)
    near_points(_readonly(np.zeros((4, 2))), 0.0, 0.0, 1.0, 2.0)
    eval_clamped(f[:2], f[:1], 0.0, 1.0, 0.0, 1.0, f[:2], True, np.arange(4.0))
    img, tab = np.zeros(16, np.uint8), np.zeros(256, bool)
    off = np.array([-4, -3, 1, 5, 4, 3, -1, -5], np.int64)
    zhang_suen_flat(img, img.copy(), i[:0], off, tab, tab)
    remove_corners_flat(img, i[:0], 4, tab)
    graph_core(np.zeros(16, np.uint8), i[:0], 4, 2, np.zeros(256, np.uint8))
    unmix_blocks(np.zeros((4, 4, 3), np.uint8), np.zeros((4, 4), np.uint8), i[:1], np.zeros((1, 1), np.float32),
                 np.zeros((1, 1, 3), np.float32), np.zeros(3, np.float32), 0.0025, 4, np.zeros((4, 4), np.uint8))
    _warm_match()
    _warm_match2()
    _warm_segment()
    from appliance.localize import kernels_tips      # (the tips' kernels, speedT: that module imports this one)
    kernels_tips.warm_up()
    from appliance.localize import kernels_forks        # (imports this module)
    kernels_forks.warm_up()
    from appliance.localize import kernels_dense     # (its own module: it imports this one)
    kernels_dense.warm_up()
    from appliance.localize import kernels_front     # (the front stages' kernels, speed02: imports this one)
    kernels_front.warm_up()
    from appliance.localize import kernels_check     # (the feature check's kernel, speedG: imports this one)
    kernels_check.warm_up()
    from appliance.localize import kernels_match    # (the match stage's, ninth pass: imports this one)
    kernels_match.warm_up()
    from appliance.localize import kernels_graph    # (rectify and graph kernels, speedR: imports this one)
    kernels_graph.warm_up()
    from appliance.localize import kernels_segment  # (the segment stage's, tenth pass: imports this one)
    kernels_segment.warm_up()
    from appliance.localize import kernels_forkglue  # (the fork and tip glue's, speedfork: imports this one)
    kernels_forkglue.warm_up()
    from appliance.localize import kernels_refine   # (refine_runs' glue, twelfth pass: imports this one)
    kernels_refine.warm_up()
    from appliance.localize import kernels_segclean  # (the segment stage's clean-up, twelfth pass: imports this one)
    kernels_segclean.warm_up()
    __import__("appliance.localize.kernels_patchshare", fromlist=["warm_up"]).warm_up()  # (gross19b: imports this one)


# --- match stage (speedm)


@numba.njit(**_JIT)
def _patch_sums(img, y0, nh, x0, nw):
    """Sum, sum of squares, minimum and maximum of the patch ``img[y0:y0 + nh, x0:x0 + nw]`` (float64:
    exact for uint8 images)."""
    s, s2, lo, hi = 0.0, 0.0, np.inf, -np.inf
    for r in range(nh):
        for j in range(nw):
            v = float(img[y0 + r, x0 + j])
            s += v
            s2 += v * v
            lo = min(lo, v)
            hi = max(hi, v)
    return s, s2, lo, hi


@numba.njit(**_JIT)
def _is_flat(s, s2, lo, hi, m, min_std):
    """``texture._flat`` from a patch's sums (``m`` pixels): the range settles it where it can, else the
    standard deviation (exact for uint8 patches; numpy's rounded one could differ only at exactly
    ``min_std``)."""
    r = hi - lo
    if r < 2 * min_std:
        return True
    if r * r > 2.02 * m * min_std * min_std:
        return False
    return m * s2 - s * s < min_std * min_std * m * m


@numba.njit(**_JIT)
def _ncc_row(left, right, y0, nh, lx0, nw, rx0, n_pos, st, st2, acc, buf, cs, cs2, out):
    """``cv2.matchTemplate(strip, tmpl, TM_CCOEFF_NORMED)[0]`` into ``out[:n_pos]`` for the uint8 template
    ``left[y0:y0 + nh, lx0:lx0 + nw]`` (sums ``st``, ``st2``) and the strip ``right[y0:y0 + nh, rx0:rx0 +
    n_pos + nw - 1]``. Every sum is exact (integers: the products summed in int32 for patches up to
    32 761 px (< 2^31), in float64 above), so the score is the correctly computed one; OpenCV's float32
    correlation (by DFT) is off by up to ~5e-4. A window without variance scores 0 (as OpenCV). ``acc``
    (int32), ``buf`` (int32), ``cs``, ``cs2`` (float): scratch of >= n_pos + nw."""
    m = float(nh * nw)
    sw = n_pos + nw - 1
    wide = nh * nw > 32761             # (int32 sums could overflow: float64, exact below 2^53)
    accf = np.zeros(n_pos if wide else 0)
    for p in range(n_pos):
        acc[p] = 0
    for x in range(sw):
        cs[x] = 0.0
        cs2[x] = 0.0
    for r in range(nh):
        lrow = left[y0 + r]
        rrow = right[y0 + r]
        for x in range(sw):
            v = np.int32(rrow[rx0 + x])
            buf[x] = v
            cs[x] += v
            cs2[x] += v * v
        for j in range(nw):             # (contiguous int32 rows: vectorised over the positions)
            t = np.int32(lrow[lx0 + j])
            b = buf[j:j + n_pos]
            if wide:
                for p in range(n_pos):
                    accf[p] += t * b[p]
            else:
                for p in range(n_pos):
                    acc[p] += t * b[p]
    vt = m * st2 - st * st
    s1, s2 = 0.0, 0.0
    for x in range(nw - 1):
        s1 += cs[x]
        s2 += cs2[x]
    for p in range(n_pos):
        s1 += cs[p + nw - 1]
        s2 += cs2[p + nw - 1]
        if p > 0:
            s1 -= cs[p - 1]
            s2 -= cs2[p - 1]
        vs = m * s2 - s1 * s1
        if vs <= 0.0 or vt <= 0.0:
            out[p] = 0.0
        else:
            c = (m * (accf[p] if wide else float(acc[p])) - st * s1) / np.sqrt(vt * vs)
            out[p] = min(max(c, -1.0), 1.0)


@numba.njit(**_JIT)
def _strip_buffers(sx0, sx1):
    """Work arrays of :func:`_strip_scores` for strips ``sx0[i]:sx1[i]``: acc, buf (int32) and cs, cs2, c."""
    big = 0
    for i in range(len(sx0)):
        big = max(big, sx1[i] - sx0[i])
    return (np.empty(big + 1, np.int32), np.empty(big + 1, np.int32), np.empty(big + 1), np.empty(big + 1),
            np.empty(big + 1))


@numba.njit(**_JIT)
def _strip_scores(left, right, y0, nh, lx0, nw, sx0, sx1, min_std, acc, buf, cs, cs2, c):
    """One patch's (``left[y0:y0 + nh, lx0:lx0 + nw]``) TM_CCOEFF_NORMED scores along the strip of ``right``
    from column ``sx0`` to ``sx1`` written into ``c``; returns their count, 0 for a flat patch
    (``texture._flat`` with ``min_std``) or a strip of fewer than 3 positions."""
    st, st2, lo, hi = _patch_sums(left, y0, nh, lx0, nw)
    if _is_flat(st, st2, lo, hi, nh * nw, min_std):
        return 0
    n_pos = sx1 - sx0 - nw + 1
    if n_pos < 3:
        return 0
    _ncc_row(left, right, y0, nh, lx0, nw, sx0, n_pos, st, st2, acc, buf, cs, cs2, c)
    return n_pos


@numba.njit(**_JIT)
def _peak(c, n_pos):
    """The first position ``k`` of the highest of ``c[:n_pos]`` and the offset of the parabola through it and
    its neighbours (0 at the strip's ends or where the parabola does not open downwards)."""
    k = 0
    for p in range(1, n_pos):
        if c[p] > c[k]:
            k = p
    off = 0.0
    if 0 < k < n_pos - 1:
        denom = c[k - 1] - 2 * c[k] + c[k + 1]
        if denom < 0:
            off = 0.5 * (c[k - 1] - c[k + 1]) / denom
    return k, off


@numba.njit(**_JIT)
def ncc_peaks(left, right, ty, tx, hh, hw, sx0, sx1, min_std):
    """``texture._search``'s one-by-one loop: for each patch ``i`` (centre ``(tx[i], ty[i])`` in ``left``,
    half height ``hh[i]``, half width ``hw``) not flat (``texture._flat`` with ``min_std``), its
    TM_CCOEFF_NORMED scores along the strip ``right[ty - hh:ty + hh + 1, sx0[i]:sx1[i]]`` (at least 3
    positions), the best position and the parabola's offset through it and its neighbours.

    Returns ok (N,) bool (False: flat, or a strip too short), k (N,) int64, off (N,), score (N,)."""
    n = len(ty)
    nw = 2 * hw + 1
    ok = np.zeros(n, np.bool_)
    ks = np.zeros(n, np.int64)
    offs = np.zeros(n)
    best = np.full(n, -1.0)
    acc, buf, cs, cs2, c = _strip_buffers(sx0, sx1)
    for i in range(n):
        n_pos = _strip_scores(left, right, ty[i] - hh[i], 2 * hh[i] + 1, tx[i] - hw, nw, sx0[i], sx1[i], min_std,
                              acc, buf, cs, cs2, c)
        if n_pos == 0:
            continue
        k, off = _peak(c, n_pos)
        ok[i], ks[i], offs[i], best[i] = True, k, off, c[k]
    return ok, ks, offs, best


@numba.njit(**_JIT)
def ncc_search(lbox, rbox, uv, hh, hw, lo, hi, h, w, by0, lx0, rx0, d_out, score):
    """``texture._search`` of uint8 images in one call: the patches centred on ``uv`` (N, 2) int (half
    heights ``hh`` (N,), half width ``hw``) that lie inside the image (H ``h``, W ``w``) searched over
    disparities ``lo``..``hi`` along their strips (:func:`ncc_peaks`) in the boxes ``lbox`` / ``rbox`` read
    at rows from ``by0`` and columns from ``lx0`` / ``rx0``; each found patch's disparity and score
    written into ``d_out``, ``score`` (N,) (the same values as the Python steps: ``u - (xs + k + off +
    hw)``)."""
    n = len(uv)
    idx = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        u, v, r = uv[i, 0], uv[i, 1], hh[i]
        if v - r >= 0 and v + r + 1 <= h and u - hw >= 0 and u + hw + 1 <= w and u - lo + hw + 1 > 0:
            idx[m] = i
            m += 1
    ty, tx, hs = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m, np.int64)
    sx0, sx1 = np.empty(m, np.int64), np.empty(m, np.int64)
    for j in range(m):
        i = idx[j]
        u = uv[i, 0]
        ty[j], tx[j], hs[j] = uv[i, 1] - by0, u - lx0, hh[i]
        sx0[j] = max(u - hi - hw, 0) - rx0
        sx1[j] = min(u - lo + hw + 1, w) - rx0
    ok, ks, offs, best = ncc_peaks(lbox, rbox, ty, tx, hs, hw, sx0, sx1, 1.0)
    for j in range(m):
        if ok[j]:
            i = idx[j]
            xs = max(uv[i, 0] - hi - hw, 0)
            d_out[i] = uv[i, 0] - ((xs + ks[j]) + offs[j] + hw)
            score[i] = best[j]


@numba.njit(**_JIT)
def ncc_scores(strip, tmpl):
    """``cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]`` of a uint8 template and a strip of its
    height (float64, exact sums: :func:`_ncc_row`; a constant template scores 1 everywhere, as OpenCV)."""
    nh, nw = tmpl.shape
    n_pos = strip.shape[1] - nw + 1
    out = np.empty(max(n_pos, 0))
    if n_pos <= 0:
        return out
    st, st2, lo, hi = _patch_sums(tmpl, 0, nh, 0, nw)
    if lo == hi:
        out[:] = 1.0
        return out
    big = strip.shape[1] + 1
    _ncc_row(tmpl, strip, 0, nh, 0, nw, 0, n_pos, st, st2, np.empty(big, np.int32), np.empty(big, np.int32),
             np.empty(big), np.empty(big), out)
    return out


@numba.njit(**_JIT)
def masked_sqdiff(strip, patch, weight):
    """``cv2.matchTemplate(strip, patch, cv2.TM_SQDIFF, mask=weight)[0]`` of a uint8 patch (h, w) with 0/1
    weights (h, w) along a uint8 strip of its height: each position's sum of the weighted squared
    differences, exact (integers), where OpenCV's float32 correlations (by DFT) carry rounding of
    ~1e-6 of the terms' sums."""
    nh, nw = patch.shape
    n_pos = strip.shape[1] - nw + 1
    out = np.zeros(max(n_pos, 0))
    acc = np.zeros(max(n_pos, 0), np.int64)
    for r in range(nh):
        srow = strip[r]
        for j in range(nw):
            if weight[r, j] == 0:
                continue
            t = np.int64(patch[r, j])
            for p in range(n_pos):
                e = np.int64(srow[j + p]) - t
                acc[p] += e * e
    for p in range(n_pos):
        out[p] = float(acc[p])
    return out


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


@numba.njit(**_JIT)
def line_vote(cand_t, cand_d, slopes, tm, tol_px):
    """``single_edge.edge_consensus``' vote: for each slope ``slopes[s]`` the offsets ``cand_d - slopes[s] *
    (cand_t - tm)`` of the lines through the candidates (C,), in bins of ``tol_px`` from the lowest
    offset ``lo`` over all slopes; the best window of two neighbouring bins (row-major first maximum of
    the (S, nb - 1) window counts, as numpy's argmax). The same values as the numpy steps (the offsets
    recomputed in the same two roundings instead of stored). Returns (lo, k_s, k_b)."""
    n_s, n_c = len(slopes), len(cand_t)
    dt = np.empty(n_c)
    for c in range(n_c):
        dt[c] = cand_t[c] - tm
    lo = np.inf
    for s in range(n_s):
        for c in range(n_c):
            lo = min(lo, cand_d[c] - slopes[s] * dt[c])
    top = 0
    bins = np.empty((n_s, n_c), np.int64)
    for s in range(n_s):
        for c in range(n_c):
            b = np.int64(((cand_d[c] - slopes[s] * dt[c]) - lo) / tol_px)
            bins[s, c] = b
            top = max(top, b)
    nb = top + 2
    votes = np.zeros((n_s, nb), np.int64)
    for s in range(n_s):
        for c in range(n_c):
            votes[s, bins[s, c]] += 1
    best, k_s, k_b = -1, 0, 0
    for s in range(n_s):
        for b in range(nb - 1):
            v = votes[s, b] + votes[s, b + 1]
            if v > best:
                best, k_s, k_b = v, s, b
    return lo, k_s, k_b


@numba.njit(**_JIT)
def centre_line(t, s, half):
    """``single_edge.centre_guess``'s values where the positions ``t`` (N,) are whole or half pixels
    (its bincount path): each position's mean ``s`` (sums in input order, as ``np.bincount``'s), then
    ``np.interp`` (numpy's rules: clamped ends, exact at the sample points, ``slope * (x - x_j) + y_j``)
    at the whole positions ``ceil(first - half)`` .. ``floor(last + half)``. Returns (ok, ts, values);
    ``ok`` False (other positions, or too sparse: the caller's numpy path) with empty arrays."""
    n = len(t)
    empty = np.zeros(0)
    if n == 0:
        return False, empty, empty
    k0, k1 = np.int64(0), np.int64(0)
    for i in range(n):
        t2 = t[i] * 2.0
        k = np.int64(t2)
        if k != t2:
            return False, empty, empty
        if i == 0 or k < k0:
            k0 = k
        if i == 0 or k > k1:
            k1 = k
    if not k1 - k0 < 8 * n + 4096:
        return False, empty, empty
    count = np.zeros(k1 - k0 + 1, np.int64)
    total = np.zeros(k1 - k0 + 1)
    for i in range(n):
        k = np.int64(t[i] * 2.0) - k0
        count[k] += 1
        total[k] += s[i]
    m = 0
    for k in range(len(count)):
        if count[k]:
            m += 1
    xp, yp = np.empty(m), np.empty(m)
    j = 0
    for k in range(len(count)):
        if count[k]:
            xp[j] = (k + k0) / 2.0
            yp[j] = total[k] / count[k]
            j += 1
    lo, hi = np.ceil(xp[0] - half), np.floor(xp[m - 1] + half) + 1
    nt = max(np.int64(np.ceil(hi - lo)), 0)
    ts, out = np.empty(nt), np.empty(nt)
    j = 0
    for i in range(nt):
        x = lo + i
        ts[i] = x
        if x <= xp[0]:
            out[i] = yp[0]              # (left of the first sample, or on it)
        elif x >= xp[m - 1]:
            out[i] = yp[m - 1]
        else:
            while xp[j + 1] <= x:       # (x rises: xp[j] <= x < xp[j + 1])
                j += 1
            if xp[j] == x:
                out[i] = yp[j]
            else:
                slope = (yp[j + 1] - yp[j]) / (xp[j + 1] - xp[j])
                out[i] = slope * (x - xp[j]) + yp[j]
    return True, ts, out


def _warm_match() -> None:
    """:func:`warm_up`'s part for the match stage's kernels above (the argument types callers pass)."""
    img, i, f = np.zeros((8, 16), np.uint8), np.ones(1, np.int64), np.zeros(1)
    ncc_peaks(img, img, 4 * i, 4 * i, i, 1, 0 * i, 16 * i, 1.0)
    ncc_search(img, img, np.zeros((1, 2), np.int64), i, 1, 0, 2, 8, 16, 0, 0, 0, f.copy(), f.copy())
    part = np.zeros((8, 3), np.uint8)                   # (C-contiguous, writable: as the callers pass them)
    ncc_scores(img, part)
    masked_sqdiff(img, part, part.copy())
    refine_steps(np.zeros((1, 7), np.float32), f[:1], i[:1], _readonly(np.zeros(256, np.float32)), 12.0, 0.25, 1.5)
    line_vote(np.zeros(2), np.zeros(2), np.zeros(3), 0.0, 1.0)
    centre_line(np.zeros(2), np.zeros(2), 0.5)


# --- match stage, second pass (speedm2)


@numba.njit(**_JIT)
def end_slopes_groups(t, y, g, n_groups, reach):
    """``curves.end_slopes_groups``' numpy steps in one loop, bit for bit: each group's least-squares
    slope (G, 2) of ``y`` over ``t`` (N,) float64 near its low and high end (within ``reach`` of it;
    all the group's samples where fewer than 5 lie there or they span less than 5), 0 without samples
    or spread. Every sum runs over the samples in index order, as ``np.bincount``'s (a sample left out
    adds 0.0 there, which changes no sum); minima and maxima as ``np.minimum.at`` / ``np.maximum.at``'s."""
    n = len(t)
    out = np.zeros((n_groups, 2))
    lo, hi = np.full(n_groups, np.inf), np.full(n_groups, -np.inf)
    for i in range(n):
        k = g[i]
        lo[k] = min(lo[k], t[i])
        hi[k] = max(hi[k], t[i])
    near = np.empty(n, np.bool_)
    cnt, s, sxx, sxy = np.empty(n_groups), np.empty(n_groups), np.empty(n_groups), np.empty(n_groups)
    t_lo, t_hi = np.empty(n_groups), np.empty(n_groups)
    whole = np.empty(n_groups, np.bool_)
    for e in range(2):
        cnt[:] = 0.0
        t_lo[:] = np.inf
        t_hi[:] = -np.inf
        for i in range(n):
            k = g[i]
            near[i] = t[i] <= lo[k] + reach if e == 0 else t[i] >= hi[k] - reach
            if near[i]:
                cnt[k] += 1.0
                t_lo[k] = min(t_lo[k], t[i])
                t_hi[k] = max(t_hi[k], t[i])
        for k in range(n_groups):
            whole[k] = cnt[k] < 5 or t_hi[k] - t_lo[k] < 5
        cnt[:] = 0.0
        s[:] = 0.0
        for i in range(n):
            k = g[i]
            near[i] = near[i] or whole[k]
            if near[i]:
                cnt[k] += 1.0
                s[k] += t[i]
        sxx[:] = 0.0
        sxy[:] = 0.0
        for i in range(n):
            k = g[i]
            dt = t[i] - s[k] / max(cnt[k], 1.0) if near[i] else 0.0
            sxx[k] += dt * dt
            sxy[k] += dt * y[i]             # (0.0 * y off the end, as numpy's: NaN stays NaN)
        for k in range(n_groups):
            out[k, e] = sxy[k] / sxx[k] if sxx[k] > 0 else 0.0
    return out


def _warm_match2() -> None:
    """:func:`warm_up`'s part for the kernels of this block (the argument types callers pass)."""
    f = np.zeros(4)
    end_slopes_groups(f, f, np.zeros(4, np.intp), 1, 60.0)
    m = np.zeros(8, np.uint8)
    for soft in (True, False):
        mask_runs(m, m.view(np.uint64), 4, 127, soft)
    nearest_per_query(np.zeros(2, np.int64), np.zeros(2))
    near_junctions(np.zeros(1), np.zeros(1), np.zeros(1, np.int64), np.zeros((1, 2), np.bool_), np.zeros((1, 2, 2)),
                   np.zeros((1, 2)))
    last_on(np.zeros((4, 4), np.uint8), np.zeros((1, 2)), np.zeros((1, 2)), np.arange(2.0), np.full(1, 2, np.int64))


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
def nearest_per_query(q, res):
    """``dense.fit_steep_many``'s pick of each query's candidate nearest the model: for ``q`` (N,)
    non-decreasing query ids, the index of each run of equal ids' smallest ``res`` (N,) (the first of
    equal ones; NaN above all), in order: ``order = np.lexsort((res, q))`` taken at each id's first
    place, the same indices."""
    n = len(q)
    out = np.empty(n, np.int64)
    m = 0
    i = 0
    while i < n:
        best = i
        j = i + 1
        while j < n and q[j] == q[i]:
            if res[j] < res[best] or (np.isnan(res[best]) and not np.isnan(res[j])):
                best = j
            j += 1
        out[m] = best
        m += 1
        i = j
    return out[:m].copy()


@numba.njit(**_JIT)
def near_junctions(xc, rows, g, junction, nxy, thr):
    """``dense._row_centres``' test of each sample (``xc``, ``rows`` (N,) float64 of piece ``g`` (N,)):
    within ``thr[g, k]`` (np.hypot of the differences, the same values) of its piece's end ``k``'s node
    ``nxy[g, k]`` (x, y) where ``junction[g, k]``. Returns (N,) bool."""
    n = len(xc)
    near = np.zeros(n, np.bool_)
    for i in range(n):
        p = g[i]
        for k in range(2):
            if junction[p, k] and np.hypot(xc[i] - nxy[p, k, 0], rows[i] - nxy[p, k, 1]) < thr[p, k]:
                near[i] = True
    return near


# --- segment (segtips)
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


def _warm_segment() -> None:
    """:func:`warm_up`'s part for :func:`blocks_hold_disc` and :func:`blocks_disc_colour`."""
    i = np.zeros(1, np.int64)
    ro = _readonly(np.zeros(1, np.int64))        # (the disc's offsets: segment._disc_offsets' cached, read-only)
    blocks_hold_disc(np.zeros((4, 4), np.uint8), i, i, i, 1, 4, ro, ro)
    blocks_disc_colour(np.zeros((4, 4), np.uint8), np.zeros((4, 4, 3), np.uint8), i, i, i, 1, 4, ro, ro)
