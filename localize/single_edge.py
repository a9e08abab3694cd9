"""Rows matched by one edge, where a branch's crossing of the row is not whole.

An occluder (a leaf, an apple, another branch at another depth) that cuts a steep branch on one
side leaves rows whose crossings differ between the views: their middles are not the axis', but
the uncut side's edge is the same outline in both views. This module matches such rows edge by
edge: on rows of a fitted piece (:func:`kernels_dense.steep_fit`), past a fitted piece's span along its own
skeleton rows (:func:`grow`), and on pieces that found no curve but continue a matched one
(:func:`carry_over`); :func:`edge_to_axis` moves one edge's disparity onto the axis (each camera
sees a thick branch's outline at other surface points).
"""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels_dense, kernels_endreads
from appliance.localize.curves import (
    BranchCurve,
    Poly,
    Spliced,
    degree_for,
    end_slopes,
    linspace,
    median,
    robust_fit,
)
from appliance.localize.edges import Runs
from appliance.localize.graph import ENDPOINT, JOINT, SkeletonGraph
from appliance.localize.matching import StereoMasks
from appliance.localize.radius import RadiusMap


def centre_guess(pts: np.ndarray, axis: int, scale: int) -> tuple[np.ndarray, np.ndarray]:
    """Integer positions along ``axis`` (1: rows) covered by a piece and its interpolated centre there."""
    t, s = pts[:, axis], pts[:, 1 - axis]
    ok, ts, xs = kernels_dense.centre_line(np.ascontiguousarray(t, float), np.ascontiguousarray(s, float),
                                     (scale - 1) / 2)
    if ok:                              # (whole or half pixels: the values below, compiled)
        return ts, xs
    t2 = t * 2.0
    k = t2.astype(np.int64)
    k0 = int(k.min()) if len(k) else 0
    if len(k) and (k == t2).all() and int(k.max()) - k0 < 8 * len(k) + 4096:
        # whole or half pixels (skeleton pixels at full resolution): the values by a bincount over
        # their doubles, the same sorted values and per-value sums as np.unique's (~3x faster)
        k -= k0
        count = np.bincount(k)
        nz = np.flatnonzero(count)
        uniq = (nz + k0) / 2.0
        s_mean = np.bincount(k, s)[nz] / count[nz]
    else:
        uniq, inv = np.unique(t, return_inverse=True)
        s_mean = np.bincount(inv, s) / np.bincount(inv)
    half = (scale - 1) / 2
    ts = np.arange(np.ceil(uniq[0] - half), np.floor(uniq[-1] + half) + 1)
    return ts, np.interp(ts, uniq, s_mean)


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
    r_max, r_min = float(rows.max()), float(rows.min())
    if r_max < lo:
        end, t = lo, linspace(lo, min(hi, lo + reach_px), 8)
    elif r_min > hi:
        end, t = hi, linspace(max(lo, hi - reach_px), hi, 8)
    else:
        return None
    if min(abs(r_max - end), abs(r_min - end)) > reach_px:
        return None
    s, d = c.s_at(t), c.d_at(t)                           # (8,) centre column, disparity
    # (Python floats, the same sums: the means are numpy's pairwise sums of 8 values, _mean8)
    s0, d0, t_mean = _mean8(s.tolist()), _mean8(d.tolist()), _mean8(t.tolist())
    if t[-1] - t[0] < 5:
        return np.full(len(rows), s0), np.full(len(rows), d0), end
    dt = t - t_mean
    slope = (np.stack([s, d]) @ dt) / float(dt @ dt)      # least-squares lines (numpy's products and sums)
    x = rows - t_mean
    return s0 + float(slope[0]) * x, d0 + float(slope[1]) * x, end


def _mean8(v: list) -> float:
    """``np.mean`` of 8 float64 values, the same value bit for bit: numpy's pairwise sum of 8 (its eight
    partial sums of one value each, added in pairs), over 8."""
    return (((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]))) / 8


def _end_half(c: BranchCurve, end: float, runs_l: Runs, n_rows: int = 30) -> float:
    """Half width along the rows of a steep curve at its ``end`` (it tapers): the median of the left
    crossings of its last ``n_rows`` rows that lie within half of what its radius gives (not merged,
    not cut short); else the radius'."""
    lo, hi = c.t_range
    t = np.arange(end, min(hi, end + n_rows) + 1.0) if end == lo else np.arange(max(lo, end - n_rows), end + 1.0)
    u = c.s_at(t)
    ref = 2 * c.radius_px * np.sqrt(1 + (float(u[-1] - u[0]) / max(float(t[-1] - t[0]), 1.0)) ** 2)
    keys, rows, x1 = runs_l._find_tables        # (compiled: the same crossings, selection and median)
    return kernels_endreads.end_half_width(keys, rows, x1, runs_l.width, runs_l.span_px, np.ascontiguousarray(t, float),
                                           np.ascontiguousarray(u, float), float(ref))


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
    f64 = [np.ascontiguousarray(a, float) for a in (rows, xc, u, d, half)]
    ok, ts, ds, cs, rs = kernels_dense.edge_track(     # (compiled: the same rules, equal up to rounding)
        runs_l._find_tables, runs_r._find_tables, runs_l.bounds_px, runs_r.bounds_px, runs_l.width, *f64, float(need), float(sm.f_px), cx,
        float(sm.offset_px))
    return (ts, ds, cs, rs) if ok else None


def grow(graph: SkeletonGraph, curves: dict[int, BranchCurve], runs_l: Runs, runs_r: Runs, sm: StereoMasks,
          centres: tuple, step_px: int = 40, reach_px: float = 120.0) -> None:
    """Matched steep curves carried on along their own skeleton rows beyond their fitted span, where
    an occluder cuts the branch on one side (no whole crossings there): window by window of
    ``step_px`` rows, each from the straight continuation of the curve so far (:func:`_donor_model`,
    :func:`_edge_track`), while the skeleton stays within half a radius + 2 px of it and 40 % of a
    window's rows give samples. The curve is then refitted to itself (one sample per row of its
    span) and the new samples. Rows near a junction are left out, as in the first fit: ``centres`` holds
    the pieces and :func:`appliance.localize.dense._row_centres` of that fit."""
    segs, rows_all, xc_all, g_all = centres
    bounds = np.searchsorted(g_all, np.arange(len(segs) + 1))
    for k, s in enumerate(segs):
        c = curves.get(s)
        if c is None or not c.by_row:
            continue
        rows, xc = rows_all[bounds[k]:bounds[k + 1]], xc_all[bounds[k]:bounds[k + 1]]
        lo, hi = c.t_range
        n = len(rows)                   # (rows ascending: 8 beyond an end iff the 8th from that end is)
        if not (n >= 8 and (float(rows[n - 8]) > hi + 1 or float(rows[7]) < lo - 1)):
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
                if sign < 0:                # (ascending rows, as np.argsort's order)
                    wr, wx = wr[::-1], wx[::-1]
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
        t = np.concatenate((tb, tn[sel]))             # (np.r_'s arrays, without its parsing)
        u, d = np.concatenate((c.s_at(tb), cn[sel])), np.concatenate((c.d_at(tb), dn[sel]))
        degree = 1 if float(np.ptp(tn[sel])) < 60 else 2
        parts[k] = (Poly.fit(t, u, degree), Poly.fit(t, d, degree))
        slopes[k] = end_slopes(t, d)[k]
        t_lo, t_hi = (float(tn[sel].min()), t_hi) if k == 0 else (t_lo, float(tn[sel].max()))
    below, above = parts.get(0, (None, None)), parts.get(1, (None, None))
    used = rn if c.right_runs is None else np.union1d(c.right_runs, rn)
    return BranchCurve(c.segment, True, (t_lo, t_hi), Spliced(s_base, lo, hi, below[0], above[0]),
                       Spliced(d_base, lo, hi, below[1], above[1]), c.radius_px, c.n_samples + len(tn),
                       tuple(slopes), used)


def carry_over(graph: SkeletonGraph, dead: list[int], curves: dict[int, BranchCurve], runs_l: Runs, runs_r: Runs,
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
        if len(yx) < 2 or any(n >= 0 and graph.node_kind[n] == ENDPOINT for n in graph.seg_nodes[s].tolist()) or \
                (int(yx[:, 0].max()) - int(yx[:, 0].min()) + 1) * graph.scale < 24:
            continue                    # (the same tests; the free end's first: no reductions)
        rows, xc = centre_guess(graph.to_full(yx), 1, graph.scale)
        if len(rows) < 24:
            continue
        r0, r1 = float(rows[0]), float(rows[-1])
        gap = np.maximum(spans[:, 0] - r1, r0 - spans[:, 1])      # rows between the piece and each donor
        best = None
        for k in ((gap > 0) & (gap <= reach_px)).nonzero()[0].tolist():     # (np.flatnonzero's indices)
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


def edge_consensus(graph: SkeletonGraph, dead: list[int], curves: dict[int, BranchCurve], runs_l: Runs,
                   runs_r: Runs, sm: StereoMasks, tol_px: float = 1.0,
                   min_share: float = 0.5, max_gradient: float = 0.25) -> dict[int, BranchCurve]:
    """Steep pieces that found no whole crossings and continue no matched branch, matched edge by
    edge on their own.

    Where an occluder (a leaf, or another branch merging with it in one view) cuts a piece by
    different amounts in the two views, no row shows it whole in both, but each row may still show
    one of its two outlines in both. For each row, each right crossing inside the working range
    (and not used by another curve) gives two candidate disparities: of the left edges and of the
    right edges. The straight line d(row), its slope at most ``max_gradient`` px per row (a branch
    pointing ~15 deg off the line of sight), on which the most rows have a candidate (within
    ``tol_px``; a vote over 21 slopes and offset bins) is the piece's if at least ``min_share`` of
    its rows (and 12) are on it and it lies in the working range. On each such row the agreeing
    edge's disparity moves onto the axis (:func:`edge_to_axis`) and gives the centre (that edge
    less the half width: the 75th percentile of the wider view's crossings, at most twice what
    the left mask's radius gives); the centre line must run within a half width (+ 2 px) of the
    piece's skeleton.
    """
    out = {}
    taken = np.zeros(len(runs_r.row), bool)
    for c in curves.values():
        if c.right_runs is not None and len(c.right_runs):
            taken[c.right_runs] = True
    dmin, dmax = sm.d_range_px
    cx = 0.5 * (sm.left_mask.shape[1] - 1)
    slopes = np.linspace(-max_gradient, max_gradient, 21)
    rm = sm.radius_map if isinstance(sm.radius_map, RadiusMap) else RadiusMap(np.asarray(sm.radius_map))
    for s in dead:
        yx = graph.seg_yx[s]
        if len(yx) < 2 or graph.seg_recovered[s]:
            continue
        pts = graph.to_full(yx).astype(float)
        rows, xc = centre_guess(pts, 1, graph.scale)
        if len(rows) < 24:
            continue
        # compiled: the vote, the checks, the step onto the axis and the fits (the numpy steps, equal up
        # to rounding); marks the piece's right runs taken when it gets a curve
        ok, uc, ut0, uts, udg, dc, dt0, dts, ddg, t_lo, t_hi, radius, n, end, used = kernels_dense.edge_consensus_piece(
            np.ascontiguousarray(rows, float), np.ascontiguousarray(xc, float), np.ascontiguousarray(pts),
            runs_l._find_tables, runs_l.bounds_px, runs_r._centre_keys, runs_r.bounds_px, runs_l.width, taken, slopes,
            float(dmin), float(dmax), rm.image, int(rm.scale), float(sm.f_px), cx, float(sm.offset_px), float(tol_px),
            float(min_share), float(max_gradient))
        if ok:
            out[s] = BranchCurve(s, True, (float(t_lo), float(t_hi)), Poly(uc[3 - udg:].copy(), float(ut0), float(uts)),
                                 Poly(dc[3 - ddg:].copy(), float(dt0), float(dts)), float(radius), int(n),
                                 (float(end[0]), float(end[1])), used)
    return out
