"""Compiled whole functions of the forks' path (ends.py's fork functions, forkplace.py; speedK).

Each kernel does one function's numpy steps in one compiled loop. Where the arithmetic is the same
(sums in the same order, the same polynomial evaluation) the values are the same bit for bit; the
trigonometry (``arctan2``, ``cos``, ``sin``: the C library's, not numpy's) may differ in the last bit
(docs/localize-numba.md, seventh pass). Registered in :func:`kernels.warm_up` (:func:`warm_up`).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize import kernels

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
        b_s = kernels.eval_clamped(c, dc, t0[j], ts[j], lo, hi, no_slopes, True, box_t)
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
        s = kernels.eval_clamped(c, dc, t0[j], ts[j], lo, hi, no_slopes, True, ta)
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


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types the callers pass."""
    f, b, n = np.zeros(1), np.zeros(1, np.bool_), np.ones(1, np.int64)
    hidden_crossings(np.zeros((2, 2)), 0.0, -1, b, f, f, f, b, np.zeros((1, 4)), n, np.zeros((1, 4)), n, f, f + 1)
