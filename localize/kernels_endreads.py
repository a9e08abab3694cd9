"""Compiled reads of the masks and row crossings at a branch's end (match stage glue; thirteenth pass, speedmatch2).

:func:`flank_shares` is :func:`tips.right_flanks_filled`'s two mask reads: the share of mask pixels in the
band beside a tip's end in each view. :func:`end_half_width` is :func:`single_edge._end_half`'s crossings
read and median. The same operations as the numpy code (the same products and sums of
the offsets and the direction, the same comparisons, the same rounding with ``np.rint``'s half to even), so
the shares are the same bit for bit. Registered in :func:`kernels.warm_up` (:func:`warm_up`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_runs import runs_find


@numba.njit(**_JIT)
def flank_shares(left_mask, right_mask, u_px, v_px, out_u, out_v, d_px, r_px):
    """Mask shares of the flanks beside a tip's end in the left view and, moved by ``d_px``, the right view.

    The flanks are the offsets (dx, dy) of the square ``[-h, h]^2`` (``h = ceil(2.5 r)``) with
    ``-r <= along <= 0.5`` and ``1.3 r < |across| <= 2.3 r``, where ``along = dx out_u + dy out_v`` and
    ``across = dy out_u - dx out_v``. Each view's share is the count of those pixels inside the image with
    mask >= 128, over the count of offsets (at least 1).

    Parameters
    ----------
    left_mask, right_mask : (H, W) uint8
        Rectified masks.
    u_px, v_px : float
        The end's left (column, row), px (rounded half to even, as ``np.rint``).
    out_u, out_v : float
        The unit direction outwards.
    d_px : float
        The end's disparity, px: the right view's column is ``u_px - d_px``.
    r_px : float
        The piece's radius, px.

    Returns
    -------
    left_share, right_share : float
    """
    h = int(math.ceil(2.5 * r_px))
    lo_across, hi_across = 1.3 * r_px, 2.3 * r_px
    yc = int(np.rint(v_px))
    xl = int(np.rint(u_px))
    xr = int(np.rint(u_px - d_px))
    hl, wl = left_mask.shape
    hr, wr = right_mask.shape
    n = 0
    n_left = 0
    n_right = 0
    for ys in range(-h, h + 1):
        for xs in range(-h, h + 1):
            along = xs * out_u + ys * out_v
            across = abs(ys * out_u - xs * out_v)
            if not (along >= -r_px and along <= 0.5 and across > lo_across and across <= hi_across):
                continue
            n += 1
            yy = yc + ys
            x = xl + xs
            if 0 <= yy < hl and 0 <= x < wl and left_mask[yy, x] >= 128:
                n_left += 1
            x = xr + xs
            if 0 <= yy < hr and 0 <= x < wr and right_mask[yy, x] >= 128:
                n_right += 1
    m = max(n, 1)
    return n_left / m, n_right / m


@numba.njit(**_JIT)
def end_half_width(keys, rows, x1, width, span_px, t, u, ref_px):
    """Half width along the rows of a steep curve at its end (:func:`single_edge._end_half`): the median of
    the left crossings' widths at rows ``t`` (N,) (whole px) and columns ``u`` (N,) that lie within half
    of ``ref_px``; ``ref_px`` when fewer than 5 do. Halved.

    Parameters
    ----------
    keys, rows, x1 : (M + 1,) int64
        The left runs' find tables (``Runs._find_tables``: a sentinel first).
    width : int
        Image width, px.
    span_px : (M,) float64
        The runs' widths, px.
    t, u : (N,) float64
        Rows (truncated to int as ``astype(int)``) and columns of the curve's last rows, px.
    ref_px : float
        The width the radius gives along the rows, px.

    Returns
    -------
    float
        Half the median width (``np.median``'s value: the middle one, or the mean of the two middle
        ones), px.
    """
    n = len(t)
    row = np.empty(n, np.int64)
    for k in range(n):
        row[k] = np.int64(t[k])
    idx = runs_find(keys, rows, x1, width, row, u)
    w = np.empty(n)
    m = 0
    for k in range(n):
        if idx[k] >= 0:
            v = span_px[idx[k]]
            if abs(v - ref_px) <= 0.5 * ref_px:
                w[m] = v
                m += 1
    if m < 5:
        return 0.5 * ref_px
    a = np.sort(w[:m])
    h = m // 2
    med = a[h] if m % 2 else (a[h - 1] + a[h]) / 2
    return 0.5 * med


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types the callers pass."""
    m = np.zeros((4, 4), np.uint8)
    flank_shares(m, m, 1.0, 1.0, 1.0, 0.0, 0.5, 1.0)
    tab = np.zeros(2, np.int64)
    tab.setflags(write=False)                  # (Runs' cached tables are read-only)
    span = np.ones(1)
    span.setflags(write=False)
    end_half_width(tab, tab, tab, 4, span, np.zeros(2), np.zeros(2), 1.0)
