"""Compiled kernels of the dense path (seventh pass, speedD; docs/localize-numba.md).

Whole functions of :mod:`single_edge` and :mod:`dense` as one compiled loop each, with the same
rules as the numpy code they replace. They agree with it up to rounding: the trigonometry of
:func:`edge_to_axis` and the means are not numpy's bit for bit (checked per feature on the
60-scene benchmark; tests/localize/test_kernels_speedD.py against the numpy versions).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT, _median, _readonly, robust_fit_groups, runs_find


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


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    tab = tuple(_readonly(np.zeros(2, np.int64)) for _ in range(3))
    f = np.zeros(1)
    ro = _readonly(np.zeros((2, 1)))
    edge_track(tab, tab, ro, ro, 4, f, f, f, f, f, 4.0, 1000.0, 0.0, 0.0)
