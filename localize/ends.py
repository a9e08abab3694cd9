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

import numpy as np
from appliance.config.schema import MatchConfig
from appliance.localize import kernels_forks, kernels_walks
from appliance.localize.curves import BranchCurve, Poly, linspace, median
from appliance.localize.edges import Runs, find_runs
from appliance.localize.forkends import ForkPlacing
from appliance.localize.graph import SkeletonGraph
from appliance.localize.matching import StereoMasks
from appliance.localize.radius import RadiusMap, radius_at
from appliance.localize.tipends import TipPlacing
from appliance.localize.walks import Walks


class EndPlacer(ForkPlacing, TipPlacing, Walks):
    """Places forks, tips and joints of one graph on its fitted curves.

    ``uvd[node]`` is a placed node's rectified (u, v, d); ``radius[node]`` its radius (px);
    nodes in ``hidden`` are placed (they end pieces) but are not features.
    """

    def __init__(self, graph: SkeletonGraph, sm: StereoMasks, curves: dict, cfg: MatchConfig,
                 runs: tuple[Runs, Runs] | None = None, runs_grey_end: tuple[Runs, Runs] | None = None):
        self.g, self.sm, self.curves, self.cfg = graph, sm, curves, cfg
        self.runs_l, self.runs_r = runs if runs is not None else (find_runs(sm.left_mask, soft=True),
                                                                  find_runs(sm.right_mask, soft=True))
        self.runs_grey_end = runs_grey_end      # a soft mask's runs on the grey step whole (tipends.TIP_GREY_END)
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
        sel, dist = kernels_walks.near_points(pts, float(p[0]), float(p[1]), float(1.6 * r), float(1.6 * r + max(40.0, 4 * r)))
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
            # (c.uv_at and c.d_at at c.t_of's one parameter: their one-point path, in Python floats)
            t = float(self.node_xy[node][1 if c.by_row else 0])
            s = c._at(c.s_poly, t)
            self.uvd[node] = np.array([s, t, c._at(c.d_poly, t, c.d_end_slopes)] if c.by_row
                                      else [t, s, c._at(c.d_poly, t, c.d_end_slopes)])
            self.radius[node] = c.radius_px
