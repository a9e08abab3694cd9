"""Compiled tips' checks: the caps' shapes, fits and disparities and the ends' outline and disparity tests
(numba; docs/localize-numba.md).

Each kernel replaces one of the tips' functions (tips.py, ends.py's tip helpers), a few dozen small
numpy calls per end, by one compiled loop: the same rules, the same values where the arithmetic is
the same (the mask reads are :func:`kernels_walks.bilinear_u8`, cv2.remap's), at rounding level where
numpy's vectorised trigonometry and libm's differ in the last bits.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from appliance.localize.kernels import _JIT
from appliance.localize.kernels_ncc import masked_sqdiff
from appliance.localize.kernels_stats import _median
from appliance.localize.kernels_walks import bilinear_u8

# (tips.py's constants, repeated for the kernels: the tests check them against tips.py's)
CAP_WIDTH_BACK = 1.5
ROUND_BACK = 1.0 - math.sqrt(0.51)       # a round cap's setback 0.7 radius off the axis, in radii


@numba.njit(**_JIT)
def _last_on1(mask, sx, sy, dx, dy, n_s):
    """``kernels_walks.last_on`` of one line ``(sx, sy) + s (dx, dy)``, ``s = 0, 0.5, 1, ...`` (its first ``n_s``
    samples): where it last has ``mask`` at or above 128, interpolated; NaN where it starts off the mask
    or does not leave it. The same values (the sample points in float32, the reads cv2.remap's)."""
    sx32, sy32, dx32, dy32 = np.float32(sx), np.float32(sy), np.float32(dx), np.float32(dy)
    half, tiny = np.float32(127.5), np.float32(1e-6)
    prev, cur = np.float32(0.0), np.float32(0.0)
    first_off = -1
    for j in range(n_s):
        sj = np.float32(j * 0.5)
        v = bilinear_u8(mask, sx32 + dx32 * sj, sy32 + dy32 * sj)
        if v < 128:
            first_off, cur = j, v
            break
        prev = v
    if first_off <= 0:
        return np.nan
    frac = (prev - half) / max(prev - cur, tiny)
    return (first_off - 1) * 0.5 + float(frac) * 0.5


@numba.njit(**_JIT)
def _n_arange(stop):
    """``len(np.arange(0.0, stop, 0.5))``."""
    return max(int(math.ceil(stop / 0.5)), 0)


@numba.njit(**_JIT)
def cap_shapes_offsets(mask, ends):
    """``tips.cap_shapes_offsets`` of the ends ``ends`` (K, 5): ``uv_edge`` (x, y), ``out`` (x, y), ``r`` (px).

    Returns
    -------
    offsets : ndarray (K,)
        The middle of each end's width across from its centre line, px towards ``(-out_y, out_x)``
        (NaN where a side is not read).
    shapes : ndarray (K, 2, 3)
        The two readings' ``(rho, back_a, back_b)`` (px, shares of a round cap's setback).
    status : ndarray (K, 2) int8
        Per reading: 1 read, 0 not (None); -1 for both where the width is not read (the end's None).
    """
    k_ends = len(ends)
    offsets = np.empty(k_ends)
    shapes = np.zeros((k_ends, 2, 3))
    status = np.zeros((k_ends, 2), np.int8)
    ev = np.empty(3)
    for i in range(k_ends):
        ux, uy, ox, oy, r = ends[i, 0], ends[i, 1], ends[i, 2], ends[i, 3], ends[i, 4]
        nx, ny = -oy, ox
        back = CAP_WIDTH_BACK * r
        px, py = ux - back * ox, uy - back * oy
        n1 = _n_arange(3.0 * r + 4.0)
        wa = _last_on1(mask, px, py, nx, ny, n1)
        wb = _last_on1(mask, px, py, -nx, -ny, n1)
        offsets[i] = 0.5 * (wa - wb)
        if not (np.isfinite(wa) and np.isfinite(wb)):
            status[i, 0] = status[i, 1] = -1
            continue
        rho0 = 0.5 * (wa + wb)
        n2 = _n_arange(1.5 * r + 2.0 * rho0 + 4.0)
        for v in range(2):
            if v == 0:
                rho, a = rho0, 0.5 * (wa - wb)
                mx, my = px + a * nx, py + a * ny
            else:
                rho = wa if not wb < wa else wb         # (Python's min)
                mx, my = px, py
            side = 0.7 * rho
            ev[0] = _last_on1(mask, mx, my, ox, oy, n2)
            ev[1] = _last_on1(mask, mx + side * nx, my + side * ny, ox, oy, n2)
            ev[2] = _last_on1(mask, mx - side * nx, my - side * ny, ox, oy, n2)
            if not np.isfinite(ev[0]):
                continue
            for j in (1, 2):
                if not np.isfinite(ev[j]):
                    ev[j] = np.inf                  # a side that never leaves the mask runs on
            expect = ROUND_BACK * rho
            shapes[i, v, 0] = rho
            shapes[i, v, 1] = (ev[0] - ev[1]) / expect
            shapes[i, v, 2] = (ev[0] - ev[2]) / expect
            status[i, v] = 1
    return offsets, shapes, status


@numba.njit(**_JIT)
def cap_fit(left, right, cx, cy, half_px, ox, oy, d_min, d_max, n_far, max_error, min_margin):
    """``caps.cap_disparity`` up to the grey images' choice: the left mask's square patch around
    (``cx``, ``cy``) (half size ``half_px``), its half towards (``ox``, ``oy``) weighted, slid along the
    right mask's rows over the disparities ``d_min`` ... ``d_max`` (uint8 masks (H, W)).

    Returns
    -------
    ok : bool
        False where the patch leaves the image, the strip is too short or the best fit's differing
        area exceeds ``max_error`` (None).
    x0, y0, s0 : int
        The patch's first column and row, and the strip's first column.
    k : int
        The best fit's offset along the strip (the smallest squared difference, the first of ties).
    err : ndarray (P,)
        The squared differences per offset (shares of the half's area, 255 = 1).
    rivals : ndarray (R,) int64
        The fits more than ``half_px`` from it among the ``n_far`` best such (by ``err``, stable) whose
        differing area is within ``min_margin`` of the best's (compared in float32, as numpy's
        float32 areas against a Python float).
    half : ndarray (2 half_px + 1, 2 half_px + 1) uint8
        The weights (1: the outward half).
    """
    h, w = left.shape
    x, y = np.int64(np.rint(cx)), np.int64(np.rint(cy))
    x0, x1, y0, y1 = x - half_px, x + half_px + 1, y - half_px, y + half_px + 1
    empty_f, empty_i = np.zeros(0), np.zeros(0, np.int64)
    size = 2 * half_px + 1
    half = np.zeros((size, size), np.uint8)
    if x0 < 0 or y0 < 0 or x1 > w or y1 > h:
        return False, x0, y0, 0, 0, empty_f, empty_i, half
    cut = -half_px / 3
    n_half = 0
    for i in range(size):
        for j in range(size):
            if ((x0 + j) - cx) * ox + ((y0 + i) - cy) * oy >= cut:
                half[i, j] = 1
                n_half += 1
    n = float(n_half) * 255.0 ** 2
    s0 = max(np.int64(np.floor(x0 - d_max)), 0)
    s1 = min(np.int64(np.ceil(x1 - d_min)), w)
    if s1 - s0 < x1 - x0 + 2:
        return False, x0, y0, s0, 0, empty_f, empty_i, half
    err = masked_sqdiff(right[y0:y1, s0:s1], left[y0:y1, x0:x1], half) / n
    k = np.argmin(err)
    # the n_far best fits more than half_px from it (a stable sort's first: the smallest, the first of ties)
    taken = np.zeros(len(err), np.bool_)
    cand = np.empty(n_far, np.int64)
    n_cand = 0
    for m in range(n_far):
        best = -1
        for j in range(len(err)):
            if abs(j - k) > half_px and not taken[j] and (best < 0 or err[j] < err[best]):
                best = j
        if best < 0:
            break
        taken[best] = True
        cand[n_cand] = best
        n_cand += 1
    cand = cand[:n_cand]
    # the share of the half's area that differs (sum |a - b|: integers, exact in float32), in float32
    den = np.float32(float(n_half) * 255.0)
    area = np.empty(len(cand) + 1, np.float32)
    for m in range(len(cand) + 1):
        off = k if m == 0 else cand[m - 1]
        acc = 0
        for i in range(size):
            for j in range(size):
                if half[i, j]:
                    acc += abs(np.int64(right[y0 + i, s0 + off + j]) - np.int64(left[y0 + i, x0 + j]))
        area[m] = np.float32(acc) / den
    if float(area[0]) > max_error:
        return False, x0, y0, s0, k, err, empty_i, half
    bound = np.float32(float(area[0]) + min_margin)
    rivals = np.empty(len(cand), np.int64)
    n_rivals = 0
    for m in range(len(cand)):
        if area[m + 1] < bound:
            rivals[n_rivals] = cand[m]
            n_rivals += 1
    return True, x0, y0, s0, k, err, rivals[:n_rivals], half


# --- the runs' look-ups and the outline's geometry, one value at a time


@numba.njit(**_JIT)
def _count_le(a, q, strict):
    """How many of the sorted ``a``'s values are <= ``q`` (< ``q`` if ``strict``): ``np.searchsorted``'s
    right (left) side, by bisection (a plain loop: compiles faster than numpy's generic one)."""
    lo, hi = 0, len(a)
    while lo < hi:
        m = (lo + hi) // 2
        if a[m] < q or (not strict and a[m] == q):
            lo = m + 1
        else:
            hi = m
    return lo


@numba.njit(**_JIT)
def _find1(rt, row, x):
    """``edges.Runs.find`` of one query (``rt``: :func:`runs_tables`' tuple): the run containing pixel
    (row, rint(x)), -1 if none (or ``x`` not finite)."""
    keys, rows, x1, width = rt[0], rt[1], rt[2], rt[8]
    if not np.isfinite(x):
        return -1
    xi = np.int64(np.rint(x))
    i = _count_le(keys, row * width + xi, False) - 1
    if rows[i] == row and x1[i] >= xi:
        return i - 1
    return -1


@numba.njit(**_JIT)
def _at_view_edge1(row, x_px, side, valid, width):
    """``tips.at_view_edge`` of one run boundary (``valid`` (0, 0): none, the image's ``width`` counts)."""
    w = valid.shape[1] if valid.shape[0] else width
    xb = np.int64(np.rint(x_px + 0.9 * side))
    if xb < 0 or xb >= w:
        return True
    return valid.shape[0] > 0 and not valid[row, xb]


@numba.njit(**_JIT)
def _silhouette1(u_px, d_px, half_width_px, side, f_px, cx_px):
    """``tips.silhouette_offset_px`` of one edge (libm's trigonometry: numpy's vectorised one may
    differ in the last bits)."""
    x_l = (u_px - cx_px) / f_px
    x_r = x_l - d_px / f_px
    rho = half_width_px / f_px
    e_l = math.tan(math.atan(x_l) + side * math.asin(min(rho / math.hypot(x_l, 1.0), 1.0)))
    e_r = math.tan(math.atan(x_r) + side * math.asin(min(rho / math.hypot(x_r, 1.0), 1.0)))
    return f_px * (e_l - e_r - (x_l - x_r))


@numba.njit(**_JIT)
def _nearest(d, n, d_prior):
    """Index of ``d[:n]``'s value nearest ``d_prior`` (the first of ties; ``np.argmin``'s)."""
    best, k = np.inf, 0
    for i in range(n):
        e = abs(d[i] - d_prior)
        if e < best:
            best, k = e, i
    return k


@numba.njit(**_JIT)
def _split_rows(mid, e_lo, e_hi, n, d_prior, split_px, out):
    """``tips.split_row_disparity`` of ``n`` rows into ``out``."""
    n_split, n_good = 0, 0
    good = np.empty(n)
    for i in range(n):
        if not abs(e_lo[i] - e_hi[i]) <= split_px:
            n_split += 1
        elif abs(mid[i] - d_prior) <= 2.0:
            good[n_good] = mid[i]
            n_good += 1
    d_ref = _median(good[:n_good]) if n_good >= 3 else d_prior
    for i in range(n):
        out[i] = mid[i]
        if n_split and not abs(e_lo[i] - e_hi[i]) <= split_px:
            best = abs(mid[i] - d_ref)              # (np.argmin over mid, e_lo, e_hi: the first of ties)
            for e in (e_lo[i], e_hi[i]):
                if abs(e - d_ref) < best:
                    best, out[i] = abs(e - d_ref), e


@numba.njit(**_JIT)
def cap_disparity(rows, s_px, rl, rr, valid_l, valid_r, px, py, ox, oy, r, d_prior, f_px, h, w,
                  cap_edge_back, split_px, split_lo, split_hi, split_share, own_rows, own_px, edge_rows, edge_px, edge_share, edge_width):
    """``ends.EndPlacer._cap_disparity`` from its candidate rows on: the disparity of a steep tip from
    the rows across its round cap.

    Parameters
    ----------
    rows : ndarray (N,) int64
        The rows within a radius of the cap's centre, up to the walk's edge.
    s_px : ndarray (N,)
        The centre line's column on them.
    rl, rr : tuple
        :func:`runs_tables` of the left and the right soft mask.
    valid_l, valid_r : ndarray (H, W) bool
        Where each rectified view sees the scene ((0, 0): everywhere in the image).
    px, py, ox, oy, r : float
        The cap's centre, the unit direction out of the piece, and the radius (px).
    d_prior, f_px : float
        The prior disparity and the rectified focal length (px); ``h``, ``w`` the image's size.
    cap_edge_back, split_px, split_lo, split_hi, split_share : float
        ``tips.CAP_EDGE_BACK``, ``tips.SPLIT_ROW_PX``, ``ends.CAP_SPLIT_PX`` and ``ends.CAP_SPLIT_SHARE``.
    own_rows, own_px : int, float
        ``tipends.OWN_CAP_ROWS`` and ``tipends.OWN_CAP_PX``: a cap none of whose rows lies within 2.5 px
        of ``d_prior`` still gives its rows' median where at least ``own_rows`` rows have both edges on
        the cap, none of them split, and all of them lie within ``own_px`` of their median (0 rows:
        never).
    edge_rows, edge_px, edge_share : int, float, float
        ``tipends.OWN_EDGE_ROWS``, ``OWN_EDGE_PX`` and ``OWN_EDGE_SHARE``: failing that, the rows with an edge on
        the cap (one or both) give the median of those within ``edge_px`` of all their median where at least
        ``edge_rows`` rows do so and they are at least ``edge_share`` of them (0 rows: never).
    edge_width : float
        ``tipends.OWN_EDGE_WIDTH``: only rows both of whose left edges lie within this many radii (and 1 px) of
        the centre line through the cap's centre count there (a row whose run is the piece's, not something wider).

    Returns
    -------
    status, d : int, float
        1 and the disparity (px); 0 (None: fewer than 3 rows); 2 (NaN: one view's outline is off
        all across the cap).
    """
    n_all = len(rows)
    lo_l, hi_l, lo_r, hi_r = np.empty(n_all), np.empty(n_all), np.empty(n_all), np.empty(n_all)
    rw = np.empty(n_all, np.int64)
    n_l, n = 0, 0
    for k in range(n_all):
        il = _find1(rl, rows[k], s_px[k])
        if il < 0:
            continue
        n_l += 1
        ir = _find1(rr, rows[k], rl[6][il] - d_prior)
        if ir < 0:
            continue
        rw[n], lo_l[n], hi_l[n], lo_r[n], hi_r[n] = rows[k], rl[3][il], rl[4][il], rr[3][ir], rr[4][ir]
        n += 1
    if n_l < 3 or len(rr[5]) == 0 or n < 3:
        return 0, 0.0
    cx, cy = 0.5 * (w - 1), 0.5 * (h - 1)
    e_lo, e_hi, mid = np.empty(n), np.empty(n), np.empty(n)
    cap_lo, cap_hi = np.zeros(n, np.bool_), np.zeros(n, np.bool_)
    for k in range(n):
        dv = rw[k] - py
        half = math.sqrt(max(r * r - dv * dv, 0.0))
        for side in (-1.0, 1.0):
            el, er = (lo_l[k], lo_r[k]) if side < 0 else (hi_l[k], hi_r[k])
            cap = ((el - px) * ox + dv * oy >= -cap_edge_back * r) and not _at_view_edge1(rw[k], el, side, valid_l, w) \
                and not _at_view_edge1(rw[k], er, side, valid_r, w)
            de = el - er
            de = de - _silhouette1(px, de, half, side, f_px, cx) if cap else np.inf
            if side < 0:
                cap_lo[k], e_lo[k] = cap, de
            else:
                cap_hi[k], e_hi[k] = cap, de
        mid[k] = 0.5 * ((lo_l[k] - lo_r[k]) + (hi_l[k] - hi_r[k]))
    # the rows with both edges on the cap: their middles, edges and splits
    b_mid, b_lo, b_hi, split = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    n_b = 0
    for k in range(n):
        if cap_lo[k] and cap_hi[k]:
            b_mid[n_b], b_lo[n_b], b_hi[n_b], split[n_b] = mid[k], e_lo[k], e_hi[k], abs(e_lo[k] - e_hi[k])
            n_b += 1
    d_both = np.empty(n_b)
    _split_rows(b_mid, b_lo, b_hi, n_b, d_prior, split_px, d_both)
    if n_b >= 3:
        m = _median(split[:n_b])
        n_alike = 0
        for k in range(n_b):
            n_alike += abs(split[k] - m) <= 1.0
        if split_lo < m <= split_hi and n_alike / n_b >= split_share:
            return 2, np.nan
    v_c = (py - cy) / f_px
    d, d_own, d_edge = np.empty(n), np.empty(n), np.empty(n)
    n_d, j, n_own, n_own_split, n_edge = 0, 0, 0, 0, 0
    for k in range(n):
        v = (rw[k] - cy) / f_px                     # (ends.cap_row_scale)
        scale = 1.0 - v * (v - v_c) / (1.0 + v * v)
        if cap_lo[k] and cap_hi[k]:
            dk = d_both[j]
            j += 1
            if abs(e_lo[k] - e_hi[k]) <= split_px:
                d_own[n_own] = dk * scale
                n_own += 1
            else:
                n_own_split += 1
        else:
            dk = e_lo[k] if cap_lo[k] else e_hi[k]
        dk = dk * scale
        # (the row's left edges' distances from the centre line: (e - P) . (-oy, ox))
        dv = rw[k] - py
        if (cap_lo[k] or cap_hi[k]) and abs(dv * ox - (lo_l[k] - px) * oy) <= edge_width * r + 1.0 \
                and abs(dv * ox - (hi_l[k] - px) * oy) <= edge_width * r + 1.0:
            d_edge[n_edge] = dk
            n_edge += 1
        if (cap_lo[k] or cap_hi[k]) and abs(dk - d_prior) <= 2.5:
            d[n_d] = dk
            n_d += 1
    if n_d >= 3:
        return 1, _median(d[:n_d])
    # the cap's own depth (tipends.OWN_CAP_ROWS): its whole rows agree among themselves, not with the prior
    if own_rows > 0 and n_own >= own_rows and n_own_split == 0:
        m = _median(d_own[:n_own])
        ok = True
        for k in range(n_own):
            if not abs(d_own[k] - m) <= own_px:
                ok = False
        if ok:
            return 1, m
    # ... or its edge rows, most of them alike (tipends.OWN_EDGE_ROWS)
    if edge_rows <= 0 or n_edge < edge_rows:
        return 0, 0.0
    m = _median(d_edge[:n_edge])
    n_in = 0
    for k in range(n_edge):
        if abs(d_edge[k] - m) <= edge_px:
            d[n_in] = d_edge[k]
            n_in += 1
    if n_in < edge_rows or n_in < edge_share * n_edge:
        return 0, 0.0
    return 1, _median(d[:n_in])


@numba.njit(**_JIT)
def end_outline_agrees(rl, rr, ux, uy, ox, d, r, h):
    """``ends.EndPlacer._end_outline_agrees``: whether a flat piece's end (``uv_edge`` (ux, uy), going
    ``ox`` along the rows) has the same outline in both views at disparity ``d``, on the rows 0.6
    radius ``r`` each side of the centre line (``rl``, ``rr``: :func:`runs_tables`; ``h`` the image's
    height)."""
    k = max(1, int(0.6 * r))
    row0 = np.int64(np.rint(uy))
    sgn = 1.0 if ox > 0 else -1.0
    n_found, n_ok = 0, 0
    for row in range(row0 - k, row0 + k + 1):
        if not 0 <= row < h:
            continue
        il = _find1(rl, row, ux - sgn * r)
        if il < 0:
            continue
        e_l = rl[4][il] if sgn > 0 else rl[3][il]
        ir = _find1(rr, row, e_l - d - sgn * r)
        if ir < 0:
            continue
        e_r = rr[4][ir] if sgn > 0 else rr[3][ir]
        n_found += 1
        n_ok += abs(e_l - e_r - d) <= 1.2
    return n_found >= 3 and n_ok / n_found >= 0.8


@numba.njit(**_JIT)
def end_disparity(rl, rr, valid_r, ux, uy, ox, oy, d_prior, r, inside_px, d_min, d_max, f_px, h, w, cut_px,
                  outvote):
    """``ends.EndPlacer._end_disparity``: the disparity of a flat piece's end from the ends of its row
    runs in both views (``rl``, ``rr``: :func:`runs_tables`; ``valid_r`` where the rectified right view
    sees the scene, (0, 0): everywhere in the image; ``cut_px``: ``ends.END_RUN_CUT_PX``; ``outvote``:
    ``tipends.END_ROWS_OUTVOTE``, the rows' own vote where the axis row's end agrees with too few). Returns whether it has one, and the disparity (px)."""
    row = np.int64(np.rint(uy))
    if not 0 <= row < h:
        return False, 0.0
    s0 = 1.0 if ox > 0 else -1.0 if ox < 0 else 0.0 if ox == 0 else np.nan     # (np.sign)
    i = _find1(rl, row, ux - s0 * inside_px)
    if i < 0:
        return False, 0.0
    r_rows = rr[5]
    j0, j1 = _count_le(r_rows, row, True), _count_le(r_rows, row + 1, True)
    if j1 == j0:
        return False, 0.0
    right_end = ox > 0
    sgn = 1.0 if right_end else -1.0
    e_l = rl[4][i] if right_end else rl[3][i]
    span_l = rl[7][i]
    d_sim, d_ok = np.empty(j1 - j0), np.empty(j1 - j0)
    n_sim, n_ok = 0, 0
    for j in range(j0, j1):
        e_r = rr[4][j] if right_end else rr[3][j]
        dj = e_l - e_r
        if not (dj >= d_min and dj <= d_max) or _at_view_edge1(row, e_r, sgn, valid_r, w):
            continue
        if abs(rr[7][j] - span_l) <= 0.2 * span_l + 3:
            d_sim[n_sim] = dj
            n_sim += 1
        if abs(dj - d_prior) <= cut_px:
            d_ok[n_ok] = dj
            n_ok += 1
    if n_sim:
        d = d_sim[_nearest(d_sim, n_sim, d_prior)]
    else:
        # the right run cut (or merged) elsewhere along the piece: its end still counts if the end's
        # outline agrees row by row
        if r <= 0 or not n_ok:
            return False, 0.0
        d = d_ok[_nearest(d_ok, n_ok, d_prior)]
        if not end_outline_agrees(rl, rr, ux, uy, ox, d, r, h):
            return False, 0.0
    k = int(0.5 * r)
    cx = 0.5 * (w - 1)
    if k >= 1:
        # the median of the rows' run ends within half a radius of the axis, near the axis row's (1 px)
        row_c = np.int64(np.rint(uy - oy * r))
        de = np.empty(2 * k + 1)
        d_all = np.empty(2 * k + 1)
        n_de, n_all = 0, 0
        for row_k in range(row_c - k, row_c + k + 1):
            if not 0 <= row_k < h:
                continue
            il = _find1(rl, row_k, e_l - sgn * (1.0 + r))
            if il < 0:
                continue
            el = rl[4][il] if right_end else rl[3][il]
            ir = _find1(rr, row_k, el - d - sgn * 1.0)
            if ir < 0 and outvote:
                # (for the rows' own vote: the right run read a radius inside, the axis row's end may be off)
                ir = _find1(rr, row_k, el - d - sgn * (1.0 + r))
                if ir < 0:
                    continue
                er = rr[4][ir] if right_end else rr[3][ir]
                if not _at_view_edge1(row_k, er, sgn, valid_r, w):
                    d_all[n_all] = el - er
                    n_all += 1
                continue
            if ir < 0:
                continue
            er = rr[4][ir] if right_end else rr[3][ir]
            if _at_view_edge1(row_k, er, sgn, valid_r, w):
                continue
            d_all[n_all] = el - er
            n_all += 1
            if abs(el - er - d) <= 1.0:
                de[n_de] = el - er
                n_de += 1
        if n_de >= 3:
            d = _median(de[:n_de])
        elif outvote and n_all >= 3:
            # the axis row's end agrees with too few rows: the rows that agree among themselves (a majority of
            # at least 3, within 1 px of their median) outvote it (one row's outline bulging in one view)
            m = _median(d_all[:n_all])
            n_in = 0
            for q in range(n_all):
                if abs(d_all[q] - m) <= 1.0:
                    de[n_in] = d_all[q]
                    n_in += 1
            if n_in >= 3 and 2 * n_in > n_all:
                d = _median(de[:n_in])
    return True, d - _silhouette1(ux, d, r, sgn, f_px, cx)


def warm_up() -> None:
    """Compile (or load) this module's kernels for the argument types the localizer passes
    (:func:`kernels.warm_up` calls it)."""
    cap_shapes_offsets(np.zeros((4, 4), np.uint8), np.zeros((1, 5)))
    cap_fit(np.zeros((4, 4), np.uint8), np.zeros((4, 4), np.uint8), 1.0, 1.0, 1, 1.0, 0.0, 0.0, 1.0, 4, 0.15, 0.15)
    i, f = _readonly(np.zeros(1, np.int64)), _readonly(np.zeros(1))
    rt = (i, i, i, f, f, i, f, f, 4)
    valid = _readonly(np.zeros((0, 0), np.bool_))
    cap_disparity(np.zeros(1, np.int64), np.zeros(1), rt, rt, valid, valid, *(0.0,) * 6, 1.0, 4, 4,
                  0.2, 1.0, 4.0, 8.0, 0.7, 4, 0.6, 8, 1.0, 0.8, 1.5)
    end_outline_agrees(rt, rt, 0.0, 0.0, 1.0, 0.0, 1.0, 4)
    end_disparity(rt, rt, valid, *(0.0,) * 9, 1.0, 4, 4, 2.0, True)


def runs_tables(runs) -> tuple:
    """An :class:`edges.Runs`' arrays as the kernels take them (read-only): the start keys, rows and
    last pixels with the sentinel first (``Runs._find_tables``), ``left_px``, ``right_px``, ``row``,
    ``centre_px``, ``span_px``, and the width."""
    keys, rows, x1 = runs._find_tables
    return (*(_readonly(np.ascontiguousarray(a, t)) for a, t in (
        (keys, np.int64), (rows, np.int64), (x1, np.int64), (runs.left_px, float), (runs.right_px, float),
        (runs.row, np.int64), (runs.centre_px, float), (runs.span_px, float))), int(runs.width))


def valid_table(valid: np.ndarray | None) -> np.ndarray:
    """A view's valid area (H, W) bool as the kernels take it (read-only; (0, 0) for None)."""
    return _readonly(np.zeros((0, 0), np.bool_) if valid is None else np.ascontiguousarray(valid, np.bool_))


def _readonly(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a`` (one argument type for the kernels, whatever the caller's array)."""
    v = a.view()
    v.setflags(write=False)
    return v
