"""Compiled kernels of the dense path: the disparity candidates' lines, fits and picks of :mod:`single_edge`
and :mod:`dense` (docs/localize-numba.md).

Whole functions of :mod:`single_edge` and :mod:`dense` as one compiled loop each, with the same
rules as the numpy code they replace. They agree with it up to rounding: the trigonometry of
:func:`edge_to_axis` and the means are not numpy's bit for bit (checked per feature on the
60-scene benchmark; tests/localize/test_kernels_dense.py against the numpy versions).

Smaller steps of the same path, with the numpy steps' values: :func:`consensus_lines`
(``dense._consensus_lines``), :func:`line_vote` and :func:`centre_line` (``single_edge.edge_consensus``' vote,
``single_edge.centre_guess``), :func:`nearest_per_query` (``dense.fit_steep_many``'s pick) and
:func:`near_junctions` (``dense._row_centres``' test).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _readonly
from appliance.localize.kernels_fit import _fit_one, _group_polys, _horner, end_slopes_groups, fit_groups, robust_fit_groups
from appliance.localize.kernels_runs import runs_between, runs_find
from appliance.localize.kernels_stats import _median, _pairwise, _sorted

OCCL_TOL_PX = 1.5       # steep_fit: a pick whose width disagreement is this + OCCL_SHARE * width off its piece's
OCCL_SHARE = 0.02       # ... median is dropped (width_disagree; docs/localize-steepdrift.md)


@numba.njit(**_JIT)
def _percentile75(a):
    """``curves.percentile(a, 75)`` (numpy's linear method: the same virtual index and interpolation)."""
    n = len(a)
    p = _sorted(a)
    vi = n * 0.75 + (1 + 0.75 * (1 - 1 - 1)) - 1
    lo = min(max(np.int64(np.floor(vi)), 0), n - 1)
    hi = min(lo + 1, n - 1)
    gamma = vi - np.floor(vi)
    x, y = p[lo], p[hi]
    diff = y - x
    return y - diff * (1 - gamma) if gamma >= 0.5 else x + diff * gamma


@numba.njit(**_JIT)
def _n_distinct(a):
    """Number of distinct values of a float array (``len(np.unique(a))``, NaN-free)."""
    if len(a) == 0:
        return 0
    p = _sorted(a)
    n = 1
    for i in range(1, len(p)):
        n += p[i] != p[i - 1]
    return n


@numba.njit(**_JIT)
def _distinct_ints(a):
    """``np.unique`` of an int64 array (sorted distinct values)."""
    if len(a) == 0:
        return a.copy()
    p = _sorted(a)
    out = np.empty(len(p), np.int64)
    out[0] = p[0]
    m = 1
    for i in range(1, len(p)):
        if p[i] != p[i - 1]:
            out[m] = p[i]
            m += 1
    return out[:m].copy()


@numba.njit(**_JIT)
def edge_to_axis_one(u_px, d_px, half_px, side, f_px, cx_px, offset_px):
    """``single_edge.edge_to_axis`` of one row: the disparity (px) of a branch's axis from that of one
    of its silhouette edges (``side`` -1 left, +1 right; ``half_px`` the half width along the row)."""
    x = (u_px - cx_px) / f_px
    rho_l = np.sqrt(1 + x * x)
    r = half_px / (f_px * rho_l)
    d = d_px - offset_px
    beta = d / f_px
    for _ in range(2):
        xr = x - beta
        rho_r = np.sqrt(1 + xr * xr)
        e_l = np.tan(np.arctan(x) + side * np.arcsin(min(r / rho_l, 0.99)))
        e_r = np.tan(np.arctan(xr) + side * np.arcsin(min(r / rho_r, 0.99)))
        beta = beta - (f_px * (e_l - e_r) - d) / f_px
    return beta * f_px + offset_px


@numba.njit(**_JIT)
def edge_track(tab_l, tab_r, edges_l, edges_r, width, rows, xc, u, d, half, need, f_px, cx_px, offset_px):
    """``single_edge._edge_track``: samples of a branch along ``rows`` (N,) float from single edges.

    Parameters
    ----------
    tab_l, tab_r : tuple of three (R + 1,) int64
        ``Runs._find_tables`` of the left and right runs (start keys, rows, last pixels).
    edges_l, edges_r : (2, R) float
        The runs' ``left_px`` and ``right_px`` (left view, right view), px.
    width : int
        Image width, px (the runs' keys).
    rows, xc, u, d, half : (N,) float
        Rows, the skeleton's centre column, the carried centre column, disparity and half width, px.
    need : float
        Fewest rows with samples (and distinct rows on the line) for a track.
    f_px, cx_px, offset_px : float
        Focal length, left principal column and ``cx_left - cx_right``, px.

    Returns
    -------
    ok : bool
        False where ``_edge_track`` returns None.
    ts, ds, cs : (K,) float
        Rows, axis disparities and centre columns of the samples (left edges first), px.
    rs : (K,) int64
        Right run of each sample.
    """
    n = len(rows)
    ri = np.empty(n, np.int64)
    for i in range(n):
        ri[i] = np.int64(rows[i])
    il = runs_find(tab_l[0], tab_l[1], tab_l[2], width, ri, u)
    il2 = runs_find(tab_l[0], tab_l[1], tab_l[2], width, ri, xc)
    m = 0
    for i in range(n):
        if il[i] < 0:
            il[i] = il2[i]
        if il[i] >= 0:
            m += 1
    e0, i0 = np.empty(0), np.empty(0, np.int64)
    if m < need:
        return False, e0, e0, e0, i0
    sel = np.empty(m, np.int64)
    j = 0
    for i in range(n):
        if il[i] >= 0:
            sel[j] = i
            j += 1
    ri, t, u, d, il, half = ri[sel], rows[sel], u[sel], d[sel], il[sel], half[sel]
    tol = max(3.0, 0.25 * (np.sum(half) / m))
    e_l = np.empty((2, m))
    d_ax = np.full((2, m), np.nan)
    good = np.zeros((2, m), np.bool_)
    ir = np.empty((2, m), np.int64)
    q = np.empty(m)
    for k in range(2):
        side = -1.0 if k == 0 else 1.0
        for i in range(m):
            e_l[k, i] = edges_l[k, il[i]]
            q[i] = e_l[k, i] - d[i] - side * 1.0
        ir[k] = runs_find(tab_r[0], tab_r[1], tab_r[2], width, ri, q)
        for i in range(m):
            if abs(e_l[k, i] - (u[i] + side * half[i])) <= tol and ir[k, i] >= 0:
                d_ax[k, i] = edge_to_axis_one(u[i], e_l[k, i] - edges_r[k, ir[k, i]], half[i], side, f_px, cx_px,
                                              offset_px)
                good[k, i] = abs(d_ax[k, i] - d[i]) <= 2.0
    n_any, n_both = 0, 0
    for i in range(m):
        n_any += good[0, i] | good[1, i]
        n_both += good[0, i] & good[1, i]
    if n_any < need:
        return False, e0, e0, e0, i0
    scale = 1.0
    if n_both >= 3:                     # the width where both edges show, else the piece's
        ratio = np.empty(n_both)
        j = 0
        for i in range(m):
            if good[0, i] & good[1, i]:
                ratio[j] = (e_l[1, i] - e_l[0, i]) / (2 * half[i])
                j += 1
        scale = _median(ratio)
    k_all = 0
    for k in range(2):
        for i in range(m):
            k_all += good[k, i]
    ts, ds, cs, rs = np.empty(k_all), np.empty(k_all), np.empty(k_all), np.empty(k_all, np.int64)
    j = 0
    for k in range(2):
        side = -1.0 if k == 0 else 1.0
        for i in range(m):
            if good[k, i]:
                ts[j], ds[j], rs[j] = t[i], d_ax[k, i], ir[k, i]
                both = good[0, i] & good[1, i]
                cs[j] = 0.5 * (e_l[0, i] + e_l[1, i]) if both else e_l[k, i] - side * (half[i] * scale)
                j += 1
    coef, t0, tsc, deg, inl = robust_fit_groups(ts, ds, np.array([0, k_all], np.int64), np.ones(1, np.int64),
                                                np.full(1, 3, np.int64), 3.5)
    c2, c3 = coef[0, 2], coef[0, 3]
    n_in = 0
    for i in range(k_all):
        if inl[i]:
            x = (ts[i] - t0[0]) / tsc[0]
            line = x * c2 + c3 if deg[0] == 1 else c3
            inl[i] = abs(ds[i] - line) <= 0.75
            n_in += inl[i]
    keep = np.flatnonzero(inl)
    if _n_distinct(ts[keep]) < need:
        return False, e0, e0, e0, i0
    return True, ts[keep], ds[keep], cs[keep], rs[keep]


@numba.njit(**_JIT)
def _count(g, ng):
    """``np.bincount(g, minlength=ng)`` of group ids ``g`` (N,) in [0, ng)."""
    n = np.zeros(ng, np.int64)
    for i in range(len(g)):
        n[g[i]] += 1
    return n


@numba.njit(**_JIT)
def _renumber(alive):
    """New ids (G,) of the ``alive`` groups (``np.cumsum(alive) - 1``: -1 before the first)."""
    out = np.empty(len(alive), np.int64)
    c = -1
    for k in range(len(alive)):
        c += alive[k]
        out[k] = c
    return out


@numba.njit(**_JIT)
def steep_candidates(rows, xc, g, sin_all, tab_l, span_l, centre_l, keys_r, centre_r, span_r, width, radius_img,
                     scale, d_min, d_max, taken):
    """``dense.fit_steep_many``'s first steps, from the row centres to each row's right candidates.

    Pieces with fewer than 4 rows are dropped (twice: before and after the width test); a row keeps
    its left crossing (the run at its centre) if that is at most ``1.5 (2 r / sin + 1) + 2`` px wide
    (r: the radius map's at the centre, nearest pixel); then if within ``0.1 w + 1.5`` px of each
    piece's width trend (a robust quadratic, 2 rounds). Each kept row's candidates are the right
    runs of its row whose centre gives a disparity in [d_min, d_max] and whose width is within
    ``0.1 w + 1.5`` px of the left one's (not ``taken``).

    Parameters
    ----------
    rows, xc : (N,) float
        Rows and centre columns (px) of the pieces' rows, piece ids ``g`` (N,) int64 non-decreasing.
    sin_all : (G0,) float
        Each piece's ``max(sin(angle from the rows), 0.2)``.
    tab_l : tuple of three (R + 1,) int64
        ``Runs._find_tables`` of the left runs; ``span_l``, ``centre_l`` (R,) their widths and centres, px.
    keys_r, centre_r, span_r : (R',) float
        The right runs' centre keys (``Runs._centre_keys``), centres and widths, px.
    width : int
        Image width, px. ``radius_img`` (h, w) float32 and ``scale``: the radius map.
    d_min, d_max : float
        Working disparity range, px.
    taken : (R',) bool or (0,) bool
        Right runs that belong to another piece (none when empty).

    Returns
    -------
    seg_idx : (G,) int64
        The surviving pieces (indices into the input pieces); groups below are numbered over them.
    rows, il, w_l, g : (M,) int64, int64, float, int64
        The rows that passed both width tests: row, left run, its width (px), group.
    rows_all, il_all, g_all : (A,) int64
        Every row with a left crossing of the surviving pieces (before the width tests).
    n : (G,) int64
        Rows per group after the width tests.
    alive : (G,) bool
        Groups with at least 4 rows and 4 candidates.
    c_l : (M,) float
        Left crossings' centres, px.
    q, rr : (K,) int64
        Candidates: row (into the M rows) and right run.
    cd, cw : (K,) float
        Their disparity and right width, px.
    degree : (G,) int64
        :func:`curves.degree_for` of each live piece's rows (1 elsewhere: ``dense._degrees``).
    """
    ng0 = len(sin_all)
    alive0 = _count(g, ng0) >= 4
    new0 = _renumber(alive0)
    m = 0
    for i in range(len(g)):
        m += alive0[g[i]]
    ri, xk, gk = np.empty(m, np.int64), np.empty(m), np.empty(m, np.int64)
    j = 0
    for i in range(len(g)):
        if alive0[g[i]]:
            ri[j], xk[j], gk[j] = np.int64(rows[i]), xc[i], new0[g[i]]
            j += 1
    seg1 = np.flatnonzero(alive0)
    ng1 = len(seg1)
    il = runs_find(tab_l[0], tab_l[1], tab_l[2], width, ri, xk)
    h, w = radius_img.shape
    ok = np.zeros(m, np.bool_)
    found = np.zeros(m, np.bool_)
    for i in range(m):
        if il[i] < 0:
            continue
        found[i] = True
        x = min(max(np.int64(np.rint((xk[i] + 0.5) / scale - 0.5)), 0), w - 1)
        y = min(max(np.int64(np.rint((ri[i] + 0.5) / scale - 0.5)), 0), h - 1)
        r = np.float64(radius_img[y, x])
        ok[i] = span_l[il[i]] <= 1.5 * (2 * r / sin_all[seg1[gk[i]]] + 1) + 2
    n1 = np.zeros(ng1, np.int64)
    for i in range(m):
        n1[gk[i]] += ok[i]
    alive1 = n1 >= 4
    new1 = _renumber(alive1)
    seg_idx = seg1[alive1]
    ng = len(seg_idx)
    n_all, n_ok = 0, 0
    for i in range(m):
        if alive1[gk[i]]:
            n_all += found[i]
            n_ok += ok[i]
    rows_all, il_all, g_all = np.empty(n_all, np.int64), np.empty(n_all, np.int64), np.empty(n_all, np.int64)
    r2, il2, w2, g2 = np.empty(n_ok, np.int64), np.empty(n_ok, np.int64), np.empty(n_ok), np.empty(n_ok, np.int64)
    a = b = 0
    for i in range(m):
        if not alive1[gk[i]]:
            continue
        if found[i]:
            rows_all[a], il_all[a], g_all[a] = ri[i], il[i], new1[gk[i]]
            a += 1
        if ok[i]:
            r2[b], il2[b], w2[b], g2[b] = ri[i], il[i], span_l[il[i]], new1[gk[i]]
            b += 1
    # the width trend: rows much narrower (partly occluded) or wider (merged) than it are not the centre
    t2 = r2.astype(np.float64)
    starts = np.searchsorted(g2, np.arange(ng + 1))
    coef, t0, ts, _, _ = robust_fit_groups(t2, w2, starts, np.full(ng, 2, np.int64), np.full(ng, 2, np.int64), 3.5)
    keep = np.zeros(n_ok, np.bool_)
    for i in range(n_ok):
        k = g2[i]
        x = (t2[i] - t0[k]) / ts[k]
        wv = ((x * coef[k, 0] + coef[k, 1]) * x + coef[k, 2]) * x + coef[k, 3]
        keep[i] = abs(w2[i] - wv) <= 0.1 * wv + 1.5
    sel = np.flatnonzero(keep)
    r3, il3, w3, g3 = r2[sel], il2[sel], w2[sel], g2[sel]
    n = _count(g3, ng)
    alive = n >= 4
    c_l = np.empty(len(sel))
    lo, hi = np.empty(len(sel)), np.empty(len(sel))
    for i in range(len(sel)):
        c_l[i] = centre_l[il3[i]]
        lo[i], hi[i] = c_l[i] - d_max, c_l[i] - d_min
    q, rr = runs_between(keys_r, r3, width, lo, hi)
    good = np.zeros(len(q), np.bool_)
    has_taken = len(taken) > 0
    for i in range(len(q)):
        wq = w3[q[i]]
        good[i] = abs(span_r[rr[i]] - wq) <= 0.1 * wq + 1.5 and alive[g3[q[i]]] and not (has_taken and taken[rr[i]])
    sel = np.flatnonzero(good)
    q, rr = q[sel], rr[sel]
    cd, cw = np.empty(len(q)), np.empty(len(q))
    nq = np.zeros(ng, np.int64)
    for i in range(len(q)):
        cd[i] = c_l[q[i]] - centre_r[rr[i]]
        cw[i] = span_r[rr[i]]
        nq[g3[q[i]]] += 1
    for k in range(ng):
        alive[k] &= nq[k] >= 4
    lo_t, hi_t = np.full(ng, np.inf), np.full(ng, -np.inf)
    for i in range(len(r3)):
        lo_t[g3[i]] = min(lo_t[g3[i]], np.float64(r3[i]))
        hi_t[g3[i]] = max(hi_t[g3[i]], np.float64(r3[i]))
    degree = np.ones(ng, np.int64)         # (dense._degrees: curves.degree_for of each live piece's rows)
    for k in range(ng):
        if alive[k]:
            span = hi_t[k] - lo_t[k]
            degree[k] = 1 if n[k] < 12 or span < 40 else (2 if span < 160 else 3)
    return seg_idx, r3, il3, w3, g3, rows_all, il_all, g_all, n, alive, c_l, q, rr, cd, cw, degree


@numba.njit(**_JIT)
def _mean(a):
    """``a.mean()`` of a 1-D float array (numpy's pairwise sum: the same value bit for bit)."""
    return _pairwise(a, 0, len(a)) / len(a)


@numba.njit(**_JIT)
def _deriv(coef, ts):
    """:meth:`curves.Poly.deriv`'s coefficients (the same products)."""
    n = len(coef) - 1
    if n <= 0:
        return np.zeros(1)
    out = np.empty(n)
    for i in range(n):
        out[i] = coef[i] * (n - i) / ts
    return out


@numba.njit(**_JIT)
def _to_axis(d_surf, radius, f_px, offset_px, k):
    """``texture.surface_to_axis`` of one patch (``k``: its depth fraction)."""
    return (d_surf - offset_px) / (1.0 + k * radius / f_px) + offset_px


@numba.njit(**_JIT)
def flat_finish(d_surf, score, u, v, right_mask, v_coef, v_t0, v_ts, radius, half_h, lo, hi, f_px, offset_px,
                slant, limits):
    """``dense._flat_finish``'s texture branch: a flat piece's disparity line (or constant) from its
    patches' surface disparities.

    Patches that matched (finite, score >= 0.6) onto the right mask (>= 128 at the matched pixel)
    count; with at least 3, their disparities go back onto the axis (``texture.patch_depth_fraction``
    over the patch's ``2 half_h + 1`` rows at the centre line's slope, ``texture.surface_to_axis``), a
    robust constant (pieces under 100 px) or line is fitted, and for a line the step is redone with
    ``texture.slant_depth_factor`` (if ``slant``) and refitted; the fit must pass
    ``flatfit.line_supported`` and ``flatfit.scatter_ok``.

    Parameters
    ----------
    d_surf, score : (N,) float
        Patches' surface disparities (px) and correlations.
    u, v : (N,) float
        Patch centres (px, rectified left view).
    right_mask : (H, W) uint8
        Right soft mask.
    v_coef : (K,) float; v_t0, v_ts : float
        The centre line v(u) (:class:`curves.Poly`).
    radius : float; half_h : int
        Piece radius and the patches' half height, px.
    lo, hi : float
        The piece's column span, px.
    f_px, offset_px : float
    slant : bool
    limits : (8,) float
        ``flatfit``'s MIN_LINE_INLIERS, MIN_LINE_SHARE, MIN_LINE_SPREAD, FEW_LINE_PATCHES,
        MAX_LINE_MAD_PX, FEW_PATCHES, MAX_FEW_MAD_PX; the shortest piece (px) given a line (100).

    Returns
    -------
    status : int
        0: fewer than 3 patches (the caller's fallback), 1: a curve, 2: withheld (None).
    coef : (4,) float; t0, ts : float; degree : int
        The disparity polynomial (``coef[3 - degree:]``), highest power first.
    n_inl : int
        Its inlier patches.
    """
    n = len(u)
    h, w = right_mask.shape
    good = np.zeros(n, np.bool_)
    for i in range(n):
        if not (np.isfinite(d_surf[i]) and score[i] >= 0.6):
            continue
        xr = np.int64(np.rint(u[i] - d_surf[i]))
        yr = np.int64(np.rint(v[i]))
        good[i] = 0 <= xr < w and 0 <= yr < h and right_mask[yr, xr] >= 128
    idx = np.flatnonzero(good)
    m = len(idx)
    coef = np.zeros(4)
    if m < 3:
        return 0, coef, 0.0, 1.0, 0, 0
    dv_coef = _deriv(v_coef, v_ts)
    ug, ds, dv, k = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    rows = np.empty(2 * half_h + 1)
    for j in range(m):
        ug[j], ds[j] = u[idx[j]], d_surf[idx[j]]
        dv[j] = _horner(dv_coef, (ug[j] - v_t0) / v_ts)
        cos_a = 1.0 / np.sqrt(1.0 + dv[j] * dv[j])          # patch_depth_fraction: the rows' mean offset
        for y in range(-half_h, half_h + 1):
            t = cos_a * y / max(radius, 1e-9)
            rows[y + half_h] = np.sqrt(max(1.0 - t * t, 0.0))
        k[j] = _mean(rows)
    d_axis = np.empty(m)
    for j in range(m):
        d_axis[j] = _to_axis(ds[j], radius, f_px, offset_px, k[j])
    degree = 0 if hi - lo < limits[7] else 1          # (limits[7]: 100 px, flatends' shorter lines)
    starts = np.array([0, m], np.int64)
    deg_a, rounds = np.full(1, degree, np.int64), np.full(1, 3, np.int64)
    c4, t0, ts, dg, inl = robust_fit_groups(ug, d_axis, starts, deg_a, rounds, 3.5)
    if slant and degree == 1:           # the axis further behind the surface where the branch turns in depth
        cx, cy = 0.5 * (w - 1), 0.5 * (h - 1)
        d_coef = c4[0, 3 - dg[0]:].copy()
        dd_coef = _deriv(d_coef, ts[0])
        for j in range(m):
            vj = _horner(v_coef, (ug[j] - v_t0) / v_ts)
            dz = max(_horner(d_coef, (ug[j] - t0[0]) / ts[0]) - offset_px, 1e-6)
            r0, r1, r2 = (ug[j] - cx) / f_px, (vj - cy) / f_px, 1.0
            z = 1.0 / dz
            dz_du = -_horner(dd_coef, (ug[j] - t0[0]) / ts[0]) * z / dz
            a0, a1, a2 = r0 * dz_du + z / f_px, r1 * dz_du + z * dv[j] / f_px, r2 * dz_du + 0.0
            rn = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            n0, n1, n2 = r0 / rn, r1 / rn, r2 / rn
            cos_t = abs(n0 * a0 + n1 * a1 + n2 * a2) / max(np.sqrt(a0 * a0 + a1 * a1 + a2 * a2), 1e-12)
            k[j] = k[j] * (n2 / np.sqrt(max(1.0 - cos_t * cos_t, 1e-6)))
            d_axis[j] = _to_axis(ds[j], radius, f_px, offset_px, k[j])
        c4, t0, ts, dg, inl = robust_fit_groups(ug, d_axis, starts, deg_a, rounds, 3.5)
    d_coef = c4[0, 3 - dg[0]:].copy()
    n_inl = 0
    u_lo, u_hi = np.inf, -np.inf
    for j in range(m):
        if inl[j]:
            n_inl += 1
            u_lo, u_hi = min(u_lo, ug[j]), max(u_hi, ug[j])
    if degree == 1 and (n_inl < max(limits[0], limits[1] * n) or u_hi - u_lo < limits[2] * (hi - lo)):
        return 2, c4[0], t0[0], ts[0], dg[0], n_inl          # a line through a handful of matches (flatfit)
    if n_inl:
        r = np.empty(n_inl)
        i = 0
        for j in range(m):
            if inl[j]:
                r[i] = d_axis[j] - _horner(d_coef, (ug[j] - t0[0]) / ts[0])
                i += 1
        med = _median(r)
        for i in range(n_inl):
            r[i] = abs(r[i] - med)
        mad = _median(r)
        ok = (n_inl > limits[3] or mad <= limits[4]) if degree >= 1 else (n_inl > limits[5] or mad <= limits[6])
        if not ok:
            return 2, c4[0], t0[0], ts[0], dg[0], n_inl      # matches scattered over px: ambiguous bark (flatfit)
    return 1, c4[0], t0[0], ts[0], dg[0], n_inl


@numba.njit(**_JIT)
def flat_line(cols, yc, junction, nxy, thr, tab_t, centre_t, span_t, width):
    """``dense._flat_search``'s centre line: a flat piece's rows v(u) from the transposed mask's runs.

    The skeleton's centre ``yc`` at columns ``cols`` (N,) (:func:`single_edge.centre_guess`), points
    inside a junction region at the piece's ends left out (within ``thr`` of the junction's point
    ``nxy``, as ``dense._row_centres``), finds each column's run (``Runs.find`` of the transposed runs); with
    4 or more, a robust polynomial (:func:`curves.degree_for`) through the runs' centres and the
    radius (the median of the inliers' half heights across the line's slope).

    Parameters
    ----------
    cols, yc : (N,) float
        Columns and the skeleton's centre rows, px.
    junction : (2,) bool; nxy : (2, 2) float; thr : (2,) float
        Whether each end is a junction, its point (x, y) and its region's radius, px.
    tab_t : tuple of three (R + 1,) int64; centre_t, span_t : (R,) float
        ``Runs._find_tables``, centres and spans of the transposed mask's runs.
    width : int
        The transposed mask's width (the image height), px.

    Returns
    -------
    ok : bool
        False where ``_flat_search`` returns None (fewer than 4 points or runs).
    coef : (4,) float; t0, ts : float; degree : int
        The centre line v(u) (``coef[3 - degree:]``).
    radius, lo, hi : float
        Radius and the inliers' column span, px.
    """
    n = len(cols)
    keep = np.ones(n, np.bool_)
    m = 0
    for i in range(n):
        for k in range(2):
            if junction[k] and np.hypot(cols[i] - nxy[k, 0], yc[i] - nxy[k, 1]) < thr[k]:
                keep[i] = False
        m += keep[i]
    coef = np.zeros(4)
    if m < 4:
        return False, coef, 0.0, 1.0, 0, 0.0, 0.0, 0.0
    ci, yk = np.empty(m, np.int64), np.empty(m)
    j = 0
    for i in range(n):
        if keep[i]:
            ci[j], yk[j] = np.int64(cols[i]), yc[i]
            j += 1
    it = runs_find(tab_t[0], tab_t[1], tab_t[2], width, ci, yk)
    idx = np.flatnonzero(it >= 0)
    k = len(idx)
    if k < 4:
        return False, coef, 0.0, 1.0, 0, 0.0, 0.0, 0.0
    t, vc, hgt = np.empty(k), np.empty(k), np.empty(k)
    for j in range(k):
        t[j], vc[j], hgt[j] = np.float64(ci[idx[j]]), centre_t[it[idx[j]]], span_t[it[idx[j]]]
    span = t.max() - t.min()
    degree = 1 if k < 12 or span < 40 else (2 if span < 160 else 3)         # (curves.degree_for)
    c4, t0, ts, dg, inl = robust_fit_groups(t, vc, np.array([0, k], np.int64), np.full(1, degree, np.int64),
                                            np.full(1, 3, np.int64), 3.5)
    v_coef = c4[0, 3 - dg[0]:].copy()
    dv = _deriv(v_coef, ts[0])
    n_in = 0
    for j in range(k):
        n_in += inl[j]
    ratio = np.empty(n_in)
    lo, hi = np.inf, -np.inf
    i = 0
    for j in range(k):
        if inl[j]:
            slope = _horner(dv, (t[j] - t0[0]) / ts[0])
            ratio[i] = 0.5 * hgt[j] / np.sqrt(1 + slope * slope)
            lo, hi = min(lo, t[j]), max(hi, t[j])
            i += 1
    return True, c4[0], t0[0], ts[0], dg[0], _median(ratio), lo, hi


@numba.njit(**_JIT)
def coarse_agree(u, d, tol_px, tol_line_px):
    """``dense._coarse_agree``: whether a flat piece's coarse texture disparities ``d`` at columns ``u``
    (N,) agree (half of them, and 2, within ``tol_px`` of one; or from 4 on, half and 3 within
    ``tol_line_px`` of a line through two of them)."""
    n = len(d)
    if n <= 1:
        return True
    need = max(2, -(-n // 2))
    for i in range(n):
        c = 0
        for j in range(n):
            c += abs(d[i] - d[j]) <= tol_px
        if c >= need:
            return True
    if n < 4:
        return False
    for i in range(n):
        for j in range(i + 1, n):
            du = u[j] - u[i]
            if du == 0:
                continue
            slope = (d[j] - d[i]) / du
            c = 0
            for m in range(n):
                c += abs(d[m] - (d[i] + slope * (u[m] - u[i]))) <= tol_line_px
            if c >= max(3, need):
                return True
    return False


@numba.njit(**_JIT)
def _robust(t, y, degree, rounds):
    """``curves.robust_fit`` of one group: coef (4,) padded, t0, ts, degree, inliers (N,)."""
    c4, t0, ts, dg, inl = robust_fit_groups(t, y, np.array([0, len(t)], np.int64), np.full(1, degree, np.int64),
                                            np.full(1, rounds, np.int64), 3.5)
    return c4[0], t0[0], ts[0], dg[0], inl


@numba.njit(**_JIT)
def _poly4(c4, t0, ts, t):
    """A padded polynomial (``GroupPolys``' Horner over 4 coefficients) at ``t``."""
    x = (t - t0) / ts
    return ((x * c4[0] + c4[1]) * x + c4[2]) * x + c4[3]


@numba.njit(**_JIT)
def edge_consensus_piece(rows, xc, pts, tab_l, edges_l, keys_r, edges_r, width, taken, slopes, d_min, d_max,
                         radius_img, scale, f_px, cx_px, offset_px, tol_px, min_share, max_gradient):
    """``single_edge.edge_consensus`` of one piece, from its row centres on: its line d(row) voted from
    both edges' candidates, checked, moved onto the axis and fitted (the numpy steps; the sums and
    trigonometry equal up to rounding). The piece's right runs are marked ``taken`` when it gets a curve.

    Parameters
    ----------
    rows, xc : (N,) float
        The piece's rows and the skeleton's centre there (:func:`single_edge.centre_guess`), px.
    pts : (P, 2) float
        Its skeleton points (x, y), px (its angle from the rows).
    tab_l : tuple of three (R + 1,) int64; edges_l : (2, R) float
        The left runs' ``_find_tables`` and their left/right boundaries, px.
    keys_r : (R',) float; edges_r : (2, R') float
        The right runs' centre keys and boundaries, px.
    width : int
        Image width, px.
    taken : (R',) bool
        Right runs used by other curves (updated).
    slopes : (S,) float
        The vote's slopes, px per row.
    d_min, d_max : float
        Working disparity range, px.
    radius_img : (h, w) float32; scale : int
        The left mask's radius map.
    f_px, cx_px, offset_px, tol_px, min_share, max_gradient : float

    Returns
    -------
    ok : bool
        Whether the piece gets a curve; then:
    u_coef, d_coef : (4,) float; u_t0, u_ts, d_t0, d_ts : float; u_deg, d_deg : int
        Its centre line u(row) and disparity d(row) (padded coefficients).
    t_lo, t_hi, radius : float
        The disparity fit's inlier rows' span and the radius, px.
    n : int
        Inlier samples.
    end_slopes : (2,) float
        ``curves.end_slopes`` of the inliers' disparities.
    right_runs : (K,) int64
        The right runs used (sorted, distinct).
    """
    e0, i0, z4 = np.zeros(2), np.zeros(0, np.int64), np.zeros(4)
    fail = (False, z4, 0.0, 1.0, 0, z4, 0.0, 1.0, 0, 0.0, 0.0, 0.0, 0, e0, i0)
    n = len(rows)
    ri = np.empty(n, np.int64)
    for i in range(n):
        ri[i] = np.int64(rows[i])
    il = runs_find(tab_l[0], tab_l[1], tab_l[2], width, ri, xc)
    sel = np.flatnonzero(il >= 0)
    ri, il = ri[sel], il[sel]
    m = len(ri)
    if m < 12:
        return fail
    a_l, b_l = np.empty(m), np.empty(m)
    lo_q, hi_q = np.empty(m), np.empty(m)
    for i in range(m):
        a_l[i], b_l[i] = edges_l[0, il[i]], edges_l[1, il[i]]
        lo_q[i], hi_q[i] = a_l[i] - d_max, b_l[i] - d_min
    q, rr = runs_between(keys_r, ri, width, lo_q, hi_q)
    keep = np.flatnonzero(~taken[rr])
    q, rr = q[keep], rr[keep]
    nq = len(q)
    if nq < 12:
        return fail
    nc = 2 * nq
    cand_t, cand_d, cand_q = np.empty(nc), np.empty(nc), np.empty(nc, np.int64)
    for i in range(nq):
        cand_t[i] = cand_t[nq + i] = np.float64(ri[q[i]])
        cand_d[i] = a_l[q[i]] - edges_r[0, rr[i]]
        cand_d[nq + i] = b_l[q[i]] - edges_r[1, rr[i]]
        cand_q[i] = cand_q[nq + i] = q[i]
    tm = np.sum(cand_t) / nc
    lo, k_s, k_b = line_vote(cand_t, cand_d, slopes, tm, tol_px)
    on = np.zeros(nc, np.bool_)
    rows_on = np.zeros(m, np.bool_)
    for c in range(nc):
        line = lo + (k_b + 1) * tol_px + slopes[k_s] * (cand_t[c] - tm)
        on[c] = abs(cand_d[c] - line) <= 1.5 * tol_px
        if on[c]:
            rows_on[cand_q[c]] = True
    need = max(12, min_share * m)
    if np.sum(rows_on) < need:
        return fail
    idx = np.flatnonzero(on)
    ts, ds = cand_t[idx], cand_d[idx]
    c4, t0, tsc, dg, inl = _robust(ts, ds, 1, 3)
    for j in range(len(idx)):
        inl[j] &= abs(ds[j] - _poly4(c4, t0, tsc, ts[j])) <= tol_px
    idx = idx[inl]
    ts, ds = cand_t[idx], cand_d[idx]
    if _n_distinct(ts) < need:
        return fail
    t_min, t_max = ts.min(), ts.max()
    d0, d1 = _poly4(c4, t0, tsc, t_min), _poly4(c4, t0, tsc, t_max)
    if min(d0, d1) < 0.95 * d_min or max(d0, d1) > 1.05 * d_max or \
            abs(d1 - d0) > max_gradient * max(t_max - t_min, 1.0):
        return fail
    k = len(idx)
    w = np.empty(k)
    side, runs_k = np.empty(k), np.empty(k, np.int64)
    for j in range(k):
        c = idx[j]
        side[j] = -1.0 if c < nq else 1.0
        runs_k[j] = rr[c % nq]
        w[j] = max(edges_l[1, il[cand_q[c]]] - edges_l[0, il[cand_q[c]]], edges_r[1, runs_k[j]] - edges_r[0, runs_k[j]])
    half_px = 0.5 * _percentile75(w)
    h, wr = radius_img.shape
    rad = np.empty(n)
    for i in range(n):
        x = min(max(np.int64(np.rint((xc[i] + 0.5) / scale - 0.5)), 0), wr - 1)
        y = min(max(np.int64(np.rint((rows[i] + 0.5) / scale - 0.5)), 0), h - 1)
        rad[i] = radius_img[y, x]
    r_px = _median(rad)
    mx, my = np.sum(pts[:, 0]) / len(pts), np.sum(pts[:, 1]) / len(pts)        # (curves.angle_deg)
    sxx = syy = sxy = 0.0
    for i in range(len(pts)):
        cx_, cy_ = pts[i, 0] - mx, pts[i, 1] - my
        sxx += cx_ * cx_
        syy += cy_ * cy_
        sxy += cx_ * cy_
    angle = abs(np.degrees(0.5 * np.arctan2(2 * sxy, sxx - syy)))
    sin_t = max(np.sin(np.radians(angle)), 0.2)
    if half_px > 2.0 * r_px / sin_t + 2:
        return fail
    u, d_ax = np.empty(k), np.empty(k)
    for j in range(k):
        e_l = a_l[cand_q[idx[j]]] if side[j] < 0 else b_l[cand_q[idx[j]]]
        u[j] = e_l - side[j] * half_px
        d_ax[j] = edge_to_axis_one(u[j], ds[j], half_px, side[j], f_px, cx_px, offset_px)
    span = t_max - t_min
    nd = _n_distinct(ts)
    degree = min(1 if nd < 12 or span < 40 else (2 if span < 160 else 3), 2)          # (curves.degree_for)
    uc, ut0, uts, udg, _ = _robust(ts, u, degree, 3)
    dc, dt0, dts, ddg, inl_d = _robust(ts, d_ax, degree, 3)
    sel = np.flatnonzero(inl_d)
    t_in, d_in = ts[sel], d_ax[sel]
    du = _deriv(uc[3 - udg:].copy(), uts)
    slope = np.empty(len(sel))
    for j in range(len(sel)):
        slope[j] = _horner(du, (t_in[j] - ut0) / uts)
    radius = half_px / np.sqrt(1 + _mean(slope) ** 2)
    dev = np.empty(n)
    for i in range(n):
        dev[i] = abs(_poly4(uc, ut0, uts, rows[i]) - xc[i])
    if _median(dev) > 0.5 * half_px + 2:
        return fail                     # not this piece's centre line (another branch's edges)
    slopes_end = end_slopes_groups(t_in, d_in, np.zeros(len(sel), np.intp), 1, 60.0)[0]
    used = _distinct_ints(runs_k[sel])
    taken[used] = True
    return (True, uc, ut0, uts, udg, dc, dt0, dts, ddg, t_in.min(), t_in.max(), radius, len(sel), slopes_end, used)


@numba.njit(**_JIT)
def disparity_refit(tf, df, bc, te, de, be, degree):
    """``dense.fit_steep_many``'s final disparity fits, all pieces at once.

    A piece with single-edge samples (``te``, ``de``) has its disparity refitted robustly to all its
    samples (whole crossings first, then single edges; :func:`curves.degree_for` of them), and keeps
    the inliers; a piece without keeps its whole crossings (``tf``, ``df``). Each piece's disparity
    is then a least-squares fit to those (:func:`kernels_fit.fit_groups`), with the straight lines' slopes
    at its ends (:func:`kernels_fit.end_slopes_groups`).

    Parameters
    ----------
    tf, df : (N,) float
        Whole crossings' rows and disparities (px), piece ``k``'s at ``bc[k]:bc[k + 1]``.
    te, de : (M,) float
        Single edges' rows and disparities, piece ``k``'s at ``be[k]:be[k + 1]``.
    degree : (G,) int64
        Each piece's degree without single edges.

    Returns
    -------
    coef : (G, 4) float; t0, ts : (G,) float; deg : (G,) int64
        The disparity polynomials (``curves.GroupPolys``).
    slopes : (G, 2) float
        Their end slopes (low end, high end), px per row.
    t_lo, t_hi : (G,) float
        Rows spanned by the samples fitted (NaN where none), px.
    n : (G,) int64
        Samples fitted.
    """
    ng = len(degree)
    has = np.zeros(ng, np.bool_)
    starts = np.zeros(ng + 1, np.int64)
    deg2 = np.ones(ng, np.int64)
    for k in range(ng):
        has[k] = be[k + 1] > be[k]
        m = (bc[k + 1] - bc[k] + be[k + 1] - be[k]) if has[k] else 0
        starts[k + 1] = starts[k] + m
    ts_, ds_ = np.empty(starts[ng]), np.empty(starts[ng])
    for k in range(ng):
        if not has[k]:
            continue
        j = starts[k]
        lo, hi = np.inf, -np.inf
        for a, b, t, d in ((bc[k], bc[k + 1], tf, df), (be[k], be[k + 1], te, de)):
            for i in range(a, b):
                ts_[j], ds_[j] = t[i], d[i]
                lo, hi = min(lo, t[i]), max(hi, t[i])
                j += 1
        n_k, span = starts[k + 1] - starts[k], hi - lo
        deg2[k] = 1 if n_k < 12 or span < 40 else (2 if span < 160 else 3)      # (curves.degree_for)
    inl = robust_fit_groups(ts_, ds_, starts, deg2, np.full(ng, 3, np.int64), 3.5)[4]
    bd = np.zeros(ng + 1, np.int64)
    for k in range(ng):
        c = 0
        if has[k]:
            for i in range(starts[k], starts[k + 1]):
                c += inl[i]
        else:
            c = bc[k + 1] - bc[k]
        bd[k + 1] = bd[k] + c
    td, dd, gd = np.empty(bd[ng]), np.empty(bd[ng]), np.empty(bd[ng], np.intp)
    fit_deg = np.empty(ng, np.int64)
    t_lo, t_hi = np.full(ng, np.nan), np.full(ng, np.nan)
    for k in range(ng):
        j = bd[k]
        if has[k]:
            fit_deg[k] = deg2[k]
            for i in range(starts[k], starts[k + 1]):
                if inl[i]:
                    td[j], dd[j] = ts_[i], ds_[i]
                    j += 1
        else:
            fit_deg[k] = degree[k]
            for i in range(bc[k], bc[k + 1]):
                td[j], dd[j] = tf[i], df[i]
                j += 1
        for i in range(bd[k], bd[k + 1]):
            gd[i] = k
            if i == bd[k]:
                t_lo[k], t_hi[k] = td[i], td[i]
            t_lo[k], t_hi[k] = min(t_lo[k], td[i]), max(t_hi[k], td[i])
    coef, t0, ts, deg = fit_groups(td, dd, bd, fit_deg)
    slopes = end_slopes_groups(td, dd, gd, ng, 60.0)
    return coef, t0, ts, deg, slopes, t_lo, t_hi, bd[1:] - bd[:-1]


@numba.njit(**_JIT)
def width_disagree(chosen, q, cw, gq, t, w_l, degree, ng, tol_px, share, junction_row):
    """The picks whose left and right crossings are about as wide as the piece's other rows.

    A leaf or an apple covering one edge of a branch in one view only leaves that view's run
    narrower on those rows: its centre, so the row's disparity, moves by half the hidden width
    (seed 263 T3: a trunk's right edge covered in the right view over 18 rows, disparity +5 px and
    a quadratic carrying it 30 rows on to the fork). Both views see the same taper on a row, so
    the right-minus-left width of a piece only drifts slowly (the views' distances to the axis);
    a pick ``tol_px + share * w`` off the piece's median is not a whole crossing. Pieces with fewer
    than 8 picks, or where fewer than half (or 4) would remain, keep all theirs; so does a piece whose
    pick nearest one of its junctions would be dropped and lies within one width (rows) of that
    junction's row: next to a fork the views' silhouettes differ
    in width anyway (the crotch), and a side shortened there is carried to its fork from rows further
    off while the fork's other side reads it (seed 273 T9: withheld as a conflict of its sides instead).

    Parameters
    ----------
    chosen : (C,) int64
        The picks (candidate indices; their pieces ``gq[chosen]`` non-decreasing).
    q, cw, gq : (K,)
        Candidates' row index into ``t``, right width (px) and piece; ``w_l`` (M,) left widths, px.
    degree : (G,) int64
        The pieces' degrees.
    junction_row : (G, 2) float
        The row (px, as ``t``) of each piece's junction ends; NaN where that end is not a junction.

    Returns
    -------
    keep : (C,) bool
    degree : (G,) int64
        :func:`curves.degree_for` of the rows kept, for the pieces that lost picks (the others' as given).
    lost : (G,) bool
        The pieces that lost picks.
    """
    c = len(chosen)
    keep = np.ones(c, np.bool_)
    lost = np.zeros(ng, np.bool_)
    degree = degree.copy()
    starts = np.searchsorted(gq[chosen], np.arange(ng + 1))
    for k in range(ng):
        a, b = starts[k], starts[k + 1]
        if b - a < 8:
            continue
        dw = np.empty(b - a)
        for j in range(a, b):
            i = chosen[j]
            dw[j - a] = cw[i] - w_l[q[i]]
        med = _median(dw)
        for j in range(a, b):
            i = chosen[j]
            dw[j - a] = (dw[j - a] - med) / (tol_px + share * w_l[q[i]])     # (in tolerances)
            keep[j] = abs(dw[j - a]) <= 1.0
        m, lo, hi = 0, np.inf, -np.inf
        for j in range(a, b):
            if keep[j]:
                m += 1
                lo, hi = min(lo, t[q[chosen[j]]]), max(hi, t[q[chosen[j]]])
        at_fork = False
        for e in range(2):
            jr = junction_row[k, e]
            if not np.isnan(jr):
                jn, dn = a, np.inf
                for j in range(a, b):
                    dj = abs(t[q[chosen[j]]] - jr)
                    if dj < dn:
                        jn, dn = j, dj
                at_fork = at_fork or (not keep[jn] and dn <= w_l[q[chosen[jn]]])
        if m < max(4, 0.5 * (b - a)) or at_fork:
            keep[a:b] = True
        elif m < b - a:
            lost[k] = True
            degree[k] = min(degree[k], 1 if m < 12 or hi - lo < 40 else (2 if hi - lo < 160 else 3))
    return keep, degree, lost


@numba.njit(**_JIT)
def steep_fit(t, alive, n, degree, q, rr, cd, cw, gq, c_l, w_l, m_coef, m_t0, m_ts, rows_all, il_all, g_all,
              tab_r, edges_l, edges_r, width, taken, occl_tol_px=-1.0, occl_share=0.0, f_px=1.0, cx_px=0.0,
              offset_px=0.0, junction_row=np.full((0, 2), np.nan)):
    """``dense.fit_steep_many``'s middle steps: each row's candidate nearest the model, twice (the
    consensus lines, then a robust fit of the picks, 1 round; then 3 rounds), the centre line and the
    width fitted to the picks, and the single-edge samples of the other rows
    (``single_edge.edge_samples`` as it was).

    Parameters
    ----------
    t : (M,) float
        The rows (px) of the pieces' left crossings; ``alive`` (G,) bool (updated copy returned),
        ``n`` (G,) rows per piece, ``degree`` (G,) int64.
    q, rr, cd, cw, gq : (K,)
        Candidates: row index into ``t``, right run, disparity and right width (px), piece.
    c_l, w_l : (M,) float
        Left crossings' centres and widths, px.
    m_coef, m_t0, m_ts : (G, 4), (G,), (G,) float
        The consensus lines (``dense._consensus_lines``).
    rows_all, il_all, g_all : (A,) int64
        Every row with a left crossing: row, left run, piece.
    tab_r : ``Runs._find_tables`` of the right runs; ``edges_l``, ``edges_r``: (2, R) boundaries, px.
    width : int
        Image width, px. ``taken`` (R',) bool or empty: right runs of other pieces.
    occl_tol_px, occl_share : float
        With ``occl_tol_px >= 0``, picks whose right-minus-left width is more than ``occl_tol_px +
        occl_share * w`` px (w: the left width) off its piece's median are dropped and the model
        refitted without them (:func:`width_disagree`: an edge hidden in one view only), and those
        pieces' single edges taken to their axis (:func:`edge_to_axis_one`; ``f_px``, ``cx_px``,
        ``offset_px`` as there; ``junction_row`` (G, 2): :func:`width_disagree`'s); negative: off.

    Returns
    -------
    ok : bool
        False where the fit returns no curve (no piece left).
    alive : (G,) bool
    tf, df, cf, wf : (C,) float; gc, rc : (C,) int64
        The picks (per piece, by row): row, disparity, left centre, mean width (px), piece, right run.
    u_inl : (C,) bool
        The centre line's inliers.
    te, de : (E,) float; re, ge : (E,) int64
        Single-edge samples (per piece, left edges first): row, disparity, right run, piece.
    degree : (G,) int64
        The pieces' degrees (lowered where :func:`width_disagree` dropped picks).
    """
    ng = len(alive)
    alive = alive.copy()
    coef, t0, ts = m_coef.copy(), m_t0.copy(), m_ts.copy()
    inl = np.zeros(0, np.bool_)
    chosen = np.zeros(0, np.int64)
    z, zi, zb = np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.bool_)
    for it in range(2):
        tol = 2.0 if it == 0 else 0.75
        sel = np.flatnonzero(alive[gq])
        q, rr, cd, cw, gq = q[sel], rr[sel], cd[sel], cw[sel], gq[sel]
        res = np.empty(len(q))
        for i in range(len(q)):
            k = gq[i]
            x = (t[q[i]] - t0[k]) / ts[k]
            res[i] = abs(cd[i] - (((x * coef[k, 0] + coef[k, 1]) * x + coef[k, 2]) * x + coef[k, 3]))
        first = nearest_per_query(q, res)
        cnt = np.zeros(ng, np.int64)
        m = 0
        for j in range(len(first)):
            if res[first[j]] <= tol:
                first[m] = first[j]
                cnt[gq[first[j]]] += 1
                m += 1
        for k in range(ng):
            alive[k] &= cnt[k] >= max(4.0, 0.25 * n[k])
        chosen = np.empty(m, np.int64)
        c = 0
        for j in range(m):
            if alive[gq[first[j]]]:
                chosen[c] = first[j]
                c += 1
        chosen = chosen[:c]
        if not alive.any():
            return False, alive, z, z, z, z, zi, zi, zb, z, z, zi, zi, degree
        tq, dq = np.empty(c), np.empty(c)
        for j in range(c):
            tq[j], dq[j] = t[q[chosen[j]]], cd[chosen[j]]
        starts = np.searchsorted(gq[chosen], np.arange(ng + 1))
        coef, t0, ts, _, inl = robust_fit_groups(tq, dq, starts, degree, np.full(ng, 1 if it == 0 else 3, np.int64),
                                                 3.5)
    chosen = chosen[inl]
    lost = np.zeros(ng, np.bool_)
    if occl_tol_px >= 0:
        keep, degree, lost = width_disagree(chosen, q, cw, gq, t, w_l, degree, ng, occl_tol_px, occl_share,
                                            junction_row)
        if lost.any():                  # those pieces' models refitted without the dropped picks
            chosen = chosen[keep]
            relo = np.flatnonzero(lost)
            sub = np.flatnonzero(lost[gq[chosen]])
            tq, dq = np.empty(len(sub)), np.empty(len(sub))
            for j in range(len(sub)):
                tq[j], dq[j] = t[q[chosen[sub[j]]]], cd[chosen[sub[j]]]
            g_sub = np.searchsorted(relo, gq[chosen[sub]])
            starts = np.searchsorted(g_sub, np.arange(len(relo) + 1))
            c2, t02, ts2, _, inl2 = robust_fit_groups(tq, dq, starts, degree[relo], np.full(len(relo), 3, np.int64),
                                                      3.5)
            for i in range(len(relo)):
                coef[relo[i]], t0[relo[i]], ts[relo[i]] = c2[i], t02[i], ts2[i]
            inl = np.ones(len(chosen), np.bool_)
            inl[sub] = inl2
            chosen = chosen[inl]
    nc = len(chosen)
    tf, df, cf, wf = np.empty(nc), np.empty(nc), np.empty(nc), np.empty(nc)
    gc, rc = np.empty(nc, np.int64), np.empty(nc, np.int64)
    t2, y2 = np.empty(2 * nc), np.empty(2 * nc)
    for j in range(nc):
        i = chosen[j]
        tf[j], df[j], cf[j] = t[q[i]], cd[i], c_l[q[i]]
        wf[j] = 0.5 * (w_l[q[i]] + cw[i])
        gc[j], rc[j] = gq[i], rr[i]
        t2[j], t2[nc + j] = tf[j], tf[j]
        y2[j], y2[nc + j] = cf[j], w_l[q[i]]
    # the centre line (1 round) and the width (a line, 2 rounds) as groups 0..ng-1 and ng..2ng-1
    bc = np.searchsorted(gc, np.arange(ng + 1))
    starts = np.concatenate((bc, nc + bc[1:]))
    deg2, rounds = np.ones(2 * ng, np.int64), np.full(2 * ng, 2, np.int64)
    deg2[:ng] = degree
    rounds[:ng] = 1
    uw, u0, us, _, uw_inl = robust_fit_groups(t2, y2, starts, deg2, rounds, 3.5)
    u_inl = uw_inl[:nc].copy()
    # the other rows of the live pieces: single edges
    wd = 0
    for i in range(len(rows_all)):
        wd = max(wd, rows_all[i])
    wd += 1
    top = 0
    for i in range(len(rows_all)):
        top = max(top, g_all[i] * wd + rows_all[i])
    for j in range(nc):
        top = max(top, gc[j] * wd + np.int64(tf[j]))
    used = np.zeros(top + 1, np.bool_)
    for j in range(nc):
        used[gc[j] * wd + np.int64(tf[j])] = True
    rest = np.zeros(len(rows_all), np.bool_)
    for i in range(len(rows_all)):
        rest[i] = not used[g_all[i] * wd + rows_all[i]] and alive[g_all[i]]
    idx = np.flatnonzero(rest)
    nr = len(idx)
    ri, tr = np.empty(nr, np.int64), np.empty(nr)
    u, half, d = np.empty(nr), np.empty(nr), np.empty(nr)
    for j in range(nr):
        i = idx[j]
        k = g_all[i]
        ri[j], tr[j] = rows_all[i], np.float64(rows_all[i])
        x = (tr[j] - u0[k]) / us[k]
        u[j] = ((x * uw[k, 0] + uw[k, 1]) * x + uw[k, 2]) * x + uw[k, 3]
        x = (tr[j] - u0[ng + k]) / us[ng + k]
        half[j] = 0.5 * (((x * uw[ng + k, 0] + uw[ng + k, 1]) * x + uw[ng + k, 2]) * x + uw[ng + k, 3])
        x = (tr[j] - t0[k]) / ts[k]
        d[j] = ((x * coef[k, 0] + coef[k, 1]) * x + coef[k, 2]) * x + coef[k, 3]
    has_taken = len(taken) > 0
    okk = np.zeros((2, nr), np.bool_)
    irs = np.empty((2, nr), np.int64)
    de2 = np.empty((2, nr))
    qx = np.empty(nr)
    for side_k in range(2):
        side = -1.0 if side_k == 0 else 1.0
        for j in range(nr):
            qx[j] = edges_l[side_k, il_all[idx[j]]] - d[j] - side * 1.0
        irs[side_k] = runs_find(tab_r[0], tab_r[1], tab_r[2], width, ri, qx)
        for j in range(nr):
            e_l = edges_l[side_k, il_all[idx[j]]]
            ir = irs[side_k, j]
            e_r = edges_r[side_k, max(ir, 0)]
            de2[side_k, j] = e_l - e_r
            if lost[g_all[idx[j]]]:
                # (such a piece's single edges carry its occluded rows: a thick branch's outlines are
                # tangents from each camera, +-1.6 px of disparity off its axis at r = 34 px, 900 mm)
                de2[side_k, j] = edge_to_axis_one(u[j], e_l - e_r, half[j], side, f_px, cx_px, offset_px)
            okk[side_k, j] = abs(e_l - (u[j] + side * half[j])) <= 1.0 and ir >= 0 \
                and abs(de2[side_k, j] - d[j]) <= 1.0 and not (has_taken and taken[max(ir, 0)])
    ne = 0
    for side_k in range(2):
        for j in range(nr):
            ne += okk[side_k, j]
    te, de = np.empty(ne), np.empty(ne)
    re, ge = np.empty(ne, np.int64), np.empty(ne, np.int64)
    e = 0
    for k in range(ng):                 # per piece (stable), its left edges first (edge_samples' order)
        for side_k in range(2):
            for j in range(nr):
                if okk[side_k, j] and g_all[idx[j]] == k:
                    te[e], de[e], re[e], ge[e] = tr[j], de2[side_k, j], irs[side_k, j], k
                    e += 1
    return True, alive, tf, df, cf, wf, gc, rc, u_inl, te, de, re, ge, degree


@numba.njit(**_JIT)
def steep_radii(tf, wf, bc, live, coef, t0, ts):
    """``dense.fit_steep_many``'s radius of each live curve, with numpy's values: the median over the
    curve's samples of half their width across its centre line, ``0.5 * w / sqrt(1 + u'(t) ** 2)``.

    Parameters
    ----------
    tf, wf : ndarray (N,) float64
        The picks' rows and widths, px (curve k's: ``bc[k]:bc[k + 1]``).
    bc : ndarray (G + 1,) int64
    live : ndarray (L,) int64
        The live curves.
    coef : ndarray (L, 4) float64
        Their centre lines' ``Poly`` coefficients, highest power first, zero-padded in front; ``t0``,
        ``ts`` (L,) their scalings. The derivative is ``Poly.deriv``'s (``c * k / ts``), evaluated by
        ``GroupPolys``' Horner sum over the padded coefficients.

    Returns
    -------
    ndarray (L,) float64
        Radii, px.
    """
    out = np.empty(len(live))
    for i in range(len(live)):
        k = live[i]
        a, b = bc[k], bc[k + 1]
        d0 = 0.0
        d1 = coef[i, 0] * 3.0 / ts[i]
        d2 = coef[i, 1] * 2.0 / ts[i]
        d3 = coef[i, 2] * 1.0 / ts[i]
        r = np.empty(b - a)
        for j in range(a, b):
            x = (tf[j] - t0[i]) / ts[i]
            y = x * d0 + d1
            y = y * x + d2
            s = y * x + d3
            r[j - a] = 0.5 * wf[j] / np.sqrt(1 + s * s)
        out[i] = _median(r)
    return out


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



def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    tab = tuple(_readonly(np.zeros(2, np.int64)) for _ in range(3))
    f = np.zeros(1)
    ro = _readonly(np.zeros((2, 1)))
    edge_track(tab, tab, ro, ro, 4, f, f, f, f, f, 4.0, 1000.0, 0.0, 0.0)
    r1 = _readonly(np.zeros(1))
    for taken in (np.zeros(0, np.bool_), np.zeros(1, np.bool_)):
        steep_candidates(f, f, np.zeros(1, np.int64), f, tab, r1, r1, r1, r1, r1, 4, np.zeros((1, 1), np.float32), 1,
                         1.0, 2.0, taken)
    f3 = np.zeros(3)
    flat_finish(f3, f3, f3, f3, np.zeros((2, 2), np.uint8), f3, 0.0, 1.0, 2.0, 1, 0.0, 1.0, 1000.0, 0.0, True,
                np.full(8, 100.0))
    flat_line(f3, f3, np.zeros(2, np.bool_), np.zeros((2, 2)), np.zeros(2), tab, r1, r1, 4)
    coarse_agree(f3, f3, 6.0, 2.0)
    edge_consensus_piece(f, f, np.zeros((1, 2)), tab, ro, r1, ro, 4, np.zeros(1, np.bool_), f3, 1.0, 2.0,
                         np.zeros((1, 1), np.float32), 1, 1000.0, 0.0, 0.0, 1.0, 0.5, 0.25)
    b2 = np.array([0, 3], np.int64)
    disparity_refit(f3, f3, b2, f3, f3, b2, np.ones(1, np.int64))
    i1, b1, f4 = np.zeros(1, np.int64), np.ones(1, np.bool_), np.zeros((1, 4))
    for taken in (np.zeros(0, np.bool_), np.zeros(1, np.bool_)):
        steep_fit(f, b1, i1, i1, i1, i1, f, f, i1, f, f, f4, f, np.ones(1), i1, i1, i1, tab, ro, ro, 4, taken,
                  OCCL_TOL_PX, OCCL_SHARE, 1000.0, 0.0, 0.0, np.full((1, 2), np.nan))
    steep_radii(f3, f3, b2, np.zeros(1, np.int64), f4, f, np.ones(1))      # (twelfth pass, speedsteep)
    f = np.zeros(4)
    consensus_lines(np.arange(4.0), f, np.array([0, 4], np.int64), np.zeros(1, np.int64), np.zeros((2, 1, 2), np.int64),
                    1.5)
    line_vote(np.zeros(2), np.zeros(2), np.zeros(3), 0.0, 1.0)
    centre_line(np.zeros(2), np.zeros(2), 0.5)
    nearest_per_query(np.zeros(2, np.int64), np.zeros(2))
    near_junctions(np.zeros(1), np.zeros(1), np.zeros(1, np.int64), np.zeros((1, 2), np.bool_), np.zeros((1, 2, 2)),
                   np.zeros((1, 2)))
