"""Compiled patch comparisons along epipolar rows: normalised cross-correlation and masked squared
differences (:mod:`matching`, :mod:`featurecheck`, :mod:`tips`; docs/localize-numba.md).

:func:`ncc_peaks` and :func:`ncc_search` score a left patch against every position of a right strip
(zero-mean NCC by running sums, flat patches refused) and return the best; :func:`ncc_scores` is
``cv2.matchTemplate``'s ``TM_CCOEFF_NORMED`` of a strip; :func:`masked_sqdiff` the weighted squared
differences of a patch along a strip. The helpers ``_strip_buffers`` / ``_strip_scores`` / ``_peak`` are
shared with :mod:`kernels_check`.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


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


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    img, i, f = np.zeros((8, 16), np.uint8), np.ones(1, np.int64), np.zeros(1)
    ncc_peaks(img, img, 4 * i, 4 * i, i, 1, 0 * i, 16 * i, 1.0)
    ncc_search(img, img, np.zeros((1, 2), np.int64), i, 1, 0, 2, 8, 16, 0, 0, 0, f.copy(), f.copy())
    part = np.zeros((8, 3), np.uint8)                   # (C-contiguous, writable: as the callers pass them)
    ncc_scores(img, part)
    masked_sqdiff(img, part, part.copy())
