"""The fork and tip glue (kernels_forkglue; forkends' and tipends' one-point paths and the hidden forks' piece
table): each kernel and step against the numpy / Python steps it replaced, bit for bit, and the piece table's cache."""

from __future__ import annotations

import numpy as np
from appliance.localize import forkends, kernels_forkglue, kernels_forks, kernels_walks
from appliance.localize.curves import BranchCurve, Poly


def _near_piece_ref(pts, p, r):
    """ForkPlacing.fork's former steps: EndPlacer._near_points, then the direction from the junction."""
    sel, dist = kernels_walks.near_points(pts, float(p[0]), float(p[1]), float(1.6 * r), float(1.6 * r + max(40.0, 4 * r)))
    near = sel if len(sel) >= 3 else pts[np.argsort(dist)[:15]]
    v = near.sum(0) / len(near) - p
    return near, v / max(np.hypot(*v), 1e-9)


def _near_piece_new(pts, p, r):
    """ForkPlacing.fork's steps now (kernels_forkglue.near_piece, the 15 nearest in numpy)."""
    near, dist, u = kernels_forkglue.near_piece(pts, float(p[0]), float(p[1]), float(r))
    if len(near) < 3:
        near = pts[np.argsort(dist)[:15]]
        v = near.sum(0) / len(near) - p
        u = v / max(np.hypot(*v), 1e-9)
    return near, u


def test_near_piece_is_the_former_steps_bit_for_bit():
    rng = np.random.default_rng(5)
    checked_few = checked_many = 0
    for trial in range(600):
        n = int(rng.integers(2, 400))
        if trial % 3 == 0:          # skeleton pixels on the grid (distances tie), as SkeletonGraph.to_full gives
            pts = (rng.integers(0, 300, (n, 2)) + 0.5) * float(rng.choice([1, 2])) - 0.5
        else:                        # a fitted curve's points
            t = np.linspace(0, rng.uniform(5, 300), n)
            pts = np.column_stack([rng.uniform(0, 600) + rng.normal(0, 30) * np.sin(t / 50), rng.uniform(0, 400) + t])
        pts = np.ascontiguousarray(pts, float)
        if trial % 2:
            pts.setflags(write=False)
        p = pts[int(rng.integers(n))] + rng.normal(0, 5, 2)
        r = float(rng.uniform(0.5, 20))
        a, ua = _near_piece_ref(pts, p, r)
        b, ub = _near_piece_new(pts, p, r)
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(ua, ub)          # (atol 0: the same sums, the same hypot)
        checked_many += len(a) >= 3 and len(a) != min(len(pts), 15)
        checked_few += len(kernels_walks.near_points(pts, float(p[0]), float(p[1]), 1.6 * r, 1.6 * r + max(40.0, 4 * r))[0]) < 3
    assert checked_few > 20 and checked_many > 100          # both paths exercised


def test_tls_line_pair_is_tls_line_of_the_concatenation():
    rng = np.random.default_rng(6)
    for _ in range(500):
        a = rng.normal(0, rng.uniform(0.1, 50), (int(rng.integers(1, 60)), 2)) + rng.uniform(0, 800, 2)
        b = rng.normal(0, rng.uniform(0.1, 50), (int(rng.integers(1, 60)), 2)) + rng.uniform(0, 800, 2)
        if rng.integers(2):
            a.setflags(write=False)
        c0, e0 = kernels_forks.tls_line(np.concatenate([a, b]))
        c1, e1 = kernels_forks.tls_line_pair(a, b)
        np.testing.assert_array_equal(c0, c1)
        np.testing.assert_array_equal(e0, e1)


def _edge_frame_ref(c, t_edge, sign):
    """TipPlacing._tip_place's former steps: the edge point and the outward direction on the curve."""
    uv_edge = c.uv_at(t_edge)[0]
    step = c.uv_at(t_edge + sign)[0] - uv_edge
    speed = max(float(np.hypot(*step)), 1e-9)
    return uv_edge, step / speed, speed


def test_edge_frame_is_uv_at_bit_for_bit():
    rng = np.random.default_rng(7)
    for trial in range(1500):
        lo = float(rng.uniform(0, 900))
        hi = lo + float(rng.choice([0.0, rng.uniform(0.5, 300)]))
        deg = int(rng.integers(0, 4))
        p = Poly(rng.normal(0, 10, deg + 1) + np.r_[np.zeros(deg), rng.uniform(0, 900)], float(rng.uniform(0, 900)),
                 float(rng.uniform(1, 150)))
        c = BranchCurve(0, bool(trial % 2), (lo, hi), p, Poly.constant(30.0), 3.0, 10)
        # the walk's edge inside the span, at its ends and carried past them (the tip beyond the fit)
        t_edge = float(rng.choice([lo, hi, rng.uniform(lo, hi + 1e-9), lo - rng.uniform(0, 60), hi + rng.uniform(0, 60)]))
        sign = float(rng.choice([-1.0, 1.0]))
        uv0, out0, sp0 = _edge_frame_ref(c, t_edge, sign)
        uv1, out1, sp1 = kernels_forkglue.edge_frame(p.coef, p._deriv.coef, p.t0, p.ts, lo, hi, c.by_row, t_edge, sign)
        np.testing.assert_array_equal(uv0, uv1)       # (atol 0 px)
        np.testing.assert_array_equal(out0, out1)
        assert sp0 == sp1


def _random_poly_curve(rng, by_row):
    lo = float(rng.uniform(0, 900))
    hi = lo + float(rng.choice([0.0, rng.uniform(0.5, 300)]))
    deg = int(rng.integers(0, 4))
    p = Poly(rng.normal(0, 10, deg + 1) + np.r_[np.zeros(deg), rng.uniform(0, 900)], float(rng.uniform(0, 900)),
             float(rng.uniform(1, 150)))
    return BranchCurve(0, by_row, (lo, hi), p, Poly.constant(30.0), float(rng.uniform(1, 10)), 10)


def test_walk_uv_is_uv_at_of_the_walk_bit_for_bit():
    rng = np.random.default_rng(8)
    for trial in range(800):
        c = _random_poly_curve(rng, bool(trial % 2))
        lo, hi = c.t_range
        t_edge = float(rng.choice([lo, hi, rng.uniform(lo, hi + 1e-9), lo - rng.uniform(0, 60), hi + rng.uniform(0, 60)]))
        sign = float(rng.choice([-1.0, 1.0]))
        reach = float(rng.choice([80.0, rng.uniform(2, 120)]))
        ref = c.uv_at(t_edge + sign * np.arange(0.0, reach, 1.0))
        p = c.s_poly
        got = kernels_forkglue.walk_uv(p.coef, p._deriv.coef, p.t0, p.ts, lo, hi, c.by_row, t_edge, sign,
                                       int(np.ceil(reach)))
        np.testing.assert_array_equal(ref, got)          # (atol 0 px)


def _curve_table_ref(curves):
    """ForkPlacing._curve_table's former table: zeroed arrays filled row by row."""
    cv = tuple(curves.values())
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
    return (np.array([c.by_row for c in cv], bool), np.array([c.t_range[0] for c in cv], float),
            np.array([c.t_range[1] for c in cv], float), np.array([c.radius_px for c in cv], float),
            poly, coef, n_coef, dcoef, n_dcoef, t0, ts)


def test_curve_table_is_the_former_table():
    from types import SimpleNamespace

    from appliance.localize.curves import Spliced
    from appliance.localize.forkends import ForkPlacing
    rng = np.random.default_rng(9)
    for trial in range(60):
        curves = {}
        for k in range(int(rng.integers(1, 25))):
            c = _random_poly_curve(rng, bool(rng.integers(2)))
            kind = rng.integers(6)
            if kind == 0:                # spliced past an occluder: not a plain Poly
                lo, hi = c.t_range
                c = BranchCurve(0, c.by_row, c.t_range, Spliced(c.s_poly, lo + 1, hi - 1, Poly(np.array([0.5, 90.0]))),
                                c.d_poly, c.radius_px, 10)
            elif kind == 1:              # degree 4: more coefficients than the table holds
                c = BranchCurve(0, c.by_row, c.t_range, Poly(rng.normal(0, 1, 5), 10.0, 50.0), c.d_poly, c.radius_px, 10)
            curves[int(rng.integers(0, 1000)) * 10 + k] = c
        placer = SimpleNamespace(curves=curves)
        row, pieces, table = ForkPlacing._curve_table(placer)
        ref = _curve_table_ref(curves)
        assert len(table) == len(ref)
        for a, b in zip(table, ref):
            assert a.dtype == b.dtype and a.shape == b.shape
            np.testing.assert_array_equal(a, b)
        assert row == {s: j for j, s in enumerate(curves)}
        assert [s for s, _ in pieces] == list(curves) and all(c is curves[s] for s, c in pieces)


def _place_on_cap_ref(self, node, uv_edge, out, r, edge_bias_px, shape, offset_px):
    """TipPlacing._place_on_cap's former steps (numpy 2-vectors)."""
    from appliance.localize.tips import CAP_WIDTH_BACK, VIEW_EDGE_PX, cap_centre
    centre = None if edge_bias_px is None else cap_centre(shape, offset_px, r)
    if centre is None:
        return
    back, across, rho = centre
    normal = np.array([-out[1], out[0]])
    uv = uv_edge - out * (edge_bias_px + back) + normal * across
    p = uv_edge - out * (CAP_WIDTH_BACK * r)
    sides = p + np.outer([shape[0][0] + offset_px, offset_px - shape[0][0]], normal)
    h, w = self.sm.left_mask.shape
    if not ((sides >= 0).all() and (sides[:, 0] <= w - 1).all() and (sides[:, 1] <= h - 1).all()):
        return
    margin = VIEW_EDGE_PX + self.g.scale
    old = self.uvd[node]
    if min(uv[0], uv[1], w - 1 - uv[0], h - 1 - uv[1]) < margin <= min(old[0], old[1], w - 1 - old[0], h - 1 - old[1]):
        return
    self.uvd[node][:2] = uv
    self.radius[node] = rho


def test_place_on_cap_is_the_former_steps_bit_for_bit():
    from types import SimpleNamespace

    from appliance.localize.tipends import TipPlacing
    from appliance.localize.tips import CAP_RADIUS_RANGE, MAX_CAP_BACK, MIN_CAP_BACK
    rng = np.random.default_rng(10)
    h, w = 120, 160
    moved = kept = 0
    for trial in range(1500):
        r = float(rng.uniform(1.0, 12.0))
        rho = r * float(rng.uniform(CAP_RADIUS_RANGE[0] * 0.9, CAP_RADIUS_RANGE[1] * 1.1))
        backs = tuple(float(v) for v in rng.uniform(MIN_CAP_BACK - 0.1, MAX_CAP_BACK + 0.1, 2))
        shape = [(rho, *backs), None if rng.integers(4) == 0 else (r * float(rng.uniform(0.5, 1.5)), 0.5, 0.5)]
        offset = float(rng.choice([rng.normal(0, r), np.nan])) if rng.integers(10) else np.nan
        a = float(rng.uniform(0, 2 * np.pi))
        out = np.array([np.cos(a), np.sin(a)])
        uv_edge = rng.uniform(-5, [w + 5, h + 5])
        bias = None if rng.integers(8) == 0 else float(rng.uniform(0, 1.5))
        start = np.array([*rng.uniform(0, [w, h]), 30.0])
        placers = []
        for f in (_place_on_cap_ref, TipPlacing._place_on_cap):
            st = SimpleNamespace(sm=SimpleNamespace(left_mask=np.zeros((h, w), np.uint8)), g=SimpleNamespace(scale=2),
                                 uvd={7: start.copy()}, radius={7: r})
            f(st, 7, uv_edge, out, r, bias, shape, offset)
            placers.append(st)
        a_st, b_st = placers
        np.testing.assert_array_equal(a_st.uvd[7], b_st.uvd[7])        # (atol 0 px)
        assert a_st.radius[7] == b_st.radius[7]
        moved += not np.array_equal(a_st.uvd[7], start)
        kept += np.array_equal(a_st.uvd[7], start)
    assert moved > 100 and kept > 100                # both outcomes exercised


def _beyond_ref(self, uv_edge, out, d):
    """TipPlacing._beyond_in_right_view's former steps (numpy's rint of a 2-vector)."""
    u, v = np.rint(uv_edge + out - np.array([d, 0.0])).astype(int)
    h, w = self.sm.right_mask.shape
    if not 0 <= u < w:
        return False
    valid = self.sm.valid_right
    if valid is None:
        return True
    row = valid[min(max(v, 0), h - 1)]
    return bool(row[u]) or not row.any()


def test_beyond_in_right_view_is_the_former_steps():
    from types import SimpleNamespace

    from appliance.localize.tipends import TipPlacing
    rng = np.random.default_rng(11)
    h, w = 60, 90
    valid = rng.random((h, w)) < 0.7
    valid[5] = False                     # a row without any valid pixel
    seen = set()
    for trial in range(4000):
        uv_edge = rng.uniform(-10, [w + 10, h + 10])
        if trial % 4 == 0:               # halves: np.rint's and round()'s ties to even
            uv_edge = np.floor(uv_edge) + 0.5
        a = float(rng.uniform(0, 2 * np.pi))
        out = np.array([np.cos(a), np.sin(a)]) if trial % 4 else np.array([0.0, 0.0])
        d = float(rng.choice([rng.uniform(-5, 40), np.nan])) if trial % 50 else float(rng.integers(-3, 30))
        if trial % 97 == 0:
            uv_edge = np.array([uv_edge[0], np.nan])
        st = SimpleNamespace(sm=SimpleNamespace(right_mask=np.zeros((h, w), np.uint8),
                                                valid_right=None if trial % 5 == 0 else valid))
        with np.errstate(invalid="ignore"):
            ref = _beyond_ref(st, uv_edge, out, d)
        assert TipPlacing._beyond_in_right_view(st, uv_edge, out, d) == ref
        seen.add(ref)
    assert seen == {True, False}


def _curve(rng, segment: int = 0) -> BranchCurve:
    """A random piece: steep or flat, degree 0-3, carried past its span along its end slopes or not."""
    lo = float(rng.uniform(0, 300))
    hi = lo + float(rng.uniform(0, 150))
    deg = int(rng.integers(0, 4))
    s_poly = Poly(rng.normal(0, 10, deg + 1) + np.r_[np.zeros(deg), rng.uniform(0, 300)],
                  float(rng.uniform(0, 300)), float(rng.uniform(1, 80)))
    d_poly = Poly(rng.normal(0, 2, 3) + np.r_[0.0, 0.0, rng.uniform(20, 250)], float(rng.uniform(0, 300)),
                  float(rng.uniform(1, 80)))
    slopes = None if rng.random() < 0.5 else (float(rng.normal(0, 0.2)), float(rng.normal(0, 0.2)))
    return BranchCurve(segment, bool(rng.integers(2)), (lo, hi), s_poly, d_poly, float(rng.uniform(1, 10)), 10,
                       slopes)


def test_t_at_is_t_of_bit_for_bit():
    """At points inside, at the ends of and far beyond the span (steep and flat pieces, with and without
    end slopes): ``d_at`` and ``uv_at`` of ``_t_at`` equal those of ``t_of``'s one-element array exactly
    (atol 0 px), and ``_t_at`` is a Python float."""
    rng = np.random.default_rng(18)
    for _ in range(300):
        c = _curve(rng)
        lo, hi = c.t_range
        for t in (lo, hi, float(rng.uniform(lo, hi)), lo - float(rng.uniform(0, 90)), hi + float(rng.uniform(0, 90))):
            xy = c.uv_at(t)[0] + rng.normal(0, 3, 2) * np.r_[not c.by_row, c.by_row]   # (off the line across it)
            t_new = forkends._t_at(c, xy)
            assert type(t_new) is float and t_new == c.t_of(xy)[0]
            np.testing.assert_array_equal(c.d_at(t_new), c.d_at(c.t_of(xy)), strict=True)
            np.testing.assert_array_equal(c.uv_at(t_new), c.uv_at(c.t_of(xy)), strict=True)
            np.testing.assert_array_equal(c.s_at(t_new), c.s_at(c.t_of(xy)), strict=True)


def _check(fp, curves):
    row, pieces, table = fp._curve_table()
    assert row == {s: j for j, s in enumerate(curves)}
    assert [s for s, _ in pieces] == list(curves) and all(isinstance(p, tuple) and p[1] is curves[p[0]] for p in pieces)
    for a, b in zip(table, _curve_table_ref(curves), strict=True):
        np.testing.assert_array_equal(a, b, strict=True)


def test_curve_table_cache_follows_the_curves():
    """The piece table equals the former one, is reused while the curves stay (the same objects), and is
    made again when a curve is added, replaced under its key (a refit) or removed."""
    rng = np.random.default_rng(5)
    fp = object.__new__(forkends.ForkPlacing)
    fp.curves = {}
    _check(fp, fp.curves)                               # (no pieces)
    fp.curves = {int(s): _curve(rng, int(s)) for s in rng.choice(200, 12, replace=False)}
    _check(fp, fp.curves)
    first = fp._curve_table()
    assert fp._curve_table() is first                   # (cached)
    s = next(iter(fp.curves))
    fp.curves[s] = _curve(rng, s)                       # (replaced: the same keys, a new curve)
    assert fp._curve_table() is not first
    _check(fp, fp.curves)
    fp.curves[1000] = _curve(rng, 1000)
    _check(fp, fp.curves)
    del fp.curves[s]
    _check(fp, fp.curves)
    assert len(fp._curve_table()[1]) == len(fp.curves)
