"""kernels_endreads against the numpy code it replaces (thirteenth pass, speedmatch2): the same values, atol 0."""

import math

import numpy as np

from appliance.localize import kernels_endreads, tips


def _shares_reference(left_mask, right_mask, uv_edge, out, d_px, r):
    """tips.right_flanks_filled's numpy reads as they were (main d7e2c88): the two shares."""
    h = int(math.ceil(2.5 * r))
    ys, xs = np.mgrid[-h:h + 1, -h:h + 1]
    along = xs * out[0] + ys * out[1]
    across = np.abs(ys * out[0] - xs * out[1])
    sel = (along >= -r) & (along <= 0.5) & (across > 1.3 * r) & (across <= 2.3 * r)
    yy = np.rint(uv_edge[1]).astype(int) + ys[sel]
    share = []
    for mask, x0 in ((left_mask, uv_edge[0]), (right_mask, uv_edge[0] - d_px)):
        xx = int(np.rint(x0)) + xs[sel]
        inside = (yy >= 0) & (yy < mask.shape[0]) & (xx >= 0) & (xx < mask.shape[1])
        share.append(np.count_nonzero(mask[yy[inside], xx[inside]] >= 128) / max(len(yy), 1))
    return share


def _masks(rng, h=120, w=160):
    """Two random blob masks (uint8, 0/255 with some grey values around 128)."""
    out = []
    for _ in range(2):
        m = (rng.random((h // 8, w // 8)) < 0.5).repeat(8, 0).repeat(8, 1).astype(np.uint8) * 255
        m[rng.random((h, w)) < 0.05] = rng.integers(120, 136)
        out.append(m)
    return out


def test_flank_shares_random_and_constructed():
    rng = np.random.default_rng(5)
    left, right = _masks(rng)
    cases = []
    for _ in range(400):                                   # random ends, some near or beyond the border
        ang = rng.uniform(0, 2 * np.pi)
        cases.append((np.array([rng.uniform(-10, 170), rng.uniform(-10, 130)]), np.array([np.cos(ang), np.sin(ang)]),
                      rng.uniform(-5, 60), rng.uniform(0.3, 12)))
    for out in ((1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (-1.0, 0.0), (math.sqrt(0.5), math.sqrt(0.5))):
        for uv in ((80.5, 60.5), (81.5, 59.5), (0.0, 0.0), (159.0, 119.0)):   # half pixels: rint's half to even
            cases.append((np.array(uv), np.array(out), 12.5, 4.0))
    for uv, out, d, r in cases:
        ref = _shares_reference(left, right, uv, out, d, r)
        got = kernels_endreads.flank_shares(left, right, float(uv[0]), float(uv[1]), float(out[0]), float(out[1]),
                                          float(d), float(r))
        np.testing.assert_allclose(got, ref, atol=0, rtol=0)
        assert tips.right_flanks_filled(left, right, uv, out, d, r) == (ref[1] - ref[0] > tips.FLANK_SHARE)


def test_flank_shares_filled_right_view():
    """A right view with mask beside the cap only: filled; the same mask in both views: not."""
    left = np.zeros((60, 80), np.uint8)
    left[:, 36:44] = 255                                   # a vertical branch, its end at row 30 (out: down)
    left[31:, :] = 0
    right = left.copy()
    uv, out, r = np.array([40.0, 30.0]), np.array([0.0, 1.0]), 4.0
    assert not tips.right_flanks_filled(left, right, uv, out, 0.0, r)
    right[20:40, 20:60] = 255                              # something beside the cap in the right view
    assert tips.right_flanks_filled(left, right, uv, out, 0.0, r)
    np.testing.assert_allclose(kernels_endreads.flank_shares(left, right, 40.0, 30.0, 0.0, 1.0, 0.0, r),
                               _shares_reference(left, right, uv, out, 0.0, r), atol=0, rtol=0)


def _donor_model_reference(c, rows, reach_px):
    """single_edge._donor_model as it was (main d7e2c88)."""
    from appliance.localize.curves import linspace
    lo, hi = c.t_range
    if rows.max() < lo:
        end, t = lo, linspace(lo, min(hi, lo + reach_px), 8)
    elif rows.min() > hi:
        end, t = hi, linspace(max(lo, hi - reach_px), hi, 8)
    else:
        return None
    if min(abs(rows.max() - end), abs(rows.min() - end)) > reach_px:
        return None
    y = np.stack([c.s_at(t), c.d_at(t)])
    y0 = y.mean(1)
    if t[-1] - t[0] < 5:
        return np.full(len(rows), y0[0]), np.full(len(rows), y0[1]), end
    dt = t - t.mean()
    slope = (y @ dt) / float(dt @ dt)
    out = y0[:, None] + slope[:, None] * (rows - t.mean())
    return out[0], out[1], end


def test_donor_model_same_values():
    """single_edge._donor_model (Python-float means, thirteenth pass) against the numpy steps it replaces:
    random steep curves (lines, quadratics; spans short and long; ends with and without slopes), rows
    on either side, near and beyond the reach; atol 0 px."""
    from appliance.localize import single_edge
    from appliance.localize.curves import BranchCurve, Poly
    rng = np.random.default_rng(11)
    n_models = 0
    for _ in range(600):
        lo = rng.uniform(0, 800)
        hi = lo + rng.choice([rng.uniform(0, 6), rng.uniform(6, 300)])
        deg = int(rng.integers(0, 3))
        s_poly = Poly(rng.normal(0, [30.0, 80.0, 600.0][-deg - 1:]) + np.r_[np.zeros(deg), 640.0],
                      float(0.5 * (lo + hi)), max(0.5 * (hi - lo), 1.0))
        d_poly = Poly(rng.normal(0, [0.5, 3.0, 40.0][-deg - 1:]), float(0.5 * (lo + hi)), max(0.5 * (hi - lo), 1.0))
        slopes = None if rng.random() < 0.5 else (float(rng.normal(0, 0.1)), float(rng.normal(0, 0.1)))
        c = BranchCurve(1, True, (lo, hi), s_poly, d_poly, float(rng.uniform(2, 12)), 50, slopes)
        side = rng.choice([-1, 1])
        r0 = (hi + rng.uniform(0.5, 160)) if side > 0 else (lo - rng.uniform(0.5, 160) - 60)
        rows = np.arange(np.floor(r0), np.floor(r0) + rng.integers(8, 60), dtype=float)
        if rng.random() < 0.1:
            rows = np.linspace(lo - 5, hi + 5, 20)         # overlapping the span: None
        reach = float(rng.choice([120.0, 40.0]))
        ref, got = _donor_model_reference(c, rows, reach), single_edge._donor_model(c, rows, reach)
        assert (ref is None) == (got is None)
        if ref is not None:
            n_models += 1
            np.testing.assert_allclose(got[0], ref[0], atol=0, rtol=0)
            np.testing.assert_allclose(got[1], ref[1], atol=0, rtol=0)
            assert got[2] == ref[2]
    assert n_models > 150


def _end_half_reference(c, end, runs_l, n_rows=30):
    """single_edge._end_half as it was (main d7e2c88)."""
    from appliance.localize.curves import median
    lo, hi = c.t_range
    t = np.arange(end, min(hi, end + n_rows) + 1.0) if end == lo else np.arange(max(lo, end - n_rows), end + 1.0)
    u = c.s_at(t)
    i = runs_l.find(t.astype(int), u)
    w = np.where(i >= 0, runs_l.span_px[np.maximum(i, 0)], np.nan)
    ref = 2 * c.radius_px * np.sqrt(1 + (float(u[-1] - u[0]) / max(float(t[-1] - t[0]), 1.0)) ** 2)
    ok = np.abs(w - ref) <= 0.5 * ref
    return 0.5 * (float(median(w[ok])) if ok.sum() >= 5 else ref)


def test_end_half_same_values():
    """single_edge._end_half (kernels_endreads.end_half_width) against the numpy steps it replaces: a soft
    mask of bands of varying width (so medians of odd and even counts, too few crossings, rows off the
    mask), curves at either end; atol 0 px."""
    from appliance.localize import single_edge
    from appliance.localize.curves import BranchCurve, Poly
    from appliance.localize.edges import find_runs
    rng = np.random.default_rng(3)
    h, w = 200, 240
    mask = np.zeros((h, w), np.uint8)
    for _ in range(6):                                     # slanted bands, widths changing along them
        x0, slope, width = rng.uniform(20, 220), rng.uniform(-0.6, 0.6), rng.uniform(3, 20)
        for y in range(h):
            xc, ww = x0 + slope * y, width + 3 * np.sin(y / 7.0)
            a, b = int(max(xc - ww / 2, 0)), int(min(xc + ww / 2, w))
            mask[y, a:b] = 255
            if 0 < a < w:
                mask[y, a - 1] = rng.integers(1, 255)      # soft edges
    mask[rng.random((h, w)) < 0.02] = 0                    # holes: runs cut short
    runs = find_runs(mask, soft=True)
    n_same = 0
    for _ in range(300):
        lo = float(rng.integers(0, 150))
        hi = lo + float(rng.choice([rng.integers(0, 10), rng.integers(10, 60)]))
        s_poly = Poly(np.array([rng.uniform(-0.6, 0.6) * 25, rng.uniform(20, 220)]), 0.5 * (lo + hi), 25.0)
        c = BranchCurve(1, True, (lo, hi), s_poly, Poly(np.array([20.0])), float(rng.uniform(1.5, 10)), 40)
        for end in (lo, hi):
            ref, got = _end_half_reference(c, end, runs), single_edge._end_half(c, end, runs)
            assert got == ref
            n_same += 1
    assert n_same == 600
