"""Forks, tips and joints placed on the fitted branch curves (improved variant).

A fork is where the child's centre line meets the parent's, with the parent's disparity
there, and is reported only if the child's own disparity agrees (else two branches merely
cross in the image). A tip is where the centre line leaves the mask, one radius back (the
round cap); an end that the right view's outline ends elsewhere (an occluder's edge), with
something nearer just beyond it, or running out of the view, is not a tip; a hidden end
whose centre line runs on into a thicker piece at the same disparity is a fork. A bridge
across an occluder stands only if both sides' curves meet.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from appliance.config.schema import MatchConfig
from appliance.localize import kernels, kernels_forks, kernels_tips
from appliance.localize.curves import BranchCurve, Poly, linspace, median
from appliance.localize.edges import Runs, find_runs
from appliance.localize.forkchild import child_texture_agrees, passes_through
from appliance.localize.forkdisp import flat_side_near, side_disparity_near, taper_radius, weigh_sides
from appliance.localize.forkplace import parent_axis
from appliance.localize.graph import SkeletonGraph
from appliance.localize.matching import StereoMasks
from appliance.localize.merged_tips import right_cap_tip
from appliance.localize.radius import RadiusMap, radius_at
from appliance.localize.texture import nearer_in_front
from appliance.localize.tips import (CAP_EDGE_BACK, CAP_WIDTH_BACK, SPLIT_ROW_PX, VIEW_EDGE_PX, cap_centre,
                                     cap_shapes_offsets, occluder_confirmed, reads_round)

# a tip's end in the right view may lie this far (px, along the branch) from the left view's:
# steep pieces (disparity from the outline; a round cap ends on the same rectified row in both views,
# and the sub-pixel walks leave no rounding between them: 2 px with whole-pixel walks), flat pieces
# (from the texture: looser)
END_SHIFT_STEEP_PX = 1.5
END_SHIFT_FLAT_PX = 6.0
# a hidden end's centre line meeting a piece at less than this is that branch running on behind
# the occluder (bent), not a child meeting its parent
HIDDEN_FORK_MIN_DEG = 20.0
# the right view's outline of a child must tell its disparity from the parent's to this (px)
OUTLINE_MAX_D_PX = 4.0
# a child without a curve within this of the rows (sine; the matcher's 20 deg of flat pieces) shows
# its depth by its bark texture only: checked there (forkchild.child_texture_agrees)
FLAT_CHILD_SIN = math.sin(math.radians(20.0))
# a flat parent side at a fork takes its disparity from its bark texture next to the fork
# (forkdisp.flat_side_near) where that moves its curve's by more than this (px)
FLAT_NEAR = True
FLAT_NEAR_MIN_PX = 0.25
# ... with the parent's radius at the fork between its two sides' (a tapering branch: EndPlacer._radius_at_fork)
FLAT_TAPER = True
# a fork whose two steep parent sides differ by more than this (px; less than the clear
# disagreement's 2 px) takes their mean weighted by how well each side's line is known there
# (forkdisp.weigh_sides) instead of the plain mean
SIDES_WEIGHTED = True
SIDES_WEIGHT_PX = 0.5
# a flat parent whose two read sides differ at the fork by more than this (px) takes the mean of
# the two and the child's right outline's disparity (if within the outline check's tolerance of
# the nearer side); the outline within 1 px of the parent's confirms the fork
FLAT_PICK = True
FLAT_SIDES_DIFFER_PX = 0.5
# a flat tip's right run of another length than the left's (cut or merged elsewhere along the piece
# in that view) still gives the end's disparity within this of the prior (px) if the ends agree
END_RUN_CUT_PX = 2.0
# a flat tip on a piece without texture (its disparity carried from its fork) keeps its run end's
# disparity only within this (px) plus this per px carried (else withheld: _carried_agrees)
CARRIED_D_PX = 2.0
CARRIED_D_PER_PX = 0.1
# a flat parent whose two sides disagree at a fork, the child's curve carried further than this to
# it (px), takes the side its child's right outline agrees with (within this, px) and the outline
CHILD_CARRY_PX = 12.0
SIDE_OUTLINE_PX = 0.5
# a stub's curve (caps.py) gained after its fork was placed from its right outline, further than this
# from the flat parent's disparity at its end next to the fork (px), discredits that outline
CHILD_DEPTH_PX = 6.0
# a steep tip whose cap rows' two edges (both the cap's) give disparities apart by a median within
# this (px), most rows alike, has no depth of its own: one view's outline is wider by a few px all
# across the cap (a colour mask taking in background on one side); a larger split is one side
# merged with another branch in one view, which split_row_disparity resolves, and so is a smaller
# one (something touching the cap, 3 px nearer: test_a_tip_touched_on_one_side...)
CAP_SPLIT_PX = (4.0, 8.0)
CAP_SPLIT_SHARE = 0.7                    # (of the rows within 1 px of that median: all across the cap)
# a fork placed from the child's outline is placed again against the parent's axis from its own
# cross-sections clear of the crotch (forkplace.parent_axis)
PARENT_FROM_SECTIONS = True
SECTIONS_MIN_MOVE_PX = 1.5          # (closer, the first place stands: the two agree within their noise)


def _line(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total-least-squares line through points (N, 2): centroid and unit direction (the direction of
    the largest spread; compiled: :func:`kernels_forks.tls_line`)."""
    return kernels_forks.tls_line(np.ascontiguousarray(pts, float))


def _intersect(c1, e1, c2, e2) -> np.ndarray | None:
    """Intersection of the lines c1 + t e1 and c2 + s e2; None when (nearly) parallel."""
    e1x, e1y, e2x, e2y = float(e1[0]), float(e1[1]), float(e2[0]), float(e2[1])
    det = e2x * e1y - e1x * e2y           # (the 2 x 2 system [e1, -e2] t = c2 - c1 by Cramer's rule: as
    if abs(det) < 0.05:                    # LAPACK's det and solve up to rounding)
        return None
    bx, by = float(c2[0] - c1[0]), float(c2[1] - c1[1])
    return c1 + ((e2x * by - bx * e2y) / det) * e1


def cap_row_scale(rows: np.ndarray, row_c: float, cy_px: float, f_px: float) -> np.ndarray:
    """Factor (N,) taking the disparity of the middle of a round cap's crossing of each rectified
    row in ``rows`` (N,) to the disparity of the cap's centre C, seen on row ``row_c``.

    A row's epipolar plane cuts the cap (a sphere around C) in a circle around the foot of C on
    that plane, and both views' crossings of the row project that circle's centre, not C: off C's
    row the foot lies nearer (or further) by the fraction ``v (v - v_C) / (1 + v^2)`` of the depth,
    ``v = (row - cy) / f`` (rows further from the image's middle row than C's are nearer). The
    principal point's row may be taken at the image's middle (a small share of the effect).
    """
    v = (np.asarray(rows, float) - cy_px) / f_px
    return 1.0 - v * (v - (row_c - cy_px) / f_px) / (1.0 + v * v)


def _agree(d1: float, d2: float) -> bool:
    """Whether two disparities (px) at one point are of one branch: within 1 px or 0.6 %."""
    return abs(d1 - d2) <= max(1.0, 0.006 * abs(d2))


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
    return kernels.walk_edges(np.ascontiguousarray(mask), np.ascontiguousarray(uv, float),
                              np.ascontiguousarray(bounds, np.int64))


class EndPlacer:
    """Places forks, tips and joints of one graph on its fitted curves.

    ``uvd[node]`` is a placed node's rectified (u, v, d); ``radius[node]`` its radius (px);
    nodes in ``hidden`` are placed (they end pieces) but are not features.
    """

    def __init__(self, graph: SkeletonGraph, sm: StereoMasks, curves: dict, cfg: MatchConfig,
                 runs: tuple[Runs, Runs] | None = None):
        self.g, self.sm, self.curves, self.cfg = graph, sm, curves, cfg
        self.runs_l, self.runs_r = runs if runs is not None else (find_runs(sm.left_mask, soft=True),
                                                                  find_runs(sm.right_mask, soft=True))
        self.node_xy = graph.to_full(graph.node_yx)
        self.incident = [[] for _ in range(len(graph.node_kind))]
        for s, ends in enumerate(graph.seg_nodes):
            for node in ends:
                if node >= 0:
                    self.incident[node].append(s)
        self.uvd: dict[int, np.ndarray] = {}
        self.radius: dict[int, float] = {}
        self.hidden: set[int] = set()
        self._box_cache: dict = {}
        # per-piece and per-node quantities asked for again (both fork rounds, a tip's four walks):
        # keyed with the piece's curve (or None), as flat pieces gain curves between rounds
        self._points_cache: dict = {}
        self._walk_cache: dict = {}
        self._node_r: np.ndarray | None = None
        self._near_cache: dict = {}
        self._deferred: set[int] = set()          # junctions whose provisional place waits (fork)
        self._pending: set[int] = set()           # junctions whose provisional place is made when read
        self._pending_curves: dict | None = None  # (the curves it is made with: those before the flat pieces')
        self.cap_segments: set[int] = set()      # flat pieces whose curve is their cap's (tips.py)
        # forks on a flat parent set from the right outline of a child without a curve yet:
        # {node: (child piece, the parent's own disparity)} (recheck_outline_forks)
        self._from_outline: dict[int, tuple[int, float]] = {}

    def seg_points(self, s: int) -> np.ndarray:
        """Centre line of a piece (N, 2): its fitted curve, or else its skeleton pixels (read-only)."""
        c = self.curves.get(s)
        hit = self._points_cache.get(s)
        if hit is not None and hit[0] is c:
            return hit[1]
        if c is not None:
            lo, hi = c.t_range
            pts = self._curve_uv(c, lo, hi, max(2, int(hi - lo) + 1))
        else:
            pts = self.g.to_full(self.g.seg_yx[s])
        pts.setflags(write=False)
        self._points_cache[s] = (c, pts)
        return pts

    @staticmethod
    def _curve_uv(c: BranchCurve, a: float, b: float, n: int) -> np.ndarray:
        """``c.uv_at(linspace(a, b, n))`` (n >= 2), compiled for a Poly centre line
        (:func:`kernels_forks.curve_points`, the same points)."""
        p = c.s_poly
        if type(p) is not Poly:
            return c.uv_at(linspace(a, b, n))
        lo, hi = c.t_range
        return kernels_forks.curve_points(np.ascontiguousarray(p.coef, float), np.ascontiguousarray(p._deriv.coef, float),
                                          float(p.t0), float(p.ts), float(lo), float(hi), bool(c.by_row), float(a),
                                          float(b), int(n))

    def _node_radius(self, node: int) -> float:
        """Radius (px) of the distance transform at a node's skeleton pixel (cached)."""
        if self._node_r is None:          # (all nodes at once: the same values)
            self._node_r = radius_at(self.sm.radius_map, self.node_xy)
        return self._node_r[node]

    def _near_points(self, s: int, p: np.ndarray, r: float) -> np.ndarray:
        """A piece's centre-line points near the junction at ``p`` but outside its blob (1.6 r)."""
        pts = self.seg_points(s)
        # (compiled: the same distances and points as np.hypot and the boolean selection)
        sel, dist = kernels.near_points(pts, float(p[0]), float(p[1]), float(1.6 * r), float(1.6 * r + max(40.0, 4 * r)))
        return sel if len(sel) >= 3 else pts[np.argsort(dist)[:15]]

    def _seg_radius(self, s: int, pts: np.ndarray) -> float:
        c = self.curves.get(s)
        if c is not None:
            return c.radius_px
        rm = self.sm.radius_map           # (compiled: the median of radius_at's values, kernels_forks.radius_median)
        if isinstance(rm, RadiusMap) and rm.image.dtype == np.float32:
            return float(kernels_forks.radius_median(np.ascontiguousarray(rm.image), int(rm.scale),
                                                     np.ascontiguousarray(pts, float)))
        return float(median(radius_at(rm, pts)))

    def fork(self, node: int, final: bool = False, needed: bool = True) -> None:
        """A fork: where the child's centre line meets the parent's, with the parent's disparity.

        The parent is the pair of pieces that continue each other (most opposite directions;
        the clearly thinnest piece is never a parent). The fork is reported only if the
        child's own disparity there agrees with the parent's: otherwise the pieces merely
        cross in the image (at different depths), and only if the child's outline leaving the
        parent is clear in the left view. Until ``final`` a fork waits for a fitted
        parent. A provisional (not ``final``) place that is not ``needed`` before the final
        round (no piece of the node gains a curve in between) is placed only if the final
        round finds no place, keeping it as placing it first would.
        """
        if not final and not needed:
            self._deferred.add(node)
            return
        segs = [s for s in self.incident[node] if not self.g.seg_recovered[s] and len(self.g.seg_yx[s]) >= 2]
        if len(segs) < 3:
            return
        p = self.node_xy[node]
        r = self._node_radius(node)
        near, rad, dirs = {}, {}, {}
        for s in segs:                  # (cached: both fork rounds ask)
            c = self.curves.get(s)
            hit = self._near_cache.get((node, s))
            if hit is None or hit[0] is not c:
                pts = self._near_points(s, p, r)
                v = pts.sum(0) / len(pts) - p           # (the piece's direction from the junction)
                hit = self._near_cache[node, s] = (c, pts, self._seg_radius(s, pts), v / max(np.hypot(*v), 1e-9))
            near[s], rad[s], dirs[s] = hit[1], hit[2], hit[3]
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
        c1, e1 = _line(np.concatenate([near[pa], near[pb]]))      # (np.vstack's, of 2-D arrays)
        if child in self.curves:             # the child's own fitted centre line where it starts
            cc = self.curves[child]
            lo, hi = cc.t_range
            tp = cc.t_of(p)[0]
            t_end = hi if abs(tp - hi) <= abs(tp - lo) else lo
            c2, e2 = _line(self._curve_uv(cc, t_end, t_end + (12.0 if t_end == lo else -12.0), 12))
        else:
            c2, e2 = _line(near[child])
        p0 = c1 + np.dot(p - c1, e1) * e1                # the junction on the parent's line
        r_par = max(rad[pa], rad[pb])
        # the child's outline where it leaves the parent, against the parent's line behind the
        # fork (the parent may bend at the fork) or else through both sides
        behind = min((pa, pb), key=lambda s: np.dot(dirs[s], dirs[child]))
        xy, outline = None, None
        lines = ([_line(near[behind])] if len(near[behind]) >= 3 else []) + [(c1, e1)] if final else []
        for cl, el in lines:               # (before the final round a rough place will do)
            xy = self._fork_from_child_outline(cl, el, c2, e2, cl + np.dot(p - cl, el) * el, r_par, rad[child])
            if xy is not None:
                outline = (cl, el)
                break
        if outline is not None and PARENT_FROM_SECTIONS:
            # the parent's line near the crotch is pulled towards the child: its axis again from its
            # own cross-sections clear of the crotch on both sides, and the child's outline against it
            ax = parent_axis(self.sm.left_mask, xy, outline[1], e2 if np.dot(c2 - xy, e2) >= 0 else -e2,
                             rad[behind], rad[pb if behind == pa else pa], rad[child])
            xy2 = None if ax is None else self._fork_from_child_outline(
                ax[0], ax[1], c2, e2, ax[0] + np.dot(p - ax[0], ax[1]) * ax[1], r_par, rad[child])
            if xy2 is not None and np.hypot(*(xy2 - xy)) > SECTIONS_MIN_MOVE_PX:     # (within it: noise)
                xy, outline = xy2, ax
        if xy is None:
            # the skeleton junction lies where the child's outline leaves the parent's, ahead of
            # the fork in the child's direction: the fork slides back along the parent further
            # than ahead
            xy = _intersect(c1, e1, c2, e2)
            if xy is None:
                xy = p0
            else:
                ahead = np.sign(np.dot(c2 - p0, e1)) or 1.0
                shift = min(max(ahead * np.dot(xy - p0, e1), -(3.0 * r_par + 2 * self.g.scale)),
                            0.5 * r_par + 2 * self.g.scale)          # (np.clip of one value, without its overhead)
                xy = p0 + ahead * shift * e1
        at = lambda s: self.curves[s].d_at(self.curves[s].t_of(xy))[0]

        def passes(s):              # a curve's disparity at the fork's row/column is its own there
            c = self.curves[s]
            return np.hypot(*(c.uv_at(c.t_of(xy))[0] - xy)) <= max(rad[s], 3.0) + 2 * self.g.scale
        parents = [s for s in parents if passes(s)]
        child_ok = child in self.curves and passes(child)
        # a side whose fit stops short of the fork is read again from its own crossings nearest it
        # (its crossings far from the junction's blob are the parent's alone: forkdisp.py); a fork
        # without the child's outline is withheld whatever its disparity (below): not read
        side_near, flat_read = {}, set()
        for s in parents if final and outline is not None else ():
            c = self.curves[s]
            if c.by_row:
                v = side_disparity_near(c, self.runs_l, self.runs_r, float(c.t_of(xy)[0]))
            elif FLAT_NEAR:     # a flat side: its bark texture next to the fork (forkdisp.flat_side_near)
                v = flat_side_near(c, self.sm.left_gray, self.sm.right_gray, float(c.t_of(xy)[0]),
                                   self.sm.f_px, self.sm.offset_px,
                                   radius_px=self._radius_at_fork(parents, xy) if FLAT_TAPER else None)
                # (within the patches' scatter of the curve, fitted on the whole piece, the curve stands)
                if v is not None:
                    flat_read.add(s)
                    if abs(v.d_px - at(s)) <= FLAT_NEAR_MIN_PX:
                        v = None
            else:
                v = None
            if v is not None:
                side_near[s] = v
        if side_near:
            at_curve = at
            at = lambda s: side_near[s].d_px if s in side_near else at_curve(s)
        d_par = [at(s) for s in parents]
        sides = None                    # (the two sides' disparities where they clearly disagree)
        if len(d_par) == 2 and child_ok and abs(d_par[0] - d_par[1]) > max(2.0, 0.012 * abs(d_par[0])):
            # the parent's two sides clearly disagree at the fork (one side's fit is off there):
            # the middle of the three pieces' disparities
            sides = d_par
            d_par = [float(sorted([*d_par, at(child)])[1])]      # (the median of three, as np.median)
        if parents:
            d = float(sum(d_par) / len(d_par))    # (np.mean's sums of one or two values, bit for bit)
        elif child_ok:
            d = float(at(child))
        else:
            if final and node in self._deferred:
                self._deferred.discard(node)
                self.fork(node)                   # the provisional place stands
            elif final:
                self.place_pending(node)          # (if not made yet: it stands)
            return
        agree = seen_right = False
        if parents and outline is not None and not any(self.curves[s].by_row for s in parents):
            # a flat parent's disparity (from its texture) may be a px or two off; the child's
            # outline leaving it in the right view tells the fork's own (along the rows)
            d_out = self._flat_fork_disparity(xy, outline[1], c2, e2, d, r_par, rad[child])
            # (unless the child's own disparity agrees with the parent's: the two views' outline
            # places may be a px or two apart, as with noisy masks)
            if d_out is None:
                pass
            elif sides is not None and self._carried_px(child, xy) > CHILD_CARRY_PX \
                    and min(abs(v - d_out) for v in sides) <= SIDE_OUTLINE_PX:
                # the median above took the child's curve carried far to the fork (its end slope
                # carried tens of rows): the side that the right outline confirms (seed 151's fork,
                # +2.5 px from the child's carried curve)
                d, agree = 0.5 * (min(sides, key=lambda v: abs(v - d_out)) + d_out), True
            elif FLAT_PICK and len(d_par) == 2 and all(s in flat_read for s in parents) \
                    and abs(d_par[0] - d_par[1]) > FLAT_SIDES_DIFFER_PX:
                # the two sides' textures next to the fork disagree: the outline's disparity too, if
                # within the outline check's tolerance of one (each view's outline place is ~1 px off)
                # (picking the nearer side alone was worse: the outline's place is noisy)
                if min(abs(v - d_out) for v in d_par) <= max(1.6, 0.009 * abs(d)):
                    d, agree = float((d_par[0] + d_par[1] + d_out) / 3.0), True
            elif FLAT_TAPER and len(d_par) == 2 and all(s in flat_read for s in parents):
                # the two sides' textures next to the fork agree: two measurements of the parent there,
                # which the outline (its place ~1 px off in each view) confirms, as within the 3 px the
                # rule below would take it, but does not replace (seed 146's fork: -1.8 px)
                seen_right = abs(d_out - d) <= 3.0
            elif FLAT_PICK and abs(d_out - d) <= 1.0:
                seen_right = True       # the child's outline in the right view leaves the parent there too
            elif 1.0 < abs(d_out - d) <= 3.0 and not (child_ok and _agree(at(child), d)):
                if child not in self.curves:            # (checked again: recheck_outline_forks)
                    self._from_outline[int(node)] = (child, d)
                d, agree = d_out, True
        from_outline = agree
        self.uvd[node] = np.array([xy[0], xy[1], d])
        self.radius[node] = rad[child]
        agree = agree or seen_right or child_ok and _agree(at(child), d)
        # the disparity the fork takes from the pieces whose fits reach it, if it agrees (below); a
        # provisional place (no outline) is hidden whatever agrees: its checks run only when that
        # disparity would differ (the same results, the work skipped otherwise)
        d_known = self._known_disparity(parents, child, child_ok, xy, d, at, side_near) \
            if parents and not from_outline else None
        out = e2 if np.dot(c2 - xy, e2) >= 0 else -e2      # (the child's direction away from the fork)
        if parents and not agree and outline is not None:     # the child's outline in the right view
            agree = self._outline_agrees(xy, outline[1], c2, e2, parents, r_par, rad[child])
        if parents and not agree and outline is not None and child not in self.curves \
                and abs(e2[1]) < FLAT_CHILD_SIN:      # a child along the rows: its bark texture (forkchild.py)
            agree = child_texture_agrees(self.sm.left_gray, self.sm.right_gray, xy, out,
                                         float(((near[child] - xy) @ out).min()), d, rad[child],
                                         self.sm.f_px, self.sm.offset_px)
        if parents and not agree and (final or d_known is not None):   # the child's own crossings next to the parent
            # (compiled: kernels.near_points, the same selection as np.hypot's)
            pts = kernels.near_points(self.seg_points(child), float(p[0]), float(p[1]), 1.2 * r, 1.2 * r + 60)[0]
            agree = self._runs_agree(pts, d, rad[child])
        if parents and agree and outline is not None:      # a branch running on past the parent crosses it: no fork
            sin_t = abs(outline[1][0] * e2[1] - outline[1][1] * e2[0])
            agree = not passes_through(self.sm.left_mask, xy, out, r_par / max(sin_t, 0.2) + 2.0, rad[child])
        if agree and d_known is not None:
            self.uvd[node][2] = d_known
        elif agree and SIDES_WEIGHTED and final and len(d_par) == 2 and abs(d_par[0] - d_par[1]) > SIDES_WEIGHT_PX \
                and all(self.curves[s].by_row for s in parents):
            # the two steep sides disagree beyond their rows' noise (the checks above took their mean):
            # each weighted by how well its line is known at the fork (fewer rows, carried further: the less)
            self.uvd[node][2] = weigh_sides(d_par, [self._side_rows(s, xy, side_near.get(s)) for s in parents])
        if not parents or not agree or outline is None:
            # (without the child's outline the fork's place is only the slide back along the
            # parent, mostly 10-100 px off: withheld)
            self.hidden.add(int(node))
        else:
            self.hidden.discard(int(node))

    def _radius_at_fork(self, parents: list, xy: np.ndarray) -> float | None:
        """The parent's radius (px) at the fork ``xy`` (2,) from its two sides' (each its span's mean,
        taken at the span's middle): a branch tapers along its length, so the distal side's radius is
        smaller than at the fork and the proximal one's larger; linear between the two middles by their
        distances in the image. None with fewer than two fitted sides (the side's own stands)."""
        if len(parents) != 2:
            return None
        (ra, da), (rb, db) = ((self.curves[s].radius_px,
                               float(np.hypot(*(self.curves[s].uv_at(np.array([0.5 * sum(self.curves[s].t_range)]))[0]
                                                - xy)))) for s in parents)
        return taper_radius(ra, da, rb, db)

    def recheck_outline_forks(self) -> None:
        """Forks on a flat parent whose disparity the right outline of a child without a curve
        set (:meth:`fork`) take the parent's own back where the child has since gained a stub's
        curve (caps.py) more than ``CHILD_DEPTH_PX`` from the parent's at its end next to the
        fork: a child pointing steeply in depth, whose right outline leaves the parent where the
        child is already nearer or further (seed 145's fork: +1.3 px from the outline, the
        parent's texture +0.3)."""
        for node, (child, d_par) in self._from_outline.items():
            c = self.curves.get(child)
            if c is None or node not in self.uvd:
                continue
            lo, hi = c.t_range
            t = float(c.t_of(self.node_xy[node])[0])
            d_child = float(c.d_at(hi if abs(t - hi) <= abs(t - lo) else lo)[0])
            if abs(d_child - d_par) > CHILD_DEPTH_PX:
                self.uvd[node][2] = d_par

    def _carried_px(self, s: int, xy: np.ndarray) -> float:
        """How far (in its parameter: rows or columns) piece ``s``'s curve is carried past its
        fitted span to reach ``xy`` (2,); 0 inside it."""
        c = self.curves[s]
        lo, hi = c.t_range
        t = float(c.t_of(xy)[0])
        return max(lo - t, t - hi, 0.0)

    def defer_forks(self, nodes) -> None:
        """Provisional forks (:meth:`fork`, not final) of ``nodes``, made only when read (their
        place: :meth:`place_pending`, by a flat piece's ends or a final round that finds no place),
        with the curves as they are now: the same places as making them now. The final round
        replaces every other one whole (place, radius, hidden), so those are never made."""
        self._pending.update(int(n) for n in nodes)
        self._pending_curves = dict(self.curves)

    def place_pending(self, node: int) -> None:
        """Make ``node``'s provisional fork now if it is still pending (:meth:`defer_forks`)."""
        if node not in self._pending:
            return
        self._pending.discard(node)
        now, self.curves = self.curves, self._pending_curves
        try:
            self.fork(node)
        finally:
            self.curves = now

    def _known_disparity(self, parents: list, child: int, child_ok: bool, xy: np.ndarray, d: float,
                         at, near=None) -> float | None:
        """The disparity (px) an agreed fork at ``xy`` (placed at disparity ``d``) takes from the pieces
        whose fits reach it (a piece fitted on a few rows and carried far past them is barely known
        there), where the others move it by more than half a pixel (within that, both sides' means
        average out the crotch's bias on each), or, when none reaches it, from the one carried
        clearly least far; None to keep ``d``. ``at(s)``: piece s's disparity at
        the fork; ``near``: {piece: :class:`forkdisp.SideNear`} of the sides read from their own crossings
        nearest the fork (known there if one lies within 12 px)."""
        reach = {s: self._reach(s, xy) for s in (*parents, child) if s in self.curves}
        for s, v in (near or {}).items():           # (read from rows within 12 px of the fork: known there)
            reach[s] = min(reach[s], v.nearest_px - 12.0)
        near_p = [s for s in parents if reach[s] <= 0]
        if near_p and len(near_p) < len(parents):
            d_near = float(sum(at(s) for s in near_p) / len(near_p))      # (np.mean's value of one)
            return d_near if abs(d_near - d) > 0.5 else None
        if not near_p and child_ok and reach[child] <= 0:
            return float(at(child))
        if not near_p:
            # none reaches it: the one carried clearly least far (12 px less than any other)
            cand = sorted((reach[s], s) for s in (*parents, *([child] if child_ok else [])))
            if len(cand) >= 2 and cand[0][0] < cand[1][0] - 12.0:
                d_best = float(at(cand[0][1]))
                return d_best if abs(d_best - d) > 0.5 else None
        return None

    def _side_rows(self, s: int, xy: np.ndarray, near=None) -> tuple[float, float]:
        """How a steep parent side's disparity at the fork ``xy`` (2,) is known: (rows, rows past the
        nearest) of its own crossings read nearest the fork (``near``: a :class:`forkdisp.SideNear`),
        or else of its fitted span and how far its curve is carried (:func:`forkdisp.weigh_sides`)."""
        if near is not None:
            return float(near.n_rows), float(near.nearest_px)
        lo, hi = self.curves[s].t_range
        return hi - lo, self._carried_px(s, xy)

    def _reach(self, s: int, xy: np.ndarray) -> float:
        """How far (px of t) piece ``s``'s curve is carried past its fitted span to reach ``xy``,
        beyond what its span vouches for (half the span, at least 12): <= 0 when it is known there."""
        c = self.curves[s]
        lo, hi = c.t_range
        t = c.t_of(xy)[0]
        return max(lo - t, t - hi) - max(12.0, 0.5 * (hi - lo))

    def _fork_from_child_outline(self, c1, e1, c2, e2, p0, r_par: float, r_child: float,
                                 mask: np.ndarray | None = None) -> np.ndarray | None:
        """The fork from the child's outline where it leaves the parent: None when unclear.

        Lines parallel to the parent's axis (``c1``, ``e1``), just clear of the parent's outline
        on the child's side, cross the child in an interval whose middle is the child's axis
        (its two edges are parallel); the middles on two such lines give the child's axis, whose
        crossing with the parent's axis is the fork. The child's line (``c2``, ``e2``) only
        tells which crossing is the child's. Intervals not as wide as the child seen at that
        angle (hidden by a leaf, merged with something) make a pair of lines unclear; a pair
        further out is tried then. The intervals' ends are where the mask's coverage (0-255,
        bilinear) crosses 128, to a fraction of a pixel. ``mask``: the left view's unless given.
        """
        mask = self.sm.left_mask if mask is None else mask
        # (compiled whole: kernels_forks.child_outline_fork; its scans kernels.child_outline_pairs, the
        # values of _line_samples + _interval_middle, the mask read only where the scans look)
        found, xy = kernels_forks.child_outline_fork(np.ascontiguousarray(mask), *(np.ascontiguousarray(v, float) for v in (
            c1, e1, c2, e2, p0)), float(r_par), float(r_child))
        return xy if found else None

    def _outline_agrees(self, xy, e1, c2, e2, parents: list, r_par: float, r_child: float) -> bool:
        """Whether the child's outline in the right view leaves the parent at the fork too.

        The parent's axis in the right view is the left one moved by its disparity; the fork
        found there from the child's right outline must be the left fork moved by the parent's
        disparity (within 1.6 px or 0.9 %: each view's place is ~1 px off): a child at another
        depth crosses the parent elsewhere. A child so near the rows that a depth difference of
        ``OUTLINE_MAX_D_PX`` would move its crossing less than that cannot tell: False.
        """
        def right_of(pt):
            ds = [self.curves[s].d_at(self.curves[s].t_of(pt))[0] for s in parents]
            d = sum(ds) / len(ds)          # (np.mean's value of one or two: the same sum and division)
            return pt - np.array([d, 0.0]), d
        r1, d1 = right_of(xy)
        r2, _ = right_of(xy + 30.0 * e1)
        er = (r2 - r1) / max(np.hypot(*(r2 - r1)), 1e-9)
        tol = max(1.6, 0.009 * d1)
        # a child at another depth by D px crosses the parent D |e2_y| / sin(angle) px further
        # along it in the right view: a child near the rows (a crossing branch) moves too little
        if tol * abs(er[0] * e2[1] - er[1] * e2[0]) > OUTLINE_MAX_D_PX * abs(e2[1]):
            return False
        xy_r = self._fork_from_child_outline(r1, er, c2 - np.array([d1, 0.0]), e2, r1, r_par, r_child,
                                             self.sm.right_mask)
        return xy_r is not None and np.hypot(*(xy_r - r1)) <= tol

    def _flat_fork_disparity(self, xy, e1, c2, e2, d: float, r_par: float, r_child: float) -> float | None:
        """The disparity of a fork on a flat parent (axis direction ``e1`` within ~25 deg of the
        rows) from the child's outline in the right view: the fork found there on the parent's
        axis (the left one moved by ``d``, along the rows) lies on the same row, moved by the
        fork's own disparity. None when unclear or not on the row (1 px)."""
        if abs(e1[0]) < 0.9:
            return None
        r1 = xy - np.array([d, 0.0])
        xy_r = self._fork_from_child_outline(r1, e1, c2 - np.array([d, 0.0]), e2, r1, r_par, r_child,
                                             self.sm.right_mask)
        if xy_r is None or abs(xy_r[1] - xy[1]) > 1.0:
            return None
        return float(xy[0] - xy_r[0])

    @staticmethod
    def _child_crossings(lines: list, e, r_child: float, sin_t: float, mask: np.ndarray) -> list:
        """Middles (parameter s along each line ``base + s e``, for each ``(base, s_c)`` of ``lines``)
        of the ``mask`` interval at or nearest to ``s_c``, where it is as wide as a piece of radius
        ``r_child`` crossed at sine ``sin_t``; else None. The mask is read once for all lines."""
        return [EndPlacer._interval_middle(*sv, r_child, sin_t)
                for sv in EndPlacer._line_samples(lines, e, r_child, sin_t, mask)]

    @staticmethod
    def _line_samples(lines: list, e, r_child: float, sin_t: float, mask: np.ndarray) -> list:
        """:meth:`_child_crossings`' samples: for each ``(base, s_c)`` of ``lines``, the parameters
        ``s`` (1 px apart, around ``s_c``), the ``mask`` along ``base + s e`` there (bilinear; one
        read for all lines: each point's value is its own) and ``s_c``."""
        reach = (4.7 * r_child + 3) / sin_t + 2          # the interval nearest s_c, whole, if as wide
        ss = [np.arange(s_c - reach, s_c + reach, 1.0) for _, s_c in lines]
        n = [len(s) for s in ss]
        s_all = np.concatenate(ss)
        uv = np.repeat(np.array([base for base, _ in lines]), n, axis=0) + s_all[:, None] * e
        val = EndPlacer._bilinear(mask, uv)
        out, i0 = [], 0
        for (_, s_c), s in zip(lines, ss):
            out.append((s, val[i0:i0 + len(s)], s_c))
            i0 += len(s)
        return out

    @staticmethod
    def _bilinear(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """``img`` (H, W) uint8 at points ``uv`` (N, 2) (x, y), bilinear (1/32 px); 0 outside."""
        m = uv.astype(np.float32)
        parts = [cv2.remap(img, m[i:i + 16384].reshape(1, -1, 2), None, cv2.INTER_LINEAR,    # (OpenCV maps up
                           borderMode=cv2.BORDER_CONSTANT, borderValue=0)[0]                 # to 32767 wide)
                 for i in range(0, max(len(m), 1), 16384)]
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    @staticmethod
    def _interval_middle(s: np.ndarray, val: np.ndarray, s_c: float, r_child: float, sin_t: float) -> float | None:
        """Middle of the interval of ``val`` >= 128 (mask coverage 0-255 at the evenly spaced samples
        ``s``) nearest ``s_c``, its ends interpolated to where the coverage crosses 128, if it is as
        wide as the child crossed at ``sin_t``."""
        ds = s[1] - s[0]
        ic = int(np.rint((s_c - s[0]) / ds))
        w = int(2 * r_child / sin_t / ds)
        lo_i, hi_i = max(ic - w, 0), min(ic + w + 1, len(s))
        if lo_i >= hi_i:
            return None
        # (scans of the samples as Python ints, from the middle outwards: the same samples as
        # searching the lists of all "on" and "off" indices, ~4 against ~16 us a call)
        vals = val.tolist()
        c = min(max(ic, lo_i), hi_i - 1)           # the nearest "on" sample to s_c in the window
        k = None                                    # (at equal distances the one before)
        for dd in range(max(c - lo_i, hi_i - 1 - c) + 1):
            if c - dd >= lo_i and vals[c - dd] >= 128:
                k = c - dd
                break
            if c + dd < hi_i and vals[c + dd] >= 128:
                k = c + dd
                break
        if k is None:
            return None
        a = k - 1                                   # the last sample off before k
        while a >= 0 and vals[a] >= 128:
            a -= 1
        b = k + 1                                   # the first off after k
        while b < len(vals) and vals[b] >= 128:
            b += 1
        if a < 0 or b == len(vals):
            return None
        va, vb = float(vals[a]), float(vals[b])
        lo = s[a] + ds * (128.0 - va) / max(float(vals[a + 1]) - va, 1e-9)
        hi = s[b] - ds * (128.0 - vb) / max(float(vals[b - 1]) - vb, 1e-9)
        if abs((hi - lo) * sin_t - 2 * r_child) > 0.8 * r_child + 2:
            return None
        return 0.5 * (lo + hi)

    def _runs_agree(self, pts: np.ndarray, d: float, r: float, min_rows: int = 3) -> bool:
        """Whether a piece's own row crossings at points ``pts`` (N, 2) have disparity ``d``.

        On each row of the points the left crossing (not wider than a piece of radius ``r``
        across that row) is compared with the right crossings of a similar width in the
        working range; rows where one of them lies within :func:`_agree` of ``d`` must be at
        least ``min_rows`` and 60 % of the rows with any (rows merged with the parent in the
        right view have none). A piece within ~17 deg of the rows: False.
        """
        # (compiled whole: kernels_forks.runs_agree, the same steps)
        rl, rr = self.runs_l, self.runs_r
        dmin, dmax = self.sm.d_range_px
        return kernels_forks.runs_agree(np.ascontiguousarray(pts, float), float(d), float(r), int(min_rows),
                                        *rl._find_tables, rl.width, rl.span_px, rl.centre_px, rr._centre_keys,
                                        rr.width, rr.span_px, rr.centre_px, float(dmin), float(dmax))

    def _box(self, s: int) -> tuple[float, float, float, float]:
        """Bounding box (u0, v0, u1, v1) of a fitted piece's centre line (cached)."""
        box = self._box_cache.get(s)
        if box is None:
            c = self.curves[s]
            uv = c.uv_at(linspace(*c.t_range, 8))
            box = self._box_cache[s] = (*uv.min(0).tolist(), *uv.max(0).tolist())
        return box

    def hidden_fork(self, node: int, reach_px: float = 80.0) -> bool:
        """An end whose branch runs on, hidden (by a leaf, an apple), into another branch: the fork.

        The end's centre line, carried straight on for at most ``reach_px``, crosses the centre
        line of a fitted piece at least as thick, at ``HIDDEN_FORK_MIN_DEG`` or more (at a
        shallower angle it is the branch itself running on, bent, behind the occluder); if the
        end's own disparity carried along agrees there with that piece's (:func:`_agree`), the
        crossing is the fork (with the parent's disparity) and the end is placed there.
        Returns whether it was.
        """
        if node not in self.hidden:
            return False
        segs = [s for s in self.incident[node] if s in self.curves]
        if not segs:
            return False
        c = self.curves[segs[0]]
        # (from the whole-pixel walk's end: its 1 px steps and checks were set with it; the sub-pixel
        # one only moves their grid, and flips borderline crossings, docs/localize-softmask.md)
        t_edge, sign = self._walk_out(c, node, whole=True)
        t = t_edge + sign * np.arange(0.0, reach_px, 1.0)
        uv = c.uv_at(t)
        # (the scan of all pieces compiled: kernels_forks.hidden_crossings, the same values)
        row, pieces, table = self._curve_table()
        cross = kernels_forks.hidden_crossings(uv, 0.8 * c.radius_px, row.get(segs[0], -1), *table)
        best = None
        for j in np.flatnonzero(cross != -1).tolist():
            k = int(cross[j]) if cross[j] >= 0 else self._hidden_crossing(uv, *pieces[j])
            if k >= 0 and (best is None or k < best[0]):
                best = (k, pieces[j][1])
        if best is None:
            return False
        k, c2 = best
        xy = uv[k]
        t2 = c2.t_of(xy)[0]
        e2 = c2.uv_at(t2 + 1.0)[0] - c2.uv_at(t2 - 1.0)[0]
        e1 = uv[min(k + 1, len(uv) - 1)] - uv[max(k - 1, 0)]
        sin_t = abs(e1[0] * e2[1] - e1[1] * e2[0]) / max(np.hypot(*e1) * np.hypot(*e2), 1e-9)
        if sin_t < np.sin(np.radians(HIDDEN_FORK_MIN_DEG)):
            return False
        d_par = float(c2.d_at(c2.t_of(xy))[0])
        d_child = float(c.d_at(c.t_of(xy))[0])
        if not _agree(d_child, d_par):
            return False
        self.uvd[node] = np.array([xy[0], xy[1], d_par])
        self.radius[node] = c.radius_px
        self.hidden.discard(int(node))
        return True

    def _curve_table(self) -> tuple[dict, list, tuple]:
        """The fitted pieces as :func:`kernels_forks.hidden_crossings`' arrays (cached while the curves
        stay): {piece: row}, the (piece, curve) of each row, and (by_row, t_lo, t_hi, radius, poly,
        coef, n_coef, dcoef, n_dcoef, t0, ts)."""
        key = tuple(self.curves.items())
        hit = getattr(self, "_table_cache", None)       # (made on first use)
        if hit is not None and hit[0] == key:
            return hit[1]
        cv = [c for _, c in key]
        n = len(cv)
        coef, dcoef = np.zeros((n, 4)), np.zeros((n, 4))
        n_coef, n_dcoef = np.zeros(n, np.int64), np.zeros(n, np.int64)
        poly = np.zeros(n, bool)
        t0, ts = np.zeros(n), np.ones(n)
        for j, c in enumerate(cv):
            p = c.s_poly
            if type(p) is Poly and len(p.coef) <= 4:
                poly[j] = True
                n_coef[j], n_dcoef[j] = len(p.coef), len(p._deriv.coef)
                coef[j, :n_coef[j]], dcoef[j, :n_dcoef[j]] = p.coef, p._deriv.coef
                t0[j], ts[j] = p.t0, p.ts
        table = (np.array([c.by_row for c in cv], bool), np.array([c.t_range[0] for c in cv], float),
                 np.array([c.t_range[1] for c in cv], float), np.array([c.radius_px for c in cv], float),
                 poly, coef, n_coef, dcoef, n_dcoef, t0, ts)
        out = ({s: j for j, (s, _) in enumerate(key)}, key, table)
        self._table_cache = (key, out)
        return out

    def _hidden_crossing(self, uv: np.ndarray, s2: int, c2: BranchCurve) -> int:
        """:func:`kernels_forks.hidden_crossings`' result for one piece ``s2`` whose centre line is not
        a plain Poly (spliced past an occluder; its span already checked): numpy."""
        lo_u, lo_v = (uv.min(0) - 2).tolist()
        hi_u, hi_v = (uv.max(0) + 2).tolist()
        u0, v0, u1, v1 = self._box(s2)
        if u0 > hi_u or v0 > hi_v or u1 < lo_u or v1 < lo_v:
            return -1
        lo, hi = c2.t_range
        ta, tb = (uv[:, 1], uv[:, 0]) if c2.by_row else (uv[:, 0], uv[:, 1])
        inside = (ta >= lo - 2) & (ta <= hi + 2)
        if inside.sum() < 2:
            return -1
        f = tb - c2.s_at(ta)
        cross = np.flatnonzero(inside[:-1] & inside[1:] & (np.sign(f[:-1]) != np.sign(f[1:])))
        return int(cross[0]) if len(cross) else -1

    def prewalk(self, nodes) -> None:
        """The plain walks (:meth:`_walk_out`: the end's first fitted piece's centre line, followed
        outwards until it leaves the left mask) of the ends ``nodes`` all at once, into the cache
        the walks read: the same parameters, points and results as walking each alone (a walk's
        points all lie beyond one end of the span: that end's value and slope, as
        :meth:`BranchCurve.uv_at`), one mask read for all."""
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
            vals.append((start, sign, c.s_poly.at(start), c.s_poly.deriv().at(start), c.by_row))
        if not ks:
            return
        n = ts
        start, sign, value, slope, by_row = (np.repeat(np.array(a), n) for a in zip(*vals))
        ends = np.cumsum(n)
        steps = np.arange(ends[-1]) - (ends - n).repeat(n)       # each walk's 0, 1, 2, ...
        t_all = start + sign * (steps * 0.25)              # (np.arange(0, reach, 0.25)'s values, each walk's t)
        s_all = value + slope * (t_all - start)            # (_eval beyond one end: the same sums)
        uv_all = np.empty((len(t_all), 2))
        uv_all[:, 0] = np.where(by_row, s_all, t_all)
        uv_all[:, 1] = np.where(by_row, t_all, s_all)
        idx, crosses = walk_edges(self.sm.left_mask, uv_all, np.r_[0, ends])
        for i, (node, c, sign) in enumerate(ks):
            a, b = ends[i] - n[i], ends[i]
            t = t_all[a:b]
            res = (self._walk_t(t, sign, idx[i], crosses[i]), sign)
            self._walk_cache[node, id(c)] = [c, t, sign, uv_all[a:b], None, {(0.0, False): res}]

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

    def tip(self, node: int) -> None:
        """A tip: the end of the mask along the centre line, less the round cap (its own radius).

        An end is hidden, not a tip (kept as the piece's end but flagged in ``self.hidden``),
        when the right view's outline ends elsewhere along the branch than the left's (an
        occluder's edge, not the branch's own cap), or when something at the branch's depth
        or nearer lies just beyond it.
        """
        self.tips([node])

    def tips(self, nodes) -> None:
        """:meth:`tip` of several ends (each placed and checked on its own); the round-cap checks of
        the ends that reach them read the mask together (:func:`tips.cap_shapes_offsets`: each end's
        values as alone), before the probes beyond them (both only hide an end: the order does not
        matter); a tip that passes them all moves onto its cap's centre (:meth:`_place_on_cap`)."""
        ends = []
        for node in nodes:
            end = self._tip_place(node)
            if end is not None:
                ends.append((node, *end))
        if not ends:
            return
        shapes, offsets = cap_shapes_offsets(self.sm.left_mask, [end[1:4] for end in ends])
        for (node, uv_edge, out, r, edge_bias_px), shape, offset in zip(ends, shapes, offsets):
            if not reads_round(shape):            # an occluder's edge ends it (tips.cap_shape)
                self.hidden.add(int(node))
                continue
            half = max(4, int(round(r)))
            probe = uv_edge + out * (half * (abs(out[0]) + abs(out[1])) + 2)   # the square patch clear of the cap
            if nearer_in_front(self.sm.left_gray, self.sm.right_gray, probe[None], self.uvd[node][2:3],
                               np.array([half]), self.sm.d_range_px[1]) and \
                    occluder_confirmed(self.sm, uv_edge, out, self.uvd[node][2], half):
                self.hidden.add(int(node))
                continue
            self._place_on_cap(node, uv_edge, out, r, edge_bias_px, shape, offset)

    def _place_on_cap(self, node: int, uv_edge: np.ndarray, out: np.ndarray, r: float, edge_bias_px: float | None,
                      shape: list | None, offset_px: float) -> None:
        """Move a tip that passed its checks onto its round cap's centre (:func:`tips.cap_centre`,
        from the round-cap readings ``shape`` and the width's middle ``offset_px``): the cap's own
        radius (a tapering branch's piece radius ``r`` is ~10 % (p95 ~40 %) larger) back from
        where the centre line leaves the mask (the half-coverage crossing: the walk's edge
        ``uv_edge`` lies ``edge_bias_px`` past it), and across the line where the branch's width
        is not centred on it; the tip's radius becomes the cap's. Its disparity stays (the cap's
        rows, the run end). A tip whose width is read up to the view's edge keeps its place (the
        width may be cut there), and so does one the move alone would take within the features'
        edge margin (dense.match_dense: like the checks, that test sees the place it had), or a
        cap cut by the view's edge (``edge_bias_px`` None: placed from its chord)."""
        centre = None if edge_bias_px is None else cap_centre(shape, offset_px, r)
        if centre is None:
            return
        back, across, rho = centre
        normal = np.array([-out[1], out[0]])
        uv = uv_edge - out * (edge_bias_px + back) + normal * across
        p = uv_edge - out * (CAP_WIDTH_BACK * r)
        sides = p + np.outer([shape[0][0] + offset_px, offset_px - shape[0][0]], normal)   # (cut: last pixel + 0.5)
        h, w = self.sm.left_mask.shape
        if not ((sides >= 0).all() and (sides[:, 0] <= w - 1).all() and (sides[:, 1] <= h - 1).all()):
            return
        margin = VIEW_EDGE_PX + self.g.scale
        old = self.uvd[node]
        if min(uv[0], uv[1], w - 1 - uv[0], h - 1 - uv[1]) < margin <= min(old[0], old[1], w - 1 - old[0], h - 1 - old[1]):
            return
        self.uvd[node][:2] = uv
        self.radius[node] = rho

    def _tip_place(self, node: int) -> tuple | None:
        """:meth:`tip` up to its round-cap check: the end placed (one piece radius back from the
        walk's edge), hidden where its checks so far say; ``(uv_edge, out, r, edge_bias_px)`` for
        the rest where it is not (yet) hidden, else None (``edge_bias_px``: how far the walk's edge
        lies past the half-coverage crossing, px; None for a cap cut by the view's edge, whose
        placement from its chord stands)."""
        segs = [s for s in self.incident[node] if s in self.curves]
        if not segs:
            return None
        c = self.curves[segs[0]]
        t_edge, sign = self._walk_out(c, node)
        uv_edge = c.uv_at(t_edge)[0]
        step = c.uv_at(t_edge + sign)[0] - uv_edge
        speed = max(float(np.hypot(*step)), 1e-9)       # px of the image per unit of t
        out = step / speed
        r = max(c.radius_px, 1.0)
        (ex, ey), (ox, oy) = uv_edge.tolist(), out.tolist()
        bx, by = round(ex + 2.5 * ox), round(ey + 2.5 * oy)        # (np.rint's in Python floats: halves to even)
        h, w = self.sm.left_mask.shape
        if not (0 <= bx < w and 0 <= by < h) or (self.sm.valid_left is not None and not self.sm.valid_left[by, bx]):
            back = self._cap_cut_by_edge(c, uv_edge, out, r)
            if back is None:
                return None                          # the branch leaves the view: no tip seen
            edge_bias_px = None                      # (placed from the chord: stays)
        else:
            back = r
            edge_bias_px = WALK_EDGE_BIAS * speed
        # (placed one piece radius back for the checks below; a tip that passes them all is moved
        # onto its cap's centre in tips())
        uv = uv_edge - out * back
        self.uvd[node] = np.array([uv[0], uv[1], c.d_at(float(uv[1] if c.by_row else uv[0]))[0]])   # (c.t_of's t)
        self.radius[node] = c.radius_px
        cap_behind = False
        if not c.by_row:
            # a flat piece's disparity comes from its texture: the tip stands only if the end of
            # its row run is found in the right view too; it takes the run end's (its outline is
            # sub-pixel: subpixel.refine_runs) when the two agree (2 px) or the end's outline agrees
            # row by row
            d_end = self._end_disparity(uv_edge, out, self.uvd[node][2], r)
            if d_end is None and c.segment in self.cap_segments:
                d_end = self.uvd[node][2]     # a flat stub's curve has its cap's disparity (tips.py)
            elif d_end is None and r > 2.0:
                # the run end is this tip's only depth of its own: a centre line inclined to the
                # rows leaves the cap where the row's own run may end sooner, read it further inside
                d_end = self._end_disparity(uv_edge, out, self.uvd[node][2], r, 0.5 * r)
            if d_end is None or not self._carried_agrees(c, node, d_end):
                self.hidden.add(int(node))
                return None
            if abs(d_end - self.uvd[node][2]) <= 2.0:
                self.uvd[node][2] = d_end
            elif self._end_outline_agrees(uv_edge, out, d_end, r):
                # an occluder's edge lies in front of the branch it cuts: an end further away
                # than the texture says is the cap's own (the texture's is off, and so is the
                # end shift below, measured with it)
                cap_behind = d_end < self.uvd[node][2]
                self.uvd[node][2] = d_end
            # else the right run's end is not the cap's (something touches it there): the texture's stands
        if not self._seen_right(self.uvd[node], r):
            self.hidden.add(int(node))                # hidden in the right view: no depth of its own
            return None
        # a tip ends where its 3D cap ends, in both views alike; an outline that cuts the branch
        # (a leaf, an apple, another branch at another depth) ends it elsewhere in the right view
        t_right, _ = self._walk_out(c, node, right=True)
        if not cap_behind and abs(t_right - t_edge) * speed > (END_SHIFT_STEEP_PX if c.by_row else END_SHIFT_FLAT_PX) and not (
                c.by_row and sign * (t_right - t_edge) > 0 and self._wider_on_right(c, t_edge, sign, r)):
            # the left cap cut by a thing in front of it, whole in the right view: placed from there
            # (merged_tips.py; its own checks of the right view's cap stand for those below)
            uvd = right_cap_tip(self, c, t_edge, t_right, sign) if c.by_row else None
            if uvd is None:
                self.hidden.add(int(node))
            else:
                self.uvd[node] = uvd
            return None
        if c.by_row:        # the cap's own rows, rather than the fitted line carried to the tip
            d_cap = self._cap_disparity(c, t_edge, uv_edge, out, sign, self.uvd[node][2], r)
            if d_cap is not None and np.isnan(d_cap):
                self.hidden.add(int(node))
                return None
            if d_cap is not None:
                self.uvd[node][2] = d_cap
        if not self._beyond_in_right_view(uv_edge, out, self.uvd[node][2]):
            self.hidden.add(int(node))                # the right view's edge cuts the cap: no end seen there
            return None
        if self.cfg.oblique_end_ratio > 0:
            # a round cap ends alike on both sides of the axis; a leaf's or an apple's outline
            # usually cuts the branch obliquely (in both views alike when the leaf sits on the
            # branch): such an end is hidden, not a tip. The sides are 0.4 radius off the axis
            # (further out, a tapering tip or a radius a little too large ends a side early)
            t_a, t_b = self._walk_sides(c, node, 0.4 * r)
            if abs(t_a - t_b) * speed > self.cfg.oblique_end_ratio * r:
                t_a, t_b = self._sides_about_middle(c, node, uv_edge, out, r, sign, abs(t_a - t_b) * speed / r, (t_a, t_b))
            if abs(t_a - t_b) * speed > self.cfg.oblique_end_ratio * r:
                self.hidden.add(int(node))
                return None
        return uv_edge, out, r, edge_bias_px

    def _sides_about_middle(self, c: BranchCurve, node: int, uv_edge: np.ndarray, out: np.ndarray, r: float,
                            sign: float, split: float, sides: tuple) -> tuple:
        """The oblique test's two sides (walk parameters) read again about the middle of the
        branch's width 1.5 radii behind the end (:func:`tips.cap_shapes_offsets`) rather than the
        fitted centre line, which a fit over the whole piece often leaves 20-60 % of the radius off
        it there. On a round cap the sides 0.4 r about a line ``m`` r off its middle end
        ``sqrt(1 - (|m| - 0.4)^2) - sqrt(1 - (|m| + 0.4)^2)`` radii apart: only a ``split`` (the
        first reading, in radii) that this offset can explain, within the test's own ratio, is read
        again (an occluder's oblique edge ends the sides further apart); else ``sides`` stand."""
        mid = float(cap_shapes_offsets(self.sm.left_mask, [(uv_edge, out, r)])[1][0]) / r
        if not np.isfinite(mid) or abs(mid) > 0.6:
            return sides
        m = abs(mid)
        expected = math.sqrt(1.0 - (m - 0.4) ** 2) - math.sqrt(max(1.0 - (m + 0.4) ** 2, 0.0))
        if split > expected + self.cfg.oblique_end_ratio:
            return sides
        return (self._walk_out(c, node, sign * mid * r + 0.4 * r)[0], self._walk_out(c, node, sign * mid * r - 0.4 * r)[0])

    def _carried_agrees(self, c: BranchCurve, node: int, d_end: float) -> bool:
        """Whether a flat tip's run-end disparity ``d_end`` (px) may stand on a piece without texture.

        A flat piece whose bark gave no disparity carries its end node's (a fork's) to the tip
        (``n_samples == 0``, not a cap curve of tips.py). The run end is picked nearest that prior,
        so when the junction is two branches merely crossing in the image (another depth) the end
        found is another branch's. Such an end must lie within ``CARRIED_D_PX`` plus
        ``CARRIED_D_PER_PX`` per px the prior was carried (a branch inclined in depth); else the
        tip has no depth of its own and is withheld.
        """
        if c.n_samples > 0 or c.segment in self.cap_segments:
            return True
        others = [n for n in self.g.seg_nodes[c.segment] if n >= 0 and n != node and n in self.uvd]
        if not others:
            return True
        carried = min(float(np.hypot(*(self.uvd[n][:2] - self.uvd[node][:2]))) for n in others)
        return bool(abs(d_end - self.uvd[node][2]) <= CARRIED_D_PX + CARRIED_D_PER_PX * carried)

    def _wider_on_right(self, c: BranchCurve, t_edge: float, sign: float, r: float) -> bool:
        """Whether the right view shows a clearly wider branch just past a steep piece's left
        end, where the piece would run on (another branch touching the tip in the right view
        only, rather than the piece itself going on behind an occluder in the left view).
        """
        rows = np.rint(t_edge + sign * np.arange(1.0, max(2 * r, 4.0))).astype(int)
        rows = rows[(rows >= 0) & (rows < self.sm.right_mask.shape[0])]
        if len(rows) == 0:
            return False
        lo, hi = c.t_range
        ds = c.s_poly.deriv()(np.minimum(np.maximum(rows, lo), hi))       # (np.clip's)
        slope = float(np.hypot(1.0, ds.sum() / len(ds)))             # (the mean: np.mean's sum and division)
        ir = self.runs_r.find(rows, c.s_at(rows) - c.d_at(rows))
        wide = (ir >= 0) & (self.runs_r.span_px[np.maximum(ir, 0)] > 1.6 * 2 * r * slope + 2)
        return bool(np.count_nonzero(wide) / len(wide) >= 0.8)

    def _cap_cut_by_edge(self, c: BranchCurve, uv_edge: np.ndarray, out: np.ndarray, r: float) -> float | None:
        """A steep piece that runs to the edge of the view: the distance (px) from its last
        row back to the centre of its round cap when the cap's chord there is clearly narrower
        than the branch (the cap is cut by the edge); None when the branch runs on out of view.
        """
        if not c.by_row:
            return None
        inner = uv_edge - out
        row = int(np.rint(inner[1]))
        if not 0 <= row < self.sm.left_mask.shape[0]:
            return None
        i = self.runs_l.find(np.array([row]), np.array([inner[0]]))[0]
        if i < 0:
            return None
        chord = self.runs_l.span_px[i] * abs(out[1])
        if chord >= 1.6 * r:
            return None
        return 1.0 + float(np.sqrt(r * r - 0.25 * chord * chord))

    def _cap_disparity(self, c: BranchCurve, t_edge: float, uv_edge: np.ndarray, out: np.ndarray, sign: float,
                       d_prior: float, r: float) -> float | None:
        """Disparity of a steep piece's tip from the rows across its round cap.

        Each rectified row cuts the cap (a sphere around the centre ``P``, one radius back from
        the end along the centre line) in a circle; the middles of the left and right crossings
        of that row both project that circle's centre, a point within the cap, whose depth
        :func:`cap_row_scale` takes back to the cap's centre. Only the cap's own outline counts:
        a crossing's edge is the cap's where it lies on the outward side of ``P`` (across the
        centre line through ``P``); behind it the outline is the piece's body, whose depth is
        another (on an oblique piece one edge of a row is the cap's and the other the body's).
        A row with both edges on the cap gives its middle, a row with one its edge's disparity
        less the outline's silhouette offset (:func:`tips.silhouette_offset_px`, for the row's
        circle), and a row whose edges disagree (:func:`tips.split_row_disparity`: one cut or
        merged in one view only) the nearest of the two and the middle to the agreeing rows. A
        run ending at the view's edge gives no edge there. Median over the rows, within 2.5 px
        of ``d_prior``; None with fewer than 3 rows. ``uv_edge``, ``out``: where the centre line
        leaves the mask (at ``t_edge``) and its unit direction there (:meth:`_tip_place`'s).
        """
        sm = self.sm
        h, w = sm.left_mask.shape
        p = uv_edge - out * r                                # the cap's centre (the tip)
        a = max(int(np.ceil(min(p[1] - r, t_edge))), 0)
        b = min(int(np.floor(max(p[1] + r, t_edge))), h - 1)
        rows = np.arange(a, b + 1)
        rows = rows[(np.abs(rows - p[1]) <= r) & (sign * (t_edge - rows) >= -0.5)]
        if len(rows) < 3:
            return None
        # (the rows' runs, edges, silhouette offsets, split rows and median: one kernel)
        rl, rr, valid_l, valid_r = EndPlacer._tip_tables(self)
        status, d = kernels_tips.cap_disparity(rows, c.s_at(rows), rl, rr, valid_l, valid_r, float(p[0]), float(p[1]),
                                               float(out[0]), float(out[1]), float(r), float(d_prior), float(sm.f_px),
                                               h, w, CAP_EDGE_BACK, SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE)
        return None if status == 0 else float(d)

    def _tip_tables(self) -> tuple:
        """The mask runs' and the valid areas' tables the tips' kernels take (:func:`kernels_tips.runs_tables`),
        made once per placer (again if its runs are replaced)."""
        # (read through getattr: the tests' stand-in placers and masks carry only what they use)
        key = (self.runs_l, self.runs_r, getattr(self.sm, "valid_left", None), getattr(self.sm, "valid_right", None))
        hit = self.__dict__.get("_tip_k")
        if hit is None or any(x is not y for x, y in zip(hit[0], key)):
            hit = self._tip_k = (key, (kernels_tips.runs_tables(key[0]), kernels_tips.runs_tables(key[1]),
                                       kernels_tips.valid_table(key[2]), kernels_tips.valid_table(key[3])))
        return hit[1]

    def _beyond_in_right_view(self, uv_edge: np.ndarray, out: np.ndarray, d: float) -> bool:
        """Whether the right view sees the pixel just past the cap's end (``uv_edge``, left px, moved by
        disparity ``d``) along its row: a cap whose end lies at or past the right view's left or right
        edge shows there only the edge, whatever rows are read. (A cap cut by the top or bottom edge
        is cut on the same rows in both views: the rows left still give its disparity.)"""
        u, v = np.rint(uv_edge + out - np.array([d, 0.0])).astype(int)
        h, w = self.sm.right_mask.shape
        if not 0 <= u < w:
            return False
        valid = self.sm.valid_right
        if valid is None:
            return True
        row = valid[min(max(v, 0), h - 1)]
        return bool(row[u]) or not row.any()

    def _seen_right(self, uvd: np.ndarray, r: float) -> bool:
        """Whether the right mask has branch within half a radius of the point's right position."""
        m = self.sm.right_mask
        u, v = float(uvd[0] - uvd[2]), float(uvd[1])          # (Python floats: round() halves to even, as numpy)
        k = max(1, int(round(0.5 * r)))
        y0, y1 = round(v) - k, round(v) + k + 1
        x0, x1 = round(u) - k, round(u) + k + 1
        if y0 < 0 or x0 < 0 or y1 > m.shape[0] or x1 > m.shape[1]:
            return False
        return bool(m[y0:y1, x0:x1].max() >= 128)

    def _end_disparity(self, uv_edge: np.ndarray, out: np.ndarray, d_prior: float, r: float = 0.0,
                       inside_px: float = 1.0) -> float | None:
        """Disparity of the end of a flat piece: the end of its row run in both views.

        The round cap's silhouette ends one image radius beyond the cap centre in both views,
        so the run ends are corresponding points. Right runs of a similar length ending in the
        disparity range are candidates; the one nearest ``d_prior`` wins. With the radius ``r``
        (px), the median over the rows within half a radius of the axis (at least 3 within 1 px
        of the axis row's): on 28 rendered scenes the median error of such tips drops by a third
        to a half (docs/localize-subpixel.md). The row's left run is the one ``inside_px`` back
        along the row from ``uv_edge``.
        """
        sm = self.sm
        h, w = sm.left_mask.shape
        rl, rr, _, valid_r = EndPlacer._tip_tables(self)
        ok, d = kernels_tips.end_disparity(rl, rr, valid_r, float(uv_edge[0]), float(uv_edge[1]), float(out[0]),
                                           float(out[1]), float(d_prior), float(r), float(inside_px),
                                           float(sm.d_range_px[0]), float(sm.d_range_px[1]), float(sm.f_px), h, w,
                                           END_RUN_CUT_PX)
        return float(d) if ok else None

    def _end_outline_agrees(self, uv_edge: np.ndarray, out: np.ndarray, d: float, r: float) -> bool:
        """Whether a flat piece's end has the same outline in both views at disparity ``d``.

        On the rows across the end (0.6 radius each side of the centre line) the left run's end
        and the right run's end (moved by ``d``) must agree within 1.2 px on at least 80 % of at
        least 3 rows: a round cap ends alike in both views; a right run that runs on into
        something touching the cap (another branch) ends elsewhere on some rows.
        """
        rl, rr, _, _ = EndPlacer._tip_tables(self)
        return bool(kernels_tips.end_outline_agrees(rl, rr, float(uv_edge[0]), float(uv_edge[1]), float(out[0]), float(d),
                                                    float(r), self.sm.left_mask.shape[0]))

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
