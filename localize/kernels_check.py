"""Compiled kernels of the feature check: its patches' placement and the per-piece estimate (docs/localize-numba.md).

:func:`place_patches` is :func:`featurecheck._patches`' per-piece work in one pass: the pieces' arc
lengths, the slope of each piece's disparity near the feature, the patch centres, directions and sizes,
and the test that each patch lies inside the image and the left mask. It follows numpy's operations
one by one (``np.interp``'s formula, the pairwise order of numpy's 9-term sums), so it gives the numpy
steps' values bit for bit.

:func:`estimate_pieces` is :func:`featurecheck.estimate`'s per-piece and per-feature steps, its sums in
``np.add.reduceat``'s order (the first term plus numpy's pairwise sum of the rest): the same values.
Tests: tests/localize/test_kernels_check.py.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_ncc import _peak, _strip_buffers, _strip_scores


@numba.njit(**_JIT)
def _interp(x, xp, fp, j0, j1):
    """``np.interp(x, xp[j0:j1], fp[j0:j1])`` for one ``x`` (xp increasing, not strictly): numpy's
    formula and its index ``j`` (the last ``xp[j] <= x``)."""
    if x < xp[j0]:
        return fp[j0]
    lo, hi = j0, j1                                  # xp[lo] <= x; the answer in [lo, hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xp[mid] <= x:
            lo = mid
        else:
            hi = mid
    j = lo
    if j == j1 - 1 or xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    y = slope * (x - xp[j]) + fp[j]
    if np.isnan(y):
        y = slope * (x - xp[j + 1]) + fp[j + 1]
        if np.isnan(y) and fp[j] == fp[j + 1]:
            y = fp[j]
    return y


@numba.njit(**_JIT)
def _sum9(a):
    """numpy's sum of 9 float64 (its pairwise order: eight partial sums paired, then the ninth)."""
    return (((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))) + a[8]


@numba.njit(**_JIT)
def place_patches(uvd, starts, k, ft_uv, r, s0, reach, dstep, mask, m, consts):
    """Every (feature, piece) pair's patches (``featurecheck._patches``' arrays, the same values).

    Parameters
    ----------
    uvd : ndarray (S, 3) float64
        The used pieces' samples (rectified u, v px, disparity px) end to end.
    starts : ndarray (U + 1,) int64
        Each used piece's first sample, and S.
    k : ndarray (K,) int64
        Each pair's piece among the used.
    ft_uv : ndarray (K, 2) float64
        Each pair's feature (u, v) px.
    r, s0, reach, dstep : ndarray (K,) float64
        Each pair's piece radius (>= 1 px), first patch's distance from the feature, span of the patches
        (before the piece's length cuts it) and step between patches, px.
    mask : ndarray (H, W) uint8
        Left branch coverage: a patch's corners, edge midpoints and centre must be >= 128.
    m : int
        Patches per pair at most.
    consts : ndarray (4,) float64
        ``MIN_SPAN_PX``, ``MAX_PIECE_SLOPE`` and the patch size's flat and steep sines (0.5, 0.87).

    Returns
    -------
    pair, col : ndarray (P,) int64
        Each kept patch's pair and index along the pair (by pair, then index).
    u, v, hh, hw : ndarray (P,) int64
        Centre (px), half height and half width.
    across : ndarray (P,) float64
        Half extent across the axis, px.
    s : ndarray (P,) float64
        Distance from the feature along the piece, px.
    slope : ndarray (K,) float64
        Each pair's disparity slope (px per px) away from the feature.
    """
    min_span, max_slope, flat_sin, steep_sin = consts[0], consts[1], consts[2], consts[3]
    n_s, n_p, n_k = len(uvd), len(starts) - 1, len(k)
    h, w = mask.shape
    # the pieces' arc lengths end to end (numpy's cumsum over all, less each piece's first), pieces ``big`` apart
    arc = np.empty(n_s)
    acc = 0.0
    for p in range(n_p):
        for i in range(starts[p], starts[p + 1]):
            if i > starts[p]:
                acc += np.hypot(uvd[i, 0] - uvd[i - 1, 0], uvd[i, 1] - uvd[i - 1, 1])
            arc[i] = acc
    length = np.empty(n_p)
    for p in range(n_p):
        a0 = arc[starts[p]]
        for i in range(starts[p], starts[p + 1]):
            arc[i] = arc[i] - a0
        length[p] = arc[starts[p + 1] - 1]
    big = length.max() + 10.0
    x = np.empty(n_s)
    for p in range(n_p):
        for i in range(starts[p], starts[p + 1]):
            x[i] = arc[i] + p * big
    du_, dv_ = uvd[:, 0].copy(), uvd[:, 1].copy()
    dd_ = uvd[:, 2].copy()
    slope = np.empty(n_k)
    cap = n_k * m
    o_pair, o_col = np.empty(cap, np.int64), np.empty(cap, np.int64)
    o_u, o_v = np.empty(cap, np.int64), np.empty(cap, np.int64)
    o_hh, o_hw = np.empty(cap, np.int64), np.empty(cap, np.int64)
    o_across, o_s = np.empty(cap), np.empty(cap)
    qs, dq, t1, t2 = np.empty(9), np.empty(9), np.empty(9), np.empty(9)
    n_out = 0
    for c in range(n_k):
        p = k[c]
        j0, j1 = starts[p], starts[p + 1]
        lk = length[p]
        off = k[c] * big
        fu, fv = ft_uv[c, 0], ft_uv[c, 1]
        from_end = np.hypot(uvd[j1 - 1, 0] - fu, uvd[j1 - 1, 1] - fv) < np.hypot(uvd[j0, 0] - fu, uvd[j0, 1] - fv)
        rc, a = r[c], s0[c]
        s1 = min(a + reach[c], lk)
        lo = max(a - rc, 0.0)
        hi = min(max(s1, a + min_span), lk)
        for i in range(9):
            qs[i] = lo + (hi - lo) * (i * 0.125)
            dq[i] = _interp(_arc_x(qs[i], from_end, lk) + off, x, dd_, j0, j1)
        qm, dm = _sum9(qs) / 9.0, _sum9(dq) / 9.0
        for i in range(9):
            qc = qs[i] - qm
            t1[i] = qc * (dq[i] - dm)
            t2[i] = qc * qc
        sl = _sum9(t1) / max(_sum9(t2), 1e-9)
        slope[c] = sl
        if not (s1 >= a and hi - lo >= 2.0 and abs(sl) <= max_slope):
            continue
        for col in range(m):
            q = a + dstep[c] * col
            if not q <= s1 + 1e-9:
                continue
            pu = _interp(_arc_x(q, from_end, lk) + off, x, du_, j0, j1)
            pv = _interp(_arc_x(q, from_end, lk) + off, x, dv_, j0, j1)
            xa, xb = _arc_x(q + 1.0, from_end, lk) + off, _arc_x(q - 1.0, from_end, lk) + off
            du = _interp(xa, x, du_, j0, j1) - _interp(xb, x, du_, j0, j1)
            dv = _interp(xa, x, dv_, j0, j1) - _interp(xb, x, dv_, j0, j1)
            ln = max(np.hypot(du, dv), 1e-9)
            eu, sa = abs(du / ln), abs(dv / ln)      # (sine of the angle to the rows)
            sq = min(max(np.rint(0.45 * rc), 2.0), 6.0)
            if sa < flat_sin:
                hh, hw = min(max(np.floor(0.6 * rc), 1.0), 7.0), 7.0
            elif sa > steep_sin:
                hh, hw = 4.0, min(max(np.rint(0.6 * rc), 2.0), 7.0)
            else:
                hh, hw = sq, sq
            ih, iw = np.int64(hh), np.int64(hw)
            ui, vi = np.int64(np.rint(pu)), np.int64(np.rint(pv))
            if not (vi >= ih and vi < h - ih and ui >= iw and ui < w - iw):
                continue
            inside = True
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    if mask[vi + dy * ih, ui + dx * iw] < 128:
                        inside = False
            if not inside:
                continue
            o_pair[n_out], o_col[n_out], o_u[n_out], o_v[n_out] = c, col, ui, vi
            o_hh[n_out], o_hw[n_out], o_s[n_out] = ih, iw, q
            o_across[n_out] = ih * eu + iw * sa
            n_out += 1
    return (o_pair[:n_out], o_col[:n_out], o_u[:n_out], o_v[:n_out], o_hh[:n_out], o_hw[:n_out],
            o_across[:n_out], o_s[:n_out], slope)


@numba.njit(**_JIT)
def _sum_at(a, idx, n):
    """``np.add.reduceat``'s sum of ``a[idx[:n]]`` (n >= 1): the first term plus numpy's pairwise sum of
    the rest (under 8 terms one after another; else eight partial sums, paired, then the remainder)."""
    if n == 1:
        return a[idx[0]]
    m = n - 1
    if m < 8:
        rest = 0.0
        for i in range(1, n):
            rest += a[idx[i]]
        return a[idx[0]] + rest
    r = np.empty(8)
    for j in range(8):
        r[j] = a[idx[1 + j]]
    i = 8
    while i < m - m % 8:
        for j in range(8):
            r[j] += a[idx[1 + i + j]]
        i += 8
    rest = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < m:
        rest += a[idx[1 + i]]
        i += 1
    return a[idx[0]] + rest


@numba.njit(**_JIT)
def estimate_pieces(feature, piece, s, d, g, score, d_px, consts, d_check, n_used, spread, agree):
    """:func:`featurecheck.estimate`'s steps (its values: numpy's sums in numpy's order) into ``d_check``,
    ``n_used``, ``spread`` (F,) (NaN, 0, NaN where no verdict) and ``agree`` (F,): where two or more pieces
    give a texture estimate (each piece's: its own line's value at the feature where it fits one, else its
    patches carried along its slope), the second largest of them when none lies under ``-oppose``, the
    second smallest when none lies over ``oppose`` (the one larger in magnitude), 0 otherwise; NaN where
    fewer than two pieces give one (relative to the feature's disparity, px).

    Parameters
    ----------
    feature, piece : ndarray (P,) int64
        Each patch's feature and piece (rows grouped by feature, then piece).
    s, d, g, score : ndarray (P,) float64
        Distance from the feature (px), texture disparity on the axis (px, NaN: none), the piece's slope
        (px per px) and the correlation.
    d_px : ndarray (F,) float64
        The features' disparities.
    consts : ndarray (8,) float64
        ``MIN_SCORE``, ``MIN_PATCHES``, ``MAX_SPREAD_PX``, ``FIT_MIN_PATCHES``, ``FIT_MIN_SPAN_PX``,
        ``FIT_MAX_RES_PX``, ``MAX_PIECE_SLOPE``, ``OPPOSE_PX`` (``oppose``).
    """
    min_score, min_patches, max_spread = consts[0], consts[1], consts[2]
    fit_min, fit_span, fit_res, max_slope = consts[3], consts[4], consts[5], consts[6]
    oppose = consts[7]
    n = len(s)
    idx = np.empty(n, np.int64)
    e, r2, sd = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        e[i] = d[i] - g[i] * s[i]
        r2[i] = s[i] * s[i]
        sd[i] = s[i] * d[i]
    cur_f, lo, hi, cnt_f, ext_f = -1, 0.0, 0.0, 0, 0.0
    # each feature's pieces' own texture estimates: how many, the two largest and the two smallest
    tex_f, t_n, t_hi1, t_hi2, t_lo1, t_lo2 = -1, 0, 0.0, 0.0, 0.0, 0.0
    i = 0
    while i <= n:
        # the next group: the confident rows of one (feature, piece)
        m = 0
        if i < n:
            f0, p0 = feature[i], piece[i]
            while i < n and feature[i] == f0 and piece[i] == p0:
                if np.isfinite(d[i]) and score[i] >= min_score:
                    idx[m] = i
                    m += 1
                i += 1
            if m == 0:
                continue
        else:
            i += 1
            f0 = -1
        if cur_f >= 0 and f0 != cur_f:                 # (the last feature's groups are done)
            d_check[cur_f] = d_px[cur_f] + (lo if lo > 0 else (hi if hi < 0 else 0.0))
            n_used[cur_f] = cnt_f
            spread[cur_f] = ext_f
            cur_f = -1
        if tex_f >= 0 and f0 != tex_f:
            if t_n >= 2:
                up = t_hi2 if (t_lo1 >= -oppose and t_hi2 > 0) else 0.0
                down = t_lo2 if (t_hi1 <= oppose and t_lo2 < 0) else 0.0
                agree[tex_f] = up if up >= -down else down
            tex_f = -1
        if m == 0:
            break
        e_lo, e_hi, s_lo, s_hi = e[idx[0]], e[idx[0]], s[idx[0]], s[idx[0]]
        for j in range(1, m):
            e_lo, e_hi = min(e_lo, e[idx[j]]), max(e_hi, e[idx[j]])
            s_lo, s_hi = min(s_lo, s[idx[j]]), max(s_hi, s[idx[j]])
        carry = np.nan
        if m >= min_patches and e_hi - e_lo <= 2 * max_spread:
            carry = _sum_at(e, idx, m) / m
        s1, s2 = _sum_at(s, idx, m), _sum_at(r2, idx, m)
        y1, sy = _sum_at(d, idx, m), _sum_at(sd, idx, m)
        den = m * s2 - s1 * s1
        b = (m * sy - s1 * y1) / (den if den > 0 else 1.0)
        a0 = (y1 - b * s1) / m
        res = 0.0
        for j in range(m):
            q = idx[j]
            v = abs(d[q] - a0 - b * s[q])
            res = v if j == 0 else max(res, v)
        dp = d_px[f0]
        if m >= fit_min and s_hi - s_lo >= fit_span and res <= fit_res and abs(b) <= max_slope:
            a_piece = (y1 - g[idx[0]] * s1) / m
            lo_b, hi_b = min(a0, a_piece) - dp, max(a0, a_piece) - dp
            diff = lo_b if lo_b > 0 else (hi_b if hi_b < 0 else 0.0)
            tex = a0 - dp
        else:
            diff = carry - dp
            tex = diff
        if np.isfinite(tex):
            if tex_f < 0:
                tex_f, t_n, t_hi1, t_hi2, t_lo1, t_lo2 = f0, 1, tex, -np.inf, tex, np.inf
            else:
                t_n += 1
                if tex > t_hi1:
                    t_hi1, t_hi2 = tex, t_hi1
                elif tex > t_hi2:
                    t_hi2 = tex
                if tex < t_lo1:
                    t_lo1, t_lo2 = tex, t_lo1
                elif tex < t_lo2:
                    t_lo2 = tex
        if not np.isfinite(diff):
            continue
        if cur_f < 0:
            cur_f, lo, hi, cnt_f, ext_f = f0, diff, diff, m, e_hi - e_lo
        else:
            lo, hi, cnt_f, ext_f = min(lo, diff), max(hi, diff), cnt_f + m, max(ext_f, e_hi - e_lo)


@numba.njit(**_JIT)
def wide_peaks(left, right, ty, tx, hh, hw, sx0, sx1, n0, n1, away, min_std):
    """:func:`kernels_ncc.ncc_peaks` over wide strips, with what tells a unique peak: for each patch ``i``
    (centre ``(tx[i], ty[i])`` in ``left``, half height ``hh[i]``, half width ``hw``) not flat, its
    TM_CCOEFF_NORMED scores at the strip positions ``0 .. sx1[i] - sx0[i] - 2 hw - 1`` of ``right``.

    Returns ok (N,) bool (False: flat, too short a strip, or the best at the strip's end), k (N,) int64
    (the best position), off (N,) (its parabola offset), best (N,) (its score), near (N,) (the best score
    at positions ``n0[i] .. n1[i]``: around the feature's own disparity; -1 where none) and second (N,)
    (the best local maximum more than ``away`` positions from the best; -1 where none)."""
    n = len(ty)
    nw = 2 * hw + 1
    ok = np.zeros(n, np.bool_)
    ks = np.zeros(n, np.int64)
    offs, best = np.zeros(n), np.full(n, -1.0)
    near, second = np.full(n, -1.0), np.full(n, -1.0)
    acc, buf, cs, cs2, c = _strip_buffers(sx0, sx1)
    for i in range(n):
        n_pos = _strip_scores(left, right, ty[i] - hh[i], 2 * hh[i] + 1, tx[i] - hw, nw, sx0[i], sx1[i], min_std,
                              acc, buf, cs, cs2, c)
        if n_pos == 0:
            continue
        k, off = _peak(c, n_pos)
        if k == 0 or k == n_pos - 1:
            continue
        ok[i], ks[i], offs[i], best[i] = True, k, off, c[k]
        for p in range(max(n0[i], 0), min(n1[i], n_pos - 1) + 1):
            near[i] = max(near[i], c[p])
        for p in range(1, n_pos - 1):
            if abs(p - k) > away and c[p] >= c[p - 1] and c[p] >= c[p + 1]:
                second[i] = max(second[i], c[p])
    return ok, ks, offs, best, near, second


@numba.njit(**_JIT)
def _arc_x(q, from_end, lk):
    """A distance ``q`` px from the feature's end as the arc length from the piece's first sample,
    clipped to the piece (``np.clip(np.where(from_end, lk - q, q), 0, lk)``)."""
    t = lk - q if from_end else q
    return min(max(t, 0.0), lk)


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    f = np.zeros(1)
    place_patches(np.zeros((2, 3)), np.array([0, 2], np.int64), np.zeros(1, np.int64), np.zeros((1, 2)), f + 1, f,
                  f, f + 3, np.zeros((2, 2), np.uint8), 1, np.zeros(4))
    i = np.zeros(1, np.int64)
    estimate_pieces(i, i, f, f, f, f, f, np.zeros(8), f.copy(), i.copy(), f.copy(), f.copy())
    img = np.zeros((3, 8), np.uint8)
    wide_peaks(img, img, i + 1, i + 1, i + 1, 1, i, i + 8, i, i, 2, 2.0)
