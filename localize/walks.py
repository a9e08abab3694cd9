"""Walks out along a fitted centre line to where the branch's mask ends (:class:`Walks`, a part of
:class:`ends.EndPlacer`): sub-pixel, in the left view or moved by the disparity into the right one.
"""

from __future__ import annotations

import math

import numpy as np
from appliance.localize import kernels_forks, kernels_walks
from appliance.localize.curves import BranchCurve, Poly

# where a walk along the centre line leaves the mask: the last sample at or above half coverage
# (bilinear, the crossing interpolated), plus this (t units) so that binary masks, whose 128 crossing is
# the pixel's boundary, give the place the whole-pixel walk (nearest pixel, + 0.5) gave on average
WALK_EDGE_BIAS = 0.375


def walk_edges(mask: np.ndarray, uv: np.ndarray, bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each walk leaves ``mask`` (uint8 coverage 0-255), read bilinear (off the image: 0).

    ``uv`` (N, 2): all walks' points, walk i being ``uv[bounds[i]:bounds[i + 1]]`` (``bounds`` (W+1,)).
    Returns, per walk, the fractional sample index (W,) of the half-coverage crossing after its last
    sample at or above 128, interpolated between that sample and the next, and whether it has one (W,)
    (False: the walk never leaves the mask, or starts off it; the index is then the last on-sample's, or 0).
    """
    return kernels_walks.walk_edges(np.ascontiguousarray(mask), np.ascontiguousarray(uv, float),
                              np.ascontiguousarray(bounds, np.int64))


class Walks:
    """:class:`ends.EndPlacer`'s walks along its curves (its state: ``curves``, ``node_xy``, the masks ``sm``)."""

    def prewalk(self, nodes) -> None:
        """The plain walks (:meth:`_walk_out`: the end's first fitted piece's centre line, followed
        outwards until it leaves the left mask) of the ends ``nodes`` all at once, into the cache
        the walks read: the same parameters, points and results as walking each alone (a walk's
        points all lie beyond one end of the span: that end's value and slope, as
        :meth:`BranchCurve.uv_at`), one mask read for all. The right view's walks (``right=True``: the
        points moved by the disparity, carried beyond the same end as :meth:`BranchCurve.d_at`) are made
        with them, all in one read of the right mask (a walk is read only up to where it leaves the mask)."""
        ks, ts, vals = [], [], []
        for node in nodes:
            segs = [s for s in self.incident[node] if s in self.curves]
            if not segs:
                continue
            c = self.curves[segs[0]]
            hit = self._walk_cache.get((node, id(c)))
            if hit is not None and hit[0] is c:
                continue
            lo, hi = c.t_range
            t_node = self.node_xy[node][1 if c.by_row else 0]            # (c.t_of's)
            start, sign = (hi, 1.0) if abs(t_node - hi) <= abs(t_node - lo) else (lo, -1.0)
            reach = 3 * c.radius_px + 3 * self.g.scale + 4
            n_t = math.ceil(reach / 0.25)                 # (len(np.arange(0, reach, 0.25)): 0.25 divides exactly)
            if n_t < 2:
                continue
            ks.append((node, c, sign))
            ts.append(n_t)
            d_slope = c.d_poly.deriv().at(start) if c.d_end_slopes is None else c.d_end_slopes[1 if sign > 0 else 0]
            vals.append((start, sign, c.s_poly.at(start), c.s_poly.deriv().at(start), c.by_row, c.d_poly.at(start),
                         d_slope))
        if not ks:
            return
        n = ts
        start, sign, value, slope, by_row, d_value, d_slope = (np.array(a).repeat(n) for a in zip(*vals))   # (np.repeat's)
        ends = np.cumsum(n)
        steps = np.arange(ends[-1]) - (ends - n).repeat(n)       # each walk's 0, 1, 2, ...
        t_all = start + sign * (steps * 0.25)              # (np.arange(0, reach, 0.25)'s values, each walk's t)
        s_all = value + slope * (t_all - start)            # (_eval beyond one end: the same sums)
        uv_all = np.empty((len(t_all), 2))
        uv_all[:, 0] = np.where(by_row, s_all, t_all)
        uv_all[:, 1] = np.where(by_row, t_all, s_all)
        bounds = np.concatenate(([0], ends))                 # (np.r_'s array, without its parsing)
        idx, crosses = walk_edges(self.sm.left_mask, uv_all, bounds)
        # the right view's walks too (the line moved by the piece's disparity, carried beyond the same end:
        # _walk_out's c.d_at, the same sums); a walk is read only up to where it leaves the mask
        uv_r = uv_all.copy()
        uv_r[:, 0] -= d_value + d_slope * (t_all - start)
        idx_r, crosses_r = walk_edges(self.sm.right_mask, uv_r, bounds)
        for i, (node, c, sign) in enumerate(ks):
            a, b = ends[i] - n[i], ends[i]
            t = t_all[a:b]
            res = (self._walk_t(t, sign, idx[i], crosses[i]), sign)
            res_r = (self._walk_t(t, sign, idx_r[i], crosses_r[i]), sign)
            self._walk_cache[node, id(c)] = [c, t, sign, uv_all[a:b], None, {(0.0, False): res, (0.0, True): res_r}]

    @classmethod
    def _walk_whole(cls, mask: np.ndarray, uv: np.ndarray, bounds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`walk_edges`' results read at the nearest whole pixels: each walk's last sample on
        the mask (index), never a crossing (the walk's edge is then that sample + 0.5)."""
        # (compiled: kernels_forks.walk_whole, the same indices as _on_mask's pixels)
        return (kernels_forks.walk_whole(np.ascontiguousarray(mask), np.ascontiguousarray(uv, float),
                                         np.ascontiguousarray(bounds, np.int64)), np.zeros(len(bounds) - 1, bool))

    @staticmethod
    def _walk_t(t: np.ndarray, sign: float, idx: float, crosses: bool) -> float:
        """A walk's edge parameter from :func:`walk_edges`' fractional index into its samples ``t``."""
        if crosses:
            return float(t[0] + sign * 0.25 * idx + sign * WALK_EDGE_BIAS)
        return float(t[int(idx)] + sign * 0.5)

    def _walk_out(self, c: BranchCurve, node: int, offset_px: float = 0.0, right: bool = False,
                  whole: bool = False) -> tuple[float, float]:
        """Parameter where the fitted centre line (or a parallel ``offset_px`` to its side),
        followed outwards, leaves the mask (``right``: the right view's, the line moved by
        the piece's disparity); and the direction (+-1) of t. ``whole``: read at the nearest
        whole pixels, not sub-pixel (:meth:`hidden_fork`'s start)."""
        key = (node, id(c))
        hit = self._walk_cache.get(key)
        if hit is None or hit[0] is not c:
            lo, hi = c.t_range
            t_node = c.t_of(self.node_xy[node])[0]
            start, sign = (hi, 1.0) if abs(t_node - hi) <= abs(t_node - lo) else (lo, -1.0)
            reach = 3 * c.radius_px + 3 * self.g.scale + 4
            t = start + sign * np.arange(0, reach, 0.25)
            hit = self._walk_cache[key] = [c, t, sign, c.uv_at(t), None, {}]
        _, t, sign, uv, normal, done = hit
        res = done.get((offset_px, right, True) if whole else (offset_px, right))   # (the plain walk: tips ask twice)
        if res is not None:
            return res
        if offset_px:
            if normal is None:
                ab = c.uv_at(np.concatenate([t + 0.5, t - 0.5]))      # (one call: the same values)
                step = ab[:len(t)] - ab[len(t):]
                step /= np.maximum(np.hypot(step[:, 0], step[:, 1]), 1e-9)[:, None]
                normal = hit[4] = np.column_stack([-step[:, 1], step[:, 0]])
            uv = uv + offset_px * normal
        if right:
            uv = uv.copy()
            uv[:, 0] -= c.d_at(t)
        walk = self._walk_whole if whole else walk_edges
        idx, crosses = walk(self.sm.right_mask if right else self.sm.left_mask, uv, np.array([0, len(t)]))
        res = (self._walk_t(t, sign, idx[0], crosses[0]), sign)
        done[(offset_px, right, True) if whole else (offset_px, right)] = res
        return res

    def _walk_runs_on(self, c: BranchCurve, node: int) -> bool:
        """Whether :meth:`_walk_out`'s plain walk never leaves the left mask (:func:`walk_edges` finds no
        crossing and its last sample, the walk's reach, is still on the mask: the edge it gives is that
        sample's, half a step on) and the mask runs on for the piece's radius and 1 px past that sample along
        the centre line (a reach ending just inside a round cap does not)."""
        t_edge, sign = self._walk_out(c, node)
        t = self._walk_cache[node, id(c)][1]
        if len(t) < 2 or t_edge != self._walk_t(t, sign, len(t) - 1, False):
            return False
        on = t[-1] + sign * np.arange(0.0, c.radius_px + 1.0, 0.25)
        _, crosses = walk_edges(self.sm.left_mask, c.uv_at(on), np.array([0, len(on)]))
        return not crosses[0]

    def _walk_sides(self, c: BranchCurve, node: int, offset_px: float) -> tuple[float, float]:
        """:meth:`_walk_out`'s parameters of the parallels ``offset_px`` and ``-offset_px`` to either
        side (left view, sub-pixel), both walks read by one :func:`walk_edges` call (each walk's
        values are its own: the same results, cached as :meth:`_walk_out` caches them)."""
        self._walk_out(c, node)                        # (the plain walk: its samples and normals cached)
        hit = self._walk_cache[node, id(c)]
        _, t, sign, uv, normal, done = hit
        keys = [(offset_px, False), (-offset_px, False)]
        if not offset_px or any(k in done for k in keys):
            return self._walk_out(c, node, offset_px)[0], self._walk_out(c, node, -offset_px)[0]
        p = c.s_poly
        if normal is None and type(p) is not Poly:
            ab = c.uv_at(np.concatenate([t + 0.5, t - 0.5]))      # (as _walk_out)
            step = ab[:len(t)] - ab[len(t):]
            step /= np.maximum(np.hypot(step[:, 0], step[:, 1]), 1e-9)[:, None]
            normal = hit[4] = np.column_stack([-step[:, 1], step[:, 0]])
        # (compiled: the normals, both walks' points and their walk_edges, kernels_forks.side_walks)
        plain, lo, hi, unused = type(p) is Poly, *c.t_range, np.zeros(1)
        idx, crosses, nrm = kernels_forks.side_walks(
            np.ascontiguousarray(self.sm.left_mask), np.ascontiguousarray(t, float), np.ascontiguousarray(uv, float),
            np.zeros((1, 2)) if normal is None else np.ascontiguousarray(normal, float), normal is not None,
            bool(c.by_row), np.ascontiguousarray(p.coef, float) if plain else unused,
            np.ascontiguousarray(p._deriv.coef, float) if plain else unused, float(p.t0) if plain else 0.0,
            float(p.ts) if plain else 1.0, float(lo), float(hi), float(offset_px))
        if normal is None:
            hit[4] = nrm
        out = []
        for i, k in enumerate(keys):
            done[k] = (self._walk_t(t, sign, idx[i], crosses[i]), sign)
            out.append(done[k][0])
        return out[0], out[1]

