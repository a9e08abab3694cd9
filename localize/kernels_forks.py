"""Compiled whole functions of the forks' path (ends.py's fork functions, forkplace.py; speedK).

Each kernel does one function's numpy steps in one compiled loop. Where the arithmetic is the same
(sums in the same order, the same polynomial evaluation) the values are the same bit for bit; the
trigonometry (``arctan2``, ``cos``, ``sin``: the C library's, not numpy's) may differ in the last bit
(docs/localize-numba.md, seventh pass). Registered in :func:`kernels.warm_up` (:func:`warm_up`).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize import kernels, kernels_fit, kernels_runs, kernels_stats, kernels_walks

_JIT = kernels._JIT


@numba.njit(**_JIT)
def _sign(x):
    """``np.sign`` of one float (NaN for NaN)."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x                                # (0.0, -0.0 or NaN, as np.sign)


@numba.njit(**_JIT)
def hidden_crossings(uv, r_min, skip, by_row, t_lo, t_hi, radius, poly, coef, n_coef, dcoef, n_dcoef, t0, ts):
    """:meth:`ends.EndPlacer.hidden_fork`'s scan of the fitted pieces: where a hidden end's walk
    ``uv`` (N, 2) (x, y; px) first crosses each piece's centre line.

    Pieces (C,): ``by_row`` (bool), span ``t_lo``..``t_hi`` (px of t), ``radius`` (px); ``poly``:
    whether the centre line is a plain :class:`curves.Poly` of coefficients ``coef[j, :n_coef[j]]``
    (``coef`` (C, 4), highest power first), its derivative's ``dcoef[j, :n_dcoef[j]]``, scaling ``t0``,
    ``ts`` (C,). A piece is skipped when it is ``skip``, thinner than ``r_min``, or its
    span (then its box: 8 points along the span) is clear of the walk's box grown by 2 px.

    Returns (C,) int64: the first sample index k whose step k -> k + 1 changes the side of the piece's
    line (both samples within its span +- 2 px; ``np.sign`` of ``x - s(t)``, NaN counting as a
    change), -1 for none or skipped, -2 where a piece that is not a plain Poly needs the Python path.
    """
    n = uv.shape[0]
    C = len(by_row)
    out = np.full(C, -1, np.int64)
    lo_u, hi_u = _min_max(uv[:, 0])
    lo_v, hi_v = _min_max(uv[:, 1])
    lo_u, lo_v, hi_u, hi_v = lo_u - 2, lo_v - 2, hi_u + 2, hi_v + 2
    ta = np.empty(n)
    box_t = np.empty(8)
    no_slopes = np.zeros(2)
    for j in range(C):
        if j == skip or radius[j] < r_min:
            continue
        lo, hi = t_lo[j], t_hi[j]
        lo_t, hi_t = (lo_v, hi_v) if by_row[j] else (lo_u, hi_u)
        if min(lo, hi) > hi_t or max(lo, hi) < lo_t:
            continue
        if not poly[j]:
            out[j] = -2
            continue
        c = coef[j, :n_coef[j]]
        dc = dcoef[j, :n_dcoef[j]]
        # the box of 8 points along the span (curves.linspace's values: arange * step + lo, last hi)
        step = (hi - lo) / 7
        for i in range(8):
            box_t[i] = i * step + lo
        box_t[7] = hi
        b_s = kernels_fit.eval_clamped(c, dc, t0[j], ts[j], lo, hi, no_slopes, True, box_t)
        s0, s1 = _min_max(b_s)
        b0, b1 = _min_max(box_t)
        u0, v0, u1, v1 = (s0, b0, s1, b1) if by_row[j] else (b0, s0, b1, s1)
        if u0 > hi_u or v0 > hi_v or u1 < lo_u or v1 < lo_v:
            continue
        a_col = 1 if by_row[j] else 0
        n_in = 0
        for i in range(n):
            ta[i] = uv[i, a_col]
            if ta[i] >= lo - 2 and ta[i] <= hi + 2:
                n_in += 1
        if n_in < 2:
            continue
        s = kernels_fit.eval_clamped(c, dc, t0[j], ts[j], lo, hi, no_slopes, True, ta)
        prev_in = ta[0] >= lo - 2 and ta[0] <= hi + 2
        prev_sg = _sign(uv[0, 1 - a_col] - s[0])
        for i in range(1, n):
            cur_in = ta[i] >= lo - 2 and ta[i] <= hi + 2
            sg = _sign(uv[i, 1 - a_col] - s[i])
            if prev_in and cur_in and prev_sg != sg:
                out[j] = i - 1
                break
            prev_in, prev_sg = cur_in, sg
    return out


@numba.njit(**_JIT)
def _min_max(a):
    """``a.min()``, ``a.max()`` of a non-empty 1-D array (NaN if any is, as numpy's)."""
    lo, hi = a[0], a[0]
    for i in range(1, len(a)):
        x = a[i]
        if np.isnan(x):
            return np.nan, np.nan
        lo = min(lo, x)
        hi = max(hi, x)
    if np.isnan(lo):
        return np.nan, np.nan
    return lo, hi


@numba.njit(**_JIT)
def tls_line_pair(a, b):
    """:func:`tls_line` of the points ``a`` (N, 2) followed by ``b`` (M, 2) (px), without
    concatenating them: the same sums in the same order. Returns the centroid (2,) and the unit
    direction (2,)."""
    n = a.shape[0] + b.shape[0]
    cx, cy = 0.0, 0.0
    for i in range(a.shape[0]):
        cx += a[i, 0]
        cy += a[i, 1]
    for i in range(b.shape[0]):
        cx += b[i, 0]
        cy += b[i, 1]
    cx /= n
    cy /= n
    sxx, syy, sxy = 0.0, 0.0, 0.0
    for i in range(a.shape[0]):
        qx, qy = a[i, 0] - cx, a[i, 1] - cy
        sxx += qx * qx
        syy += qy * qy
        sxy += qx * qy
    for i in range(b.shape[0]):
        qx, qy = b[i, 0] - cx, b[i, 1] - cy
        sxx += qx * qx
        syy += qy * qy
        sxy += qx * qy
    ang = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    c, e = np.empty(2), np.empty(2)
    c[0], c[1] = cx, cy
    e[0], e[1] = np.cos(ang), np.sin(ang)
    return c, e


@numba.njit(**_JIT)
def tls_line(pts):
    """Total-least-squares line through points ``pts`` (N, 2) (x, y; px): centroid (2,) and unit
    direction (2,) (``ends._line``, and :func:`parent_axis`' fits: the centroid as numpy's row-by-row
    sum, the second moments summed in order, the direction ``0.5 arctan2(2 sxy, sxx - syy)``; equal up
    to rounding)."""
    return tls_line_pair(pts, pts[:0])


@numba.njit(**_JIT)
def _sections_k(mask, base, e, n, s, r, half, middle_max_r):
    """:func:`parent_axis`' scans of the cross-sections: per section k (``s`` (K,)), from its sample nearest
    ``t = 0`` that is on (within ``middle_max_r`` r + 1) outwards to the first off sample each side
    (``t`` in -half..half, the mask read lazily by :func:`kernels_walks.bilinear_u8`, cv2.remap's values).
    Returns per section (K, 3): found (1/0), middle t, width (px)."""
    K = len(s)
    T = 2 * half + 1
    out = np.zeros((K, 3))
    lim = middle_max_r * r + 1.0
    for k in range(K):
        bx, by = base[0] + s[k] * e[0], base[1] + s[k] * e[1]
        vals = np.full(T, -1.0)
        c = -1
        for dd in range(half + 1):
            if dd > lim:
                break
            for j in (half - dd, half + dd):
                if vals[j] < 0:
                    t = float(j - half)
                    vals[j] = kernels_walks.bilinear_u8(mask, np.float32(bx + t * n[0]), np.float32(by + t * n[1]))
                if vals[j] >= 128.0:
                    c = j
                    break
            if c >= 0:
                break
        if c < 0:
            continue
        a = c - 1
        while a >= 0:
            if vals[a] < 0:
                t = float(a - half)
                vals[a] = kernels_walks.bilinear_u8(mask, np.float32(bx + t * n[0]), np.float32(by + t * n[1]))
            if vals[a] < 128.0:
                break
            a -= 1
        b = c + 1
        while b < T:
            if vals[b] < 0:
                t = float(b - half)
                vals[b] = kernels_walks.bilinear_u8(mask, np.float32(bx + t * n[0]), np.float32(by + t * n[1]))
            if vals[b] < 128.0:
                break
            b += 1
        if a < 0 or b >= T:                     # the section runs off its window
            continue
        va, vb = vals[a], vals[b]
        lo = (a - half) + (128.0 - va) / max(vals[a + 1] - va, 1e-9)
        hi = (b - half) - (128.0 - vb) / max(vals[b - 1] - vb, 1e-9)
        out[k, 0], out[k, 1], out[k, 2] = 1.0, 0.5 * (lo + hi), hi - lo
    return out


@numba.njit(**_JIT)
def parent_axis(mask, xy, e1, out, r_behind, r_ahead, r_child, n_sections, step_r, step_min_px, width_tol,
                width_tol_px, middle_max_r, same_width, same_width_px, middle_off_px, max_turn_sin):
    """:func:`forkplace.parent_axis` compiled whole (its arguments, then its module's constants): the
    parent's axis at a fork from its cross-sections clear of the crotch (:func:`_sections_k`' scans). Returns (found, centroid (2,), unit direction (2,)); equal to the numpy steps up to rounding
    (the sums of the line fits, the trigonometry)."""
    c0, e0 = np.zeros(2), np.zeros(2)
    sg = 1.0 if e1[0] * out[0] + e1[1] * out[1] >= 0.0 else -1.0
    e = np.empty(2)
    e[0], e[1] = sg * e1[0], sg * e1[1]
    nrm = np.empty(2)
    nrm[0], nrm[1] = -e[1], e[0]
    cos_a = e[0] * out[0] + e[1] * out[1]
    sin_a = abs(e[0] * out[1] - e[1] * out[0])
    if sin_a < 0.2:
        return False, c0, e0
    r = min(r_behind, r_ahead)
    step = max(step_r * r, step_min_px)
    K = n_sections
    s = np.empty(2 * K)
    behind = max(0.0, (r_child - r * cos_a) / sin_a)
    ahead = (r * cos_a + r_child) / sin_a
    for k in range(K):
        s[k] = -(behind + 0.5 * r + 3.0 + step * k)
        s[K + k] = ahead + 0.5 * r + 3.0 + step * k
    half = int(np.ceil(2.5 * r + 4.0))
    f = _sections_k(mask, xy, e, nrm, s, r, half, middle_max_r)
    ok = np.zeros(2 * K, np.bool_)
    n_ok = 0
    for k in range(2 * K):
        ok[k] = f[k, 0] > 0 and abs(f[k, 2] - 2.0 * r) <= width_tol * 2.0 * r + width_tol_px \
            and abs(f[k, 1]) <= middle_max_r * r + 1.0
        n_ok += ok[k]
    if n_ok == 0:
        return False, c0, e0
    widths = np.empty(n_ok)
    j = 0
    for k in range(2 * K):
        if ok[k]:
            widths[j] = f[k, 2]
            j += 1
    w = kernels_stats._median(widths)
    mids = np.empty((n_ok, 2))
    m = 0
    for k in range(2 * K):
        if ok[k] and abs(f[k, 2] - w) <= same_width * w + same_width_px:
            mids[m, 0] = xy[0] + s[k] * e[0] + f[k, 1] * nrm[0]
            mids[m, 1] = xy[1] + s[k] * e[1] + f[k, 1] * nrm[1]
            m += 1
    if m < 3:
        return False, c0, e0
    mids = mids[:m]
    c, ea = tls_line(mids)
    n_in = 0
    res_ok = np.empty(m, np.bool_)
    for i in range(m):
        res = abs((mids[i, 0] - c[0]) * -ea[1] + (mids[i, 1] - c[1]) * ea[0])
        res_ok[i] = res <= middle_off_px
        n_in += res_ok[i]
    if n_in < m and n_in >= 3:                  # (off middles: left out once)
        keep = np.empty((n_in, 2))
        j = 0
        for i in range(m):
            if res_ok[i]:
                keep[j, 0], keep[j, 1] = mids[i, 0], mids[i, 1]
                j += 1
        c, ea = tls_line(keep)
    return abs(ea[0] * e[1] - ea[1] * e[0]) <= max_turn_sin, c, ea


@numba.njit(**_JIT)
def child_outline_fork(mask, c1, e1, c2, e2, p0, r_par, r_child):
    """``ends.EndPlacer._fork_from_child_outline`` compiled whole: the fork from the child's outline in
    ``mask`` (H, W) uint8 where it leaves the parent (axis ``c1`` + t ``e1``; ``p0``: the junction on
    it; the child's line ``c2``, ``e2``; radii in px). Returns (found, xy (2,)); the scans are
    :func:`kernels_walks.child_outline_pairs`' (the same values), the products around them equal to numpy's
    up to rounding."""
    xy = np.zeros(2)
    nx, ny = -e1[1], e1[0]
    side = _sign((c2[0] - p0[0]) * nx + (c2[1] - p0[1]) * ny)
    if side == 0.0:
        side = 1.0
    nx, ny = side * nx, side * ny
    sin_t = abs(e1[0] * e2[1] - e1[1] * e2[0])
    if sin_t < 0.2:
        return False, xy
    cot = (e2[0] * e1[0] + e2[1] * e1[1]) / (e2[0] * nx + e2[1] * ny)
    dx, dy = c2[0] - c1[0], c2[1] - c1[1]
    s0 = (dx * e1[0] + dy * e1[1]) - (dx * nx + dy * ny) * cot      # the child's line on the parent's
    step = max(1.5 * r_child, 6.0)
    hs = np.empty(4)
    hs[0], hs[1] = r_par + 3.0, r_par + 3.0 + step
    hs[2], hs[3] = r_par + 3.0 + r_child, r_par + 3.0 + r_child + step
    bases, s_c = np.empty((4, 2)), np.empty(4)
    for k in range(4):
        bases[k, 0], bases[k, 1] = c1[0] + hs[k] * nx, c1[1] + hs[k] * ny
        s_c[k] = s0 + hs[k] * cot
    reach = (4.7 * r_child + 3) / sin_t + 2
    i, m1, m2 = kernels_walks.child_outline_pairs(mask, bases, s_c, e1, reach, r_child, sin_t)
    if i < 0:
        return False, xy
    t = m1 - (m2 - m1) * hs[2 * i] / step
    xy[0], xy[1] = c1[0] + t * e1[0], c1[1] + t * e1[1]
    return True, xy


@numba.njit(**_JIT)
def _line_fit(x, y):
    """``forkdisp``'s least-squares line ``y = a x + b`` (closed form; the plain sums numpy's pairwise
    ones, the products' sums in order): (ok, a, b), not ok when ``x`` has no spread."""
    n = len(x)
    sx, sy = kernels_stats._pairwise(x, 0, n), kernels_stats._pairwise(y, 0, n)
    sxx, sxy = 0.0, 0.0
    for i in range(n):
        sxx += x[i] * x[i]
        sxy += x[i] * y[i]
    det = n * sxx - sx * sx
    if det <= 0:
        return False, 0.0, 0.0
    a = (n * sxy - sx * sy) / det
    return True, a, (sy - a * sx) / n


@numba.njit(**_JIT)
def _quad_fit(x, y):
    """Least-squares parabola ``y = c x^2 + a x + b`` (normal equations, Cramer's rule; ``x`` scaled by its
    largest magnitude): (ok, c, a, b), not ok when the rows span too few distinct values."""
    n = len(x)
    sc = 0.0
    for i in range(n):
        sc = max(sc, abs(x[i]))
    if n < 3 or sc <= 0:
        return False, 0.0, 0.0, 0.0
    s0, s1, s2, s3, s4, t0, t1, t2 = float(n), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for i in range(n):
        u = x[i] / sc
        u2 = u * u
        s1 += u
        s2 += u2
        s3 += u2 * u
        s4 += u2 * u2
        t0 += y[i]
        t1 += u * y[i]
        t2 += u2 * y[i]
    det = s0 * (s2 * s4 - s3 * s3) - s1 * (s1 * s4 - s3 * s2) + s2 * (s1 * s3 - s2 * s2)
    if abs(det) <= 1e-12 * max(s0 * s2 * s4, 1e-300):
        return False, 0.0, 0.0, 0.0
    b = (t0 * (s2 * s4 - s3 * s3) - s1 * (t1 * s4 - s3 * t2) + s2 * (t1 * s3 - s2 * t2)) / det
    a = (s0 * (t1 * s4 - s3 * t2) - t0 * (s1 * s4 - s3 * s2) + s2 * (s1 * t2 - t1 * s2)) / det
    c = (s0 * (s2 * t2 - t1 * s3) - s1 * (s1 * t2 - t1 * s2) + t0 * (s1 * s3 - s2 * s2)) / det
    return True, c / (sc * sc), a / sc, b


@numba.njit(**_JIT)
def side_near(keys_l, rows_l, x1_l, width_l, span_l, centre_l, keys_r, rows_r, x1_r, width_r, span_r, centre_r,
              n_gap, span_rows, sg, end, s_end, slope_s, d_end, slope_d, ratio, t_fork, tol_d_px, width_tol_px,
              min_rows, k_mad, grow_frac, grow_px, grow_tol_px, grow_max_w, deg=1):
    """:func:`forkdisp.side_disparity_near` compiled from its rows on: the rows ``(i - n_gap) sg + end``
    (i = 0 .. n_gap + span_rows), the curve carried along its tangent at the span's ``end`` (column
    ``s_end + slope_s dt``, disparity ``d_end + slope_d dt``, the right view's widths ``ratio`` times
    the left's), both views' runs (``edges.Runs``' find tables, widths and centres), the robust line
    through the rows kept (one refit without the residuals beyond ``k_mad`` MADs, as
    ``forkdisp._robust_line`` was). A left crossing wider than the span's by up to ``grow_frac`` of its
    width plus ``grow_px`` (the child's pixels joined to the parent's outline in the crotch), on a row
    within ``grow_max_w`` span widths of the fork's, counts where its centre is within half the excess
    more of the line and its right crossing is as much wider (within ``grow_tol_px``; 0, 0: none counts).
    Returns (found, d at the fork, rows kept, of them in the gap, nearest kept row's distance to the fork
    (px), scaled MAD, slope); equal to the numpy steps up to the rounding of the line fits' product sums.
    ``deg`` 2: a parabola in the row through the same rows (its value and slope at the fork; ``forkdisp``'s
    ``SIDE_TURN_QUAD``)."""
    fail = (False, 0.0, 0, 0, 0.0, 0.0, 0.0)
    n = n_gap + span_rows + 1
    rows = np.empty(n)
    ri = np.empty(n, np.int64)
    u, d = np.empty(n), np.empty(n)
    r_min = np.inf
    for i in range(n):
        rows[i] = float(i - n_gap) * sg + end
        r_min = min(r_min, rows[i])
        ri[i] = np.int64(rows[i])
        dt = rows[i] - end
        u[i] = s_end + slope_s * dt
        d[i] = d_end + slope_d * dt
    if r_min < 0 or n < min_rows:
        return fail
    il = kernels_runs.runs_find(keys_l, rows_l, x1_l, width_l, ri, u)
    m = min(n_gap + 20, n) - n_gap
    ref = np.empty(max(m, 0))
    n_ref = 0
    for i in range(n_gap, n_gap + m):
        if il[i] >= 0:
            ref[n_ref] = span_l[il[i]]
            n_ref += 1
    if n_ref == 0:
        return fail
    w_end = kernels_stats._median(ref[:n_ref])
    k = np.empty(n, np.int64)
    tol_w = np.empty(n)
    nk = 0
    for i in range(n):
        if il[i] < 0:
            continue
        ex = span_l[il[i]] - w_end
        tol_c = 0.15 * w_end + 1.5
        if abs(ex) <= 0.1 * w_end + 1.5:
            tw = width_tol_px
        elif 0.0 < ex <= grow_frac * w_end + grow_px and abs(rows[i] - t_fork) <= grow_max_w * w_end:
            # (widened by the child on one side in the crotch: the middle moves half)
            tw = grow_tol_px
            tol_c += 0.5 * ex
        else:
            continue
        if abs(centre_l[il[i]] - u[i]) <= tol_c:
            k[nk] = i
            tol_w[nk] = tw
            nk += 1
    if nk < min_rows:
        return fail
    k = k[:nk]
    c_l, w_l, rq, xq = np.empty(nk), np.empty(nk), np.empty(nk, np.int64), np.empty(nk)
    for j in range(nk):
        c_l[j] = centre_l[il[k[j]]]
        w_l[j] = span_l[il[k[j]]]
        rq[j] = ri[k[j]]
        xq[j] = c_l[j] - d[k[j]]
    ir = kernels_runs.runs_find(keys_r, rows_r, x1_r, width_r, rq, xq)
    x, y, kk = np.empty(nk), np.empty(nk), np.empty(nk, np.int64)
    n2 = 0
    for j in range(nk):
        j0 = max(ir[j], 0)
        cd = c_l[j] - centre_r[j0]
        if ir[j] >= 0 and abs(cd - d[k[j]]) <= tol_d_px and abs(span_r[j0] - ratio * w_l[j]) <= tol_w[j]:
            x[n2] = rows[k[j]] - t_fork
            y[n2] = cd
            kk[n2] = k[j]
            n2 += 1
    if n2 < min_rows:
        return fail
    x, y, kk = x[:n2], y[:n2], kk[:n2]
    c2 = 0.0
    if deg == 2:
        ok, c2, a, b = _quad_fit(x, y)
    else:
        ok, a, b = _line_fit(x, y)
    if not ok:
        return fail
    res = np.empty(n2)
    for j in range(n2):
        res[j] = y[j] - ((c2 * x[j] + a) * x[j] + b)
    med = kernels_stats._median(res)
    dev = np.empty(n2)
    for j in range(n2):
        dev[j] = abs(res[j] - med)
    mad = 1.4826 * kernels_stats._median(dev)
    keep = np.empty(n2, np.bool_)
    n_keep = 0
    for j in range(n2):
        keep[j] = abs(res[j]) <= k_mad * (mad + 1e-3) + 0.05
        n_keep += keep[j]
    if n_keep < min_rows:
        return fail
    if n_keep < n2:
        xk, yk = np.empty(n_keep), np.empty(n_keep)
        j2 = 0
        for j in range(n2):
            if keep[j]:
                xk[j2], yk[j2] = x[j], y[j]
                j2 += 1
        if deg == 2:
            ok, c2, a, b = _quad_fit(xk, yk)
        else:
            ok, a, b = _line_fit(xk, yk)
        if not ok:
            return fail
    n_gap_k = 0
    nearest = np.inf
    for j in range(n2):
        if keep[j]:
            n_gap_k += kk[j] < n_gap
            nearest = min(nearest, abs(x[j]))
    return True, b, n_keep, n_gap_k, nearest, mad, a


@numba.njit(**_JIT)
def runs_agree(pts, d, r, min_rows, keys_l, rows_l, x1_l, width_l, span_l, centre_l, ckeys_r, width_r, span_r,
               centre_r, d_min, d_max):
    """``ends.EndPlacer._runs_agree`` compiled whole: whether a piece's own row crossings at points ``pts``
    (N, 2) have disparity ``d`` (px). The rows of the points' line (:func:`tls_line`), the left crossing
    on each (``kernels_runs.runs_find``; not wider than a piece of radius ``r`` across the row), the right
    crossings of a similar width in the working range ``d_min``..``d_max`` (``kernels_runs.runs_between`` on
    the right runs' centre keys); rows where one lies within 1 px or 0.6 % of ``d`` must be at least
    ``min_rows`` and 60 % of the rows with any. The same steps as numpy (the line up to rounding)."""
    if len(pts) < 2:
        return False
    c, e = tls_line(pts)
    sin_t = abs(e[1])
    y_lo, y_hi = np.inf, -np.inf
    for i in range(len(pts)):
        y_lo = min(y_lo, pts[i, 1])
        y_hi = max(y_hi, pts[i, 1])
    v0, v1 = np.ceil(y_lo), np.floor(y_hi)
    nv = max(int(np.ceil(v1 + 1 - v0)), 0)            # (len(np.arange(v0, v1 + 1)))
    if nv < min_rows or sin_t < 0.3:
        return False
    rows = np.empty(nv, np.int64)
    x = np.empty(nv)
    for i in range(nv):
        v = v0 + i
        rows[i] = np.int64(v)
        x[i] = c[0] + (v - c[1]) * e[0] / e[1]
    il = kernels_runs.runs_find(keys_l, rows_l, x1_l, width_l, rows, x)
    w_max = 2.4 * r / sin_t + 3
    n = 0
    for i in range(nv):
        if il[i] >= 0 and span_l[il[i]] <= w_max:
            rows[n], il[n] = rows[i], il[i]
            n += 1
    if n < min_rows:
        return False
    rows, il = rows[:n], il[:n]
    c_l, w_l, lo, hi = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        c_l[i], w_l[i] = centre_l[il[i]], span_l[il[i]]
        lo[i], hi[i] = c_l[i] - d_max, c_l[i] - d_min
    q, rr = kernels_runs.runs_between(ckeys_r, rows, width_r, lo, hi)
    tol = max(1.0, 0.006 * abs(d))
    n_cand = n_ok = 0
    last_c = last_ok = -1
    for j in range(len(q)):                     # (q ascending: distinct rows where it changes)
        k = q[j]
        if abs(span_r[rr[j]] - w_l[k]) > 0.15 * w_l[k] + 1.5:
            continue
        if k != last_c:
            n_cand += 1
            last_c = k
        if abs(c_l[k] - centre_r[rr[j]] - d) <= tol and k != last_ok:
            n_ok += 1
            last_ok = k
    return n_ok >= min_rows and n_ok >= 0.6 * n_cand


@numba.njit(**_JIT)
def radius_median(img, scale, pts):
    """The median (``np.median``'s value; NaN for no points) of ``radius.radius_at``: the radius map
    ``img`` (H, W) (map pixels ``scale`` full-resolution px wide) at its pixels nearest the
    full-resolution points ``pts`` (N, 2) (x, y), clipped to the map."""
    n = len(pts)
    if n == 0:
        return np.nan
    h, w = img.shape
    vals = np.empty(n)
    for i in range(n):
        x = min(max(np.int64(np.rint((pts[i, 0] + 0.5) / scale - 0.5)), 0), w - 1)
        y = min(max(np.int64(np.rint((pts[i, 1] + 0.5) / scale - 0.5)), 0), h - 1)
        vals[i] = img[y, x]
    return kernels_stats._median(vals)


@numba.njit(**_JIT)
def passes_through(mask, c, e, s_far_px, r_child_px, reach_px):
    """:func:`forkchild.passes_through` compiled whole: along ``c - s e`` (``c``, ``e`` (2,)) for ``s`` in
    ``s_far_px`` .. ``s_far_px + reach_px`` (1 px apart, ``np.arange``'s values), a sample is the
    branch's where ``mask`` (bilinear, :func:`kernels_walks.bilinear_u8`: cv2.remap's values at the float32
    points) covers the line (>= 128) and leaves both sides ``1.5 r + 2`` px off it clear; whether
    ``max(6, ceil(1.5 r))`` such samples come in a row. Reads each sample's sides only where the line is
    covered, and stops at the first such run (the same answer)."""
    n = int(np.ceil(((s_far_px + reach_px) - s_far_px) / 1.0))
    need = max(6, int(np.ceil(1.5 * r_child_px)))
    if n < need:
        return False
    k = 1.5 * r_child_px + 2.0
    ox, oy = k * -e[1], k * e[0]
    run = 0
    delta = (s_far_px + 1.0) - s_far_px           # (np.arange's fill: start, start + step, start + i delta)
    for i in range(n):
        s = s_far_px if i == 0 else s_far_px + 1.0 if i == 1 else s_far_px + i * delta
        x, y = c[0] - s * e[0], c[1] - s * e[1]
        if kernels_walks.bilinear_u8(mask, np.float32(x), np.float32(y)) >= 128 \
                and kernels_walks.bilinear_u8(mask, np.float32(x + ox), np.float32(y + oy)) < 128 \
                and kernels_walks.bilinear_u8(mask, np.float32(x - ox), np.float32(y - oy)) < 128:
            run += 1
            if run >= need:
                return True
        else:
            run = 0
    return False


@numba.njit(**_JIT)
def side_walks(mask, t, uv, normal, have_normal, by_row, coef, dcoef, t0, ts, lo, hi, offset_px):
    """``ends.EndPlacer._walk_sides``' two walks compiled: the walk's points ``uv`` (N, 2) at parameters
    ``t`` (N,) moved ``offset_px`` and ``-offset_px`` along the unit normals (N, 2) (``normal`` where
    ``have_normal``, else made as ``_walk_out`` makes them: the centre line (a :class:`curves.Poly` of
    coefficients ``coef``, derivative's ``dcoef``, scaling ``t0``, ``ts``, span ``lo``..``hi``; ``by_row``)
    half a unit of t either side, their difference normalised, turned a quarter), each read by
    :func:`kernels_walks.walk_edges` on ``mask``. Returns (index (2,), crosses (2,), the normals (N, 2)): the
    same values as the numpy steps."""
    n = len(t)
    if not have_normal:
        tt = np.empty(2 * n)
        for i in range(n):
            tt[i] = t[i] + 0.5
            tt[n + i] = t[i] - 0.5
        sv = kernels_fit.eval_clamped(coef, dcoef, t0, ts, lo, hi, np.zeros(2), True, tt)
        normal = np.empty((n, 2))
        for i in range(n):
            if by_row:
                sx, sy = sv[i] - sv[n + i], tt[i] - tt[n + i]
            else:
                sx, sy = tt[i] - tt[n + i], sv[i] - sv[n + i]
            norm = max(np.hypot(sx, sy), 1e-9)
            sx /= norm
            sy /= norm
            normal[i, 0], normal[i, 1] = -sy, sx
    pts = np.empty((2 * n, 2))
    neg = -offset_px
    for i in range(n):
        pts[i, 0] = uv[i, 0] + offset_px * normal[i, 0]
        pts[i, 1] = uv[i, 1] + offset_px * normal[i, 1]
        pts[n + i, 0] = uv[i, 0] + neg * normal[i, 0]
        pts[n + i, 1] = uv[i, 1] + neg * normal[i, 1]
    bounds = np.empty(3, np.int64)
    bounds[0], bounds[1], bounds[2] = 0, n, 2 * n
    idx, crosses = kernels_walks.walk_edges(mask, pts, bounds)
    return idx, crosses, normal


@numba.njit(**_JIT)
def walk_whole(mask, uv, bounds):
    """``ends.EndPlacer._walk_whole`` compiled: per walk (points ``uv[bounds[i]:bounds[i + 1]]``, (x, y))
    the index of its last point before the first whose nearest pixel (``np.rint``) is off ``mask``
    (< 128, or outside the image), at least 0 (W,) int. Reads each walk only up to that point."""
    h, w = mask.shape
    nw = len(bounds) - 1
    idx = np.empty(nw, np.int64)
    for i in range(nw):
        start, end = bounds[i], bounds[i + 1]
        first_off = end
        for j in range(start, end):
            x, y = np.rint(uv[j, 0]), np.rint(uv[j, 1])
            if not (0 <= x < w and 0 <= y < h and mask[int(y), int(x)] >= 128):
                first_off = j
                break
        idx[i] = max(first_off - 1 - start, 0)
    return idx


@numba.njit(**_JIT)
def curve_points(coef, dcoef, t0, ts, lo, hi, by_row, a, b, n):
    """A fitted piece's centre line (n, 2) (x, y) at ``curves.linspace(a, b, n)`` (n >= 2; its values:
    numpy's ``np.linspace`` steps): ``BranchCurve.uv_at`` of a :class:`curves.Poly` centre line
    (coefficients ``coef``, derivative's ``dcoef``, scaling ``t0``, ``ts``; span ``lo``..``hi``, carried
    beyond it along its end slopes), the same values."""
    t = np.empty(n)
    delta = b - a
    div = n - 1
    step = delta / div
    for i in range(n):
        t[i] = (i / div) * delta + a if step == 0 else i * step + a
    t[n - 1] = b
    sv = kernels_fit.eval_clamped(coef, dcoef, t0, ts, lo, hi, np.zeros(2), True, t)
    out = np.empty((n, 2))
    j, k = (0, 1) if by_row else (1, 0)
    for i in range(n):
        out[i, j] = sv[i]
        out[i, k] = t[i]
    return out


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types the callers pass."""
    f, b, n = np.zeros(1), np.zeros(1, np.bool_), np.ones(1, np.int64)
    hidden_crossings(np.zeros((2, 2)), 0.0, -1, b, f, f, f, b, np.zeros((1, 4)), n, np.zeros((1, 4)), n, f, f + 1)
    from appliance.localize import forkplace                 # (imports this module)
    forkplace.parent_axis(np.zeros((4, 4), np.uint8), np.zeros(2), np.array([1.0, 0.0]), np.array([0.0, 1.0]),
                          1.0, 1.0, 1.0)
    ro_i = np.zeros(2, np.int64)
    ro_f = np.zeros(2)
    ro_i.setflags(write=False)                                # (Runs' cached tables are read-only)
    ro_f.setflags(write=False)
    side_near(ro_i, ro_i, ro_i, 4, ro_f, ro_f, ro_i, ro_i, ro_i, 4, ro_f, ro_f, 1, 1, 1.0, 1.0, 1.0, 0.0, 1.0, 0.0,
              1.0, 0.0, 2.5, 1.2, 12, 3.5, 0.2, 2.5, 0.6, 0.5, 1)
    runs_agree(np.zeros((3, 2)), 1.0, 1.0, 3, ro_i, ro_i, ro_i, 4, ro_f, ro_f, ro_f, 4, ro_f, ro_f, 0.0, 1.0)
    v = np.array([1.0, 0.0])
    curve_points(v, v[:1], 0.0, 1.0, 0.0, 1.0, True, 0.0, 1.0, 2)
    walk_whole(np.zeros((4, 4), np.uint8), np.zeros((2, 2)), np.array([0, 2], np.int64))
    for have in (False, True):
        side_walks(np.zeros((4, 4), np.uint8), f, np.zeros((1, 2)), np.zeros((1, 2)), have, True, f, f, 0.0, 1.0,
                   0.0, 1.0, 1.0)
    passes_through(np.zeros((4, 4), np.uint8), v, v, 1.0, 1.0, 80.0)
    child_outline_fork(np.zeros((4, 4), np.uint8), v, v, v, v[::-1].copy(), v, 1.0, 1.0)
    pts = np.zeros((3, 2))
    tls_line(pts)
    tls_line_pair(pts, pts)
    radius_median(np.zeros((2, 2), np.float32), 1, pts)
    pts.setflags(write=False)                                 # (EndPlacer.seg_points' read-only points)
    tls_line(pts)
    radius_median(np.zeros((2, 2), np.float32), 1, pts)
