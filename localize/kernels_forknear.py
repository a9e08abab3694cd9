"""Compiled steps of a fork's reads next to its junction (forkends.ForkPlacing.fork and its callees; speedfork20).

``fork`` reads, for each piece at a junction, the piece's centre-line points near it and the piece's
direction from it. :func:`kernels_forkglue.near_piece` keeps the points 1.6 r to 1.6 r + max(40, 4 r)
from the junction; where fewer than 3 lie there, ``fork`` took the 15 nearest (``np.argsort`` of the
distances) and their mean's direction in numpy. :func:`near_or_nearest` does both in one call, with the
same operations in the same order, so the values are the same bit for bit. numpy's sort orders tied
distances its own way: where a tie could change the 15 points or their order (two equal distances among
the 16 nearest) the kernel says so and the caller keeps numpy's steps.

A flat parent side's texture next to the fork (:func:`forkdisp.flat_side_near`) searches a few patches along
the rows, each its template's range, correlation scores and sub-pixel peak in Python; :func:`patch_peaks`
does all of a side's patches in one call, with the same exact sums (:func:`kernels_ncc._ncc_row`) and the
same float steps. Both texture reads take a patch's depth fraction (:func:`texture.patch_depth_fraction` of one
patch along the rows): :func:`depth_fraction` is its value without numpy's dozen small calls.
Registered in :func:`kernels.warm_up` (:func:`warm_up`).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_forkglue import near_piece
from appliance.localize.kernels_ncc import _ncc_row, _patch_sums
from appliance.localize.kernels_stats import _pairwise

# the nearest points a piece keeps where fewer than 3 lie in the ring around the junction
NEAREST_K = 15


@numba.njit(**_JIT)
def near_or_nearest(pts, px, py, r):
    """A piece's points near a junction and its unit direction from it, with the 15-nearest fallback.

    Parameters
    ----------
    pts : (N, 2) float64
        The piece's centre line (x, y; px), :meth:`ends.EndPlacer.seg_points` (N >= 1).
    px, py : float
        The junction (px).
    r : float
        The junction's radius (px).

    Returns
    -------
    sel : (K, 2) float64
        :func:`kernels_forkglue.near_piece`'s points where K >= 3; else the ``NEAREST_K`` nearest (all
        N if fewer) by distance, nearest first (``pts[np.argsort(dist)[:15]]``).
    dist : (N,) float64
        Every point's distance from the junction (``np.hypot``).
    u : (2,) float64
        The unit direction from the junction to the mean of ``sel`` (the rows added in order, divided
        by K, the junction subtracted, over ``max(np.hypot(v), 1e-9)``).
    ok : bool
        False where the fallback's points or their order are numpy's sort's to tell (a NaN distance,
        or two equal distances among the K + 1 nearest: the points' order matters to the sums of
        their lines, ``kernels_forks.tls_line``): ``sel`` and ``u`` are then undefined and the caller
        takes numpy's steps.
    """
    sel, dist, u = near_piece(pts, px, py, r)
    if len(sel) >= 3:
        return sel, dist, u, True
    n = len(dist)
    for i in range(n):
        if np.isnan(dist[i]):
            return sel, dist, u, False
    order = np.argsort(dist, kind="mergesort")
    k = min(NEAREST_K, n)
    for i in range(min(k + 1, n) - 1):         # (a tie among the k + 1 nearest: numpy's sort orders them)
        if dist[order[i]] == dist[order[i + 1]]:
            return sel, dist, u, False
    near = np.empty((k, 2))
    for i in range(k):
        near[i, 0], near[i, 1] = pts[order[i], 0], pts[order[i], 1]
    sx, sy = near[0, 0], near[0, 1]            # (ndarray.sum(0) of (K, 2): the rows added in order)
    for i in range(1, k):
        sx += near[i, 0]
        sy += near[i, 1]
    vx, vy = sx / k - px, sy / k - py
    h = np.hypot(vx, vy)
    h = 1e-9 if 1e-9 > h else h                # (Python's max(h, 1e-9): NaN stays NaN)
    u = np.empty(2)
    u[0], u[1] = vx / h, vy / h
    return near, dist, u, True


@numba.njit(**_JIT)
def patch_peaks(lbox, rbox, ui, hh, hw, lo, hi, y0, x0, d_out, score):
    """Each patch's sub-pixel disparity and correlation (``forkdisp._patch_disparity``'s loop, uint8 images).

    Parameters
    ----------
    lbox, rbox : (BH, BW) and (BH, BW + hi - lo) uint8
        The left view's box ``[y0:y1, x0:x1]`` over the patches and the right view's ``[y0:y1, x0 - hi:x1 - lo]``.
    ui : (N, 2) int64
        The patches' centres (u, v), rounded, px, inside the box.
    hh, hw : int
        The patches' half height and half width, px.
    lo, hi : int
        The disparities searched, px.
    y0, x0 : int
        The left box's origin, px.
    d_out, score : (N,) float64
        Filled in: ``hi - (k + off)`` (the best of the TM_CCOEFF_NORMED scores, exact sums as
        :func:`kernels_ncc.ncc_scores`, at position ``k``, the first maximum, ``off`` its parabola's vertex
        where the curvature is negative) and the score there; left as given for a patch whose range (max -
        min) is below 2 (no texture: ``cv2.minMaxLoc``'s test).
    """
    nh, nw = 2 * hh + 1, 2 * hw + 1
    n_pos = hi - lo + 1
    big = n_pos + nw
    acc, buf = np.empty(big, np.int32), np.empty(big, np.int32)
    cs, cs2 = np.empty(big), np.empty(big)
    cc = np.empty(n_pos)
    for i in range(len(ui)):
        ty, tx = ui[i, 1] - hh - y0, ui[i, 0] - hw - x0
        st, st2, v_lo, v_hi = _patch_sums(lbox, ty, nh, tx, nw)
        if v_hi - v_lo < 2.0:                   # (no texture: texture._flat's bound)
            continue
        _ncc_row(lbox, rbox, ty, nh, tx, nw, tx, n_pos, st, st2, acc, buf, cs, cs2, cc)
        k = 0                                   # (np.argmax: the first maximum, a NaN first of all)
        for j in range(n_pos):
            if np.isnan(cc[j]):
                k = j
                break
            if cc[j] > cc[k]:
                k = j
        off = 0.0
        if 0 < k < n_pos - 1:
            den = cc[k - 1] - 2 * cc[k] + cc[k + 1]
            off = 0.5 * (cc[k - 1] - cc[k + 1]) / den if den < 0 else 0.0
        d_out[i] = hi - (k + off)
        score[i] = cc[k]


@numba.njit(**_JIT)
def depth_fraction(radius_px, half_h_px):
    """:func:`texture.patch_depth_fraction` of one patch along the rows (``slope`` 0): the mean of
    ``sqrt(max(1 - (y / r)^2, 0))`` over the rows ``y = -half_h_px .. half_h_px``.

    Parameters
    ----------
    radius_px : float
        The branch's radius, px (at least 1e-9 as a divisor, as ``max(radius_px, 1e-9)``).
    half_h_px : int
        The patch's half height, rows.

    Returns
    -------
    float
        The fraction of a radius (0..1): numpy's mean (the pairwise sum of the values, :func:`kernels_stats._pairwise`,
        divided by the count), the same value bit for bit.
    """
    n = 2 * half_h_px + 1
    r = 1e-9 if 1e-9 > radius_px else radius_px        # (Python's max(radius_px, 1e-9))
    val = np.empty(n)
    for i in range(n):
        t = (1.0 * float(i - half_h_px)) / r            # (cos(a) = 1 / sqrt(1 + 0^2) = 1 times the row)
        v = 1.0 - t * t
        val[i] = np.sqrt(0.0 if v < 0.0 else v)        # (np.clip(v, 0, None): NaN stays NaN)
    return _pairwise(val, 0, n) / n


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types the callers pass."""
    pts = np.zeros((3, 2))
    pts.setflags(write=False)                  # (EndPlacer.seg_points' read-only points)
    near_or_nearest(pts, 0.0, 0.0, 1.0)
    depth_fraction(1.0, 1)
    box = np.zeros((3, 3), np.uint8)
    patch_peaks(box, np.zeros((3, 4), np.uint8), np.ones((1, 2), np.int64), 1, 1, 0, 1, 0, 0, np.zeros(1), np.zeros(1))
