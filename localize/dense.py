"""Improved matching: dense sub-pixel centre lines along every branch piece.

For a steep piece, each rectified row crosses the branch once in each image; the middle
of that crossing (sub-pixel edges, :mod:`edges`) is the projection of the axis point of
that row's epipolar plane in both views, so its disparity is the axis' disparity. The
right crossing is chosen among the runs of the same row inside the working disparity
range with a similar width, on the straight line (u, v, d) through most candidates, then
refined to a robust polynomial in the row: the piece becomes a smooth (u, v, d) curve
(:mod:`curves`). A right crossing belongs to one piece only.

Flat pieces (rows ambiguous) take their disparity from the bark texture (:mod:`texture`),
or else from the forks/joints at their ends; a flat piece with neither is left out rather
than guessed. Forks, tips and bridges are then placed on the curves (:mod:`ends`).
"""

from __future__ import annotations

import functools

import numpy as np
from appliance.config.schema import MatchConfig
from appliance.localize.curves import (
    BranchCurve,
    GroupPolys,
    Poly,
    Spliced,
    degree_for,
    end_slopes,
    median,
    robust_fit,
    robust_fit_groups,
)
from appliance.localize.edges import Runs, find_runs
from appliance.localize.ends import EndPlacer
from appliance.localize.graph import ENDPOINT, JOINT, JUNCTION, SkeletonGraph
from appliance.localize.matching import FeatureUVD, Matching, PieceUVD, StereoMasks
from appliance.localize.radius import radius_at
from appliance.localize.texture import (
    surface_disparity,
    surface_to_axis,
)


def _angle_deg(pts: np.ndarray) -> float:
    """Angle of a point set's main direction from the horizontal, degrees (0..90)."""
    c = pts - pts.mean(0)
    sxx, syy, sxy = float(c[:, 0] @ c[:, 0]), float(c[:, 1] @ c[:, 1]), float(c[:, 0] @ c[:, 1])
    return abs(float(np.degrees(0.5 * np.arctan2(2 * sxy, sxx - syy))))


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


def _regroup(g: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """Group ids (N,) renumbered over the ``alive`` groups (samples of dead groups dropped by the caller)."""
    return (np.cumsum(alive) - 1)[g]


def _row_centres(graph: SkeletonGraph, segs: list[int], radius_map) -> tuple[np.ndarray, ...]:
    """:func:`_centre_guess` by rows of every segment in ``segs`` at once, points inside a junction
    region at a segment's end (:func:`_near_junction`) left out.

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
    near = np.zeros(len(rows), bool)
    for k in range(2):                                # a junction at either end
        nodes = graph.seg_nodes[np.asarray(segs, int), k]
        junction = (nodes >= 0) & (graph.node_kind[np.maximum(nodes, 0)] == JUNCTION)
        nxy = graph.to_full(graph.node_yx[np.maximum(nodes, 0)])
        r = radius_at(radius_map, nxy)
        d = np.column_stack([xc, rows]) - nxy[g]
        near |= junction[g] & (np.hypot(d[:, 0], d[:, 1]) < (1.6 * r + graph.scale + 1)[g])
    keep = ~near
    return rows[keep], xc[keep], g[keep]


def _degrees(t: np.ndarray, g: np.ndarray, live: np.ndarray) -> np.ndarray:
    """:func:`degree_for` of each group's samples (``t`` (N,), group ``g`` (N,)); 1 where not ``live`` (G,)."""
    ng = len(live)
    n = np.bincount(g, minlength=ng)
    lo, hi = np.full(ng, np.inf), np.full(ng, -np.inf)
    np.minimum.at(lo, g, t), np.maximum.at(hi, g, t)
    return np.array([degree_for(int(n[k]), float(hi[k] - lo[k])) if live[k] else 1 for k in range(ng)])


def fit_steep_many(graph: SkeletonGraph, segs: list[int], runs_l: Runs, runs_r: Runs, sm: StereoMasks,
                   angle_deg: dict[int, float], taken: np.ndarray | None = None) -> dict[int, BranchCurve]:
    """Dense row-by-row match of steep segments, all at once: {segment: curve} of those that find enough.

    Every step runs over the samples of all pieces together (a piece id per sample; the fits
    by :func:`robust_fit_groups`), with the same rules per piece as matching it alone.
    ``angle_deg`` holds each segment's angle from the rows (:func:`_angle_deg`); ``taken`` (bool per
    right run) marks right crossings that belong to another piece. A curve's ``right_runs`` are the
    right crossings it used. Without ``taken`` (the first fit), the curves are then carried on past
    occluders along their own rows (:func:`_grow`) and onto pieces that found nothing
    (:func:`_carry_over`).
    """
    segs0 = list(segs)
    rows, xc, g = _row_centres(graph, segs, sm.radius_map)
    centres = (segs0, rows, xc, g)
    alive = np.bincount(g, minlength=len(segs)) >= 4
    if not alive.any():
        return {}
    keep = alive[g]
    rows, xc, g = rows[keep].astype(int), xc[keep], _regroup(g[keep], alive)
    segs = np.asarray(segs)[alive]
    sin_t = np.array([max(np.sin(np.radians(angle_deg[s])), 0.2) for s in segs.tolist()])
    il = runs_l.find(rows, xc)
    r_loc = radius_at(sm.radius_map, np.column_stack([xc, rows]))
    ok = il >= 0
    rows_all, il_all, g_all = rows[ok], il[ok], g[ok]
    w_l = np.where(ok, runs_l.span_px[np.maximum(il, 0)], np.inf)
    ok &= w_l <= 1.5 * (2 * r_loc / sin_t[g] + 1) + 2
    rows, il, w_l, g = rows[ok], il[ok], w_l[ok], g[ok]
    alive = np.bincount(g, minlength=len(segs)) >= 4
    # a branch's width varies smoothly along it: rows much narrower (partly occluded) or wider
    # (merged with a crossing branch) than the trend are not its centre
    keep = alive[g]
    rows, il, w_l, g = rows[keep], il[keep], w_l[keep], _regroup(g[keep], alive)
    keep = alive[g_all]
    rows_all, il_all, g_all = rows_all[keep], il_all[keep], _regroup(g_all[keep], alive)
    segs = segs[alive]
    ng = len(segs)
    if ng == 0:
        return {}
    rf = rows.astype(float)
    w_fit, _ = robust_fit_groups(rf, w_l, g, ng, np.full(ng, 2), rounds=2)
    wv = w_fit(g, rf)
    ok = np.abs(w_l - wv) <= 0.1 * wv + 1.5
    rows, il, w_l, g = rows[ok], il[ok], w_l[ok], g[ok]
    n = np.bincount(g, minlength=ng)
    alive = n >= 4
    c_l = runs_l.centre_px[il]
    dmin, dmax = sm.d_range_px
    q, rr = runs_r.between(rows, c_l - dmax, c_l - dmin)
    cd = c_l[q] - runs_r.centre_px[rr]
    cw = runs_r.span_px[rr]
    good = (np.abs(cw - w_l[q]) <= 0.1 * w_l[q] + 1.5) & alive[g[q]]
    if taken is not None:
        good &= ~taken[rr]
    q, rr, cd, cw = q[good], rr[good], cd[good], cw[good]
    alive &= np.bincount(g[q], minlength=ng) >= 4
    if not alive.any():
        return {}
    t = rows.astype(float)
    degree = _degrees(t, g, alive)
    gq = g[q]
    bounds = np.searchsorted(gq, np.arange(ng + 1))
    model = _consensus_lines(t[q], cd, bounds, alive)
    for k, tol in enumerate((2.0, 0.75)):           # per row, the candidate nearest the model
        sel = alive[gq]
        q, rr, cd, cw, gq = q[sel], rr[sel], cd[sel], cw[sel], gq[sel]
        res = np.abs(cd - model(gq, t[q]))
        order = np.lexsort((res, q))
        first = order[np.r_[True, q[order][1:] != q[order][:-1]]]
        chosen = first[res[first] <= tol]
        alive &= np.bincount(gq[chosen], minlength=ng) >= np.maximum(4, 0.25 * n)
        chosen = chosen[alive[gq[chosen]]]
        if not alive.any():
            return {}
        model, inl = robust_fit_groups(t[q[chosen]], cd[chosen], gq[chosen], ng, degree, rounds=1 if k == 0 else 3)
    chosen = chosen[inl]
    gc = gq[chosen]
    tf, df, cf = t[q[chosen]], cd[chosen], c_l[q[chosen]]
    wf = 0.5 * (w_l[q[chosen]] + cw[chosen])
    u_poly, u_inl = robust_fit_groups(tf, cf, gc, ng, degree, rounds=1)
    # rows where the branch is partly hidden still show one true edge in both views
    w_poly, _ = robust_fit_groups(tf, w_l[q[chosen]], gc, ng, np.ones(ng, int), rounds=2)
    width = int(rows_all.max()) + 1
    rest = ~np.isin(g_all * width + rows_all, gc * width + tf.astype(int)) & alive[g_all]
    te, de, re, ge = _edge_samples(rows_all[rest], il_all[rest], g_all[rest], u_poly, w_poly, model,
                                   runs_l, runs_r, taken)
    # pieces with edge samples: the disparity refitted to all their samples, in each piece's order
    ta, da, ga = np.r_[tf, te], np.r_[df, de], np.r_[gc, ge]
    o = np.argsort(ga, kind="stable")
    ta, da, ga = ta[o], da[o], ga[o]
    has_edges = np.bincount(ge, minlength=ng) > 0
    sel = has_edges[ga]
    ts_, ds_, gs_ = ta[sel], da[sel], ga[sel]
    deg2 = _degrees(ts_, gs_, has_edges)
    inl2 = robust_fit_groups(ts_, ds_, gs_, ng, deg2)[1] if sel.any() else np.zeros(0, bool)
    bc, be, ba = (np.searchsorted(a, np.arange(ng + 1)) for a in (gc, ge, gs_))
    # each curve's polynomials refitted alone to its inliers: the same coefficients as fitting the
    # piece alone, bit for bit (the batched sums differ in rounding, which matters on exact drawings)
    curves = {}
    for k in np.flatnonzero(alive).tolist():
        a, b = bc[k], bc[k + 1]
        used = rr[chosen[a:b]]
        if has_edges[k]:
            keep = inl2[ba[k]:ba[k + 1]]
            tk, dk = ts_[ba[k]:ba[k + 1]][keep], ds_[ba[k]:ba[k + 1]][keep]
            d_poly = Poly.fit(tk, dk, int(deg2[k]))
            used = np.r_[used, re[be[k]:be[k + 1]]]
        else:
            tk, dk = tf[a:b], df[a:b]
            d_poly = Poly.fit(tk, dk, int(degree[k]))
        ku = u_inl[a:b]
        u_k = Poly.fit(tf[a:b][ku], cf[a:b][ku], int(degree[k]))
        radius = float(median(0.5 * wf[a:b] / np.sqrt(1 + u_k.deriv()(tf[a:b]) ** 2)))
        s = int(segs[k])
        curves[s] = BranchCurve(s, True, (float(tk.min()), float(tk.max())), u_k, d_poly, radius,
                                len(tk), end_slopes(tk, dk), used)
    if taken is None:
        _grow(graph, curves, runs_l, runs_r, sm, centres)
        curves.update(_carry_over(graph, [int(s) for s in segs0 if int(s) not in curves], curves, runs_l, runs_r, sm))
    return curves


def edge_to_axis(u_px: np.ndarray, d_px: np.ndarray, half_px: np.ndarray, side: float, f_px: float,
                 cx_px: float, offset_px: float = 0.0) -> np.ndarray:
    """Disparity (N,) of a branch's axis from the disparity ``d_px`` of one of its silhouette edges.

    Each camera sees a cylinder's outline where its own lines of sight graze it, not at the same
    surface points: along a row (a circle of half-width ``half_px`` around the centre column
    ``u_px``, in the row's epipolar plane) the left (``side`` -1) or right (+1) edge's disparity
    differs from the axis' by up to ~1.5 px for thick branches off the image's centre, with
    opposite signs on the two sides (a branch tilted in the image is taken as its row section). ``cx_px``: left principal point column; ``offset_px``: ``cx_left - cx_right``.
    Everything in units of the axis' depth, so no baseline is needed.
    """
    x = (np.asarray(u_px, float) - cx_px) / f_px
    rho_l = np.sqrt(1 + x * x)
    r = np.asarray(half_px, float) / (f_px * rho_l)          # radius / depth
    d = np.asarray(d_px, float) - offset_px
    beta = d / f_px                                          # baseline / depth (first guess: the edge's)
    for _ in range(2):
        xr = x - beta
        rho_r = np.sqrt(1 + xr * xr)
        e_l = np.tan(np.arctan(x) + side * np.arcsin(np.minimum(r / rho_l, 0.99)))
        e_r = np.tan(np.arctan(xr) + side * np.arcsin(np.minimum(r / rho_r, 0.99)))
        beta = beta - (f_px * (e_l - e_r) - d) / f_px       # edge disparity (model) - measured
    return beta * f_px + offset_px


def _donor_model(c: BranchCurve, rows: np.ndarray, reach_px: float) -> tuple[np.ndarray, np.ndarray, float] | None:
    """A matched steep curve's centre column and disparity carried over rows (N,) beyond its span: the
    straight lines fitted to its last ``reach_px`` of rows on that side, and that end's row. None if the
    rows overlap its span or lie further than ``reach_px`` from it."""
    lo, hi = c.t_range
    if rows.max() < lo:
        end, t = lo, np.linspace(lo, min(hi, lo + reach_px), 8)
    elif rows.min() > hi:
        end, t = hi, np.linspace(max(lo, hi - reach_px), hi, 8)
    else:
        return None
    if min(abs(rows.max() - end), abs(rows.min() - end)) > reach_px:
        return None
    y = np.stack([c.s_at(t), c.d_at(t)])                  # (2, 8) centre column, disparity
    y0 = y.mean(1)
    if t[-1] - t[0] < 5:
        return np.full(len(rows), y0[0]), np.full(len(rows), y0[1]), end
    dt = t - t.mean()
    slope = (y @ dt) / float(dt @ dt)                      # least-squares lines
    out = y0[:, None] + slope[:, None] * (rows - t.mean())
    return out[0], out[1], end


def _end_half(c: BranchCurve, end: float, runs_l: Runs, n_rows: int = 30) -> float:
    """Half width along the rows of a steep curve at its ``end`` (it tapers): the median of the left
    crossings of its last ``n_rows`` rows that lie within half of what its radius gives (not merged,
    not cut short); else the radius'."""
    lo, hi = c.t_range
    t = np.arange(end, min(hi, end + n_rows) + 1.0) if end == lo else np.arange(max(lo, end - n_rows), end + 1.0)
    u = c.s_at(t)
    i = runs_l.find(t.astype(int), u)
    w = np.where(i >= 0, runs_l.span_px[np.maximum(i, 0)], np.nan)
    ref = 2 * c.radius_px * np.sqrt(1 + (float(u[-1] - u[0]) / max(float(t[-1] - t[0]), 1.0)) ** 2)
    ok = np.abs(w - ref) <= 0.5 * ref
    return 0.5 * (float(median(w[ok])) if ok.sum() >= 5 else ref)


def _edge_track(rows: np.ndarray, xc: np.ndarray, u: np.ndarray, d: np.ndarray, half: np.ndarray, runs_l: Runs,
                runs_r: Runs, sm: StereoMasks, need: float):
    """Samples of a branch along rows (N,) whose centre column ``u`` and disparity ``d`` (N,) are carried
    over from a matched piece, with its half width along the rows ``half`` (N,) (the skeleton's centre
    ``xc`` (N,) finds the left crossing where ``u`` falls off the mask).

    The left crossing's edge where the branch's outline lies (``max(3, half / 4)`` px) and the right
    crossing's same-side edge at that disparity (2 px, moved onto the axis by :func:`edge_to_axis`) are a
    sample; its centre is the middle of the row's two edges where both are, else the edge less the half
    width (rescaled to the rows where both show). Returns rows, disparities, centres and right runs, or None
    when fewer than ``need`` rows give samples (or fewer than ``need`` stay within 0.75 px of a line).
    """
    cx = 0.5 * (sm.left_mask.shape[1] - 1)    # the principal point taken at the centre (a few % of the effect)
    ri = rows.astype(int)
    il = runs_l.find(ri, u)
    il = np.where(il >= 0, il, runs_l.find(ri, xc))
    ok = il >= 0
    if ok.sum() < need:
        return None
    ri, t, u, d, il, half = ri[ok], rows[ok], u[ok], d[ok], il[ok], half[ok]
    tol = max(3.0, 0.25 * float(half.mean()))
    edges, ok_side, irs = [], [], []
    for side, edge_l, edge_r in ((-1.0, runs_l.left_px, runs_r.left_px), (1.0, runs_l.right_px, runs_r.right_px)):
        e_l = edge_l[il]
        ir = runs_r.find(ri, e_l - d - side * 1.0)
        good = (np.abs(e_l - (u + side * half)) <= tol) & (ir >= 0)
        d_ax = np.full(len(t), np.nan)
        if good.any():
            d_ax[good] = edge_to_axis(u[good], e_l[good] - edge_r[ir[good]], half[good], side, sm.f_px, cx,
                                      sm.offset_px)
        good &= np.abs(d_ax - d) <= 2.0
        edges.append((e_l, d_ax)), ok_side.append(good), irs.append(ir)
    if (ok_side[0] | ok_side[1]).sum() < need:
        return None
    both = ok_side[0] & ok_side[1]
    if both.sum() >= 3:                     # the width where both edges show, else the piece's
        half = half * float(median((edges[1][0] - edges[0][0])[both] / (2 * half[both])))
    ts, ds, cs, rs = [], [], [], []
    for side, (e_l, dd), good, ir in zip((-1.0, 1.0), edges, ok_side, irs):
        ts.append(t[good]), ds.append(dd[good]), rs.append(ir[good])
        cs.append(np.where(both, 0.5 * (edges[0][0] + edges[1][0]), e_l - side * half)[good])
    ts, ds, cs, rs = (np.concatenate(a) for a in (ts, ds, cs, rs))
    d_line, inl = robust_fit(ts, ds, 1)
    inl &= np.abs(ds - d_line(ts)) <= 0.75
    if len(np.unique(ts[inl])) < need:
        return None
    return ts[inl], ds[inl], cs[inl], rs[inl]


def _grow(graph: SkeletonGraph, curves: dict[int, BranchCurve], runs_l: Runs, runs_r: Runs, sm: StereoMasks,
          centres: tuple, step_px: int = 40, reach_px: float = 120.0) -> None:
    """Matched steep curves carried on along their own skeleton rows beyond their fitted span, where
    an occluder cuts the branch on one side (no whole crossings there): window by window of
    ``step_px`` rows, each from the straight continuation of the curve so far (:func:`_donor_model`,
    :func:`_edge_track`), while the skeleton stays within half a radius + 2 px of it and 40 % of a
    window's rows give samples. The curve is then refitted to itself (one sample per row of its
    span) and the new samples. Rows near a junction are left out, as in the first fit: ``centres`` holds
    the pieces and :func:`_row_centres` of that fit."""
    segs, rows_all, xc_all, g_all = centres
    bounds = np.searchsorted(g_all, np.arange(len(segs) + 1))
    for k, s in enumerate(segs):
        c = curves.get(s)
        if c is None or not c.by_row:
            continue
        rows, xc = rows_all[bounds[k]:bounds[k + 1]], xc_all[bounds[k]:bounds[k + 1]]
        lo, hi = c.t_range
        if not ((rows > hi + 1).sum() >= 8 or (rows < lo - 1).sum() >= 8):
            continue
        new = []
        cur = c
        ends = [(float(graph.to_full(graph.node_yx[n])[0, 1]), int(graph.node_kind[n])) for n in graph.seg_nodes[s]
                if n >= 0]
        for sign in (1.0, -1.0):
            if any(k in (ENDPOINT, JOINT) and sign * (v - 0.5 * (lo + hi)) > 0 for v, k in ends):
                continue                    # towards a free end or a bridged gap (a tip, an occluder): left alone
            beyond = rows > hi + 1 if sign > 0 else rows < lo - 1
            r_s, x_s = rows[beyond], xc[beyond]
            if sign < 0:
                r_s, x_s = r_s[::-1], x_s[::-1]
            for w0 in range(0, len(r_s), step_px):
                wr, wx = r_s[w0:w0 + step_px], x_s[w0:w0 + step_px]
                if len(wr) < 8:
                    break
                o = np.argsort(wr)
                wr, wx = wr[o], wx[o]
                m = _donor_model(cur, wr, reach_px)
                if m is None or float(median(np.abs(m[0] - wx))) > 0.5 * c.radius_px + 2:
                    break
                half = np.full(len(wr), _end_half(cur, m[2], runs_l))
                track = _edge_track(wr, wx, m[0], m[1], half, runs_l, runs_r, sm, max(4, 0.4 * len(wr)))
                if track is None:
                    break
                new.append(track)
                cur = _refit(c, new)
        if new:
            curves[s] = cur


def _refit(c: BranchCurve, new: list) -> BranchCurve:
    """``c`` carried on by the samples ``new`` (a list of :func:`_edge_track` results) beyond its span: its
    own polynomials inside the span, on each side a line (a quadratic past 60 rows) fitted to the new
    samples and the curve's last 20 rows (:class:`curves.Spliced`)."""
    lo, hi = c.t_range
    tn, dn, cn, rn = (np.concatenate(a) for a in zip(*new))
    s_base = c.s_poly.base if isinstance(c.s_poly, Spliced) else c.s_poly
    d_base = c.d_poly.base if isinstance(c.d_poly, Spliced) else c.d_poly
    parts = {}
    slopes = list(c.d_end_slopes) if c.d_end_slopes is not None else [d_base.deriv().at(lo), d_base.deriv().at(hi)]
    t_lo, t_hi = lo, hi
    for k, sel, edge in ((0, tn < lo, lo), (1, tn > hi, hi)):
        if not sel.any():
            continue
        tb = np.arange(max(lo, edge - 20), edge + 1.0) if k else np.arange(edge, min(hi, edge + 20) + 1.0)
        t = np.r_[tb, tn[sel]]
        u, d = np.r_[c.s_at(tb), cn[sel]], np.r_[c.d_at(tb), dn[sel]]
        degree = 1 if float(np.ptp(tn[sel])) < 60 else 2
        parts[k] = (Poly.fit(t, u, degree), Poly.fit(t, d, degree))
        slopes[k] = end_slopes(t, d)[k]
        t_lo, t_hi = (float(tn[sel].min()), t_hi) if k == 0 else (t_lo, float(tn[sel].max()))
    below, above = parts.get(0, (None, None)), parts.get(1, (None, None))
    used = rn if c.right_runs is None else np.union1d(c.right_runs, rn)
    return BranchCurve(c.segment, True, (t_lo, t_hi), Spliced(s_base, lo, hi, below[0], above[0]),
                       Spliced(d_base, lo, hi, below[1], above[1]), c.radius_px, c.n_samples + len(tn),
                       tuple(slopes), used)


def _carry_over(graph: SkeletonGraph, dead: list[int], curves: dict[int, BranchCurve], runs_l: Runs, runs_r: Runs,
                sm: StereoMasks, reach_px: float = 120.0) -> dict[int, BranchCurve]:
    """Steep pieces that found no whole crossings (cut by occluders on one side, at other depths in
    each view), matched by single edges against the branch they continue.

    A matched steep curve whose straight continuation (:func:`_donor_model`) runs along the dead
    piece's skeleton (within half its radius + 2 px) gives each row the branch's centre, width and
    disparity for :func:`_edge_track`. A piece keeps a curve when at least 4 rows and 40 % of its
    rows give samples; a piece with a free end (a tip or an occluder's edge) is left alone.
    """
    out = {}
    donors = [c for c in curves.values() if c.by_row]
    if not donors:
        return out
    spans = np.array([c.t_range for c in donors])
    for s in dead:
        yx = graph.seg_yx[s]
        if len(yx) < 2 or (int(yx[:, 0].max()) - int(yx[:, 0].min()) + 1) * graph.scale < 24 or \
                (graph.node_kind[[n for n in graph.seg_nodes[s] if n >= 0]] == ENDPOINT).any():
            continue
        rows, xc = _centre_guess(graph.to_full(yx), 1, graph.scale)
        if len(rows) < 24:
            continue
        r0, r1 = float(rows[0]), float(rows[-1])
        gap = np.maximum(spans[:, 0] - r1, r0 - spans[:, 1])      # rows between the piece and each donor
        best = None
        for k in np.flatnonzero((gap > 0) & (gap <= reach_px)).tolist():
            c = donors[k]
            near = 0 if spans[k, 0] > r1 else -1                    # the piece's row nearest the donor
            if abs(c.s_at(rows[near:][:1])[0] - xc[near]) > c.radius_px + 10:
                continue
            m = _donor_model(c, rows, reach_px)
            if m is None:
                continue
            err = float(median(np.abs(m[0] - xc)))
            if err <= 0.5 * c.radius_px + 2 and (best is None or err < best[0]):
                best = (err, c, m)
        if best is None:
            continue
        _, c, (u, d, end) = best
        half = np.full(len(rows), _end_half(c, end, runs_l))
        track = _edge_track(rows, xc, u, d, half, runs_l, runs_r, sm, max(4, 0.4 * len(rows)))
        if track is None:
            continue
        tk, dk, ck, rk = track
        span = float(tk.max() - tk.min())
        degree = min(degree_for(len(tk), span), 2)
        u_poly, _ = robust_fit(tk, ck, degree)
        if span < 60:                       # short: the donor's slope, the piece's own offset
            slope = float((d[-1] - d[0]) / (rows[-1] - rows[0])) if rows[-1] > rows[0] else 0.0
            off, inl_d = robust_fit(tk, dk - slope * tk, 0)
            d_poly = Poly(np.array([slope, float(off(tk[:1])[0])]))
            slopes = (slope, slope)
        else:
            d_poly, inl_d = robust_fit(tk, dk, degree)
            slopes = end_slopes(tk[inl_d], dk[inl_d])
        tk = tk[inl_d]
        out[s] = BranchCurve(s, True, (float(tk.min()), float(tk.max())), u_poly, d_poly, c.radius_px, len(tk),
                             slopes, np.unique(rk[inl_d]))
    return out


def _edge_samples(rows: np.ndarray, il: np.ndarray, g: np.ndarray, u_poly: GroupPolys, w_fit: GroupPolys,
                  d_model: GroupPolys, runs_l: Runs, runs_r: Runs, taken: np.ndarray | None):
    """Disparity samples from single edges, on rows whose crossing is not whole.

    On such a row (of piece ``g``, left run ``il``) the left crossing's edge that lies where the
    fitted centre line and width put the branch's outline (within 1 px) is a true edge; the
    same-side edge of the right crossing at the fitted disparity (within 1 px) is its match.
    Returns rows, disparities, right run indices and pieces, per side (left edges first).
    """
    t = rows.astype(float)
    u, half, d = u_poly(g, t), 0.5 * w_fit(g, t), d_model(g, t)
    out = []
    for side, edge_l, edge_r in ((-1.0, runs_l.left_px, runs_r.left_px), (1.0, runs_l.right_px, runs_r.right_px)):
        e_l = edge_l[il]
        ir = runs_r.find(rows, e_l - d - side * 1.0)            # a pixel just inside the right edge
        e_r = edge_r[np.maximum(ir, 0)]
        ok = (np.abs(e_l - (u + side * half)) <= 1.0) & (ir >= 0) & (np.abs(e_l - e_r - d) <= 1.0)
        if taken is not None:
            ok &= ~taken[np.maximum(ir, 0)]
        out.append((t[ok], (e_l - e_r)[ok], ir[ok], g[ok]))
    te, de, re, ge = (np.concatenate(a) for a in zip(*out))
    o = np.argsort(ge, kind="stable")                    # per piece, its left edges first
    return te[o], de[o], re[o], ge[o]


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
    polys = [Poly.constant(0.0)] * len(alive)
    live = np.flatnonzero(alive)
    if len(live) == 0:
        return GroupPolys.of(polys)
    ij = np.stack([_pairs(int(bounds[k + 1] - bounds[k]), n_hyp) + bounds[k] for k in live], axis=1)   # (2, G, H)
    i, j = ij
    dt = t[j] - t[i]
    ok = np.abs(dt) >= 3
    slope = (d[j] - d[i]) / np.where(ok, dt, 1.0)
    lo, hi = bounds[live], bounds[live + 1]
    g = np.repeat(np.arange(len(live)), hi - lo)
    sel = np.concatenate([np.arange(a, b) for a, b in zip(lo.tolist(), hi.tolist())])
    ts, ds = t[sel], d[sel]
    i_s, sl_s = i[g].T, slope[g].T                       # (H, N) each sample's piece's hypotheses
    inl = np.abs(ds[None, :] - (d[i_s] + sl_s * (ts[None, :] - t[i_s]))) <= tol_px
    starts = np.r_[0, np.cumsum(hi - lo)[:-1]]
    count = np.add.reduceat(inl, starts, axis=1, dtype=np.int64).T     # (G, H)
    count[~ok] = -1
    best = count.argmax(1)
    for m, k in enumerate(live.tolist()):
        tk, dk = t[lo[m]:hi[m]], d[lo[m]:hi[m]]
        if not ok[m].any():
            polys[k] = Poly.constant(float(median(dk)))
            continue
        on = inl[best[m], starts[m]:starts[m] + hi[m] - lo[m]]
        polys[k] = Poly.fit(tk[on], dk[on], 1)
    return GroupPolys.of(polys)


def _coarse_agree(u: np.ndarray, d: np.ndarray, tol_px: float = 6.0, tol_line_px: float = 2.0) -> bool:
    """Whether a flat piece's coarse texture disparities ``d`` at columns ``u`` (N,) agree: at least half
    of them (and 2) within ``tol_px`` of one value, or, from 4 on, at least half (and 3) within
    ``tol_line_px`` of a line through two of them (a piece's disparity changes along it). One agrees."""
    n = len(d)
    if n <= 1:
        return True
    need = max(2, -(-n // 2))
    if int((np.abs(d[:, None] - d[None, :]) <= tol_px).sum(1).max()) >= need:
        return True
    if n < 4:
        return False
    i, j = np.triu_indices(n, 1)
    du = u[j] - u[i]
    ok = du != 0
    slope = (d[j] - d[i])[ok] / du[ok]
    fit = d[i][ok][:, None] + slope[:, None] * (u[None, :] - u[i][ok][:, None])
    return bool(ok.any()) and int((np.abs(d[None, :] - fit) <= tol_line_px).sum(1).max()) >= max(3, need)


def _flat_curve(b: EndPlacer, s: int, runs_lt: Runs) -> BranchCurve | None:
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
    radius = float(median(0.5 * hgt[inl] / np.sqrt(1 + slope ** 2)))
    lo, hi = float(t[inl].min()), float(t[inl].max())
    u = np.arange(lo, hi + 1, 6.0)
    uv = np.column_stack([u, v_poly(u)])
    half_h = np.full(len(u), max(1, int(0.6 * radius)))
    # a few patches searched over the whole range give a prior; all patches then search near it
    coarse = np.unique(np.linspace(0, len(u) - 1, min(6, -(-len(u) // 3))).round().astype(int))
    d0, s0 = surface_disparity(sm.left_gray, sm.right_gray, uv[coarse], half_h[coarse], sm.d_range_px, half_w_px=12)
    if not (np.isfinite(d0) & (s0 >= 0.6)).any():
        d_surf, score = d0, s0
        u, uv = u[coarse], uv[coarse]
    else:
        sure = np.isfinite(d0) & (s0 >= 0.6)
        if not _coarse_agree(u[coarse][sure], d0[sure]):
            return None                     # the bark matches at several disparities: not guessed
        prior = float(median(d0[sure]))
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


def _oriented(uvd: np.ndarray, start: np.ndarray | None, end: np.ndarray | None) -> np.ndarray:
    """Samples (N, 3) ordered to run from the ``start`` node's point towards the ``end`` node's."""
    def dist(a, b):
        return np.hypot(*(a[:2] - b[:2]))
    if start is not None:
        return uvd[::-1] if dist(uvd[-1], start) < dist(uvd[0], start) else uvd
    if end is not None:
        return uvd[::-1] if dist(uvd[0], end) < dist(uvd[-1], end) else uvd
    return uvd


def _piece_uvd(c: BranchCurve, ends: list, node_xy: np.ndarray, reach_px: float = 60.0) -> np.ndarray:
    """A piece's samples (N, 3) from its start node to its end node.

    ``ends`` are the two end nodes' placed (u, v, d) (or None), ``node_xy`` their skeleton
    positions (2,) (or None). A placed end at the disparity the curve reaches there (2 px or 3 %)
    is joined to the curve; otherwise (a fork whose parent is another branch, an unplaced
    end) the curve itself is carried on towards the end's skeleton position, at most
    ``reach_px``.
    """
    uvd = _oriented(c.uvd(), *ends)
    ends = [e if e is not None and abs(e[2] - c.d_at(c.t_of(e[:2]))[0]) <= max(2.0, 0.03 * e[2]) else None
            for e in ends]
    parts = [uvd]
    for k, (e, xy) in enumerate(zip(ends, node_xy)):
        if e is None:
            if xy is None:
                continue
            t_n = float(c.t_of(xy)[0])
            t_near = float(c.t_of(uvd[0 if k == 0 else -1, :2])[0])
            if abs(t_n - t_near) < 2:
                continue
            t = np.linspace(t_near, t_near + np.clip(t_n - t_near, -reach_px, reach_px), 6)[1:]
            ext = np.column_stack([c.uv_at(t), c.d_at(t)])
            e = ext[::-1] if k == 0 else ext
        else:
            e = e[None]
        parts.insert(0 if k == 0 else len(parts), e)
    return np.vstack(parts)


def match_dense(graph: SkeletonGraph, sm: StereoMasks, cfg: MatchConfig, border_px: float = 3.0) -> Matching:
    """Dense matching of a left skeleton graph against the right mask (see module docstring)."""
    runs_l = find_runs(sm.left_mask, soft=True)
    runs_r = find_runs(sm.right_mask, soft=True)
    angle = {s: _angle_deg(graph.to_full(yx)) for s, yx in enumerate(graph.seg_yx)
             if not graph.seg_recovered[s] and graph.seg_length_px[s] >= cfg.min_segment_px and len(yx) >= 2}
    steep = [s for s, a in angle.items() if a >= cfg.max_horizontal_deg]
    flat = [s for s, a in angle.items() if a < cfg.max_horizontal_deg]
    curves = fit_steep_many(graph, steep, runs_l, runs_r, sm, angle)
    _resolve_shared(curves, graph, runs_l, runs_r, sm, angle)
    b = EndPlacer(graph, sm, curves, cfg, (runs_l, runs_r))
    kinds = graph.node_kind
    flat_set = set(flat)
    for node in np.flatnonzero(kinds == JUNCTION):      # anchors for flat pieces without texture
        b.fork(node, needed=not flat_set.isdisjoint(b.incident[node]))
    for node in np.flatnonzero(kinds == JOINT):
        b.joint(node)
    if flat:
        runs_lt = find_runs(sm.left_mask.T, soft=True)
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
    for node in np.flatnonzero(kinds == ENDPOINT):
        if b.hidden_fork(node):
            kinds[node] = JUNCTION
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
