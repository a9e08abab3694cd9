"""Compiled kernels of the match stage's per-curve glue: a curve's samples, its side test, the runs near
points and the flat search's line (docs/localize-numba.md).

Each gives the values of the numpy / Python-float steps it replaces, bit for bit on every call recorded
(fixtures 00-03, both mask sources) and on the 60 scenes:

- :func:`piece_uvd`: :func:`dense._piece_uvd` of a curve whose centre line and disparity are
  :class:`curves.Poly` (the samples along the span, ``BranchCurve.uvd``; their orientation,
  ``dense._oriented``; the end nodes joined or the curve carried towards them): ``curves.linspace``'s,
  ``Poly.__call__``'s and ``BranchCurve._at``'s sums (``kernels_fit.eval_clamped``'s values, point by point).
  The orientation's two distances are libm's ``hypot``: Python's ``math.hypot`` may differ in the last
  bit, which decides only between two distances that are equal.
- :func:`wider_on_right`: :meth:`tipends.TipPlacing._wider_on_right` of a Poly curve (the mean slope in
  numpy's pairwise order, ``Runs.find`` by bisection).
- :func:`runs_near`: :func:`subpixel.near_points`' grid of cells and its look-up (numpy's slice rules).
- :func:`flat_search_line`: :func:`dense._flat_search` up to its image reads (the centre line by
  ``kernels_dense.flat_line``, the patches along it by ``np.arange``'s values, the coarse patches, the
  boxes).

Tests: tests/localize/test_kernels_match.py.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from appliance.localize.curves import Poly
from appliance.localize.kernels import _JIT
from appliance.localize.kernels_dense import centre_line
from appliance.localize.kernels_fit import _horner
from appliance.localize.kernels_stats import _pairwise
from appliance.localize.kernels_dense import flat_line


_NO_SLOPES = np.zeros(2)


def curve_args(c) -> tuple | None:
    """A :class:`curves.BranchCurve`'s polynomials as the kernels here take them: ``(s_coef, s_dcoef, s_t0,
    s_ts, d_coef, d_dcoef, d_t0, d_ts, lo, hi, d_slopes, own_d_slopes)`` (contiguous float64 coefficients,
    the derivatives' from ``Poly.deriv``); None unless both are :class:`curves.Poly` over a finite span."""
    sp, dp = c.s_poly, c.d_poly
    lo, hi = c.t_range
    if type(sp) is not Poly or type(dp) is not Poly or not (math.isfinite(lo) and math.isfinite(hi)):
        return None
    sl = c.d_end_slopes
    f = np.ascontiguousarray
    return (f(sp.coef, float), f(sp._deriv.coef, float), float(sp.t0), float(sp.ts), f(dp.coef, float),
            f(dp._deriv.coef, float), float(dp.t0), float(dp.ts), float(lo), float(hi),
            _NO_SLOPES if sl is None else np.array(sl, float), sl is None)


@numba.njit(**_JIT)
def _linspace(lo, hi, n):
    """``curves.linspace(lo, hi, n)`` (n >= 2): numpy's steps, the same values."""
    t = np.empty(n)
    delta = hi - lo
    div = n - 1
    step = delta / div
    for i in range(n):
        t[i] = (i / div) * delta + lo if step == 0 else i * step + lo
    t[n - 1] = hi
    return t


@numba.njit(**_JIT)
def _at(coef, dcoef, t0, ts, lo, hi, slopes, own_slopes, t1):
    """``BranchCurve._at``: the polynomial at ``t1`` inside [lo, hi], beyond it carried on along the end's
    slope (the derivative's when ``own_slopes``, else ``slopes`` (2,))."""
    tc1 = min(max(t1, lo), hi)
    if tc1 == t1:
        return _horner(coef, (tc1 - t0) / ts)
    if own_slopes:
        slope = _horner(dcoef, (tc1 - t0) / ts)
    else:
        slope = slopes[0] if t1 < lo else slopes[1]
    return _horner(coef, (tc1 - t0) / ts) + slope * (t1 - tc1)


@numba.njit(**_JIT)
def piece_uvd(s_coef, s_dcoef, s_t0, s_ts, d_coef, d_dcoef, d_t0, d_ts, lo, hi, d_slopes, own_d_slopes, by_row,
              ends, has_end, node_xy, has_xy, reach_px, step_px):
    """``dense._piece_uvd`` of a curve with Poly centre line and disparity.

    Parameters
    ----------
    s_coef, s_dcoef, s_t0, s_ts : ndarray (K,), ndarray (K - 1 or 1,), float, float
        The centre line ``s(t)``: its coefficients, its derivative's, its scaling.
    d_coef, d_dcoef, d_t0, d_ts
        The disparity ``d(t)``, likewise.
    lo, hi : float
        The fitted span of t (finite), px.
    d_slopes : ndarray (2,)
        The disparity's end slopes (``d_end_slopes``), px per px; its own derivative's when ``own_d_slopes``.
    by_row : bool
        t is the row v (else the column u).
    ends : ndarray (2, 3)
        The start and end nodes' placed (u, v, d), px, where ``has_end``.
    has_end : ndarray (2,) bool
    node_xy : ndarray (2, 2)
        Their skeleton positions (x, y), px, where ``has_xy``.
    has_xy : ndarray (2,) bool
    reach_px, step_px : float
        How far the curve is carried towards an end node at most; the samples' step in t.

    Returns
    -------
    ndarray (N, 3)
        (u, v, d) from the start node to the end node, px.
    """
    ax = 1 if by_row else 0
    n = max(2, int(np.ceil((hi - lo) / step_px)) + 1)
    t = _linspace(lo, hi, n)
    # dense._oriented: from the start node's point (or towards the end node's); its distances from the
    # span's two ends (BranchCurve.uvd's first and last samples)
    flip = False
    if has_end[0] or has_end[1]:
        k = 0 if has_end[0] else 1
        ta, tb = (t[n - 1], t[0]) if k == 0 else (t[0], t[n - 1])
        sa, sb = _horner(s_coef, (ta - s_t0) / s_ts), _horner(s_coef, (tb - s_t0) / s_ts)
        ua, va, ub, vb = (sa, ta, sb, tb) if by_row else (ta, sa, tb, sb)
        flip = math.hypot(ua - ends[k, 0], va - ends[k, 1]) < math.hypot(ub - ends[k, 0], vb - ends[k, 1])
    # each end: joined where its disparity is the curve's there (2 px or 3 %), else the curve carried on
    # (n_ext[k] points, the start's run towards the curve)
    ext = np.empty((10, 3))
    n_ext = np.zeros(2, np.int64)
    for k in range(2):
        keep = False
        if has_end[k]:
            dk = _at(d_coef, d_dcoef, d_t0, d_ts, lo, hi, d_slopes, own_d_slopes, ends[k, ax])
            keep = abs(ends[k, 2] - dk) <= max(2.0, 0.03 * ends[k, 2])
        if keep:
            for c in range(3):
                ext[5 * k, c] = ends[k, c]
            n_ext[k] = 1
            continue
        if not has_xy[k]:
            continue
        t_n = node_xy[k, ax]
        t_near = t[(n - 1 if flip else 0) if k == 0 else (0 if flip else n - 1)]
        if abs(t_n - t_near) < 2:
            continue
        te = _linspace(t_near, t_near + min(max(t_n - t_near, -reach_px), reach_px), 6)
        for i in range(5):                      # (kernels_fit.eval_clamped's values, point by point: finite t)
            j = 5 * k + (4 - i if k == 0 else i)
            ext[j, ax] = te[i + 1]
            ext[j, 1 - ax] = _at(s_coef, s_dcoef, s_t0, s_ts, lo, hi, d_slopes, True, te[i + 1])
            ext[j, 2] = _at(d_coef, d_dcoef, d_t0, d_ts, lo, hi, d_slopes, own_d_slopes, te[i + 1])
        n_ext[k] = 5
    m0 = n_ext[0]
    out = np.empty((m0 + n + n_ext[1], 3))
    for i in range(m0):
        for c in range(3):
            out[i, c] = ext[i, c]
    for i in range(n):                      # BranchCurve.uvd: the polynomials themselves (oriented)
        ti = t[n - 1 - i if flip else i]
        out[m0 + i, ax] = ti
        out[m0 + i, 1 - ax] = _horner(s_coef, (ti - s_t0) / s_ts)
        out[m0 + i, 2] = _horner(d_coef, (ti - d_t0) / d_ts)
    for i in range(n_ext[1]):
        for c in range(3):
            out[m0 + n + i, c] = ext[5 + i, c]
    return out


@numba.njit(**_JIT)
def _run_at(keys, rows, x1, width, row, x):
    """``kernels_runs.runs_find`` of one query (``Runs.find``): the run containing pixel (row, rint(x)), -1 if none
    (or ``x`` not finite); the last start key at or before the pixel's by bisection."""
    if not np.isfinite(x):
        return -1
    xi = np.int64(np.rint(x))
    key = row * width + xi
    lo, hi = 0, len(keys)                   # keys[0] is the sentinel (the smallest): keys[lo] <= key
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if keys[mid] <= key:
            lo = mid
        else:
            hi = mid
    if rows[lo] == row and x1[lo] >= xi:
        return lo - 1
    return -1


@numba.njit(**_JIT)
def wider_on_right(s_coef, s_dcoef, s_t0, s_ts, d_coef, d_dcoef, d_t0, d_ts, lo, hi, d_slopes, own_d_slopes,
                   t_edge, sign, r, height, fk_row, fk_x0, fk_x1, width, span_px):
    """``TipPlacing._wider_on_right`` of a steep piece with Poly curves (t is the row): whether the right
    view's runs (``Runs.find``'s tables ``fk_*``, ``width``; ``span_px`` (R,)) are clearly wider than
    the branch (radius ``r`` px) on at least 80 % of the rows just past its left end ``t_edge`` in the
    direction ``sign``, within the image's ``height``."""
    m = max(2 * r, 4.0)
    n = 0
    k = 1.0
    while k < m:                            # np.arange(1.0, m)'s count
        n += 1
        k += 1.0
    rows = np.empty(n, np.int64)
    q = 0
    for i in range(n):
        v = np.int64(np.rint(t_edge + sign * (1.0 + i)))
        if 0 <= v < height:
            rows[q] = v
            q += 1
    if q == 0:
        return False
    rows = rows[:q]
    ds = np.empty(q)
    for i in range(q):                      # the centre line's slope at the rows, clamped to the span
        ds[i] = _horner(s_dcoef, (min(max(float(rows[i]), lo), hi) - s_t0) / s_ts)
    slope = math.hypot(1.0, _pairwise(ds, 0, q) / q)          # (np.mean's sum: numpy's pairwise order)
    wide = 0
    lim = 1.6 * 2 * r * slope + 2
    for i in range(q):                      # (c.s_at - c.d_at: kernels_fit.eval_clamped's values, point by point)
        t = float(rows[i])
        x = _at(s_coef, s_dcoef, s_t0, s_ts, lo, hi, d_slopes, True, t) - \
            _at(d_coef, d_dcoef, d_t0, d_ts, lo, hi, d_slopes, own_d_slopes, t)
        j = _run_at(fk_row, fk_x0, fk_x1, width, rows[i], x)
        if j >= 0 and span_px[j] > lim:
            wide += 1
    return wide / q >= 0.8


@numba.njit(**_JIT)
def _slice_end(b, n):
    """Python's end of a slice ``[a:b]`` along ``n`` items (a negative ``b`` counts from the end)."""
    if b < 0:
        b += n
    return min(max(b, 0), n)


@numba.njit(**_JIT)
def runs_near(row, x0, x1, box, n_rows, n_cols, cell_px):
    """``subpixel.near_points``' grid and look-up: the cells (``n_rows``, ``n_cols``) of the boxes ``box`` (P, 4)
    (first and last cell row and column, the firsts clamped to 0; the lasts as numpy's slices take
    ``last + 1``, negative ones counting from the end) set, then each run (``row``, ``x0``, ``x1`` (R,))
    looked up by its middle pixel's cell. Returns ndarray (R,) bool."""
    grid = np.zeros((n_rows, n_cols), np.bool_)
    for k in range(box.shape[0]):
        y0, y1 = min(np.int64(box[k, 0]), n_rows), _slice_end(np.int64(box[k, 1]) + 1, n_rows)
        c0, c1 = min(np.int64(box[k, 2]), n_cols), _slice_end(np.int64(box[k, 3]) + 1, n_cols)
        for y in range(y0, y1):
            for x in range(c0, c1):
                grid[y, x] = True
    out = np.empty(len(row), np.bool_)
    for i in range(len(row)):
        out[i] = grid[row[i] // cell_px, min((x0[i] + x1[i]) // (2 * cell_px), n_cols - 1)]
    return out


@numba.njit(**_JIT)
def _arange(start, stop, step):
    """``np.arange(start, stop, step)`` of floats: numpy's length and values (``start``, ``start + step``,
    then ``start + i * delta`` with ``delta = (start + step) - start``, as its fill)."""
    n = max(np.int64(np.ceil((stop - start) / step)), 0)
    out = np.empty(n)
    if n > 0:
        out[0] = start
    if n > 1:
        out[1] = start + step
        delta = out[1] - start
        for i in range(2, n):
            out[i] = start + i * delta
    return out


@numba.njit(**_JIT)
def flat_search_line(seg_yx, scale, node_yx, junction, rm_image, rm_scale, tab_t, centre_t, span_t, width, step_px):
    """``dense._flat_search`` up to its image reads: a flat piece's centre line v(u) (``kernels_dense.flat_line``
    from its skeleton's column centres, ``single_edge.centre_guess``, with the junctions' regions left out),
    then its texture patches along it and the boxes the searches read; numpy's steps, the same values.

    Parameters
    ----------
    seg_yx : ndarray (N, 2) int64
        The piece's skeleton pixels (row, col); ``scale`` the skeleton's (``SkeletonGraph.to_full``).
    node_yx : ndarray (2, 2) float64
        Its end nodes' skeleton positions (row, col) (a missing node's: any node's); ``junction`` (2,)
        bool: which are junctions.
    rm_image, rm_scale : ndarray (h, w) float32, int
        The radius map (``radius.radius_at``).
    tab_t, centre_t, span_t, width
        The transposed mask's runs (``Runs._find_tables``, ``centre_px``, ``span_px``, ``width``).
    step_px : float
        The patches' step along u (6 px).

    Returns
    -------
    status : int
        0: the skeleton's columns are not whole or half pixels (the caller's numpy path); 1: no centre line
        (None); 2: found.
    coef, t0, ts, degree, radius, lo, hi
        The centre line (``flat_line``'s).
    u, uv, half_h, coarse : ndarray (P,), (P, 2), (P,) int64, (C,) int64
        The patches' columns, centres, half heights (``_patch_half_h``) and the coarse search's patches.
    box : ndarray (4,) int64
        ``y0, y1, u0, u1``: the rows and the first and last column the patches' centres need.
    """
    n = seg_yx.shape[0]
    cx = np.empty(n)
    cy = np.empty(n)
    for i in range(n):                      # SkeletonGraph.to_full
        cx[i] = (np.float64(seg_yx[i, 1]) + 0.5) * scale - 0.5
        cy[i] = (np.float64(seg_yx[i, 0]) + 0.5) * scale - 0.5
    ok, cols, yc = centre_line(cx, cy, (scale - 1) / 2)
    z, zi = np.zeros(0), np.zeros(0, np.int64)
    if not ok:
        return 0, z, 0.0, 1.0, 0, 0.0, 0.0, 0.0, z, np.zeros((0, 2)), zi, zi, zi
    nxy = np.empty((2, 2))
    thr = np.empty(2)
    h, w = rm_image.shape
    for k in range(2):                      # the nodes' full-resolution points and radius_at's radii
        nxy[k, 0] = (node_yx[k, 1] + 0.5) * scale - 0.5
        nxy[k, 1] = (node_yx[k, 0] + 0.5) * scale - 0.5
        x = min(max(np.int64(np.rint((nxy[k, 0] + 0.5) / rm_scale - 0.5)), 0), w - 1)
        y = min(max(np.int64(np.rint((nxy[k, 1] + 0.5) / rm_scale - 0.5)), 0), h - 1)
        thr[k] = 1.6 * np.float64(rm_image[y, x]) + scale + 1
    found, coef, t0, ts, degree, radius, lo, hi = flat_line(cols, yc, junction, nxy, thr, tab_t, centre_t, span_t,
                                                            width)
    if not found:
        return 1, coef, t0, ts, degree, radius, lo, hi, z, np.zeros((0, 2)), zi, zi, zi
    c = coef[3 - degree:]
    u = _arange(lo, hi + 1, step_px)
    m = len(u)
    uv = np.empty((m, 2))
    for i in range(m):                      # Poly.__call__
        uv[i, 0] = u[i]
        uv[i, 1] = _horner(c, (u[i] - t0) / ts)
    hh = max(1, np.int64(0.6 * radius))
    half_h = np.full(m, hh)
    nc = min(6, -(-m // 3))                 # the coarse patches: linspace(0, m - 1, nc), rounded, unique
    if nc < 2:
        coarse = np.zeros(min(nc, 1), np.int64)
    else:
        pos = _linspace(0.0, float(m - 1), nc)
        coarse = np.empty(nc, np.int64)
        q = 0
        for i in range(nc):
            k = np.int64(np.rint(pos[i]))
            if q == 0 or k != coarse[q - 1]:    # (ascending: unique keeps the first of equal values)
                coarse[q] = k
                q += 1
        coarse = coarse[:q]
    y_lo, y_hi = np.int64(1) << 62, -(np.int64(1) << 62)
    u_lo, u_hi = np.int64(1) << 62, -(np.int64(1) << 62)
    for i in range(m):
        ui, vi = np.int64(np.rint(uv[i, 0])), np.int64(np.rint(uv[i, 1]))
        y_lo, y_hi, u_lo, u_hi = min(y_lo, vi), max(y_hi, vi), min(u_lo, ui), max(u_hi, ui)
    box = np.array([y_lo - hh, y_hi + hh + 1, u_lo, u_hi])
    return 2, coef, t0, ts, degree, radius, lo, hi, u, uv, half_h, coarse, box


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    f2, b2 = np.zeros(2), np.zeros(2, np.bool_)
    piece_uvd(f2, f2[:1], 0.0, 1.0, f2, f2[:1], 0.0, 1.0, 0.0, 4.0, f2, True, True, np.zeros((2, 3)), b2,
              np.zeros((2, 2)), b2, 60.0, 4.0)
    ro_i = np.zeros(2, np.int64)
    ro_i.setflags(write=False)                                # (Runs' cached tables are read-only)
    ro_f = np.zeros(2)
    ro_f.setflags(write=False)
    i2 = np.zeros(2, np.int64)
    flat_search_line(np.zeros((2, 2), np.int64), 4, np.zeros((2, 2)), b2, np.zeros((4, 4), np.float32), 4,
                     (ro_i, ro_i, ro_i), ro_f, ro_f, 4, 6.0)
    runs_near(i2, i2, i2, np.zeros((1, 4)), 2, 2, 16)                 # (Runs' own row, x0, x1: writable)
    wider_on_right(f2, f2[:1], 0.0, 1.0, f2, f2[:1], 0.0, 1.0, 0.0, 4.0, f2, True, 1.0, 1.0, 2.0, 4, ro_i, ro_i, ro_i,
                   4, ro_f)
