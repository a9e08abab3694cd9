"""Compiled kernels of the dense path (seventh pass, speedD; docs/localize-numba.md).

Whole functions of :mod:`single_edge` and :mod:`dense` as one compiled loop each, with the same
rules as the numpy code they replace. They agree with it up to rounding: the trigonometry of
:func:`edge_to_axis` and the means are not numpy's bit for bit (checked per feature on the
60-scene benchmark; tests/localize/test_kernels_speedD.py against the numpy versions).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _median, _readonly, robust_fit_groups, runs_between, runs_find


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
    t_in = np.sort(ts[keep])
    distinct = 0
    for i in range(n_in):
        if i == 0 or t_in[i] != t_in[i - 1]:
            distinct += 1
    if distinct < need:
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
    return seg_idx, r3, il3, w3, g3, rows_all, il_all, g_all, n, alive, c_l, q, rr, cd, cw


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
