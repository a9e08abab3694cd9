"""Compiled steps of the fork and tip glue (forkends.ForkPlacing.fork, tipends.TipPlacing._tip_place; speedfork).

Each kernel does a few of the glue's numpy / Python-float steps in one call, with the same operations in the
same order, so the values are the same bit for bit: the points near a junction and the piece's direction
from it (``fork``), the total-least-squares line through two point sets (``fork``'s parent line, without
``np.concatenate``), and a tip's edge point and outward direction on its curve (``_tip_place``).
Registered in :func:`kernels.warm_up` (:func:`warm_up`).
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_fit import eval_clamped
from appliance.localize.kernels_match import _at


@numba.njit(**_JIT)
def near_piece(pts, px, py, r):
    """A piece's centre-line points near a junction and its direction from it (``fork``'s first steps).

    Parameters
    ----------
    pts : (N, 2) float64
        The piece's centre line (x, y; px), :meth:`ends.EndPlacer.seg_points`.
    px, py : float
        The junction (px).
    r : float
        The junction's radius (px): the points kept lie 1.6 r to 1.6 r + max(40, 4 r) from it.

    Returns
    -------
    sel : (K, 2) float64
        The points kept, in order (:func:`kernels_walks.near_points`' selection).
    dist : (N,) float64
        Every point's distance from the junction (``np.hypot``).
    u : (2,) float64
        The unit direction from the junction to the mean of ``sel`` (numpy's row-by-row sum, ``np.hypot``,
        at least 1e-9); NaN when K < 3 (the caller then takes the 15 nearest points, as before).
    """
    lo = 1.6 * r
    hi = 1.6 * r + max(40.0, 4 * r)
    n = len(pts)
    dist = np.empty(n)
    m = 0
    for i in range(n):
        dist[i] = np.hypot(pts[i, 0] - px, pts[i, 1] - py)
        if dist[i] >= lo and dist[i] <= hi:
            m += 1
    sel = np.empty((m, 2))
    j = 0
    for i in range(n):
        if dist[i] >= lo and dist[i] <= hi:
            sel[j, 0], sel[j, 1] = pts[i, 0], pts[i, 1]
            j += 1
    u = np.full(2, np.nan)
    if m >= 3:
        sx, sy = sel[0, 0], sel[0, 1]          # (ndarray.sum(0) of (K, 2): the rows added in order)
        for i in range(1, m):
            sx += sel[i, 0]
            sy += sel[i, 1]
        vx, vy = sx / m - px, sy / m - py
        h = max(np.hypot(vx, vy), 1e-9)
        u[0], u[1] = vx / h, vy / h
    return sel, dist, u


@numba.njit(**_JIT)
def edge_frame(coef, dcoef, t0, ts, lo, hi, by_row, t_edge, sign):
    """A tip's edge point on its centre line and the line's outward direction there (``_tip_place``).

    Parameters
    ----------
    coef, dcoef : (K,) float64
        The centre line's ``Poly`` (``s(t)``) and its derivative's coefficients (highest power first).
    t0, ts : float
        The polynomial's parameter offset and scale.
    lo, hi : float
        The fitted span of ``t`` (px); beyond it the line runs on along its end's slope
        (``BranchCurve._at``).
    by_row : bool
        ``t`` is the row (a steep piece), else the column.
    t_edge, sign : float
        The walk's edge parameter (px) and the outward sign of ``t``.

    Returns
    -------
    uv_edge : (2,) float64
        ``c.uv_at(t_edge)[0]`` (px).
    out : (2,) float64
        ``(c.uv_at(t_edge + sign)[0] - uv_edge) / speed``.
    speed : float
        ``max(np.hypot(step), 1e-9)``: px of the image per unit of ``t``.
    """
    s0 = _at(coef, dcoef, t0, ts, lo, hi, dcoef, True, t_edge)
    t1 = t_edge + sign
    s1 = _at(coef, dcoef, t0, ts, lo, hi, dcoef, True, t1)
    uv = np.empty(2)
    out = np.empty(2)
    if by_row:
        uv[0], uv[1] = s0, t_edge
        sx, sy = s1 - s0, t1 - t_edge
    else:
        uv[0], uv[1] = t_edge, s0
        sx, sy = t1 - t_edge, s1 - s0
    speed = max(np.hypot(sx, sy), 1e-9)
    out[0], out[1] = sx / speed, sy / speed
    return uv, out, speed


@numba.njit(**_JIT)
def walk_uv(coef, dcoef, t0, ts, lo, hi, by_row, t_edge, sign, n):
    """A hidden end's centre line carried straight on from its walk's edge (``hidden_fork``): the points
    ``c.uv_at(t_edge + sign * np.arange(0.0, n, 1.0))`` (n >= 2) of a :class:`curves.Poly` centre line
    (``coef``, ``dcoef``, ``t0``, ``ts``: as :func:`edge_frame`; its own slopes beyond [lo, hi]).

    Returns
    -------
    uv : (n, 2) float64
        (u, v) px, 1 px of ``t`` apart (:func:`kernels_fit.eval_clamped`'s values).
    """
    t = np.empty(n)
    for i in range(n):
        t[i] = t_edge + sign * float(i)
    s = eval_clamped(coef, dcoef, t0, ts, lo, hi, dcoef, True, t)
    uv = np.empty((n, 2))
    for i in range(n):
        if by_row:
            uv[i, 0], uv[i, 1] = s[i], t[i]
        else:
            uv[i, 0], uv[i, 1] = t[i], s[i]
    return uv


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types the callers pass."""
    pts = np.zeros((3, 2))
    pts.setflags(write=False)                  # (EndPlacer.seg_points' read-only points)
    near_piece(pts, 0.0, 0.0, 1.0)
    v = np.array([1.0, 0.0])
    edge_frame(v, v[:1], 0.0, 1.0, 0.0, 1.0, True, 0.5, 1.0)
    walk_uv(v, v[:1], 0.0, 1.0, 0.0, 1.0, True, 0.5, 1.0, 80)
