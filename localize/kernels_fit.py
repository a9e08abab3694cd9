"""Compiled polynomial fits per group of samples and their evaluation (docs/localize-numba.md).

:func:`fit_groups` and :func:`robust_fit_groups` are :mod:`curves`' per-piece least-squares and
iteratively reweighted (MAD-clipped) polynomial fits, one call for all the pieces: the power sums are
numpy's pairwise sums (those of ``np.add.reduceat`` bit for bit, :mod:`kernels_stats`); the small
normal-equation systems are solved by Gaussian elimination with partial pivoting instead of LAPACK's
``dgesv`` (equal up to rounding). :func:`eval_clamped` is ``curves.BranchCurve._eval`` of a Poly (Horner,
carried on straight beyond the span) and :func:`end_slopes_groups` the groups' least-squares end slopes.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_stats import _median, _segment_sum, _sorted


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


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    f = np.zeros(4)
    bounds = np.array([0, 4], np.int64)
    fit_groups(np.arange(4.0), f, bounds, np.ones(1, np.int64))
    robust_fit_groups(np.arange(4.0), f, bounds, np.ones(1, np.int64), np.ones(1, np.int64), 3.5)
    eval_clamped(f[:2], f[:1], 0.0, 1.0, 0.0, 1.0, f[:2], True, np.arange(4.0))
    end_slopes_groups(f, f, np.zeros(4, np.intp), 1, 60.0)
