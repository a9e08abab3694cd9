"""The forks' kernels of the seventh numba pass (localize/kernels_forks.py, speedK) against the numpy
code they replace."""

from __future__ import annotations

import numpy as np

from appliance.localize import kernels_forks, kernels_walks
from appliance.localize.curves import BranchCurve, Poly, Spliced, linspace


def _crossings_numpy(uv, r_min, skip, curves):
    """ends.EndPlacer.hidden_fork's former loop over the pieces (each piece's first crossing, or -1)."""
    lo_u, lo_v = (uv.min(0) - 2).tolist()
    hi_u, hi_v = (uv.max(0) + 2).tolist()
    out = []
    for j, c2 in enumerate(curves):
        out.append(-1)
        if j == skip or c2.radius_px < r_min:
            continue
        lo, hi = c2.t_range
        lo_t, hi_t = (lo_v, hi_v) if c2.by_row else (lo_u, hi_u)
        if min(lo, hi) > hi_t or max(lo, hi) < lo_t:
            continue
        box = c2.uv_at(linspace(*c2.t_range, 8))
        u0, v0, u1, v1 = (*box.min(0).tolist(), *box.max(0).tolist())
        if u0 > hi_u or v0 > hi_v or u1 < lo_u or v1 < lo_v:
            continue
        ta, tb = (uv[:, 1], uv[:, 0]) if c2.by_row else (uv[:, 0], uv[:, 1])
        inside = (ta >= lo - 2) & (ta <= hi + 2)
        if inside.sum() < 2:
            continue
        f = tb - c2.s_at(ta)
        cross = np.flatnonzero(inside[:-1] & inside[1:] & (np.sign(f[:-1]) != np.sign(f[1:])))
        if len(cross):
            out[-1] = int(cross[0])
    return np.array(out)


def _table(curves):
    """hidden_crossings' piece arrays (as EndPlacer._curve_table)."""
    n = len(curves)
    coef, dcoef = np.zeros((n, 4)), np.zeros((n, 4))
    n_coef, n_dcoef = np.zeros(n, np.int64), np.zeros(n, np.int64)
    poly, t0, ts = np.zeros(n, bool), np.zeros(n), np.ones(n)
    for j, c in enumerate(curves):
        p = c.s_poly
        if type(p) is Poly:
            poly[j] = True
            n_coef[j], n_dcoef[j] = len(p.coef), len(p._deriv.coef)
            coef[j, :n_coef[j]], dcoef[j, :n_dcoef[j]] = p.coef, p._deriv.coef
            t0[j], ts[j] = p.t0, p.ts
    return (np.array([c.by_row for c in curves]), np.array([c.t_range[0] for c in curves], float),
            np.array([c.t_range[1] for c in curves], float), np.array([c.radius_px for c in curves], float),
            poly, coef, n_coef, dcoef, n_dcoef, t0, ts)


def _random_curve(rng, spliced=False):
    lo = float(rng.uniform(0, 200))
    hi = lo + float(rng.choice([0.0, rng.uniform(1, 150)]))
    deg = int(rng.integers(0, 4))
    p = Poly(rng.normal(0, 10, deg + 1) + np.r_[np.zeros(deg), rng.uniform(0, 200)], float(rng.uniform(0, 200)),
             float(rng.uniform(1, 80)))
    s_poly = Spliced(p, lo + 5, hi - 5, Poly(np.array([0.5, 90.0]))) if spliced else p
    return BranchCurve(0, bool(rng.integers(2)), (lo, hi), s_poly, Poly.constant(30.0), float(rng.uniform(1, 10)), 10)


def test_hidden_crossings_is_the_numpy_loop():
    """Random walks (straight, through the pieces' region; one with a NaN) against random pieces (steep and
    flat, degrees 0-3, zero-length spans, thin ones, a skipped one): the same first crossing per piece,
    and -2 exactly where a spliced piece passes the span check (its box and crossing then in numpy)."""
    rng = np.random.default_rng(5)
    n_found = 0
    for trial in range(400):
        curves = [_random_curve(rng, spliced=rng.random() < 0.1) for _ in range(int(rng.integers(1, 12)))]
        a, b = rng.uniform(-20, 250, 2), rng.uniform(-20, 250, 2)
        if trial % 2:                           # (through a point of one of the pieces)
            c = curves[int(rng.integers(len(curves)))]
            p = c.uv_at(float(rng.uniform(*c.t_range)))[0]
            e = rng.normal(size=2)
            a = p - rng.uniform(5, 70) * e / np.hypot(*e)
            b = a + 80 * e / np.hypot(*e)
        uv = a + np.linspace(0, 1, 80)[:, None] * (b - a)
        if trial == 7:
            uv[40, 0] = np.nan
        r_min, skip = float(rng.uniform(0, 8)), int(rng.integers(-1, len(curves)))
        want = _crossings_numpy(uv, r_min, skip, curves)
        got = kernels_forks.hidden_crossings(uv, r_min, skip, *_table(curves))
        plain = np.array([type(c.s_poly) is Poly for c in curves])
        assert np.array_equal(got[plain], want[plain])
        assert set(got[~plain].tolist()) <= {-1, -2}
        n_found += int((want[plain] >= 0).sum())
    assert n_found > 100


def _line_numpy(pts):
    """forkends._line's former numpy steps."""
    c = pts.sum(0) / len(pts)
    q = pts - c
    sxx, syy, sxy = float(np.dot(q[:, 0], q[:, 0])), float(np.dot(q[:, 1], q[:, 1])), float(np.dot(q[:, 0], q[:, 1]))
    a = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    return c, np.array([np.cos(a), np.sin(a)])


def test_tls_line_is_numpys_line_up_to_rounding():
    """Random point sets (2-300 points, lines with scatter, collinear, isotropic blobs, coordinates up to
    1300 px): the centroid within 1e-9 px and the direction within 1e-12 (both ways round being one
    line only when the spread is isotropic: those are left out of the direction check)."""
    rng = np.random.default_rng(7)
    for trial in range(1000):
        n = int(rng.integers(2, 300))
        a = rng.uniform(0, np.pi)
        t = rng.uniform(-80, 80, n)
        pts = rng.uniform(0, 1300, 2) + t[:, None] * np.array([np.cos(a), np.sin(a)])
        pts += rng.normal(0, [0.0, 0.5, 3.0][trial % 3], (n, 2))
        if trial % 7 == 0:
            pts = np.round(pts)                     # (skeleton pixels)
        c, e = kernels_forks.tls_line(pts)
        c0, e0 = _line_numpy(pts)
        np.testing.assert_allclose(c, c0, rtol=0, atol=1e-9)
        q = pts - c0
        sxx, syy, sxy = q[:, 0] @ q[:, 0], q[:, 1] @ q[:, 1], q[:, 0] @ q[:, 1]
        if np.hypot(sxx - syy, 2 * sxy) > 1e-6 * (sxx + syy):
            np.testing.assert_allclose(e, e0, rtol=0, atol=1e-12)


def _parent_axis_numpy(mask, xy, e1, out, r_behind, r_ahead, r_child):
    """forkplace.parent_axis' former numpy steps around its cross-section scans."""
    from appliance.localize import forkplace as fp
    from appliance.localize.curves import median
    e = e1 if float(np.dot(e1, out)) >= 0.0 else -e1
    n = np.array([-e[1], e[0]])
    cos_a = float(np.dot(e, out))
    sin_a = abs(float(e[0] * out[1] - e[1] * out[0]))
    if sin_a < 0.2:
        return None
    r = min(r_behind, r_ahead)
    step = max(fp.SECTION_STEP_R * r, fp.SECTION_STEP_MIN_PX)
    k = step * np.arange(fp.SECTIONS)
    s = np.concatenate([-(max(0.0, (r_child - r * cos_a) / sin_a) + 0.5 * r + 3.0 + k),
                        (r * cos_a + r_child) / sin_a + 0.5 * r + 3.0 + k])
    half = int(np.ceil(2.5 * r + 4.0))
    f = kernels_forks._sections_k(mask, np.asarray(xy, float), e, n, s, float(r), half, fp.MIDDLE_MAX_R)
    ok = (f[:, 0] > 0) & (np.abs(f[:, 2] - 2.0 * r) <= fp.WIDTH_TOL * 2.0 * r + fp.WIDTH_TOL_PX) \
        & (np.abs(f[:, 1]) <= fp.MIDDLE_MAX_R * r + 1.0)
    f, s = f[ok], s[ok]
    if len(f):
        w = float(median(f[:, 2]))
        keep = np.abs(f[:, 2] - w) <= fp.SAME_WIDTH * w + fp.SAME_WIDTH_PX
        f, s = f[keep], s[keep]
    mids = xy + s[:, None] * e + f[:, 1:2] * n
    if len(mids) < 3:
        return None
    c, ea = _line_numpy(mids)
    res = np.abs((mids - c) @ np.array([-ea[1], ea[0]]))
    if (res > fp.MIDDLE_OFF_PX).any() and (res <= fp.MIDDLE_OFF_PX).sum() >= 3:
        c, ea = _line_numpy(mids[res <= fp.MIDDLE_OFF_PX])
    return (c, ea) if abs(ea[0] * e[1] - ea[1] * e[0]) <= fp.MAX_TURN_SIN else None


def test_parent_axis_kernel_is_the_numpy_steps_up_to_rounding():
    """Forks on random soft and binary Y masks (parent and child radii, angles, the fork placed a few px
    and degrees off, radii read too large or small, flipped directions, masks with leaves cut out): the
    same None / axis as the numpy steps, the centroid within 1e-9 px and the direction within 1e-12."""
    import cv2

    from appliance.localize.forkplace import parent_axis
    rng = np.random.default_rng(11)
    n_axis = n_none = 0
    for trial in range(200):
        r_par, r_child = rng.uniform(3, 30), rng.uniform(2, 15)
        f = rng.uniform(120, 280, 2)
        a_par = rng.uniform(0, np.pi)
        e_par = np.array([np.cos(a_par), np.sin(a_par)])
        a_ch = a_par + rng.choice([-1, 1]) * rng.uniform(np.radians(8), np.radians(80))
        e_ch = np.array([np.cos(a_ch), np.sin(a_ch)])
        ss = 4
        big = np.zeros((400 * ss, 400 * ss), np.uint8)
        px = lambda p: (int(round((p[0] + 0.5) * ss - 0.5)), int(round((p[1] + 0.5) * ss - 0.5)))
        cv2.line(big, px(f - 300 * e_par), px(f + 300 * e_par), 255, max(1, int(round(2 * r_par * ss))))
        cv2.line(big, px(f), px(f + 200 * e_ch), 255, max(1, int(round(2 * r_child * ss))))
        if trial % 4 == 1:                         # a leaf over the parent
            cv2.circle(big, px(f - rng.uniform(10, 60) * e_par), int(rng.uniform(5, 20) * ss), 0, -1)
        mask = cv2.resize(big, (400, 400), interpolation=cv2.INTER_AREA)
        if trial % 2:
            mask = ((mask >= 128) * 255).astype(np.uint8)
        turn = rng.normal(0, np.radians(3))
        e1 = np.cos(turn) * e_par + np.sin(turn) * np.array([-e_par[1], e_par[0]])
        e1 = e1 if trial % 3 else -e1
        xy = f + rng.normal(0, 2, 2)
        r_b, r_a = r_par * rng.uniform(0.7, 1.4), r_par * rng.uniform(0.7, 1.4)
        want = _parent_axis_numpy(mask, xy, e1, e_ch, r_b, r_a, r_child)
        got = parent_axis(mask, xy, e1, e_ch, r_b, r_a, r_child)
        assert (got is None) == (want is None)
        if want is None:
            n_none += 1
            continue
        n_axis += 1
        np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(got[1], want[1], rtol=0, atol=1e-12)
    assert n_axis > 40 and n_none > 15


def _child_outline_numpy(c1, e1, c2, e2, p0, r_par, r_child, mask):
    """ends.EndPlacer._fork_from_child_outline's former numpy steps around kernels_walks.child_outline_pairs."""
    n = np.array([-e1[1], e1[0]])
    n = (np.sign(np.dot(c2 - p0, n)) or 1.0) * n
    sin_t = abs(e1[0] * e2[1] - e1[1] * e2[0])
    if sin_t < 0.2:
        return None
    cot = np.dot(e2, e1) / np.dot(e2, n)
    s0 = float(np.dot(c2 - c1, e1) - np.dot(c2 - c1, n) * cot)
    step = max(1.5 * r_child, 6.0)
    pairs = [(r_par + 3.0, r_par + 3.0 + step), (r_par + 3.0 + r_child, r_par + 3.0 + r_child + step)]
    hs = np.array([h for pair in pairs for h in pair])
    reach = (4.7 * r_child + 3) / sin_t + 2
    i, m1, m2 = kernels_walks.child_outline_pairs(np.ascontiguousarray(mask), c1 + hs[:, None] * n, s0 + hs * cot,
                                            np.asarray(e1, float), float(reach), float(r_child), float(sin_t))
    if i < 0:
        return None
    return c1 + (m1 - (m2 - m1) * pairs[i][0] / step) * e1


def test_child_outline_fork_is_the_numpy_steps_up_to_rounding():
    """Random Y masks (soft and binary; the parent's line a few px and degrees off, the child's line
    shifted, children at 8-90 deg, leaves over the child): the same None / fork as the numpy steps
    around the same scans, within 1e-9 px."""
    import cv2

    from appliance.localize.ends import EndPlacer
    rng = np.random.default_rng(3)
    n_found = n_none = 0
    for trial in range(300):
        r_par, r_child = rng.uniform(3, 25), rng.uniform(2, 12)
        f = rng.uniform(120, 280, 2)
        a_par = rng.uniform(0, 2 * np.pi)
        e_par = np.array([np.cos(a_par), np.sin(a_par)])
        a_ch = a_par + rng.choice([-1, 1]) * rng.uniform(np.radians(8), np.radians(90))
        e_ch = np.array([np.cos(a_ch), np.sin(a_ch)])
        mask = np.zeros((400, 400), np.uint8)
        px = lambda p: (int(round(p[0] * 4)), int(round(p[1] * 4)))
        cv2.line(mask, px(f - 300 * e_par), px(f + 300 * e_par), 255, max(1, int(round(2 * r_par))), cv2.LINE_AA, 2)
        cv2.line(mask, px(f), px(f + 200 * e_ch), 255, max(1, int(round(2 * r_child))), cv2.LINE_AA, 2)
        if trial % 4 == 1:
            cv2.circle(mask, px(f + rng.uniform(10, 50) * e_ch), int(rng.uniform(3, 12) * 4), 0, -1, cv2.LINE_AA, 2)
        if trial % 2:
            mask = ((mask >= 128) * 255).astype(np.uint8)
        turn = rng.normal(0, np.radians(3))
        e1 = np.cos(turn) * e_par + np.sin(turn) * np.array([-e_par[1], e_par[0]])
        c1 = f + rng.normal(0, 2, 2) - 40 * e1
        c2 = f + rng.uniform(20, 60) * e_ch + rng.normal(0, 1, 2)
        p0 = c1 + np.dot(f - c1, e1) * e1
        want = _child_outline_numpy(c1, e1, c2, e_ch, p0, r_par, r_child, mask)
        got = EndPlacer._fork_from_child_outline(None, c1, e1, c2, e_ch, p0, r_par, r_child, mask)
        assert (got is None) == (want is None)
        if want is None:
            n_none += 1
            continue
        n_found += 1
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert n_found > 60 and n_none > 20


def _side_near_numpy(c, runs_l, runs_r, t_fork, **kw):
    """forkdisp.side_disparity_near's numpy steps: the plain read, and where its rows stop more than
    ``SIDE_GROWN_SHORT_PX`` short of the fork the read with the crotch's widened rows (when it holds and
    keeps ``SIDE_GROWN_MIN_ROWS`` more rows); None
    for a short span's read without a row past it. (d, rows kept, of them in the gap, gap, nearest, MAD,
    slope) or None."""
    from appliance.localize import forkdisp as fd
    out = _side_near_pass(c, runs_l, runs_r, t_fork, grow=False, **kw)
    if out is not None and out[4] > fd.SIDE_GROWN_SHORT_PX:
        grown = _side_near_pass(c, runs_l, runs_r, t_fork, grow=True, **kw)
        out = grown if grown is not None and grown[1] >= out[1] + fd.SIDE_GROWN_MIN_ROWS else out
    lo, hi = c.t_range
    if out is None or (out[2] == 0 and hi - lo < 2 * kw.get("span_rows", 40)):
        return None
    return out


def _side_near_pass(c, runs_l, runs_r, t_fork, gap_min_px=6.0, span_rows=40, tol_d_px=2.5, width_tol_px=1.2,
                    min_rows=12, max_gap_px=300, grow=False):
    """forkdisp.side_disparity_near's former numpy steps (with its _carried, _robust_line, _line_fit), with
    ``grow`` the rows widened by the child (``SIDE_GROWN_*``): (d, rows kept, of them in the gap, gap,
    nearest, MAD, slope) or None, before the short span's check."""
    import math

    from appliance.localize import forkdisp as fd
    from appliance.localize.curves import median
    if not c.by_row or not math.isfinite(t_fork):
        return None
    lo, hi = c.t_range
    if lo - gap_min_px < t_fork < hi + gap_min_px:
        return None
    end, sg = (lo, 1.0) if t_fork < lo else (hi, -1.0)
    n_gap = int(abs(t_fork - end))
    if n_gap > max_gap_px:
        return None
    rows = np.arange(-n_gap, span_rows + 1, dtype=float)
    rows *= sg
    rows += end
    if rows.min() < 0 or len(rows) < min_rows:
        return None
    slope_d = c.d_poly.deriv().at(end) if c.d_end_slopes is None else c.d_end_slopes[0 if end == lo else 1]
    slope_s = c.s_poly.deriv().at(end)
    dt = rows - end
    w_ratio = math.hypot(1.0, slope_s - slope_d) / math.hypot(1.0, slope_s)
    u, d = c.s_poly.at(end) + slope_s * dt, c.d_poly.at(end) + slope_d * dt
    il = runs_l.find(rows, u)
    i0 = np.maximum(il, 0)
    w_l, c_l, found = runs_l.span_px.take(i0), runs_l.centre_px.take(i0), il >= 0
    ref = found[n_gap:n_gap + 20]
    if not ref.any():
        return None
    w_end = float(median(w_l[n_gap:n_gap + 20][ref]))
    ex = w_l - w_end
    plain = np.abs(ex) <= 0.1 * w_end + 1.5
    grown = ~plain & (ex > 0) & (ex <= fd.SIDE_GROWN_FRAC * w_end + fd.SIDE_GROWN_PX) & grow
    grown &= np.abs(rows - t_fork) <= fd.SIDE_GROWN_MAX_W * w_end
    ok = found & (plain | grown)
    ok &= np.abs(c_l - u) <= 0.15 * w_end + 1.5 + np.where(grown, 0.5 * ex, 0.0)
    k = np.flatnonzero(ok)
    if len(k) < min_rows:
        return None
    c_l, d, w_l = c_l.take(k), d.take(k), w_l.take(k)
    tol_w = np.where(grown.take(k), fd.SIDE_GROWN_TOL_PX, width_tol_px)
    ir = runs_r.find(rows.take(k), c_l - d)
    j0 = np.maximum(ir, 0)
    cd = c_l - runs_r.centre_px.take(j0)
    ok = (ir >= 0) & (np.abs(cd - d) <= tol_d_px)
    ok &= np.abs(runs_r.span_px.take(j0) - w_ratio * w_l) <= tol_w
    k2 = np.flatnonzero(ok)
    if len(k2) < min_rows:
        return None
    k, cd = k.take(k2), cd.take(k2)
    x, y = rows.take(k) - t_fork, cd

    def line_fit(x, y):
        n = len(x)
        sx, sy = float(x.sum()), float(y.sum())
        det = n * float(x @ x) - sx * sx
        if det <= 0:
            return None
        a = (n * float(x @ y) - sx * sy) / det
        return a, (sy - a * sx) / n
    ab = line_fit(x, y)
    if ab is None:
        return None
    res = y - (ab[0] * x + ab[1])
    mad = 1.4826 * float(median(np.abs(res - median(res))))
    keep = np.abs(res) <= 3.5 * (mad + 1e-3) + 0.05
    if int(np.count_nonzero(keep)) < min_rows:
        return None
    if np.count_nonzero(keep) < len(x):
        ab = line_fit(x[keep], y[keep])
        if ab is None:
            return None
    n_gap_k = int(np.count_nonzero(keep & (k < n_gap)))
    return ab[1], int(np.count_nonzero(keep)), n_gap_k, n_gap, float(np.abs(x[keep]).min()), mad, ab[0]


def test_side_near_kernel_is_the_numpy_steps_up_to_rounding():
    """Steep parents (soft masks, the right view moved by a disparity leaning along the rows, a child
    widening rows near the fork, ragged edges, a leaf cutting rows) read at random fork rows either side
    of random spans (some reads with the crotch's widened rows): the same None / values as the numpy steps
    (rows counted alike; disparity and slope within 1e-9 px, the MAD within 1e-9)."""
    from appliance.localize.edges import find_runs
    from appliance.localize.forkdisp import side_disparity_near
    rng = np.random.default_rng(13)
    h, w = 400, 320
    n_found = n_none = n_grown = 0
    for trial in range(60):
        a_u, b_u = rng.uniform(100, 200), rng.uniform(-0.6, 0.6)
        a_d, b_d = rng.uniform(20, 60), rng.uniform(-0.03, 0.03)
        half, fork_row, child = rng.uniform(4, 14), rng.uniform(60, 340), rng.uniform(0, 10)
        v = np.arange(h, dtype=float)[:, None]
        u = np.arange(w, dtype=float)[None, :]
        masks = []
        for view in (0, 1):
            c = a_u + b_u * v - view * (a_d + b_d * v) + rng.normal(0, 0.3 * (trial % 3), (h, 1))
            lo_e = c - half - np.where(np.abs(v - fork_row) <= 15, child, 0.0)
            cov = np.clip(np.minimum(u - lo_e, c + half - u) + 0.5, 0.0, 1.0)
            m = np.rint(255 * cov).astype(np.uint8)
            if trial % 4 == 3:
                r0 = int(rng.uniform(0, h - 20))
                m[r0:r0 + int(rng.uniform(3, 20))] = 0
            masks.append(m)
        runs_l, runs_r = find_runs(masks[0], soft=True), find_runs(masks[1], soft=True)
        for _ in range(8):
            lo = float(rng.integers(0, 300))
            hi = lo + float(rng.integers(10, 200))
            t = np.arange(lo, hi + 1)
            err = rng.normal(0, 0.01)
            cv = BranchCurve(0, True, (lo, min(hi, 399.0)), Poly.fit(t, a_u + b_u * t, 1),
                             Poly.fit(t, a_d + b_d * t + err * (t - t.mean()), 1), half, len(t))
            t_fork = float(rng.uniform(0, 399))
            want = _side_near_numpy(cv, runs_l, runs_r, t_fork)
            got = side_disparity_near(cv, runs_l, runs_r, t_fork)
            assert (got is None) == (want is None)
            if want is None:
                n_none += 1
                continue
            n_grown += want != _side_near_pass(cv, runs_l, runs_r, t_fork)      # (the crotch's rows read)
            n_found += 1
            assert (got.n_rows, got.n_gap_rows, got.gap_px) == want[1:4]
            assert got.nearest_px == want[4]
            np.testing.assert_allclose([got.d_px, got.mad_px, got.slope], [want[0], want[5], want[6]], rtol=0,
                                       atol=1e-9)
    assert n_found > 50 and n_none > 50 and n_grown >= 2


def _runs_agree_numpy(runs_l, runs_r, d_range, pts, d, r, min_rows=3):
    """ends.EndPlacer._runs_agree's former numpy steps."""
    if len(pts) < 2:
        return False
    c, e = _line_numpy(pts)
    sin_t = abs(e[1])
    v = np.arange(np.ceil(pts[:, 1].min()), np.floor(pts[:, 1].max()) + 1)
    if len(v) < min_rows or sin_t < 0.3:
        return False
    rows = v.astype(int)
    il = runs_l.find(rows, c[0] + (v - c[1]) * e[0] / e[1])
    keep = il >= 0
    w_l = runs_l.span_px[np.maximum(il, 0)]
    keep &= w_l <= 2.4 * r / sin_t + 3
    rows, il, w_l = rows[keep], il[keep], w_l[keep]
    if len(rows) < min_rows:
        return False
    c_l = runs_l.centre_px[il]
    dmin, dmax = d_range
    q, rr = runs_r.between(rows, c_l - dmax, c_l - dmin)
    similar = np.abs(runs_r.span_px[rr] - w_l[q]) <= 0.15 * w_l[q] + 1.5
    q, rr = q[similar], rr[similar]
    near_d = np.abs(c_l[q] - runs_r.centre_px[rr] - d) <= max(1.0, 0.006 * abs(d))
    qd = q[near_d]
    n_cand = int(np.count_nonzero(q[1:] != q[:-1])) + 1 if len(q) else 0
    n_ok = int(np.count_nonzero(qd[1:] != qd[:-1])) + 1 if len(qd) else 0
    return n_ok >= min_rows and n_ok >= 0.6 * n_cand


def test_runs_agree_kernel_is_the_numpy_steps():
    """Pieces of random slope and width in both views (the right one moved by a disparity leaning along
    the rows, ragged, some rows cut, a second branch in the right view), asked at points along them
    (2-80 points, near-flat ones too) at disparities near and off theirs: the same answers as numpy."""
    from types import SimpleNamespace

    from appliance.localize.edges import find_runs
    from appliance.localize.ends import EndPlacer
    rng = np.random.default_rng(19)
    h, w = 300, 400
    n_true = n_false = 0
    for trial in range(40):
        a_u, b_u = rng.uniform(120, 280), rng.choice([rng.uniform(-0.8, 0.8), rng.uniform(-4, 4)])
        a_d, b_d = rng.uniform(20, 60), rng.uniform(-0.03, 0.03)
        half = rng.uniform(2, 10)
        v = np.arange(h, dtype=float)[:, None]
        u = np.arange(w, dtype=float)[None, :]
        masks = []
        for view in (0, 1):
            c = a_u + b_u * (v - 150) - view * (a_d + b_d * v) + rng.normal(0, 0.4 * (trial % 3), (h, 1))
            cov = np.clip(np.minimum(u - (c - half), c + half - u) + 0.5, 0.0, 1.0)
            if view and trial % 3 == 2:          # another branch nearby in the right view
                c2 = c + rng.uniform(-30, 30)
                cov = np.maximum(cov, np.clip(np.minimum(u - (c2 - half), c2 + half - u) + 0.5, 0.0, 1.0))
            m = np.rint(255 * cov).astype(np.uint8)
            if trial % 4 == 3:
                m[int(rng.uniform(0, h - 30)):][:int(rng.uniform(3, 30))] = 0
            masks.append(m)
        placer = SimpleNamespace(runs_l=find_runs(masks[0], soft=True), runs_r=find_runs(masks[1], soft=True),
                                 sm=SimpleNamespace(d_range_px=(10.0, 80.0)))
        for _ in range(10):
            n = int(rng.integers(2, 80))
            t = rng.uniform(0, h - 1) + np.sort(rng.uniform(0, rng.uniform(1, 120), n))
            pts = np.column_stack([a_u + b_u * (t - 150), t]) + rng.normal(0, 0.5, (n, 2))
            d = a_d + b_d * float(t.mean()) + rng.choice([0.0, rng.normal(0, 1.5), 10.0])
            r = half * rng.uniform(0.7, 1.3)
            want = _runs_agree_numpy(placer.runs_l, placer.runs_r, (10.0, 80.0), pts, d, r)
            assert EndPlacer._runs_agree(placer, pts, d, r) == want
            n_true += want
            n_false += not want
    assert n_true > 60 and n_false > 60


def test_radius_median_is_radius_ats_median():
    """Random float32 radius maps (scales 1-3) read at random points (on and off the map, on pixel
    boundaries): the same median as radius.radius_at + curves.median, bit for bit."""
    from appliance.localize.curves import median
    from appliance.localize.radius import RadiusMap, radius_at
    rng = np.random.default_rng(23)
    for trial in range(300):
        scale = int(rng.integers(1, 4))
        img = rng.uniform(0, 20, (int(rng.integers(1, 30)), int(rng.integers(1, 30)))).astype(np.float32)
        n = int(rng.integers(0, 40))
        pts = rng.uniform(-5, 35 * scale, (n, 2))
        if trial % 3 == 0:
            pts = np.round(pts * 2) / 2
        want = median(radius_at(RadiusMap(img, scale), pts))
        got = kernels_forks.radius_median(img, scale, pts)
        assert (np.isnan(got) and np.isnan(want)) or got == want


def test_intersect_is_lapacks_up_to_rounding():
    """forkends._intersect (Cramer's rule) against numpy's det and solve: the same None, the point within 1e-9 px."""
    from appliance.localize.forkends import _intersect
    rng = np.random.default_rng(29)
    for _ in range(1000):
        c1, c2 = rng.uniform(0, 1000, 2), rng.uniform(0, 1000, 2)
        a1, a2 = rng.uniform(0, 2 * np.pi, 2)
        if rng.random() < 0.3:
            a2 = a1 + rng.normal(0, 0.05)
        e1, e2 = np.array([np.cos(a1), np.sin(a1)]), np.array([np.cos(a2), np.sin(a2)])
        a = np.column_stack([e1, -e2])
        got = _intersect(c1, e1, c2, e2)
        if abs(np.linalg.det(a)) < 0.05:
            assert got is None
            continue
        want = c1 + np.linalg.solve(a, c2 - c1)[0] * e1
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * max(1.0, np.abs(want).max() / 1000))


def _passes_through_numpy(mask, c_px, e, s_far_px, r_child_px):
    """forkchild.passes_through's former numpy / OpenCV steps."""
    import cv2
    c, e = np.asarray(c_px, float), np.asarray(e, float)
    n = np.array([-e[1], e[0]])
    s = np.arange(s_far_px, s_far_px + 80.0, 1.0)
    line = c - s[:, None] * e
    off = (1.5 * r_child_px + 2.0) * n
    uv = np.vstack([line, line + off, line - off]).astype(np.float32)
    val = cv2.remap(mask, uv.reshape(1, -1, 2), None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                    borderValue=0)[0].reshape(3, -1)
    band = (val[0] >= 128) & (val[1] < 128) & (val[2] < 128)
    need = max(6, int(np.ceil(1.5 * r_child_px)))
    return len(band) >= need and bool((np.convolve(band, np.ones(need, int), "valid") >= need).any())


def test_passes_through_kernel_is_the_remap_steps():
    """Crossing branches, forks and blobs (soft and binary masks; lines running off the image, starting at
    fractional distances, narrow and wide children, leaves cutting the line): the same answer as
    cv2.remap's samples and the convolution."""
    import cv2

    from appliance.localize.forkchild import passes_through
    rng = np.random.default_rng(31)
    n_true = n_false = 0
    for trial in range(400):
        mask = np.zeros((300, 300), np.uint8)
        f = rng.uniform(20, 280, 2)
        a = rng.uniform(0, 2 * np.pi)
        e = np.array([np.cos(a), np.sin(a)])
        r_c = rng.uniform(1.5, 12)
        px = lambda p: (int(round(p[0] * 4)), int(round(p[1] * 4)))
        far = f - rng.uniform(40, 200) * e if trial % 2 else f
        cv2.line(mask, px(far), px(f + 100 * e), 255, max(1, int(round(2 * r_c * rng.uniform(0.7, 1.6)))),
                 cv2.LINE_AA, 2)
        if trial % 5 == 0:
            cv2.circle(mask, px(f - rng.uniform(10, 60) * e), int(rng.uniform(2, 15) * 4), 255, -1, cv2.LINE_AA, 2)
        if trial % 3 == 0:
            mask = ((mask >= 128) * 255).astype(np.uint8)
        s_far = rng.uniform(0, 30)
        want = _passes_through_numpy(mask, f, e, s_far, r_c)
        assert passes_through(mask, f, e, s_far, r_c) == want
        n_true += want
        n_false += not want
    assert n_true > 60 and n_false > 60


def test_side_walks_is_the_numpy_steps_bit_for_bit():
    """Walks out of random curves' ends (steep and flat, degrees 0-3, inside and beyond the span) over
    soft discs: the same normals as _walk_out's numpy steps and the same walk_edges results, bit for bit
    (with the normals made by the kernel and given to it)."""
    import cv2

    from appliance.localize.walks import walk_edges
    rng = np.random.default_rng(37)
    n_cross = 0
    for trial in range(200):
        deg = int(rng.integers(0, 4))
        p = Poly(rng.normal(0, 0.3, deg + 1) + np.r_[np.zeros(deg), rng.uniform(60, 140)], float(rng.uniform(50, 150)),
                 float(rng.uniform(5, 60)))
        lo = float(rng.uniform(40, 120))
        c = BranchCurve(0, bool(trial % 2), (lo, lo + float(rng.uniform(0, 60))), p, Poly.constant(20.0), 5.0, 10)
        start = c.t_range[1] if trial % 3 else c.t_range[0]
        t = start + rng.choice([-1.0, 1.0]) * np.arange(0, rng.uniform(5, 40), 0.25)
        uv = c.uv_at(t)
        mask = np.zeros((200, 200), np.uint8)
        ctr = uv[int(rng.integers(len(uv)))]
        cv2.circle(mask, (int(ctr[0] * 4), int(ctr[1] * 4)), int(rng.uniform(3, 30) * 4), 255, -1, cv2.LINE_AA, 2)
        off = float(rng.uniform(0.5, 6))
        ab = c.uv_at(np.concatenate([t + 0.5, t - 0.5]))
        step = ab[:len(t)] - ab[len(t):]
        step /= np.maximum(np.hypot(step[:, 0], step[:, 1]), 1e-9)[:, None]
        normal = np.column_stack([-step[:, 1], step[:, 0]])
        n = len(t)
        want = walk_edges(mask, np.concatenate([uv + off * normal, uv + -off * normal]), np.array([0, n, 2 * n]))
        for have in (False, True):
            idx, crosses, nrm = kernels_forks.side_walks(mask, t, uv, normal if have else np.zeros((1, 2)), have,
                                                         c.by_row, p.coef, p._deriv.coef, p.t0, p.ts, *c.t_range, off)
            assert np.array_equal(nrm, normal) and np.array_equal(idx, want[0]) and np.array_equal(crosses, want[1])
        n_cross += int(want[1].sum())
    assert n_cross > 60


def _walk_whole_numpy(mask, uv, bounds):
    """ends.EndPlacer._walk_whole's former numpy steps (with its _on_mask)."""
    with np.errstate(invalid="ignore"):             # (a NaN's cast: off the mask either way)
        xy = np.rint(uv).astype(np.intp)
    h, w = mask.shape
    x, y = xy[:, 0], xy[:, 1]
    inside = (x.view(np.uintp) < w) & (y.view(np.uintp) < h)
    on = (mask.reshape(-1).take(y * w + x, mode="clip") >= 128) & inside
    starts, ends = bounds[:-1], bounds[1:]
    off = np.flatnonzero(~on)
    if len(off):
        j = np.searchsorted(off, starts)
        first_off = np.minimum(np.where(j < len(off), off[np.minimum(j, len(off) - 1)], ends), ends)
    else:
        first_off = ends.copy()
    return np.maximum(first_off - 1 - starts, 0)


def test_walk_whole_is_the_numpy_steps():
    """Random walks (in, out of and beyond the image, points on half-pixels, empty walks, a NaN) over
    random masks: the same indices as the numpy steps."""
    rng = np.random.default_rng(41)
    for trial in range(300):
        mask = (rng.random((30, 40)) < rng.uniform(0.3, 1.0)).astype(np.uint8) * int(rng.choice([128, 255]))
        n_w = int(rng.integers(1, 6))
        lens = rng.integers(0, 30, n_w)
        bounds = np.r_[0, np.cumsum(lens)].astype(np.int64)
        a, e = rng.uniform(-5, 45, (bounds[-1], 2)), rng.normal(0, 1, 2)
        uv = a if trial % 2 else rng.uniform(-3, 43, 2) + np.arange(bounds[-1])[:, None] * 0.5 * e
        if trial % 3 == 0:
            uv = np.round(uv * 2) / 2
        if trial == 5 and len(uv):
            uv[0, 0] = np.nan
        assert np.array_equal(kernels_forks.walk_whole(mask, uv, bounds), _walk_whole_numpy(mask, uv, bounds))


def test_curve_points_are_uv_at_linspace():
    """Random curves (steep and flat, degrees 0-3, spans of 0-150 px, 2-151 points; and 12 points from an
    end 12 px in or out): the same points as BranchCurve.uv_at(curves.linspace(a, b, n)), bit for bit."""
    rng = np.random.default_rng(43)
    for trial in range(300):
        c = _random_curve(rng)
        lo, hi = c.t_range
        n = max(2, int(hi - lo) + 1)
        p = c.s_poly
        got = kernels_forks.curve_points(p.coef, p._deriv.coef, p.t0, p.ts, lo, hi, c.by_row, lo, hi, n)
        assert np.array_equal(got, c.uv_at(linspace(lo, hi, n)))
        a = float(rng.choice([lo, hi]))                # (the child's 12 points next to an end: beyond the span too)
        b = a + float(rng.choice([-12.0, 12.0]))
        got = kernels_forks.curve_points(p.coef, p._deriv.coef, p.t0, p.ts, lo, hi, c.by_row, a, b, 12)
        assert np.array_equal(got, c.uv_at(linspace(a, b, 12)))
