"""The dense path's kernels (localize/kernels_dense.py) against the numpy code
they replace (kept here as the reference)."""

from __future__ import annotations

import cv2
import numpy as np

from appliance.localize import kernels_dense, single_edge
from appliance.localize.curves import degree_for, median, robust_fit
from appliance.localize.edges import find_runs
from appliance.localize.matching import StereoMasks


def _edge_track_numpy(rows, xc, u, d, half, runs_l, runs_r, sm, need):
    """``single_edge._edge_track`` as it was in numpy (before the kernel)."""
    cx = 0.5 * (sm.left_mask.shape[1] - 1)
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
            d_ax[good] = single_edge.edge_to_axis(u[good], e_l[good] - edge_r[ir[good]], half[good], side, sm.f_px,
                                                  cx, sm.offset_px)
        good &= np.abs(d_ax - d) <= 2.0
        edges.append((e_l, d_ax)), ok_side.append(good), irs.append(ir)
    if (ok_side[0] | ok_side[1]).sum() < need:
        return None
    both = ok_side[0] & ok_side[1]
    if both.sum() >= 3:
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


def _degrees(t, g, live):
    """``dense._degrees`` as it was: ``curves.degree_for`` of each group's samples (``t`` (N,), group ``g``
    (N,)); 1 where not ``live`` (G,)."""
    ng = len(live)
    n = np.bincount(g, minlength=ng)
    lo, hi = np.full(ng, np.inf), np.full(ng, -np.inf)
    np.minimum.at(lo, g, t), np.maximum.at(hi, g, t)
    return np.array([degree_for(int(n[k]), float(hi[k] - lo[k])) if live[k] else 1 for k in range(ng)])


def _soft(draw) -> np.ndarray:
    """A soft mask (240 x 320 uint8) from a binary drawing at 4x, area-averaged (sub-pixel outlines)."""
    big = np.zeros((960, 1280), np.uint8)
    draw(big)
    return cv2.resize(big, (320, 240), interpolation=cv2.INTER_AREA)


def test_edge_to_axis_one_is_the_numpy_function():
    """Random rows (thin to thick branches, both sides, off-centre columns): the same axis disparity to 1e-9 px."""
    rng = np.random.default_rng(1)
    u, d, half = rng.uniform(0, 1280, 500), rng.uniform(80, 400, 500), rng.uniform(0.5, 60, 500)
    for side in (-1.0, 1.0):
        want = single_edge.edge_to_axis(u, d, half, side, 1450.0, 639.5, 3.0)
        got = [kernels_dense.edge_to_axis_one(*a, side, 1450.0, 639.5, 3.0) for a in zip(u, d, half)]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


def test_edge_track_is_the_numpy_track():
    """Tilted branches drawn in both views at a disparity, one side cut by an occluder in one view, other
    branches nearby; random carried centres, disparities (some off), half widths and ``need``: the same
    None, and otherwise the same rows, right runs (exact) and disparities and centres (to 1e-9 px)."""
    rng = np.random.default_rng(2)
    n_track = n_none = 0
    for trial in range(60):
        x0, slope, w = rng.uniform(100, 220), rng.uniform(-0.4, 0.4), int(rng.integers(3, 30))
        disp, grad = rng.uniform(20, 60), rng.uniform(-0.05, 0.05)

        def branch(img, shift, x0=x0, slope=slope, w=w, disp=disp, grad=grad):
            for y in range(0, 960, 8):
                x = 4 * (x0 + slope * y / 4 - shift * (disp + grad * y / 4))
                cv2.rectangle(img, (int(x - 2 * w), y), (int(x + 2 * w), y + 7), 255, -1)
            if rng.random() < 0.5:
                cv2.circle(img, (int(rng.uniform(0, 1280)), int(rng.uniform(0, 960))), int(rng.uniform(20, 200)),
                           255 * int(shift), -1)           # an occluder (right view) or a hole (left)
            cv2.line(img, (int(rng.uniform(0, 1280)), 0), (int(rng.uniform(0, 1280)), 959), 255, 12)
        left, right = _soft(lambda m: branch(m, 0.0)), _soft(lambda m: branch(m, 1.0))
        sm = StereoMasks(left, right, left, right, None, (10.0, 80.0), float(rng.uniform(300, 1500)),
                         float(rng.uniform(-5, 5)))
        runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
        rows = np.arange(rng.uniform(0, 100), rng.uniform(120, 240)).astype(float)
        if trial % 3 == 0:
            rows = rows + 0.5                       # half rows (truncated as the rows' integers)
        true_u = x0 + slope * rows
        u = true_u + rng.normal(0, 0.5 + 3 * (trial % 4 == 1), len(rows))
        xc = true_u + rng.normal(0, 2, len(rows))
        d = disp + grad * rows + rng.normal(0, 0.3 + 2 * (trial % 5 == 2), len(rows))
        half = np.full(len(rows), w / 4 * rng.uniform(0.7, 1.3))
        need = max(4, 0.4 * len(rows)) if trial % 2 else 4.0
        want = _edge_track_numpy(rows, xc, u, d, half, runs_l, runs_r, sm, need)
        got = single_edge._edge_track(rows, xc, u, d, half, runs_l, runs_r, sm, need)
        assert (want is None) == (got is None)
        if want is None:
            n_none += 1
            continue
        n_track += 1
        for a, b in zip(want, got):
            assert a.shape == b.shape
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[3], want[3])
        np.testing.assert_allclose(got[1], want[1], rtol=0, atol=1e-9)       # px of disparity
        np.testing.assert_allclose(got[2], want[2], rtol=0, atol=1e-9)       # px
    assert n_track >= 15 and n_none >= 5


def _candidates_numpy(rows, xc, g, sin_all, runs_l, runs_r, rm, d_range_px, taken):
    """``dense.fit_steep_many``'s steps from the row centres to the right candidates, as they were in numpy."""
    from appliance.localize.curves import robust_fit_groups
    from appliance.localize.dense import _regroup
    from appliance.localize.radius import radius_at
    segs = np.arange(len(sin_all))
    alive = np.bincount(g, minlength=len(segs)) >= 4
    keep = alive[g]
    rows, xc, g = rows[keep].astype(int), xc[keep], _regroup(g[keep], alive)
    segs = segs[alive]
    sin_t = sin_all[segs]
    il = runs_l.find(rows, xc)
    r_loc = radius_at(rm, np.column_stack([xc, rows]))
    ok = il >= 0
    rows_all, il_all, g_all = rows[ok], il[ok], g[ok]
    w_l = np.where(ok, runs_l.span_px[np.maximum(il, 0)], np.inf)
    ok &= w_l <= 1.5 * (2 * r_loc / sin_t[g] + 1) + 2
    rows, il, w_l, g = rows[ok], il[ok], w_l[ok], g[ok]
    alive = np.bincount(g, minlength=len(segs)) >= 4
    keep = alive[g]
    rows, il, w_l, g = rows[keep], il[keep], w_l[keep], _regroup(g[keep], alive)
    keep = alive[g_all]
    rows_all, il_all, g_all = rows_all[keep], il_all[keep], _regroup(g_all[keep], alive)
    segs = segs[alive]
    ng = len(segs)
    rf = rows.astype(float)
    w_fit, _ = robust_fit_groups(rf, w_l, g, ng, np.full(ng, 2), rounds=2)
    wv = w_fit(g, rf)
    ok = np.abs(w_l - wv) <= 0.1 * wv + 1.5
    rows, il, w_l, g = rows[ok], il[ok], w_l[ok], g[ok]
    n = np.bincount(g, minlength=ng)
    alive = n >= 4
    c_l = runs_l.centre_px[il]
    dmin, dmax = d_range_px
    q, rr = runs_r.between(rows, c_l - dmax, c_l - dmin)
    cd = c_l[q] - runs_r.centre_px[rr]
    cw = runs_r.span_px[rr]
    good = (np.abs(cw - w_l[q]) <= 0.1 * w_l[q] + 1.5) & alive[g[q]]
    if taken is not None:
        good &= ~taken[rr]
    q, rr, cd, cw = q[good], rr[good], cd[good], cw[good]
    alive &= np.bincount(g[q], minlength=ng) >= 4
    return segs, rows, il, w_l, g, rows_all, il_all, g_all, n, alive, c_l, q, rr, cd, cw


def _steep_scenes(n_scenes, seed):
    """Synthetic steep pieces for the fit's kernels: several tilted branches (widths varying, some merged
    with a crossing branch or cut by an occluder) in both views, pieces of 2 to 150 rows (some off the
    mask), radius maps at scales 1 and 2, every third scene with taken right runs. Yields
    ``(rows, xc, g, sin_all, runs_l, runs_r, rm, taken)``."""
    from appliance.localize.radius import ridge_radius_map
    rng = np.random.default_rng(seed)
    for trial in range(n_scenes):
        pieces = [(rng.uniform(20, 300), rng.uniform(-0.6, 0.6), int(rng.integers(3, 40)), rng.uniform(15, 50))
                  for _ in range(int(rng.integers(1, 6)))]

        def draw(img, shift):
            for x0, slope, w, disp in pieces:
                for y in range(0, 960, 8):
                    x = 4 * (x0 + slope * y / 4 - shift * disp)
                    ww = w * (1 + 0.3 * np.sin(y / 200))
                    cv2.rectangle(img, (int(x - 2 * ww), y), (int(x + 2 * ww), y + 7), 255, -1)
            cv2.line(img, (0, int(rng.uniform(0, 960))), (1279, int(rng.uniform(0, 960))), 255, int(rng.integers(8, 60)))
            if shift and rng.random() < 0.5:
                cv2.circle(img, (int(rng.uniform(0, 1280)), int(rng.uniform(0, 960))), int(rng.uniform(20, 200)), 0, -1)
        left, right = _soft(lambda m: draw(m, 0.0)), _soft(lambda m: draw(m, 1.0))
        runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
        scale = 1 + trial % 2
        rm = ridge_radius_map(left[::scale, ::scale] if scale > 1 else left, 3 if scale > 1 else 1, scale)
        rows, xc, g = [], [], []
        for k, (x0, slope, w, disp) in enumerate(pieces):
            r = np.arange(rng.uniform(0, 200), rng.uniform(0, 240)).round()[:int(rng.integers(2, 150))]
            rows.append(r), xc.append(x0 + slope * r + rng.normal(0, 1.0, len(r))), g.append(np.full(len(r), k))
        rows, xc, g = (np.concatenate(a) for a in (rows, xc, g))
        sin_all = np.maximum(rng.uniform(0, 1, len(pieces)), 0.2)
        taken = rng.random(len(runs_r.row)) < 0.2 if trial % 3 == 1 else None
        yield rows, xc, g.astype(np.int64), sin_all, runs_l, runs_r, rm, taken


def _candidates(rows, xc, g, sin_all, runs_l, runs_r, rm, taken):
    return kernels_dense.steep_candidates(rows, xc, g, sin_all, runs_l._find_tables, runs_l.span_px,
                                          runs_l.centre_px, runs_r._centre_keys, runs_r.centre_px, runs_r.span_px,
                                          runs_l.width, rm.image, rm.scale, 10.0, 60.0,
                                          np.zeros(0, bool) if taken is None else taken)


def test_steep_candidates_are_the_numpy_steps():
    """:func:`_steep_scenes`' pieces, with and without taken right runs: every output the same (bit for
    bit: the same comparisons and sums)."""
    seen = 0
    for rows, xc, g, sin_all, runs_l, runs_r, rm, taken in _steep_scenes(40, 3):
        want = _candidates_numpy(rows, xc, g, sin_all, runs_l, runs_r, rm, (10.0, 60.0), taken)
        got = _candidates(rows, xc, g, sin_all, runs_l, runs_r, rm, taken)
        for a, b in zip(want, got):
            np.testing.assert_array_equal(b, a)
        np.testing.assert_array_equal(got[15], _degrees(want[1].astype(float), want[4], want[9]))
        seen += bool(want[9].any())
    assert seen >= 15


def _edge_samples_numpy(rows, il, g, u_poly, w_fit, d_model, runs_l, runs_r, taken):
    """``single_edge.edge_samples`` as it was (numpy): disparity samples from single edges, on rows whose
    crossing is not whole.

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


def _steep_fit_numpy(t, alive, n, degree, q, rr, cd, cw, gq, c_l, w_l, model, rows_all, il_all, g_all, runs_l,
                     runs_r, taken):
    """``dense.fit_steep_many``'s middle steps as they were in numpy (the picks, the centre line and width,
    ``single_edge.edge_samples``)."""
    from appliance.localize.curves import GroupPolys, robust_fit_groups
    ng = len(alive)
    alive = alive.copy()
    for k, tol in enumerate((2.0, 0.75)):
        sel = alive[gq]
        q, rr, cd, cw, gq = q[sel], rr[sel], cd[sel], cw[sel], gq[sel]
        res = np.abs(cd - model(gq, t[q]))
        first = kernels_dense.nearest_per_query(q, res)
        chosen = first[res[first] <= tol]
        alive &= np.bincount(gq[chosen], minlength=ng) >= np.maximum(4, 0.25 * n)
        chosen = chosen[alive[gq[chosen]]]
        if not alive.any():
            return None
        model, inl = robust_fit_groups(t[q[chosen]], cd[chosen], gq[chosen], ng, degree, rounds=1 if k == 0 else 3)
    chosen = chosen[inl]
    gc = gq[chosen]
    tf, df, cf = t[q[chosen]], cd[chosen], c_l[q[chosen]]
    wf = 0.5 * (w_l[q[chosen]] + cw[chosen])
    uw, uw_inl = robust_fit_groups(np.concatenate([tf, tf]), np.concatenate([cf, w_l[q[chosen]]]),
                                   np.concatenate([gc, gc + ng]), 2 * ng,
                                   np.concatenate([degree, np.ones(ng, int)]), rounds=np.repeat([1, 2], ng))
    u_poly = GroupPolys(uw.coef[:ng], uw.t0[:ng], uw.ts[:ng], uw.degree[:ng])
    w_poly = GroupPolys(uw.coef[ng:], uw.t0[ng:], uw.ts[ng:], uw.degree[ng:])
    width = int(rows_all.max()) + 1
    key_all, key_used = g_all * width + rows_all, gc * width + tf.astype(int)
    used_key = np.zeros(max(int(key_all.max()), int(key_used.max(initial=0))) + 1, bool)
    used_key[key_used] = True
    rest = ~used_key[key_all] & alive[g_all]
    te, de, re, ge = _edge_samples_numpy(rows_all[rest], il_all[rest], g_all[rest], u_poly, w_poly, model,
                                         runs_l, runs_r, taken)
    return alive, tf, df, cf, wf, gc, rr[chosen], uw_inl[:len(tf)], te, de, re, ge


# steep_fit's optional arguments at their defaults (no occlusion test, no fork rows), passed explicitly: the
# localizer's signature, loaded from numba's cache (left out, they are a signature of their own, compiled anew
# in every process: ~30 s)
_STEEP_FIT_DEFAULTS = (-1.0, 0.0, 1.0, 0.0, 0.0, np.full((0, 2), np.nan))


def test_steep_fit_is_the_numpy_steps():
    """:func:`_steep_scenes`' pieces through :func:`kernels_dense.steep_candidates`, the degrees and the
    consensus lines: the same picks, lines' inliers and single-edge samples, bit for bit."""
    from appliance.localize.dense import _consensus_lines
    seen = 0
    for rows, xc, g, sin_all, runs_l, runs_r, rm, taken in _steep_scenes(40, 9):
        seg_idx, r3, il3, w3, g3, rows_all, il_all, g_all, n, alive, c_l, q, rr, cd, cw, _ = _candidates(
            rows, xc, g, sin_all, runs_l, runs_r, rm, taken)
        if not len(seg_idx) or not alive.any():
            continue
        t = r3.astype(float)
        degree = _degrees(t, g3, alive)
        gq = g3[q]
        model = _consensus_lines(t[q], cd, np.searchsorted(gq, np.arange(len(alive) + 1)), alive)
        want = _steep_fit_numpy(t, alive, n, degree, q, rr, cd, cw, gq, c_l, w3, model, rows_all, il_all, g_all,
                                runs_l, runs_r, taken)
        got = kernels_dense.steep_fit(t, alive, n, degree.astype(np.int64), q, rr, cd, cw, gq, c_l, w3, model.coef,
                                      model.t0, model.ts, rows_all, il_all, g_all, runs_r._find_tables,
                                      runs_l.bounds_px, runs_r.bounds_px, runs_l.width,
                                      np.zeros(0, bool) if taken is None else taken, *_STEEP_FIT_DEFAULTS)
        assert got[0] == (want is not None)
        if want is None:
            continue
        seen += 1
        for a, b in zip(want, got[1:]):
            np.testing.assert_array_equal(b, a)
    assert seen >= 10


def _flat_texture_numpy(d_surf, score, u, uv, right_mask, v_poly, radius, lo, hi, f_px, offset_px):
    """``dense._flat_finish``'s texture branch as it was in numpy: (status, d_poly or None, inliers) with
    status 0 (fewer than 3 patches), 1 (a curve), 2 (withheld)."""
    from appliance.localize.dense import _patch_half_h
    from appliance.localize.flatfit import line_supported, scatter_ok
    from appliance.localize.texture import patch_depth_fraction, slant_depth_factor, surface_to_axis
    good = np.isfinite(d_surf) & (score >= 0.6)
    xr = np.rint(u - np.where(np.isnan(d_surf), 0.0, d_surf)).astype(int)
    yr = np.rint(uv[:, 1]).astype(int)
    h, w = right_mask.shape
    on_right = (xr >= 0) & (xr < w) & (yr >= 0) & (yr < h)
    good &= on_right
    good[on_right] &= right_mask[yr[on_right], xr[on_right]] >= 128
    if good.sum() < 3:
        return 0, None, 0
    ug, dv = u[good], v_poly.deriv()(u[good])
    k = patch_depth_fraction(radius, _patch_half_h(radius), dv)
    d_axis = surface_to_axis(d_surf[good], radius, f_px, offset_px, k)
    degree = 0 if hi - lo < 100 else 1
    d_poly, inl_d = robust_fit(ug, d_axis, degree)
    if degree == 1:
        k = k * slant_depth_factor(ug, v_poly(ug), d_poly(ug), d_poly.deriv()(ug), dv, f_px,
                                   (0.5 * (w - 1), 0.5 * (h - 1)), offset_px)
        d_axis = surface_to_axis(d_surf[good], radius, f_px, offset_px, k)
        d_poly, inl_d = robust_fit(ug, d_axis, degree)
    if degree == 1 and not line_supported(ug[inl_d], len(u), lo, hi):
        return 2, d_poly, int(inl_d.sum())
    if not scatter_ok((d_axis - d_poly(ug))[inl_d], degree):
        return 2, d_poly, int(inl_d.sum())
    return 1, d_poly, int(inl_d.sum())


def test_flat_finish_is_the_numpy_texture_fit():
    """Flat pieces short (a constant) and long (a line, with the slant step), radii 2-40 px (patches of 3-49
    rows), disparities turning in depth, noisy and gross matches, patches off the right mask or the view,
    few patches: the same status and inliers, the same disparity polynomial to 1e-9 px."""
    from appliance.localize.curves import Poly
    from appliance.localize.dense import _FLAT_LIMITS, _patch_half_h
    rng = np.random.default_rng(4)
    seen = {0: 0, 1: 0, 2: 0}
    for trial in range(150):
        lo = rng.uniform(0, 600)
        hi = lo + rng.choice([rng.uniform(10, 99), rng.uniform(100, 600)])
        u = np.arange(lo, hi + 1, 6.0)
        v_poly = Poly(np.concatenate([rng.normal(0, 2, int(rng.integers(0, 3))), [rng.uniform(100, 400)]]),
                      float(0.5 * (lo + hi)), float(max(0.5 * (hi - lo), 1.0)))
        uv = np.column_stack([u, v_poly(u)])
        d_true = rng.uniform(60, 200) + rng.uniform(-0.15, 0.15) * (u - lo)
        d_surf = d_true + rng.normal(0, rng.choice([0.1, 1.0, 3.0]), len(u))
        gross = rng.random(len(u)) < rng.uniform(0, 0.5)
        d_surf[gross] += rng.uniform(-30, 30, gross.sum())
        d_surf[rng.random(len(u)) < 0.1] = np.nan
        score = rng.uniform(0.3, 1.0, len(u))
        right_mask = np.zeros((480, 1100), np.uint8)
        right_mask[:, int(rng.uniform(0, 300)):] = 200
        right_mask[:, int(rng.integers(0, 5))::5] = 0              # (columns off the mask)
        radius, f_px, off = rng.uniform(2, 40), rng.uniform(800, 1600), rng.uniform(-5, 5)
        want = _flat_texture_numpy(d_surf, score, u, uv, right_mask, v_poly, radius, lo, hi, f_px, off)
        status, coef, t0, ts, degree, n_inl = kernels_dense.flat_finish(
            d_surf, score, u, np.ascontiguousarray(uv[:, 1]), right_mask, v_poly.coef, v_poly.t0, v_poly.ts, radius,
            _patch_half_h(radius), lo, hi, f_px, off, True, _FLAT_LIMITS)
        assert status == want[0]
        seen[status] += 1
        if status == 0:
            continue
        assert n_inl == want[2] and degree == len(want[1].coef) - 1
        np.testing.assert_allclose(coef[3 - degree:], want[1].coef, rtol=0, atol=1e-9)
        assert abs(t0 - want[1].t0) <= 1e-9 and abs(ts - want[1].ts) <= 1e-9
    assert min(seen.values()) >= 10, seen


def _flat_line_numpy(cols, yc, junction, nxy, thr, runs_t):
    """``dense._flat_search``'s centre line as it was in numpy: None or (v_poly, radius, lo, hi)."""
    from appliance.localize.curves import degree_for
    near = np.zeros(len(cols), bool)
    for k in range(2):
        if junction[k]:
            near |= np.hypot(*(np.column_stack([cols, yc]) - nxy[k]).T) < thr[k]
    cols, yc = cols[~near].astype(int), yc[~near]
    if len(cols) < 4:
        return None
    it = runs_t.find(cols, yc)
    ok = it >= 0
    if ok.sum() < 4:
        return None
    t, vc, hgt = cols[ok].astype(float), runs_t.centre_px[it[ok]], runs_t.span_px[it[ok]]
    v_poly, inl = robust_fit(t, vc, degree_for(len(t), float(t.max() - t.min())))
    slope = v_poly.deriv()(t[inl])
    return v_poly, float(median(0.5 * hgt[inl] / np.sqrt(1 + slope ** 2))), float(t[inl].min()), float(t[inl].max())


def test_flat_line_is_the_numpy_centre_line():
    """Near-horizontal branches (straight and bent, 2-40 px thick, some cut by gaps) in a mask's columns,
    pieces of 2-300 columns with junction regions at none, one or both ends: the same None, and the same
    line (to 1e-9 px), radius and span."""
    rng = np.random.default_rng(5)
    seen = [0, 0]
    for trial in range(80):
        v0, a, b, w = rng.uniform(40, 200), rng.uniform(-0.4, 0.4), rng.uniform(-1e-3, 1e-3), rng.uniform(1, 20)

        def draw(img):
            for x in range(0, 1280, 8):
                v = 4 * (v0 + a * x / 4 + b * (x / 4 - 160) ** 2)
                cv2.rectangle(img, (x, int(v - 2 * w)), (x + 7, int(v + 2 * w)), 255, -1)
            for _ in range(int(rng.integers(0, 4))):
                x = int(rng.uniform(0, 1280))
                cv2.rectangle(img, (x, 0), (x + int(rng.uniform(4, 80)), 959), 0, -1)
        mask = _soft(draw)
        runs_t = find_runs(mask.T, soft=True)
        c0 = rng.uniform(0, 300)
        cols = np.arange(c0, min(c0 + rng.uniform(2, 300), 319)).round()
        yc = v0 + a * cols + b * (cols - 160) ** 2 + rng.normal(0, 1, len(cols))
        junction = rng.random(2) < 0.5
        nxy = np.array([[cols[0], yc[0]], [cols[-1], yc[-1]]]) if len(cols) else np.zeros((2, 2))
        thr = rng.uniform(2, 40, 2)
        want = _flat_line_numpy(cols, yc, junction, nxy, thr, runs_t)
        ok, coef, t0, ts, degree, radius, lo, hi = kernels_dense.flat_line(
            cols, yc, junction, nxy, thr, runs_t._find_tables, runs_t.centre_px, runs_t.span_px, runs_t.width)
        assert ok == (want is not None)
        seen[ok] += 1
        if not ok:
            continue
        v_poly, r, lo0, hi0 = want
        assert degree == len(v_poly.coef) - 1 and (lo, hi) == (lo0, hi0)
        np.testing.assert_allclose(coef[3 - degree:], v_poly.coef, rtol=0, atol=1e-9)
        assert (t0, ts) == (v_poly.t0, v_poly.ts)
        assert abs(radius - r) <= 1e-9                      # px
    assert min(seen) >= 10, seen


def _coarse_agree_numpy(u, d, tol_px=6.0, tol_line_px=2.0):
    """``dense._coarse_agree`` as it was in numpy."""
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


def test_coarse_agree_is_the_numpy_test():
    """1-6 coarse disparities (equal columns included), agreeing, on a line, scattered: the same answer."""
    rng = np.random.default_rng(6)
    answers = []
    for trial in range(3000):
        n = int(rng.integers(0, 7))
        u = np.sort(rng.choice([rng.uniform(0, 300, n), rng.integers(0, 3, n).astype(float)]))
        d = 150 + rng.choice([0.0, 0.3]) * u + rng.normal(0, rng.choice([0.5, 3.0, 30.0]), n)
        want = _coarse_agree_numpy(u, d)
        assert kernels_dense.coarse_agree(u, d, 6.0, 2.0) == want
        answers.append(want)
    assert 0.2 < np.mean(answers) < 0.9


def _consensus_piece_numpy(rows, xc, pts, runs_l, runs_r, taken, rm, d_range_px, f_px, offset_px, cx,
                           tol_px=1.0, min_share=0.5, max_gradient=0.25):
    """``single_edge.edge_consensus``'s steps for one piece as they were in numpy: None or (u_poly, d_poly,
    t_range, radius, n, end_slopes, right_runs); marks the right runs taken."""
    from appliance.localize.curves import angle_deg, degree_for, end_slopes, percentile
    from appliance.localize.radius import radius_at
    dmin, dmax = d_range_px
    slopes = np.linspace(-max_gradient, max_gradient, 21)
    ri = rows.astype(int)
    il = runs_l.find(ri, xc)
    ok = il >= 0
    ri, il = ri[ok], il[ok]
    if len(ri) < 12:
        return None
    a_l, b_l = runs_l.left_px[il], runs_l.right_px[il]
    q, rr = runs_r.between(ri, a_l - dmax, b_l - dmin)
    keep = ~taken[rr]
    q, rr = q[keep], rr[keep]
    if len(q) < 12:
        return None
    t = ri[q].astype(float)
    cand_t = np.concatenate([t, t])
    cand_d = np.concatenate([a_l[q] - runs_r.left_px[rr], b_l[q] - runs_r.right_px[rr]])
    cand_q = np.concatenate([q, q])
    tm = float(cand_t.mean())
    lo, k_s, k_b = kernels_dense.line_vote(cand_t, cand_d, slopes, tm, float(tol_px))
    line = lo + (k_b + 1) * tol_px + slopes[k_s] * (cand_t - tm)
    sel = np.abs(cand_d - line) <= 1.5 * tol_px
    if np.count_nonzero(np.bincount(cand_q[sel])) < max(12, min_share * len(ri)):
        return None
    ts, ds, qs = cand_t[sel], cand_d[sel], cand_q[sel]
    side = np.concatenate([np.full(len(q), -1.0), np.full(len(q), 1.0)])[sel]
    runs = np.concatenate([rr, rr])[sel]
    d_line, inl = robust_fit(ts, ds, 1)
    inl &= np.abs(ds - d_line(ts)) <= tol_px
    ts, ds, qs, side, runs = ts[inl], ds[inl], qs[inl], side[inl], runs[inl]
    if len(np.unique(ts)) < max(12, min_share * len(ri)):
        return None
    d_ends = d_line(np.array([ts.min(), ts.max()]))
    if d_ends.min() < 0.95 * dmin or d_ends.max() > 1.05 * dmax or \
            abs(d_ends[1] - d_ends[0]) > max_gradient * max(float(ts.max() - ts.min()), 1.0):
        return None
    w = np.maximum(runs_l.span_px[il[qs]], runs_r.span_px[runs])
    half_px = 0.5 * percentile(w, 75)
    r_px = float(median(radius_at(rm, np.column_stack([xc, rows]))))
    sin_t = max(float(np.sin(np.radians(angle_deg(pts)))), 0.2)
    if half_px > 2.0 * r_px / sin_t + 2:
        return None
    e_l = np.where(side < 0, a_l[qs], b_l[qs])
    u = e_l - side * half_px
    d_ax = single_edge.edge_to_axis(u, ds, np.full(len(ds), half_px), side, f_px, cx, offset_px)
    degree = min(degree_for(len(np.unique(ts)), float(ts.max() - ts.min())), 2)
    u_poly, _ = robust_fit(ts, u, degree)
    d_poly, inl_d = robust_fit(ts, d_ax, degree)
    ts = ts[inl_d]
    radius = half_px / float(np.sqrt(1 + np.mean(u_poly.deriv()(ts)) ** 2))
    if float(median(np.abs(u_poly(rows) - xc))) > 0.5 * half_px + 2:
        return None
    used = np.unique(runs[inl_d])
    taken[used] = True
    return u_poly, d_poly, (float(ts.min()), float(ts.max())), radius, len(ts), end_slopes(ts, d_ax[inl_d]), used


def test_edge_consensus_piece_is_the_numpy_steps():
    """Steep branches cut on alternate sides by occluders in each view (no whole crossing), at a disparity
    turning in depth, with other branches in the right view and some right runs taken: the same curve or
    None, the same samples and right runs, the lines to 1e-9 px and the end slopes to 1e-6 px per row."""
    from appliance.localize.radius import ridge_radius_map
    rng = np.random.default_rng(7)
    got_curves = 0
    for trial in range(60):
        x0, slope, w = rng.uniform(100, 220), rng.uniform(-0.3, 0.3), rng.uniform(3, 12)
        disp, grad = rng.uniform(20, 60), rng.uniform(-0.04, 0.04) * (trial % 4 != 0)

        def draw(img, shift):
            for y in range(0, 960, 8):
                x = 4 * (x0 + slope * y / 4 - shift * (disp + grad * y / 4))
                cut = (y // 64) % 2 if shift else (y // 64 + 1) % 2          # alternate sides, each view its own
                a, b = (x - 4 * w, x + (4 * w if cut else w)) if trial % 2 else (x - (4 * w if cut else w), x + 4 * w)
                cv2.rectangle(img, (int(a), y), (int(b), y + 7), 255, -1)
            if shift:
                cv2.line(img, (int(rng.uniform(0, 1280)), 0), (int(rng.uniform(0, 1280)), 959), 255, 16)
        left, right = _soft(lambda m: draw(m, 0.0)), _soft(lambda m: draw(m, 1.0))
        runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
        rm = ridge_radius_map(left)
        rows = np.arange(rng.uniform(0, 40), rng.uniform(150, 240)).round()
        xc = x0 + slope * rows + rng.normal(0, 0.5, len(rows))
        pts = np.column_stack([xc, rows])
        taken = rng.random(len(runs_r.row)) < (0.05 if trial % 3 == 0 else 0.0)
        f_px, off, cx = rng.uniform(300, 1500), rng.uniform(-3, 3), 159.5
        t0 = taken.copy()
        want = _consensus_piece_numpy(rows, xc, pts, runs_l, runs_r, t0, rm, (10.0, 80.0), f_px, off, cx)
        t1 = taken.copy()
        got = kernels_dense.edge_consensus_piece(rows, xc, pts, runs_l._find_tables, runs_l.bounds_px,
                                                 runs_r._centre_keys, runs_r.bounds_px, runs_l.width, t1,
                                                 np.linspace(-0.25, 0.25, 21), 10.0, 80.0, rm.image, rm.scale, f_px,
                                                 cx, off, 1.0, 0.5, 0.25)
        assert got[0] == (want is not None)
        np.testing.assert_array_equal(t1, t0)
        if want is None:
            continue
        got_curves += 1
        ok, uc, ut0, uts, udg, dc, dt0, dts, ddg, t_lo, t_hi, radius, n, end, used = got
        u_poly, d_poly, t_range, r, n0, end0, used0 = want
        assert (t_lo, t_hi) == t_range and n == n0 and np.array_equal(used, used0)
        for c, t_0, t_s, dg, p in ((uc, ut0, uts, udg, u_poly), (dc, dt0, dts, ddg, d_poly)):
            assert dg == len(p.coef) - 1 and (t_0, t_s) == (p.t0, p.ts)
            np.testing.assert_allclose(c[3 - dg:], p.coef, rtol=0, atol=1e-9)     # px
        assert abs(radius - r) <= 1e-9
        np.testing.assert_allclose(end, end0, rtol=0, atol=1e-6)                  # px per row
    assert got_curves >= 8


def _refit_numpy(tf, df, gc, te, de, ge, ng, degree):
    """``dense.fit_steep_many``'s final disparity fits as they were in numpy."""
    from appliance.localize.curves import end_slopes_groups, fit_groups, robust_fit_groups
    ta, da, ga = np.concatenate([tf, te]), np.concatenate([df, de]), np.concatenate([gc, ge])
    o = np.argsort(ga, kind="stable")
    ta, da, ga = ta[o], da[o], ga[o]
    has_edges = np.bincount(ge, minlength=ng) > 0
    sel = has_edges[ga]
    ts_, ds_, gs_ = ta[sel], da[sel], ga[sel]
    deg2 = _degrees(ts_, gs_, has_edges)
    inl2 = robust_fit_groups(ts_, ds_, gs_, ng, deg2)[1] if sel.any() else np.zeros(0, bool)
    own = ~has_edges[gc]
    sel2 = np.flatnonzero(inl2)
    td = np.concatenate([tf[own], ts_[sel2]])
    dd = np.concatenate([df[own], ds_[sel2]])
    gd = np.concatenate([gc[own], gs_[sel2]])
    o = np.argsort(gd, kind="stable")
    td, dd, gd = td[o], dd[o], gd[o]
    d_polys = fit_groups(td, dd, gd, ng, np.where(has_edges, deg2, degree))
    bd = np.searchsorted(gd, np.arange(ng + 1))
    span = [(td[a:b].min(), td[a:b].max()) if b > a else (np.nan, np.nan) for a, b in zip(bd[:-1], bd[1:])]
    return d_polys, end_slopes_groups(td, dd, gd, ng), np.array(span).reshape(-1, 2), np.diff(bd)


def test_disparity_refit_is_the_numpy_fits():
    """1-8 pieces of 4-300 rows (degrees 1-3), some with single-edge samples (a few, or many with
    outliers), some pieces empty: the same polynomials, end slopes, spans and counts, bit for bit."""
    rng = np.random.default_rng(8)
    for trial in range(200):
        ng = int(rng.integers(1, 9))
        tf, df, gc, te, de, ge = [], [], [], [], [], []
        degree = rng.integers(1, 4, ng)
        for k in range(ng):
            n = int(rng.choice([0, 4, 20, 300])) if trial % 7 else 0
            r0 = rng.uniform(0, 600)
            t = np.sort(rng.choice(np.arange(r0, r0 + max(2 * n, 8)), n, replace=False)) if n else np.zeros(0)
            tf.append(t), df.append(50 + 0.05 * t + rng.normal(0, 0.3, n)), gc.append(np.full(n, k))
            m = int(rng.choice([0, 0, 3, 40]))
            t2 = rng.uniform(r0 - 50, r0 + 350, m).round()
            d2 = 50 + 0.05 * t2 + rng.normal(0, 0.3, m)
            d2[rng.random(m) < 0.2] += 20
            order = np.argsort(rng.random(m))                # (edge_samples' order: left edges, then right)
            te.append(t2[order]), de.append(d2[order]), ge.append(np.full(m, k))
        tf, df, gc, te, de, ge = (np.concatenate(a) for a in (tf, df, gc, te, de, ge))
        gc, ge = gc.astype(np.int64), ge.astype(np.int64)
        polys, slopes, span, n_fit = _refit_numpy(tf, df, gc, te, de, ge, ng, degree)
        bc, be = (np.searchsorted(a, np.arange(ng + 1)) for a in (gc, ge))
        coef, t0, ts, deg, sl, t_lo, t_hi, n = kernels_dense.disparity_refit(tf, df, bc, te, de, be,
                                                                             degree.astype(np.int64))
        for a, b in ((coef, polys.coef), (t0, polys.t0), (ts, polys.ts), (deg, polys.degree), (sl, slopes),
                     (t_lo, span[:, 0]), (t_hi, span[:, 1]), (n, n_fit)):
            np.testing.assert_array_equal(a, b)


def _vote_by_numpy(cand_t, cand_d, slopes, tm, tol_px):
    """single_edge.edge_consensus' former vote (numpy)."""
    d0 = slopes[:, None] * (cand_t - tm)
    np.subtract(cand_d, d0, out=d0)
    lo = float(d0.min())
    d0 -= lo
    d0 /= tol_px
    bins = d0.astype(np.intp)
    nb = int(bins.max()) + 2
    bins += np.arange(len(slopes))[:, None] * nb
    votes = np.bincount(bins.ravel(), minlength=len(slopes) * nb).reshape(len(slopes), nb)
    window = votes[:, :-1] + votes[:, 1:]
    k_s, k_b = np.unravel_index(int(window.argmax()), window.shape)
    return lo, int(k_s), int(k_b)


def test_line_vote_is_the_numpy_vote():
    rng = np.random.default_rng(9)
    slopes = np.linspace(-0.25, 0.25, 21)
    for _ in range(300):
        n = int(rng.integers(1, 400))
        t = np.sort(rng.integers(0, 900, n)).astype(float)
        d = rng.uniform(100, 300, n)
        if rng.random() < 0.7:                                     # a line through some of them
            on = rng.random(n) < rng.uniform(0.2, 0.9)
            d[on] = 180 + rng.uniform(-0.2, 0.2) * (t[on] - t.mean()) + rng.normal(0, 0.3, on.sum())
        if rng.random() < 0.2:
            d = np.round(d)                                        # ties between bins and windows
        tm = float(t.mean())
        tol = float(rng.choice([1.0, 0.5, 1.5]))
        assert kernels_dense.line_vote(t, d, slopes, tm, tol) == _vote_by_numpy(t, d, slopes, tm, tol)


def _centre_guess_by_numpy(pts, axis, scale):
    """single_edge.centre_guess' numpy steps (bincount means, np.interp)."""
    t, s = pts[:, axis], pts[:, 1 - axis]
    k = (t * 2.0).astype(np.int64)
    k0 = int(k.min())
    k -= k0
    count = np.bincount(k)
    nz = np.flatnonzero(count)
    uniq = (nz + k0) / 2.0
    s_mean = np.bincount(k, s)[nz] / count[nz]
    half = (scale - 1) / 2
    ts = np.arange(np.ceil(uniq[0] - half), np.floor(uniq[-1] + half) + 1)
    return ts, np.interp(ts, uniq, s_mean)


def test_centre_line_is_centre_guess_numpy_steps():
    from appliance.localize.single_edge import centre_guess
    rng = np.random.default_rng(10)
    for trial in range(500):
        n = int(rng.integers(1, 300))
        scale = int(rng.choice([1, 2, 4]))
        t = np.sort(rng.integers(0, 900, n)) / (2.0 if trial % 2 else 1.0)      # whole or half pixels
        s = np.cumsum(rng.normal(0, 1.5, n)) + rng.uniform(0, 1000)
        if trial % 7 == 0:
            s = np.round(s)
        pts = np.column_stack([s, t]) if trial % 3 else np.column_stack([t, s])
        axis = 1 if trial % 3 else 0
        ok, ts, xs = kernels_dense.centre_line(np.ascontiguousarray(pts[:, axis]), np.ascontiguousarray(pts[:, 1 - axis]),
                                         (scale - 1) / 2)
        assert ok
        ref = _centre_guess_by_numpy(pts, axis, scale)
        assert np.array_equal(ts, ref[0]) and np.array_equal(xs, ref[1])
        got = centre_guess(pts, axis, scale)
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
    # other positions (not whole or half pixels), or sparse ones: the numpy path
    assert not kernels_dense.centre_line(np.array([0.25, 3.0]), np.zeros(2), 0.0)[0]
    assert not kernels_dense.centre_line(np.array([0.0, 1e6]), np.zeros(2), 0.0)[0]
    ts, xs = centre_guess(np.array([[0.0, 0.25], [2.0, 3.0]]), 1, 1)
    assert np.array_equal(ts, [1.0, 2.0, 3.0])


def test_nearest_per_query_is_lexsorts_pick():
    """Sorted query ids with ties and NaN residuals: the same picks as lexsort at each id's first place."""
    rng = np.random.default_rng(3)
    for trial in range(1000):
        n = int(rng.integers(1, 60))
        q = np.sort(rng.integers(0, max(n // 2, 1), n)).astype(np.int64)
        res = np.round(rng.uniform(0, 3, n), 1)            # (ties)
        if trial % 4 == 0:
            res[rng.random(n) < 0.3] = np.nan
        order = np.lexsort((res, q))
        want = order[np.concatenate([[True], q[order][1:] != q[order][:-1]])]
        assert np.array_equal(kernels_dense.nearest_per_query(q, res), want)


def test_near_junctions_is_the_numpy_test():
    """Samples near pieces' end nodes (junction or not, thresholds per end): the same as the former numpy
    steps (the differences to each end's node, np.hypot, the threshold per piece)."""
    rng = np.random.default_rng(4)
    for _ in range(300):
        n_pieces, n = int(rng.integers(1, 8)), int(rng.integers(1, 200))
        g = np.sort(rng.integers(0, n_pieces, n)).astype(np.int64)
        xc, rows = rng.uniform(0, 100, n), np.round(rng.uniform(0, 100, n))
        junction = rng.random((n_pieces, 2)) < 0.6
        nxy = rng.uniform(0, 100, (n_pieces, 2, 2))
        thr = rng.uniform(1, 40, (n_pieces, 2))
        want = np.zeros(n, bool)
        for k in range(2):
            d = np.column_stack([xc, rows]) - nxy[:, k][g]
            want |= junction[:, k][g] & (np.hypot(d[:, 0], d[:, 1]) < thr[:, k][g])
        assert np.array_equal(kernels_dense.near_junctions(xc, rows, g, junction, nxy, thr), want)


def test_steep_radii_equal_the_numpy_tail_bit_for_bit():
    """kernels_dense.steep_radii against fit_steep_many's former numpy steps (GroupPolys of the centre lines'
    derivatives, the widths across the slope, each curve's median): random curves of degrees 0-3, dead
    curves between live ones, even and odd sample counts; atol 0 px."""
    from appliance.localize import kernels_dense
    from appliance.localize.curves import GroupPolys, Poly
    rng = np.random.default_rng(11)
    for _ in range(200):
        ng = int(rng.integers(1, 9))
        counts = rng.integers(1, 40, ng)
        bc = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        alive = rng.random(ng) < 0.75
        tf = np.concatenate([np.sort(rng.uniform(0, 960, c)) for c in counts])
        wf = rng.uniform(1, 60, bc[-1])
        live = np.flatnonzero(alive).tolist()
        u_polys = [Poly(rng.normal(0, 30, int(rng.integers(1, 5))), float(rng.uniform(0, 960)),
                        float(rng.uniform(1, 400))) for _ in live]
        sel = np.repeat(alive, np.diff(bc))
        slope_u = GroupPolys.of([p.deriv() for p in u_polys])(np.repeat(np.arange(len(live)), np.diff(bc)[live]),
                                                             tf[sel]) if live else np.zeros(0)
        ratio = 0.5 * wf[sel] / np.sqrt(1 + slope_u ** 2)
        starts = np.concatenate([[0], np.cumsum(np.diff(bc)[live])]).tolist()
        want = [float(median(ratio[starts[i]:starts[i + 1]])) for i in range(len(live))]
        ucoef = np.zeros((len(live), 4))
        for i, p in enumerate(u_polys):
            ucoef[i, 4 - len(p.coef):] = p.coef
        got = kernels_dense.steep_radii(tf, wf, bc, np.array(live, np.int64), ucoef,
                                        np.array([p.t0 for p in u_polys], float), np.array([p.ts for p in u_polys], float))
        np.testing.assert_array_equal(got, want)
