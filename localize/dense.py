"""Improved matching: dense sub-pixel centre lines along every branch piece.

For a steep piece, each rectified row crosses the branch once in each image; the middle
of that crossing (sub-pixel edges, :mod:`edges`) is the projection of the axis point of
that row's epipolar plane in both views, so its disparity is the axis' disparity. The
matching right crossing is chosen among the runs of the same row inside the working
disparity range with a similar width, consistently along the piece (a robust polynomial
in the row), and the piece becomes a smooth (u, v, d) curve (:mod:`curves`).

Forks are placed where the child's centre line meets the parent's, with the parent's
disparity there; tips where the centre line leaves the mask, with the piece's disparity
extrapolated. Flat pieces (rows ambiguous) take the disparity of the forks/joints at
their ends and, at a tip, the horizontal offset of the branch's end between the views;
a flat piece with no such anchor is left out rather than guessed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from appliance.config.schema import MatchConfig
from appliance.localize.curves import (
    BranchCurve,
    Poly,
    degree_for,
    end_slopes,
    robust_fit,
)
from appliance.localize.edges import Runs, find_runs
from appliance.localize.graph import ENDPOINT, JOINT, JUNCTION, SkeletonGraph
from appliance.localize.matching import FeatureUVD, Matching, PieceUVD
from appliance.localize.radius import RadiusMap, radius_at
from appliance.localize.texture import (
    nearer_in_front,
    surface_disparity,
    surface_to_axis,
)


@dataclass(frozen=True, eq=False)
class StereoMasks:
    """The rectified pair as the dense matcher needs it.

    Attributes
    ----------
    left_mask, right_mask : ndarray (H, W) uint8
        Branch coverage 0-255 (binary masks remapped with linear interpolation); branch
        where >= 128.
    left_gray, right_gray : ndarray (H, W) uint8
        Rectified grey images.
    radius_map : RadiusMap
        Left mask's radius map (:func:`radius.ridge_radius_map`).
    d_range_px : (float, float)
        Disparities of the working range.
    f_px, offset_px : float
        Rectified focal length and principal-point difference ``cx_left - cx_right``.
    valid_left : ndarray (H, W) bool, optional
        Where the rectified left image sees the scene; a branch end at its edge leaves the view.
    """

    left_mask: np.ndarray
    right_mask: np.ndarray
    left_gray: np.ndarray
    right_gray: np.ndarray
    radius_map: RadiusMap
    d_range_px: tuple[float, float]
    f_px: float
    offset_px: float = 0.0
    valid_left: np.ndarray | None = None


def _angle_deg(pts: np.ndarray) -> float:
    """Angle of a point set's main direction from the horizontal, degrees (0..90)."""
    c = pts - pts.mean(0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    return float(np.degrees(np.arctan2(abs(vt[0, 1]), abs(vt[0, 0]))))


def _centre_guess(pts: np.ndarray, axis: int, scale: int) -> tuple[np.ndarray, np.ndarray]:
    """Integer positions along ``axis`` (1: rows) covered by a piece and its interpolated centre there."""
    t, s = pts[:, axis], pts[:, 1 - axis]
    uniq, inv = np.unique(t, return_inverse=True)
    s_mean = np.bincount(inv, s) / np.bincount(inv)
    half = (scale - 1) / 2
    ts = np.arange(np.ceil(uniq[0] - half), np.floor(uniq[-1] + half) + 1)
    return ts, np.interp(ts, uniq, s_mean)


def _near_junction(graph: SkeletonGraph, s: int, xy: np.ndarray, radius_map: np.ndarray) -> np.ndarray:
    """True where a point (N, 2) lies inside a junction region at an end of segment ``s``."""
    near = np.zeros(len(xy), bool)
    for node in graph.seg_nodes[s]:
        if node >= 0 and graph.node_kind[node] == JUNCTION:
            nxy = graph.to_full(graph.node_yx[node])
            r = radius_at(radius_map, nxy)[0]
            near |= np.hypot(*(xy - nxy).T) < 1.6 * r + graph.scale + 1
    return near


def fit_steep(graph: SkeletonGraph, s: int, runs_l: Runs, runs_r: Runs, sm: StereoMasks,
              taken: np.ndarray | None = None) -> BranchCurve | None:
    """Dense row-by-row match of a steep segment; None when it finds too little.

    ``taken`` (bool per right run) marks right crossings that belong to another piece.
    The curve's ``right_runs`` are the right crossings it used.
    """
    pts = graph.to_full(graph.seg_yx[s])
    rows, xc = _centre_guess(pts, 1, graph.scale)
    keep = ~_near_junction(graph, s, np.column_stack([xc, rows]), sm.radius_map)
    rows, xc = rows[keep].astype(int), xc[keep]
    if len(rows) < 4:
        return None
    il = runs_l.find(rows, xc)
    sin_t = max(np.sin(np.radians(_angle_deg(pts))), 0.2)
    r_loc = radius_at(sm.radius_map, np.column_stack([xc, rows]))
    ok = il >= 0
    w_l = np.where(ok, runs_l.span_px[np.maximum(il, 0)], np.inf)
    ok &= w_l <= 1.5 * (2 * r_loc / sin_t + 1) + 2
    rows, il, w_l = rows[ok], il[ok], w_l[ok]
    n = len(rows)
    if n < 4:
        return None
    # a branch's width varies smoothly along it: rows much narrower (partly occluded) or wider
    # (merged with a crossing branch) than the trend are not its centre
    w_fit, _ = robust_fit(rows.astype(float), w_l, 2, rounds=2)
    ok = np.abs(w_l - w_fit(rows)) <= 0.1 * w_fit(rows) + 1.5
    rows, il, w_l = rows[ok], il[ok], w_l[ok]
    n = len(rows)
    if n < 4:
        return None
    c_l = runs_l.centre_px[il]
    dmin, dmax = sm.d_range_px
    q, rr = runs_r.between(rows, c_l - dmax, c_l - dmin)
    cd = c_l[q] - runs_r.centre_px[rr]
    cw = runs_r.span_px[rr]
    good = np.abs(cw - w_l[q]) <= 0.1 * w_l[q] + 1.5
    if taken is not None:
        good &= ~taken[rr]
    q, rr, cd, cw = q[good], rr[good], cd[good], cw[good]
    if len(q) < 4:
        return None
    t = rows.astype(float)
    degree = degree_for(n, float(t.max() - t.min()))
    model = _consensus_line(t[q], cd)
    for k, tol in enumerate((2.0, 0.75)):           # per row, the candidate nearest the model
        res = np.abs(cd - model(t[q]))
        order = np.lexsort((res, q))
        first = order[np.r_[True, q[order][1:] != q[order][:-1]]]
        chosen = first[res[first] <= tol]
        if len(chosen) < max(4, 0.25 * n):
            return None
        model, inl = robust_fit(t[q[chosen]], cd[chosen], degree, rounds=1 if k == 0 else 3)
    chosen = chosen[inl]
    tf, df, cf = t[q[chosen]], cd[chosen], c_l[q[chosen]]
    wf = 0.5 * (w_l[q[chosen]] + cw[chosen])
    u_poly, _ = robust_fit(tf, cf, degree, rounds=1)
    slope = u_poly.deriv()(tf)
    radius = float(np.median(0.5 * wf / np.sqrt(1 + slope ** 2)))
    return BranchCurve(s, True, (float(tf.min()), float(tf.max())), u_poly, model, radius, len(tf),
                       end_slopes(tf, df), rr[chosen])


def _resolve_shared(curves: dict, graph: SkeletonGraph, runs_l: Runs, runs_r: Runs, sm: StereoMasks) -> None:
    """Uniqueness: a right crossing belongs to one piece. Where two pieces matched the same
    crossings (parallel twigs of similar width), the one with fewer samples is matched again
    without them, or dropped."""
    for _ in range(2):
        owner = np.full(len(runs_r.row), -1)
        conflict = set()
        for s in sorted(curves, key=lambda k: -curves[k].n_samples):
            used = curves[s].right_runs
            if used is None or len(used) == 0:
                continue
            clash = owner[used] >= 0
            if clash.mean() > 0.2:
                conflict.add(s)
            else:
                owner[used[~clash]] = s
        if not conflict:
            return
        for s in conflict:
            c = fit_steep(graph, s, runs_l, runs_r, sm, taken=owner >= 0)
            if c is None:
                del curves[s]
            else:
                curves[s] = c


def _consensus_line(t: np.ndarray, d: np.ndarray, n_hyp: int = 96, tol_px: float = 1.5) -> Poly:
    """The straight line d(t) through the most candidates (RANSAC over candidate pairs, fixed seed).

    Candidates of one row belong to different branches crossing it; the piece's own
    disparities are the largest set on one line.
    """
    rng = np.random.default_rng(0)
    i, j = rng.integers(0, len(t), (2, n_hyp))
    dt = t[j] - t[i]
    ok = np.abs(dt) >= 3
    if not ok.any():
        return Poly.constant(float(np.median(d)))
    i, j, dt = i[ok], j[ok], dt[ok]
    slope = (d[j] - d[i]) / dt
    inl = np.abs(d[None, :] - (d[i, None] + slope[:, None] * (t[None, :] - t[i, None]))) <= tol_px
    best = int(np.argmax(inl.sum(1)))
    return Poly.fit(t[inl[best]], d[inl[best]], 1)


def _line(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c = pts.mean(0)
    _, _, vt = np.linalg.svd(pts - c, full_matrices=False)
    return c, vt[0]


def _intersect(c1, e1, c2, e2) -> np.ndarray | None:
    a = np.column_stack([e1, -e2])
    if abs(np.linalg.det(a)) < 0.05:
        return None
    t = np.linalg.solve(a, c2 - c1)
    return c1 + t[0] * e1


class _Builder:
    """Places forks, tips and joints on the fitted curves and collects pieces."""

    def __init__(self, graph: SkeletonGraph, sm: StereoMasks, curves: dict, cfg: MatchConfig):
        self.g, self.sm, self.curves, self.cfg = graph, sm, curves, cfg
        self.node_xy = graph.to_full(graph.node_yx)
        self.incident = [[] for _ in range(len(graph.node_kind))]
        for s, ends in enumerate(graph.seg_nodes):
            for node in ends:
                if node >= 0:
                    self.incident[node].append(s)
        self.uvd: dict[int, np.ndarray] = {}
        self.radius: dict[int, float] = {}
        self.hidden: set[int] = set()

    def seg_points(self, s: int) -> np.ndarray:
        c = self.curves.get(s)
        if c is not None:
            lo, hi = c.t_range
            return c.uv_at(np.linspace(lo, hi, max(2, int(hi - lo) + 1)))
        return self.g.to_full(self.g.seg_yx[s])

    def _near_points(self, s: int, p: np.ndarray, r: float) -> np.ndarray:
        pts = self.seg_points(s)
        dist = np.hypot(*(pts - p).T)
        sel = pts[(dist >= 1.6 * r) & (dist <= 1.6 * r + max(40.0, 4 * r))]
        return sel if len(sel) >= 3 else pts[np.argsort(dist)[:15]]

    def _seg_radius(self, s: int, pts: np.ndarray) -> float:
        c = self.curves.get(s)
        return c.radius_px if c is not None else float(np.median(radius_at(self.sm.radius_map, pts)))

    def fork(self, node: int, final: bool = False) -> None:
        """A fork: where the child's centre line meets the parent's, with the parent's disparity.

        The parent is the pair of pieces that continue each other (most opposite directions;
        the clearly thinnest piece is never a parent). The fork is reported only if the
        child's own disparity there agrees with the parent's: otherwise the pieces merely
        cross in the image (at different depths). Until ``final`` a fork waits for a fitted
        parent.
        """
        segs = [s for s in self.incident[node] if not self.g.seg_recovered[s] and len(self.g.seg_yx[s]) >= 2]
        if len(segs) < 3:
            return
        p = self.node_xy[node]
        r = radius_at(self.sm.radius_map, p)[0]
        near = {s: self._near_points(s, p, r) for s in segs}
        dirs = {}
        for s, pts in near.items():
            v = pts.mean(0) - p
            dirs[s] = v / max(np.hypot(*v), 1e-9)
        rad = {s: self._seg_radius(s, near[s]) for s in segs}
        thin = min(segs, key=rad.get)
        rest = [s for s in segs if s != thin]
        if len(segs) == 3 and rad[thin] < 0.8 * min(rad[s] for s in rest):
            pa, pb = rest
        else:
            _, pa, pb = min((np.dot(dirs[a], dirs[b]), a, b) for i, a in enumerate(segs) for b in segs[i + 1:])
        children = [s for s in segs if s not in (pa, pb)]
        child = max(children, key=lambda s: (s in self.curves, rad[s]))
        parents = [s for s in (pa, pb) if s in self.curves]
        if not parents and not final:
            return
        c1, e1 = _line(np.vstack([near[pa], near[pb]]))
        c2, e2 = _line(near[child])
        p0 = c1 + np.dot(p - c1, e1) * e1                # the junction on the parent's line
        xy = _intersect(c1, e1, c2, e2)
        limit = 1.5 * max(rad[pa], rad[pb]) + 2 * self.g.scale
        if xy is None:
            xy = p0
        else:
            xy = p0 + np.clip(np.dot(xy - p0, e1), -limit, limit) * e1
        at = lambda s: self.curves[s].d_at(self.curves[s].t_of(xy))[0]
        if parents:
            d = float(np.mean([at(s) for s in parents]))
        elif child in self.curves:
            d = float(at(child))
        else:
            return
        self.uvd[node] = np.array([xy[0], xy[1], d])
        self.radius[node] = rad[child]
        if not parents or child not in self.curves or abs(at(child) - d) > max(1.5, 0.015 * d):
            self.hidden.add(int(node))
        else:
            self.hidden.discard(int(node))

    def _walk_out(self, c: BranchCurve, node: int, offset_px: float = 0.0) -> tuple[float, float]:
        """Parameter where the fitted centre line (or a parallel ``offset_px`` to its side),
        followed outwards, leaves the mask; and the direction (+-1) of t."""
        lo, hi = c.t_range
        t_node = c.t_of(self.node_xy[node])[0]
        start, sign = (hi, 1.0) if abs(t_node - hi) <= abs(t_node - lo) else (lo, -1.0)
        reach = 3 * c.radius_px + 3 * self.g.scale + 4
        t = start + sign * np.arange(0, reach, 0.25)
        uv = c.uv_at(t)
        if offset_px:
            step = c.uv_at(t + 0.5) - c.uv_at(t - 0.5)
            step /= np.maximum(np.hypot(step[:, 0], step[:, 1]), 1e-9)[:, None]
            uv = uv + offset_px * np.column_stack([-step[:, 1], step[:, 0]])
        uv = np.rint(uv).astype(int)
        h, w = self.sm.left_mask.shape
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
        on = np.zeros(len(t), bool)
        on[inside] = self.sm.left_mask[uv[inside, 1], uv[inside, 0]] >= 128
        off = np.flatnonzero(~on)
        last = (off[0] - 1) if len(off) else len(t) - 1
        return float(t[max(last, 0)] + sign * 0.5), sign

    def tip(self, node: int) -> None:
        """A tip: the end of the mask along the centre line, less the round cap (one radius).

        An end with something nearer just beyond it is hidden, not a tip: it is kept
        as the piece's end but flagged (``self.hidden``).
        """
        segs = [s for s in self.incident[node] if s in self.curves]
        if not segs:
            return
        c = self.curves[segs[0]]
        t_edge, sign = self._walk_out(c, node)
        uv_edge = c.uv_at(t_edge)[0]
        step = c.uv_at(t_edge + sign)[0] - uv_edge
        out = step / max(np.hypot(*step), 1e-9)
        r = max(c.radius_px, 1.0)
        if self.cfg.oblique_end_ratio > 0:
            # a round cap ends alike on both sides of the axis; a leaf's or an apple's outline
            # usually cuts the branch obliquely: such an end is hidden, not a tip
            t_a, _ = self._walk_out(c, node, 0.7 * r)
            t_b, _ = self._walk_out(c, node, -0.7 * r)
            speed = float(np.hypot(*(c.uv_at(t_edge + 0.5)[0] - c.uv_at(t_edge - 0.5)[0])))
            if abs(t_a - t_b) * speed > self.cfg.oblique_end_ratio * r:
                self.hidden.add(int(node))
                return
        beyond = np.rint(uv_edge + 2.5 * out).astype(int)
        h, w = self.sm.left_mask.shape
        if not (0 <= beyond[0] < w and 0 <= beyond[1] < h) or (
                self.sm.valid_left is not None and not self.sm.valid_left[beyond[1], beyond[0]]):
            return                                   # the branch leaves the view: no tip seen
        uv = uv_edge - out * r
        t = c.t_of(uv)
        self.uvd[node] = np.array([uv[0], uv[1], c.d_at(t)[0]])
        self.radius[node] = c.radius_px
        if not c.by_row:
            # a flat piece's disparity comes from its texture: the tip stands only if the end of
            # its row run is found in the right view too, and takes that run end's disparity
            # when the two disagree
            d_end = self._end_disparity(uv_edge, out, self.uvd[node][2])
            if d_end is None:
                self.hidden.add(int(node))
                return
            if abs(d_end - self.uvd[node][2]) > 2.0:
                self.uvd[node][2] = d_end
        half = max(4, int(round(r)))
        probe = uv_edge + out * (half + 2)
        if nearer_in_front(self.sm.left_gray, self.sm.right_gray, probe[None], self.uvd[node][2:3],
                           np.array([half]), self.sm.d_range_px[1]):
            self.hidden.add(int(node))

    def _end_disparity(self, uv_edge: np.ndarray, out: np.ndarray, d_prior: float) -> float | None:
        """Disparity of the end of a flat piece: the end of its row run in both views.

        The round cap's silhouette ends one image radius beyond the cap centre in both views,
        so the run ends are corresponding points. Right runs of a similar length ending in the
        disparity range are candidates; the one nearest ``d_prior`` wins.
        """
        sm = self.sm
        row = int(np.rint(uv_edge[1]))
        if not 0 <= row < sm.left_mask.shape[0]:
            return None
        runs_l = find_runs(sm.left_mask[row:row + 1], soft=True)
        i = runs_l.find(np.zeros(1, int), np.array([uv_edge[0] - np.sign(out[0])]))[0]
        runs_r = find_runs(sm.right_mask[row:row + 1], soft=True)
        if i < 0 or len(runs_r.row) == 0:
            return None
        right_end = out[0] > 0
        e_l = runs_l.right_px[i] if right_end else runs_l.left_px[i]
        e_r = runs_r.right_px if right_end else runs_r.left_px
        d = e_l - e_r
        ok = (d >= sm.d_range_px[0]) & (d <= sm.d_range_px[1])
        ok &= np.abs(runs_r.span_px - runs_l.span_px[i]) <= 0.2 * runs_l.span_px[i] + 3
        if not ok.any():
            return None
        d = d[ok]
        return float(d[np.argmin(np.abs(d - d_prior))])

    def bridge_holds(self, s: int) -> bool:
        """A recovered piece joins one branch only if each side's disparity, carried along its
        own curve to the other side, lands on the other side's (2 px or 3 %)."""
        a, z = self.g.seg_nodes[s]
        if a not in self.uvd or z not in self.uvd:
            return False
        for p, q in ((a, z), (z, a)):
            curves = [self.curves[t] for t in self.incident[p] if t in self.curves]
            if curves:
                d_ext = curves[0].d_at(curves[0].t_of(self.uvd[q][:2]))[0]
                if abs(d_ext - self.uvd[q][2]) > max(2.0, 0.03 * self.uvd[q][2]):
                    return False
        return True

    def joint(self, node: int) -> None:
        segs = [s for s in self.incident[node] if s in self.curves]
        if segs:
            c = self.curves[segs[0]]
            t = c.t_of(self.node_xy[node])
            self.uvd[node] = np.array([*c.uv_at(t)[0], c.d_at(t)[0]])
            self.radius[node] = c.radius_px


def _flat_curve(b: _Builder, s: int, runs_lt: Runs) -> BranchCurve | None:
    """A flat piece: centre line v(u) from the columns; disparity from the bark texture, or
    else from the forks/joints at its ends."""
    g, sm = b.g, b.sm
    pts = g.to_full(g.seg_yx[s])
    cols, yc = _centre_guess(pts, 0, g.scale)
    keep = ~_near_junction(g, s, np.column_stack([cols, yc]), sm.radius_map)
    cols, yc = cols[keep].astype(int), yc[keep]
    if len(cols) < 4:
        return None
    it = runs_lt.find(cols, yc)
    ok = it >= 0
    if ok.sum() < 4:
        return None
    t, vc, hgt = cols[ok].astype(float), runs_lt.centre_px[it[ok]], runs_lt.span_px[it[ok]]
    degree = degree_for(len(t), float(t.max() - t.min()))
    v_poly, inl = robust_fit(t, vc, degree)
    slope = v_poly.deriv()(t[inl])
    radius = float(np.median(0.5 * hgt[inl] / np.sqrt(1 + slope ** 2)))
    lo, hi = float(t[inl].min()), float(t[inl].max())
    u = np.arange(lo, hi + 1, 4.0)
    uv = np.column_stack([u, v_poly(u)])
    half_h = np.full(len(u), max(1, int(0.6 * radius)))
    # a few patches searched over the whole range give a prior; all patches then search near it
    d0, s0 = surface_disparity(sm.left_gray, sm.right_gray, uv[::3], half_h[::3], sm.d_range_px, half_w_px=12)
    if not (np.isfinite(d0) & (s0 >= 0.6)).any():
        d_surf, score = d0, s0
        u, uv = u[::3], uv[::3]
    else:
        prior = float(np.median(d0[np.isfinite(d0) & (s0 >= 0.6)]))
        d_surf, score = surface_disparity(sm.left_gray, sm.right_gray, uv, half_h, (prior - 6, prior + 6),
                                          half_w_px=12)
    good = np.isfinite(d_surf) & (score >= 0.6)
    xr = np.rint(u - np.nan_to_num(d_surf)).astype(int)
    on_right = (xr >= 0) & (xr < sm.right_mask.shape[1])
    good &= on_right                                   # the match must land on a branch in the right view
    good[on_right] &= sm.right_mask[np.rint(uv[on_right, 1]).astype(int), xr[on_right]] >= 128
    if good.sum() >= 3:
        d_axis = surface_to_axis(d_surf[good], radius, sm.f_px, sm.offset_px)
        # texture disparities are noisy: a constant for short pieces, a line for long ones
        d_poly, inl_d = robust_fit(u[good], d_axis, 0 if hi - lo < 100 else 1)
        return BranchCurve(s, False, (lo, hi), v_poly, d_poly, radius, int(inl_d.sum()))
    ends = np.array([b.uvd[n][[0, 2]] for n in g.seg_nodes[s] if n >= 0 and n in b.uvd]).reshape(-1, 2)
    if len(ends) == 0:
        return None
    d_poly = Poly.fit(ends[:, 0], ends[:, 1], 1) if len(ends) == 2 and abs(ends[1, 0] - ends[0, 0]) > 1 \
        else Poly.constant(ends[:, 1].mean())
    return BranchCurve(s, False, (lo, hi), v_poly, d_poly, radius, 0)


def match_dense(graph: SkeletonGraph, sm: StereoMasks, cfg: MatchConfig, border_px: float = 3.0) -> Matching:
    """Dense matching of a left skeleton graph against the right mask (see module docstring)."""
    runs_l = find_runs(sm.left_mask, soft=True)
    runs_r = find_runs(sm.right_mask, soft=True)
    curves, flat = {}, []
    for s, yx in enumerate(graph.seg_yx):
        if graph.seg_recovered[s] or graph.seg_length_px[s] < cfg.min_segment_px or len(yx) < 2:
            continue
        if _angle_deg(graph.to_full(yx)) < cfg.max_horizontal_deg:
            flat.append(s)
            continue
        c = fit_steep(graph, s, runs_l, runs_r, sm)
        if c is not None:
            curves[s] = c
    _resolve_shared(curves, graph, runs_l, runs_r, sm)
    b = _Builder(graph, sm, curves, cfg)
    kinds = graph.node_kind
    for node in np.flatnonzero(kinds == JUNCTION):      # anchors for flat pieces without texture
        b.fork(node)
    for node in np.flatnonzero(kinds == JOINT):
        b.joint(node)
    if flat:
        runs_lt = find_runs(np.ascontiguousarray(sm.left_mask.T), soft=True)
        for s in flat:
            c = _flat_curve(b, s, runs_lt)
            if c is not None:
                curves[s] = c
    for node in np.flatnonzero(kinds == JUNCTION):
        b.fork(node, final=True)
    for node in np.flatnonzero(kinds == ENDPOINT):
        b.tip(node)
    for node in np.flatnonzero(kinds == JOINT):
        b.joint(node)
    kinds = kinds.copy()
    bridges = []
    for s in np.flatnonzero(graph.seg_recovered):
        if b.bridge_holds(s):
            bridges.append(s)
        else:                                   # not one branch: its ends are ends again
            for node in graph.seg_nodes[s]:
                kinds[node] = ENDPOINT
                b.uvd.pop(node, None)
                b.tip(node)

    h, w = sm.left_mask.shape
    dmin, dmax = sm.d_range_px
    features = []
    for node, (u, v, d) in sorted(b.uvd.items()):
        kind = {ENDPOINT: "endpoint", JUNCTION: "bifurcation"}.get(int(kinds[node]))
        if kind is None or node in b.hidden or not (0.95 * dmin <= d <= 1.05 * dmax):
            continue
        if kind == "endpoint" and min(u, v, w - 1 - u, h - 1 - v) < border_px + graph.scale:
            continue
        if any(f.kind == kind and np.hypot(f.u - u, f.v - v) < 3 for f in features):
            continue                                 # two graph ends placed on one tip
        features.append(FeatureUVD(int(node), kind, float(u), float(v), float(d), b.radius[node]))
    pieces = []
    for s, c in sorted(curves.items()):
        uvd = c.uvd()
        a, z = graph.seg_nodes[s]
        ends = [b.uvd.get(n) for n in (a, z)]
        # order the samples from node a to node z and put the nodes' own points at the ends
        if ends[0] is not None and np.hypot(*(uvd[-1, :2] - ends[0][:2])) < np.hypot(*(uvd[0, :2] - ends[0][:2])) or ends[0] is None and ends[1] is not None and \
                np.hypot(*(uvd[0, :2] - ends[1][:2])) < np.hypot(*(uvd[-1, :2] - ends[1][:2])):
            uvd = uvd[::-1]
        parts = ([ends[0][None]] if ends[0] is not None else []) + [uvd] + \
                ([ends[1][None]] if ends[1] is not None else [])
        pieces.append(PieceUVD(s, np.vstack(parts), c.radius_px, False, (int(a), int(z))))
    for s in bridges:
        a, z = graph.seg_nodes[s]
        if a in b.uvd and z in b.uvd:
            r = np.mean([b.radius.get(a, np.nan), b.radius.get(z, np.nan)])
            pieces.append(PieceUVD(int(s), np.vstack([b.uvd[a], b.uvd[z]]), float(r), True, (int(a), int(z))))
    stats = {"segments": len(graph.seg_yx), "matched_segments": len(curves), "flat_segments": len(flat),
             "hidden_ends": len(b.hidden)}
    return Matching(features, pieces, stats)
