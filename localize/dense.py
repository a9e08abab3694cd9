"""Improved matching: dense sub-pixel centre lines along every branch piece.

For a steep piece, each rectified row crosses the branch once in each image; the middle
of that crossing (sub-pixel edges, :mod:`edges`) is the projection of the axis point of
that row's epipolar plane in both views, so its disparity is the axis' disparity. The
right crossing is chosen among the runs of the same row inside the working disparity
range with a similar width, on the straight line (u, v, d) through most candidates, then
refined to a robust polynomial in the row: the piece becomes a smooth (u, v, d) curve
(:mod:`curves`). A right crossing belongs to one piece only. Rows an occluder cuts on one
side, and pieces that only continue a matched one past occluders, are matched by one edge
(:mod:`single_edge`).

Flat pieces (rows ambiguous) take their disparity from the bark texture (:mod:`texture`),
or else from the forks/joints at their ends; a flat piece with neither is left out rather
than guessed. Steep pieces still without a curve that end in a tip take one from the tip's
round cap (:mod:`caps`). Forks, tips and bridges are then placed on the curves (:mod:`ends`).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from appliance.config.schema import MatchConfig
from appliance.localize.curves import (
    BranchCurve,
    GroupPolys,
    Poly,
    angle_deg_groups,
    linspace,
    median,
)
from appliance.localize import kernels_dense, kernels_match, kernels_patchshare
from appliance.localize.caps import cap_curves
from appliance.localize.tips import flat_cap_curves
from appliance.localize.flatfit import (
    FEW_LINE_PATCHES,
    FEW_PATCHES,
    MAX_FEW_MAD_PX,
    MAX_LINE_MAD_PX,
    MIN_LINE_INLIERS,
    MIN_LINE_SHARE,
    MIN_LINE_SPREAD,
    at_window_edge_dropped,
)
from appliance.localize.edges import Runs, find_runs
from appliance.localize.ends import EndPlacer
from appliance.localize.graph import ENDPOINT, JOINT, JUNCTION, SkeletonGraph
from appliance.localize.matching import FeatureUVD, Matching, PieceUVD, StereoMasks
from appliance.localize.radius import RadiusMap, radius_at
from appliance.localize.rectify import ReadBox
from appliance.localize.steepcheck import withheld_segments
from appliance.localize.stubtips import stub_tips, taken_points
from appliance.localize.single_edge import (
    carry_over,
    centre_guess,
    edge_consensus,
    grow,
)
from appliance.localize.subpixel import near_points, refine_runs
from appliance.localize.texture import surface_disparity_many
from appliance.localize.tipends import GREY_END_DEV_PX, TIP_GREY_END

SLANT = True           # flat pieces: the surface-to-axis step along the slanted line of sight
STUB_TIPS = True        # tips of short isolated stubs (stubtips.py; searched from the block mask since stop 22:
                        # docs/localize-stubfast22.md)
STUB_NODE = 1 << 30     # ... their features' node ids (no graph node: none of a piece's)
END_REACH_PX = 48       # run boundaries refined within this of a graph end (its cap, its end rows)
RIGHT_VIEW_EDGE = True  # a feature whose right position (u - d) lies over its radius off the right view is
                        # not reported: nothing there in the right image matched it (issue 5, seed 392 T9)


def _ends_disparity(graph: SkeletonGraph, curves: dict, d_range_px: tuple[float, float],
                    margin_px: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """The graph's ends (E, 2) (x, y) and the disparities (E, 2) (lo, hi) where each may show in
    the right view: its fitted curve's at the end +- ``margin_px``, else the working range."""
    ends = np.flatnonzero(graph.node_kind == ENDPOINT)
    xy = graph.to_full(graph.node_yx[ends])
    d = np.tile(np.asarray(d_range_px, float), (len(ends), 1))
    row = {n: k for k, n in enumerate(ends.tolist())}
    for s, nodes in enumerate(graph.seg_nodes.tolist()):
        c = curves.get(s)
        for n in nodes if c is not None else ():
            k = row.get(n)
            if k is not None:               # (c.d_at(c.t_of(xy[k]))[0]: its one-point path, in Python floats)
                d_end = c._at(c.d_poly, float(xy[k, 1 if c.by_row else 0]), c.d_end_slopes)
                d[k] = d_end - margin_px, d_end + margin_px
    return xy, d


def _regroup(g: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """Group ids (N,) renumbered over the ``alive`` groups (samples of dead groups dropped by the caller)."""
    return (np.cumsum(alive) - 1)[g]


def _row_centres(graph: SkeletonGraph, segs: list[int], radius_map) -> tuple[np.ndarray, ...]:
    """:func:`centre_guess` by rows of every segment in ``segs`` at once, points inside a junction
    region at a segment's end (within 1.6 of its radius + the graph's scale + 1 px of it) left out.

    Returns rows (N,) float, centre columns (N,) and piece index into ``segs`` (N,) (non-decreasing):
    the same values as per piece, bit for bit (one np.interp over the pieces side by side, each
    piece's rows offset by a power of two and its points clamped to its own span).
    """
    yx = [graph.seg_yx[s] for s in segs]
    if not sum(len(a) for a in yx):
        return np.zeros(0), np.zeros(0), np.zeros(0, int)
    pts = graph.to_full(np.concatenate(yx))
    gp = np.repeat(np.arange(len(segs)), [len(a) for a in yx])
    off = 2.0 ** 16                                   # rows < 2^16: keys exact
    uniq, inv = np.unique(pts[:, 1] + gp * off, return_inverse=True)
    s_mean = np.bincount(inv, pts[:, 0]) / np.bincount(inv)
    gu = (uniq // off).astype(int)
    tu = uniq - gu * off
    bu = np.searchsorted(gu, np.arange(len(segs) + 1))
    half = (graph.scale - 1) / 2
    lo_u, hi_u = tu[bu[:-1]], tu[bu[1:] - 1]
    lo, hi = np.ceil(lo_u - half), np.floor(hi_u + half)
    n = (hi - lo + 1).astype(int)
    g = np.repeat(np.arange(len(segs)), n)
    first = np.cumsum(n) - n
    rows = lo[g] + (np.arange(n.sum()) - first[g])
    xc = np.interp(np.minimum(np.maximum(rows, lo_u[g]), hi_u[g]) + g * off, uniq, s_mean)
    nodes = graph.seg_nodes[np.asarray(segs, int)]                     # (G, 2): a junction at either end
    junction = (nodes >= 0) & (graph.node_kind[np.maximum(nodes, 0)] == JUNCTION)
    nxy = graph.to_full(graph.node_yx[np.maximum(nodes, 0).reshape(-1)])   # (2G, 2)
    thr = (1.6 * radius_at(radius_map, nxy) + graph.scale + 1).reshape(-1, 2)
    keep = ~kernels_dense.near_junctions(xc, rows, g.astype(np.int64), np.ascontiguousarray(junction),   # (compiled:
                                   np.ascontiguousarray(nxy.reshape(-1, 2, 2), float), thr)       # the same tests)
    return rows[keep], xc[keep], g[keep]


_NO_TAKEN = np.zeros(0, bool)


def _junction_rows(graph: SkeletonGraph, segs: np.ndarray) -> np.ndarray:
    """(G, 2) float: the row (px, full resolution) of each segment's end nodes that are junctions, NaN
    at its other ends."""
    nodes = graph.seg_nodes[np.asarray(segs, int)]
    junction = (nodes >= 0) & (graph.node_kind[np.maximum(nodes, 0)] == JUNCTION)
    rows = graph.to_full(graph.node_yx[np.maximum(nodes, 0).reshape(-1)])[:, 1].reshape(-1, 2)
    return np.where(junction, rows, np.nan).astype(float)


def fit_steep_many(graph: SkeletonGraph, segs: list[int], runs_l: Runs, runs_r: Runs, sm: StereoMasks,
                   angle_deg: dict[int, float], taken: np.ndarray | None = None) -> dict[int, BranchCurve]:
    """Dense row-by-row match of steep segments, all at once: {segment: curve} of those that find enough.

    Every step runs over the samples of all pieces together (a piece id per sample; the fits
    by :func:`robust_fit_groups`), with the same rules per piece as matching it alone.
    ``angle_deg`` holds each segment's angle from the rows (:func:`curves.angle_deg`); ``taken`` (bool per
    right run) marks right crossings that belong to another piece. A curve's ``right_runs`` are the
    right crossings it used. Without ``taken`` (the first fit), the curves are then carried on past
    occluders along their own rows (:func:`grow`) and onto pieces that found nothing
    (:func:`carry_over`).
    """
    segs0 = list(segs)
    rows, xc, g = _row_centres(graph, segs, sm.radius_map)
    centres = (segs0, rows, xc, g)
    sin_t = np.array([max(np.sin(np.radians(angle_deg[s])), 0.2) for s in segs0])
    rm = sm.radius_map if isinstance(sm.radius_map, RadiusMap) else RadiusMap(np.asarray(sm.radius_map))
    # the rows' left crossings, two width tests and the right candidates (compiled: the same rules)
    seg_idx, rows, il, w_l, g, rows_all, il_all, g_all, n, alive, c_l, q, rr, cd, cw, degree = \
        kernels_dense.steep_candidates(
        np.ascontiguousarray(rows, float), np.ascontiguousarray(xc, float), np.ascontiguousarray(g, np.int64), sin_t,
        runs_l._find_tables, runs_l.span_px, runs_l.centre_px, runs_r._centre_keys, runs_r.centre_px, runs_r.span_px,
        runs_l.width, rm.image, int(rm.scale), *map(float, sm.d_range_px),
        _NO_TAKEN if taken is None else np.ascontiguousarray(taken, np.bool_))
    segs = np.asarray(segs0)[seg_idx]
    ng = len(segs)
    if ng == 0 or not alive.any():
        return {}
    t = rows.astype(float)
    gq = g[q]
    bounds = np.searchsorted(gq, np.arange(ng + 1))
    model = _consensus_lines(t[q], cd, bounds, alive)
    # per row, the candidate nearest the model (twice), the centre line and width fitted to the picks
    # (rows where the branch is partly hidden still show one true edge in both views), and the other
    # rows' single edges (single_edge.edge_samples' steps, moved into the kernel); compiled: the same steps
    ok, alive, tf, df, cf, wf, gc, rc, u_inl, te, de, re, ge, degree = kernels_dense.steep_fit(
        t, alive, n, np.ascontiguousarray(degree, np.int64), q, rr, cd, cw, gq, c_l, w_l, model.coef, model.t0,
        model.ts, rows_all, il_all, g_all, runs_r._find_tables, runs_l.bounds_px, runs_r.bounds_px, runs_l.width,
        _NO_TAKEN if taken is None else np.ascontiguousarray(taken, np.bool_), kernels_dense.OCCL_TOL_PX,
        kernels_dense.OCCL_SHARE, float(sm.f_px), 0.5 * (sm.left_mask.shape[1] - 1), float(sm.offset_px),
        _junction_rows(graph, segs))
    if not ok:
        return {}
    # the disparity fitted to each curve's inliers, all curves at once (rounding-level differences from
    # fitting each alone): to all samples (whole crossings and single edges) of the pieces with edge
    # samples, robustly refitted (in each piece's order), to the whole crossings elsewhere (compiled:
    # kernels_dense.disparity_refit). The centre line u(v) is fitted per curve: fitted all at
    # once (coefficients ~1e-13 apart) it moved the fork and a tip of an exact drawing in
    # tests/localize/test_ends.py by 1-2 px (docs/localize-speed.md, third pass)
    bc, be = (np.searchsorted(a, np.arange(ng + 1)) for a in (gc, ge))
    coef, t0, ts, deg, slopes, t_lo, t_hi, n_fit = kernels_dense.disparity_refit(
        np.ascontiguousarray(tf, float), np.ascontiguousarray(df, float), bc, np.ascontiguousarray(te, float),
        np.ascontiguousarray(de, float), be, np.ascontiguousarray(degree, np.int64))
    d_polys = GroupPolys(coef, t0, ts, deg)
    has_edges = be[1:] > be[:-1]
    live = np.flatnonzero(alive).tolist()
    u_polys = []
    for k in live:
        a, b = bc[k], bc[k + 1]
        ku = u_inl[a:b]                     # the centre line alone, bit for bit (see above)
        u_polys.append(Poly.fit(tf[a:b][ku], cf[a:b][ku], int(degree[k])))
    # every curve's radius from its samples' widths across its centre line's slope (the derivatives'
    # Horner sums over zero-padded coefficients: the same values as each Poly's), each curve's median
    # (compiled: the same values, kernels_dense.steep_radii)
    ucoef = np.zeros((len(live), 4))
    for i, p in enumerate(u_polys):
        ucoef[i, 4 - len(p.coef):] = p.coef
    radii = kernels_dense.steep_radii(np.ascontiguousarray(tf, float), np.ascontiguousarray(wf, float), bc,
                                      np.array(live, np.int64), ucoef, np.array([p.t0 for p in u_polys], float),
                                      np.array([p.ts for p in u_polys], float)).tolist()
    curves = {}
    for i, k in enumerate(live):
        a, b = bc[k], bc[k + 1]
        used = rc[a:b]
        if has_edges[k]:
            used = np.concatenate([used, re[be[k]:be[k + 1]]])
        s = int(segs[k])
        radius = radii[i]
        curves[s] = BranchCurve(s, True, (float(t_lo[k]), float(t_hi[k])), u_polys[i], d_polys.poly(k), radius,
                                int(n_fit[k]), (float(slopes[k, 0]), float(slopes[k, 1])), used)
    if taken is None:
        grow(graph, curves, runs_l, runs_r, sm, centres)
        curves.update(carry_over(graph, [int(s) for s in segs0 if int(s) not in curves], curves, runs_l, runs_r, sm))
    return curves


def _resolve_shared(curves: dict, graph: SkeletonGraph, runs_l: Runs, runs_r: Runs, sm: StereoMasks,
                    angle_deg: dict[int, float]) -> None:
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
        again = fit_steep_many(graph, sorted(conflict), runs_l, runs_r, sm, angle_deg, taken=owner >= 0)
        for s in conflict:
            if s in again:
                curves[s] = again[s]
            else:
                del curves[s]


@functools.lru_cache(maxsize=4096)
def _pairs(n: int, n_hyp: int) -> np.ndarray:
    """RANSAC's candidate pairs (2, n_hyp) for ``n`` candidates (fixed seed: the same pairs every time)."""
    out = np.random.default_rng(0).integers(0, n, (2, n_hyp))
    out.flags.writeable = False
    return out


def _consensus_lines(t: np.ndarray, d: np.ndarray, bounds: np.ndarray, alive: np.ndarray, n_hyp: int = 96,
                     tol_px: float = 1.5) -> GroupPolys:
    """Per piece, the straight line d(t) through the most candidates (RANSAC over candidate pairs, fixed seed),
    all pieces at once: piece k's candidates are ``t, d[bounds[k]:bounds[k + 1]]`` (pieces not ``alive``
    get a constant 0).

    Candidates of one row belong to different branches crossing it; the piece's own
    disparities are the largest set on one line.
    """
    live = np.flatnonzero(alive)
    ij = np.zeros((2, 0, n_hyp), np.int64) if len(live) == 0 else \
        np.stack([_pairs(int(bounds[k + 1] - bounds[k]), n_hyp) + bounds[k] for k in live], axis=1)   # (2, G, H)
    coef, t0, ts, deg = kernels_dense.consensus_lines(np.ascontiguousarray(t, float), np.ascontiguousarray(d, float),
                                                np.ascontiguousarray(bounds, np.int64), live,
                                                np.ascontiguousarray(ij, np.int64), float(tol_px))
    return GroupPolys(coef, t0, ts, deg)


def _coarse_agree(u: np.ndarray, d: np.ndarray, tol_px: float = 6.0, tol_line_px: float = 2.0) -> bool:
    """Whether a flat piece's coarse texture disparities ``d`` at columns ``u`` (N,) agree: at least half
    of them (and 2) within ``tol_px`` of one value, or, from 4 on, at least half (and 3) within
    ``tol_line_px`` of a line through two of them (a piece's disparity changes along it). One agrees."""
    return kernels_dense.coarse_agree(np.ascontiguousarray(u, float), np.ascontiguousarray(d, float), float(tol_px),
                                      float(tol_line_px))          # (compiled: the same tests)


def _patch_half_h(radius_px: float) -> int:
    """A flat piece's texture patches' half height, px: 0.6 radius (inside the branch)."""
    return max(1, int(0.6 * radius_px))


def _flat_curve(b: EndPlacer, s: int, runs_lt: Runs) -> BranchCurve | None:
    """A flat piece: centre line v(u) from the columns; disparity from the bark texture, or
    else from the forks/joints at its ends (:func:`_flat_curves` of one piece)."""
    return _flat_curves(b, [s], runs_lt).get(s)


def _flat_curves(b: EndPlacer, segs: list[int], runs_lt: Runs) -> dict[int, BranchCurve]:
    """:func:`_flat_curve` of several pieces: {piece: curve} of those that get one. The pieces'
    fine texture searches run together (:func:`texture.surface_disparity_many`: each patch's
    result is its own); each piece's curve is as if found alone."""
    found = [_flat_search(b, s, runs_lt) for s in segs]
    # the coarse searches of all pieces together (each patch's result its own: as one by one), then each
    # piece's prior and its fine search
    coarse = [k for k, f in enumerate(found) if f is not None and len(f) > 8]
    for k, (d0, s0) in zip(coarse, surface_disparity_many([found[k][8] for k in coarse])):
        found[k] = _flat_prior(found[k], d0, s0)
    fine = [f for f in found if f is not None and f[7] is not None]
    for f, res in zip(fine, surface_disparity_many([f[7] for f in fine])):
        f[6] = (at_window_edge_dropped(res[0], f[7][4]), res[1])
    out = {}
    for s, f in zip(segs, found):
        c = _flat_finish(b, s, *f[:7]) if f is not None else None
        if c is not None:
            out[s] = c
    return out


def _flat_search(b: EndPlacer, s: int, runs_lt: Runs) -> list | None:
    """:func:`_flat_curve`'s centre line and its coarse texture search's job: None (no curve), or
    :func:`_flat_texture`'s list (the coarse search pending, for :func:`_flat_prior`)."""
    g, sm = b.g, b.sm
    rm = sm.radius_map
    if isinstance(rm, RadiusMap) and rm.image.dtype == np.float32 and isinstance(g.scale, int):
        # compiled: the centre line, the patches and the boxes, the same values (kernels_match.flat_search_line)
        nodes = g.seg_nodes[s]
        status, coef, t0, ts, degree, radius, lo, hi, u, uv, half_h, coarse, box = kernels_match.flat_search_line(
            np.ascontiguousarray(g.seg_yx[s], np.int64), g.scale,
            np.ascontiguousarray(g.node_yx[np.maximum(nodes, 0)], float),
            (nodes >= 0) & (g.node_kind[np.maximum(nodes, 0)] == JUNCTION), rm.image, int(rm.scale),
            runs_lt._find_tables, runs_lt.centre_px, runs_lt.span_px, runs_lt.width, 6.0)
        if status == 1:
            return None
        if status == 2:
            v_poly = Poly(coef[3 - degree:].copy(), t0, ts)
            return _flat_texture(sm, v_poly, radius, lo, hi, u, uv, half_h, coarse, *box.tolist())
    pts = g.to_full(g.seg_yx[s])
    cols, yc = centre_guess(pts, 0, g.scale)
    nodes = g.seg_nodes[s]                                                 # (2,): a junction at either end
    junction = (nodes >= 0) & (g.node_kind[np.maximum(nodes, 0)] == JUNCTION)
    nxy = g.to_full(g.node_yx[np.maximum(nodes, 0)]).astype(float)        # (2, 2) (x, y)
    thr = 1.6 * radius_at(sm.radius_map, nxy) + g.scale + 1
    # compiled: the junctions' regions left out, the columns' runs, the robust line and the radius
    ok, coef, t0, ts, degree, radius, lo, hi = kernels_dense.flat_line(
        np.ascontiguousarray(cols, float), np.ascontiguousarray(yc, float), junction, nxy, thr,
        runs_lt._find_tables, runs_lt.centre_px, runs_lt.span_px, runs_lt.width)
    if not ok:
        return None
    v_poly = Poly(coef[3 - degree:].copy(), t0, ts)
    u = np.arange(lo, hi + 1, 6.0)
    uv = np.column_stack([u, v_poly(u)])
    half_h = np.full(len(u), _patch_half_h(radius))
    # a few patches searched over the whole range give a prior; all patches then search near it
    coarse = np.unique(linspace(0, len(u) - 1, min(6, -(-len(u) // 3))).round().astype(int))
    # both searches read one neighbourhood of each image: one lazy read each (the coarse search's
    # strips over the whole range, with 8 px to spare for the fine one's around its prior)
    ui = np.rint(uv).astype(int)
    hh = int(half_h[0])
    y0, y1, u0, u1 = int(ui[:, 1].min()) - hh, int(ui[:, 1].max()) + hh + 1, int(ui[:, 0].min()), int(ui[:, 0].max())
    return _flat_texture(sm, v_poly, radius, lo, hi, u, uv, half_h, coarse, y0, y1, u0, u1)


def _flat_texture(sm: StereoMasks, v_poly: Poly, radius: float, lo: float, hi: float, u: np.ndarray, uv: np.ndarray,
                  half_h: np.ndarray, coarse: np.ndarray, y0: int, y1: int, u0: int, u1: int) -> list:
    """:func:`_flat_search`'s reads and coarse texture search's job for the patches at ``u`` (``uv``,
    ``half_h``; the coarse ones ``coarse``), whose centres lie in rows ``y0 + hh .. y1 - hh - 1`` and
    columns ``u0 .. u1``: ``[v_poly, radius, lo, hi, u, uv, None, None, job, coarse, half_h]``, ``job`` a
    :func:`texture.surface_disparity_many` search (its result goes to :func:`_flat_prior`)."""
    hw = 12
    dmin, dmax = sm.d_range_px
    left = ReadBox(sm.left_gray, y0, y1, u0 - hw, u1 + hw + 1)
    right = ReadBox(sm.right_gray, y0, y1, u0 - int(np.ceil(dmax)) - hw - 8, u1 - int(np.floor(dmin)) + hw + 9)
    return [v_poly, radius, lo, hi, u, uv, None, None, (left, right, uv[coarse], half_h[coarse], sm.d_range_px, 12),
            coarse, half_h]


def _flat_prior(f: list, d0: np.ndarray, s0: np.ndarray) -> list | None:
    """A piece's coarse search's result (``d0``, ``s0``) for :func:`_flat_texture`'s list ``f``: None (no
    curve), or ``[v_poly, radius, lo, hi, u, uv, (d_surf, score), fine]`` where ``fine`` is the fine
    search's job for :func:`texture.surface_disparity_many` (its result goes in place of ``(d_surf,
    score)``), or None when the coarse search's stand."""
    v_poly, radius, lo, hi, u, uv, _, _, job, coarse, half_h = f
    if not (np.isfinite(d0) & (s0 >= 0.6)).any():
        return [v_poly, radius, lo, hi, u[coarse], uv[coarse], (d0, s0), None]
    sure = np.isfinite(d0) & (s0 >= 0.6)
    if not _coarse_agree(u[coarse][sure], d0[sure]):
        return None                     # the bark matches at several disparities: not guessed
    prior = float(median(d0[sure]))
    return [v_poly, radius, lo, hi, u, uv, None, (job[0], job[1], uv, half_h, (prior - 6, prior + 6), 12)]


_FLAT_LIMITS = np.array([MIN_LINE_INLIERS, MIN_LINE_SHARE, MIN_LINE_SPREAD, FEW_LINE_PATCHES, MAX_LINE_MAD_PX,
                         FEW_PATCHES, MAX_FEW_MAD_PX, 100.0], float)
# flatends (docs/localize-flatends.md): a flat piece shorter than 100 px (a constant disparity before) gets a
# texture line when it spans at least SHORT_LINE_MIN_PX and the line is clean: at least 5 patches, every one
# of them matched and an inlier, spread over 60 % of its length, none of their surface disparities more than
# SHORT_LINE_MAX_RES_PX off a straight line (a curving piece keeps its constant); otherwise the constant as
# before. SHORT_LINE_MIN_PX = 100 (the line's length before) turns the rule off.
SHORT_LINE_MIN_PX = 30.0
SHORT_LINE_MAX_RES_PX = 0.3
_SHORT_LINE_LIMITS = np.array([5, 1.0, 0.6, 1e9, 0.3, FEW_PATCHES, MAX_FEW_MAD_PX, 0.0], float)


def _short_line_clean(d_surf: np.ndarray, score: np.ndarray, u: np.ndarray) -> bool:
    """Whether a short flat piece's patches' surface disparities ``d_surf`` (N,) px (correlations ``score``,
    columns ``u`` px) all matched and lie on one straight line within ``SHORT_LINE_MAX_RES_PX``."""
    ok = np.isfinite(d_surf) & (score >= 0.6)
    if ok.sum() < 5 or not ok.all():
        return False
    # the least-squares line in closed form about the mean column (np.polyfit's line up to rounding: a
    # residual within ~1e-12 px of the limit could go the other way)
    x = u - u.mean()
    y = d_surf - d_surf.mean()
    sxx = float(x @ x)
    res = y - (float(x @ y) / sxx) * x if sxx > 0 else y
    return bool(np.abs(res).max() <= SHORT_LINE_MAX_RES_PX)


# gross19b (docs/localize-gross19b.md): a flat piece's texture patch counts only where its share on the branch
# in the left view and in the right view at the piece's disparity agree within FLAT_MAX_SHARE_DIFF (patchmask.py: a
# leaf over the piece in one view pulls the patch's reading, and with it the piece's whole curve). None: off.
FLAT_MAX_SHARE_DIFF = 0.15
FLAT_SHARE_MIN_KEPT = 3                 # the patches dropped only where at least this many matched ones stay


def _two_view_patches(sm: StereoMasks, uv: np.ndarray, d_surf: np.ndarray, radius: float) -> np.ndarray:
    """``d_surf`` (N,) px with the patches at ``uv`` (N, 2) whose two views' shares on the branch differ by
    more than ``FLAT_MAX_SHARE_DIFF`` (:func:`patchmask.share_difference`, the right view at the piece's
    Theil-Sen line through the readings) set to NaN; ``d_surf`` itself when the rule is off, no patch
    differs, or fewer than ``FLAT_SHARE_MIN_KEPT`` matched patches would stay."""
    ok = np.isfinite(d_surf)
    left_mask = getattr(sm, "left_mask", None)          # (a stand-in with the right mask only: not checked)
    if FLAT_MAX_SHARE_DIFF is None or left_mask is None or not ok.any():
        return d_surf
    # compiled: the line, patchmask.share_difference's numbers, the drop and the FLAT_SHARE_MIN_KEPT guard
    bad = kernels_patchshare.flat_share_dropped(left_mask, sm.right_mask, np.ascontiguousarray(uv[ok, 0], float),
                                                np.ascontiguousarray(uv[ok, 1], float), d_surf[ok],
                                                _patch_half_h(radius), 12, float(FLAT_MAX_SHARE_DIFF),
                                                FLAT_SHARE_MIN_KEPT)
    if not bad.any():
        return d_surf
    out = np.array(d_surf, float)
    out[np.flatnonzero(ok)[bad]] = np.nan
    return out


def _flat_finish(b: EndPlacer, s: int, v_poly: Poly, radius: float, lo: float, hi: float, u: np.ndarray,
                 uv: np.ndarray, found: tuple) -> BranchCurve | None:
    """:func:`_flat_curve`'s curve from the texture disparities ``found`` (d, score) of the patches at
    ``u`` (``uv``), or else from the forks/joints at the piece's ends."""
    g, sm = b.g, b.sm
    d_surf, score = found
    d_surf = _two_view_patches(sm, uv, np.asarray(d_surf, float), radius)
    # compiled: the texture patches' fit (the numpy steps of texture.py and flatfit.py, equal up to rounding)
    args = (np.ascontiguousarray(d_surf, float), np.ascontiguousarray(score, float), np.ascontiguousarray(u, float),
            np.ascontiguousarray(uv[:, 1]), sm.right_mask, np.ascontiguousarray(v_poly.coef, float), float(v_poly.t0),
            float(v_poly.ts), float(radius), _patch_half_h(radius), float(lo), float(hi), float(sm.f_px),
            float(sm.offset_px), SLANT)
    status = 2
    if SHORT_LINE_MIN_PX <= hi - lo < 100 and _short_line_clean(d_surf, score, u):  # (flatends), else constant
        lim = _SHORT_LINE_LIMITS.copy()
        lim[7] = SHORT_LINE_MIN_PX
        status, coef, t0, ts, degree, n_inl = kernels_dense.flat_finish(*args, lim)
        if status == 1:                 # the short line inside the piece's span, level beyond it
            return BranchCurve(s, False, (lo, hi), v_poly, Poly(coef[3 - degree:].copy(), t0, ts), radius, n_inl,
                               d_end_slopes=(0.0, 0.0))
    if status == 2:
        status, coef, t0, ts, degree, n_inl = kernels_dense.flat_finish(*args, _FLAT_LIMITS)
    if status == 1:
        return BranchCurve(s, False, (lo, hi), v_poly, Poly(coef[3 - degree:].copy(), t0, ts), radius, n_inl)
    if status == 2:
        return None                     # too few patches on the line or scattered over px (flatfit.py)
    for n in g.seg_nodes[s]:
        b.place_pending(n)                # (a provisional fork, made when read)
    ends = np.array([b.uvd[n][[0, 2]] for n in g.seg_nodes[s] if n >= 0 and n in b.uvd]).reshape(-1, 2)
    if len(ends) == 0:
        return None
    d_poly = Poly.fit(ends[:, 0], ends[:, 1], 1) if len(ends) == 2 and abs(ends[1, 0] - ends[0, 0]) > 1 \
        else Poly.constant(ends[:, 1].mean())
    return BranchCurve(s, False, (lo, hi), v_poly, d_poly, radius, 0)


def _oriented(uvd: np.ndarray, start: np.ndarray | None, end: np.ndarray | None) -> np.ndarray:
    """Samples (N, 3) ordered to run from the ``start`` node's point towards the ``end`` node's."""
    def dist(a, b):                     # (math.hypot of the differences: np.hypot's value, as floats)
        return math.hypot(float(a[0]) - float(b[0]), float(a[1]) - float(b[1]))
    if start is not None:
        return uvd[::-1] if dist(uvd[-1], start) < dist(uvd[0], start) else uvd
    if end is not None:
        return uvd[::-1] if dist(uvd[0], end) < dist(uvd[-1], end) else uvd
    return uvd


_NO_POINT2, _NO_POINT3 = np.zeros(2), np.zeros(3)


def _piece_uvd(c: BranchCurve, ends: list, node_xy: np.ndarray, reach_px: float = 60.0) -> np.ndarray:
    """A piece's samples (N, 3) from its start node to its end node.

    ``ends`` are the two end nodes' placed (u, v, d) (or None), ``node_xy`` their skeleton
    positions (2,) (or None). A placed end at the disparity the curve reaches there (2 px or 3 %)
    is joined to the curve; otherwise (a fork whose parent is another branch, an unplaced
    end) the curve itself is carried on towards the end's skeleton position, at most
    ``reach_px``.
    """
    args = kernels_match.curve_args(c)
    if args is not None:                # compiled: the same sums (kernels_match.piece_uvd)
        has_end = np.array([e is not None for e in ends])
        has_xy = np.array([xy is not None for xy in node_xy])
        e = np.array([e if e is not None else _NO_POINT3 for e in ends], float)
        xy = np.array([p if p is not None else _NO_POINT2 for p in node_xy], float)
        return kernels_match.piece_uvd(*args, bool(c.by_row), e, has_end, xy, has_xy, float(reach_px), 4.0)
    uvd = _oriented(c.uvd(), *ends)
    ax = 1 if c.by_row else 0           # (a point's parameter, c.t_of's, and the curve there, c.d_at's, as floats)
    ends = [e if e is not None and abs(float(e[2]) - c._at(c.d_poly, float(e[ax]), c.d_end_slopes))
            <= max(2.0, 0.03 * float(e[2])) else None for e in ends]
    parts = [uvd]
    for k, (e, xy) in enumerate(zip(ends, node_xy)):
        if e is None:
            if xy is None:
                continue
            t_n = float(xy[ax])
            t_near = float(uvd[0 if k == 0 else -1, ax])
            if abs(t_n - t_near) < 2:
                continue
            t = linspace(t_near, t_near + min(max(t_n - t_near, -reach_px), reach_px), 6)[1:]
            ext = np.column_stack([c.uv_at(t), c.d_at(t)])
            e = ext[::-1] if k == 0 else ext
        else:
            e = e[None]
        parts.insert(0 if k == 0 else len(parts), e)
    return np.concatenate(parts)                    # (2-D parts: np.vstack's array)


def _slide(b: EndPlacer, f: FeatureUVD) -> float:
    """How far (px) a feature was placed from its graph node's skeleton pixel."""
    return float(np.hypot(*(b.node_xy[f.node] - (f.u, f.v))))


def match_dense(graph: SkeletonGraph, sm: StereoMasks, cfg: MatchConfig, border_px: float = 3.0) -> Matching:
    """Dense matching of a left skeleton graph against the right mask (see module docstring)."""
    runs_l = find_runs(sm.left_mask, soft=True)
    runs_r = find_runs(sm.right_mask, soft=True)
    used = [s for s, yx in enumerate(graph.seg_yx)
            if not graph.seg_recovered[s] and graph.seg_length_px[s] >= cfg.min_segment_px and len(yx) >= 2]
    angle = {}
    if used:                            # (all pieces at once: curves.angle_deg up to rounding)
        yx = [graph.seg_yx[s] for s in used]
        g = np.repeat(np.arange(len(used)), [len(a) for a in yx])
        angle = dict(zip(used, angle_deg_groups(graph.to_full(np.concatenate(yx)), g, len(used)).tolist()))
    steep = [s for s, a in angle.items() if a >= cfg.max_horizontal_deg]
    flat = [s for s, a in angle.items() if a < cfg.max_horizontal_deg]
    curves = fit_steep_many(graph, steep, runs_l, runs_r, sm, angle)
    _resolve_shared(curves, graph, runs_l, runs_r, sm, angle)
    withheld = withheld_segments(curves, sm)    # short pieces whose bark shows another surface (steepcheck.py)
    # tips on the grey image's sub-pixel outline near the ends (measured: the fits above gain depth
    # with it too but lose a little recall and precision; forks gain nothing)
    ends_xy, ends_d = _ends_disparity(graph, curves, sm.d_range_px)
    # (with TIP_GREY_END also a soft mask's runs on the grey step whole: a flat tip's run end, tipends.TIP_GREY_END)
    whole = GREY_END_DEV_PX if TIP_GREY_END else None
    runs_l = refine_runs(runs_l, sm.left_gray, sm.left_mask, near_points(runs_l, ends_xy, END_REACH_PX),
                         whole_dev_px=whole)
    runs_r = refine_runs(runs_r, sm.right_gray, sm.right_mask, near_points(runs_r, ends_xy, END_REACH_PX, ends_d),
                         whole_dev_px=whole)
    grey_end = None
    if TIP_GREY_END:
        (runs_l, grey_l), (runs_r, grey_r) = runs_l, runs_r
        if grey_l is not None or grey_r is not None:
            grey_end = (runs_l if grey_l is None else grey_l, runs_r if grey_r is None else grey_r)
    b = EndPlacer(graph, sm, curves, cfg, (runs_l, runs_r), grey_end)
    kinds = graph.node_kind
    flat_set = set(flat)
    needed = []
    # (ndarray.nonzero()[0] of the 1-D tests below: np.flatnonzero's indices without its wrapper)
    for node in (kinds == JUNCTION).nonzero()[0].tolist():      # anchors for flat pieces without texture
        if flat_set.isdisjoint(b.incident[node]):
            b.fork(node, needed=False)
        else:
            needed.append(node)
    b.defer_forks(needed)                 # (made when read: most are replaced whole by the final round)
    for node in (kinds == JOINT).nonzero()[0]:
        b.joint(node)
    if flat:
        runs_lt = find_runs(sm.left_mask.T, soft=True)
        curves.update(_flat_curves(b, flat, runs_lt))      # (in the pieces' order, as one by one)
    for node in (kinds == JUNCTION).nonzero()[0]:
        b.fork(node, final=True)
    curves.update(cap_curves(graph, sm, runs_l, runs_r, curves, cfg.max_horizontal_deg))
    b.recheck_outline_forks()           # (a child's new stub curve may discredit its right outline)
    if flat:            # short flat pieces without texture: their tips by the round cap (tips.py)
        curves.update(flat_cap_curves(b, [s for s in flat if s not in curves], runs_lt))
    ends = (kinds == ENDPOINT).nonzero()[0].tolist()
    b.prewalk(ends)                     # (the tips' walks out, all at once)
    b.tips(ends)
    for node in (kinds == JOINT).nonzero()[0]:
        b.joint(node)
    kinds = kinds.copy()
    for node in (kinds == ENDPOINT).nonzero()[0]:
        if b.hidden_fork(node):
            kinds[node] = JUNCTION
    bridges = []
    for s in graph.seg_recovered.nonzero()[0]:
        if b.bridge_holds(s):
            bridges.append(s)
        else:                                   # not one branch: its ends are ends again
            for node in graph.seg_nodes[s]:
                kinds[node] = ENDPOINT
                b.uvd.pop(node, None)
                b.tip(node)
    # steep pieces still without a curve, matched edge by edge on their own: branches to keep clear of,
    # not trusted for forks and tips (placed above without them)
    # (the withheld pieces' curves served the forks and tips above, as before: dropped there, ends.py lost
    # correct forks; they are not reported, nor matched again here)
    curves = {s: c for s, c in curves.items() if s not in withheld}
    curves.update(edge_consensus(graph, [s for s in steep if s not in curves and s not in withheld], curves,
                                 runs_l, runs_r, sm))

    h, w = sm.left_mask.shape
    dmin, dmax = sm.d_range_px
    features = []
    for node, (u, v, d) in sorted(b.uvd.items()):
        kind = {ENDPOINT: "endpoint", JUNCTION: "bifurcation"}.get(int(kinds[node]))
        if kind is None or node in b.hidden or not (0.95 * dmin <= d <= 1.05 * dmax):
            continue
        # a tip at the view's edge: its branch runs out of view; a fork on the edge itself: its
        # pieces leave the view there (the axes' crossing lies outside, where they meet)
        if min(u, v, w - 1 - u, h - 1 - v) < (border_px + graph.scale if kind == "endpoint" else 1.0):
            continue
        # ... and its position in the right view over a radius past that image's edge: nothing of it is
        # there, its pieces' curves were carried beyond the edge (seed 392 T9: 40 px, +8.7 mm; forks a
        # few px past it are placed right)
        if RIGHT_VIEW_EDGE and min(u - d, w - 1 - (u - d)) < -b.radius[node]:
            continue
        ft = FeatureUVD(int(node), kind, float(u), float(v), float(d), b.radius[node])
        # two graph ends placed on one tip; two junctions placing one fork (a loop of the
        # skeleton at a thick crotch): the one slid least from its junction stands
        near = 3.0 if kind == "endpoint" else max(3.0, b.radius[node])
        same = [i for i, f in enumerate(features) if f.kind == kind and np.hypot(f.u - u, f.v - v) < near
                and (kind == "endpoint" or abs(f.d - d) <= max(1.0, 0.006 * d))]
        if same:
            i = same[0]
            if kind == "bifurcation" and _slide(b, ft) < _slide(b, features[i]):
                features[i] = ft
            continue
        features.append(ft)
    if STUB_TIPS:           # short isolated stubs without a piece of their own (stubtips.py)
        for k, (u, v, d, rho) in enumerate(stub_tips(b, taken_points(graph, curves, b.uvd))):
            if not (0.95 * dmin <= d <= 1.05 * dmax) or min(u, v, w - 1 - u, h - 1 - v) < border_px + graph.scale:
                continue
            if RIGHT_VIEW_EDGE and min(u - d, w - 1 - (u - d)) < -rho:
                continue
            if any(f.kind == "endpoint" and np.hypot(f.u - u, f.v - v) < 3.0 for f in features):
                continue
            features.append(FeatureUVD(STUB_NODE + k, "endpoint", u, v, d, rho))
    pieces = []
    for s, c in sorted(curves.items()):
        a, z = graph.seg_nodes[s]
        xy = [b.node_xy[n] if n >= 0 else None for n in (a, z)]
        pieces.append(PieceUVD(s, _piece_uvd(c, [b.uvd.get(n) for n in (a, z)], xy), c.radius_px, False,
                               (int(a), int(z))))
    for s in bridges:
        a, z = graph.seg_nodes[s]
        if a in b.uvd and z in b.uvd:
            r = np.mean([b.radius.get(a, np.nan), b.radius.get(z, np.nan)])
            pieces.append(PieceUVD(int(s), np.vstack([b.uvd[a], b.uvd[z]]), float(r), True, (int(a), int(z))))
    stats = {"segments": len(graph.seg_yx), "matched_segments": len(curves), "flat_segments": len(flat),
             "hidden_ends": len(b.hidden)}
    return Matching(features, pieces, stats)
