"""Polynomial curves along branch pieces (localize/curves.py) against numpy's reference routines."""

from __future__ import annotations

import numpy as np
import pytest
from appliance.localize.curves import (
    BranchCurve,
    GroupPolys,
    Poly,
    Spliced,
    _solve,
    angle_deg,
    angle_deg_groups,
    end_slopes,
    end_slopes_groups,
    median,
    percentile,
    robust_fit,
    robust_fit_groups,
)


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_fit_is_the_least_squares_polynomial(degree):
    rng = np.random.default_rng(degree)
    t = np.sort(rng.uniform(100, 900, 60))
    y = 3.0 + 0.02 * t - 1e-5 * t ** 2 + rng.normal(0, 0.3, len(t))
    p = Poly.fit(t, y, degree)
    x = (t - p.t0) / p.ts
    ref = np.linalg.lstsq(np.vander(x, degree + 1), y, rcond=None)[0]
    np.testing.assert_allclose(p.coef, ref, rtol=1e-10, atol=1e-10)
    assert p.t0 == pytest.approx(t.mean()) and p.ts == pytest.approx(np.abs(t - t.mean()).max())
    np.testing.assert_allclose(p(t), np.polyval(ref, x), rtol=1e-10, atol=1e-10)


def test_fit_lowers_the_degree_to_the_distinct_samples():
    t = np.array([5.0, 5.0, 9.0, 9.0, 5.0])          # two distinct values: a line at most
    y = np.array([1.0, 3.0, 6.0, 8.0, 2.0])
    p = Poly.fit(t, y, 3)
    assert len(p.coef) == 2
    np.testing.assert_allclose(p(np.array([5.0, 9.0])), [2.0, 7.0])
    assert len(Poly.fit(np.array([4.0]), np.array([2.5]), 2).coef) == 1
    assert Poly.fit(np.array([4.0]), np.array([2.5]), 2)(10.0) == pytest.approx(2.5)
    assert Poly.fit(np.array([3.0, 1.0, 2.0]), np.array([3.0, 1.0, 2.0]), 2)(7.0) == pytest.approx(7.0)


def test_call_and_derivative_match_polyval():
    p = Poly(np.array([0.5, -2.0, 1.0, 4.0]), t0=10.0, ts=4.0)
    t = np.linspace(-5, 30, 17)
    x = (t - 10.0) / 4.0
    np.testing.assert_allclose(p(t), np.polyval(p.coef, x), rtol=1e-14)
    np.testing.assert_allclose(p.deriv()(t), np.polyval(np.polyder(p.coef), x) / 4.0, rtol=1e-14)
    assert p.deriv() is p.deriv()                       # cached
    assert Poly.constant(2.0)(np.zeros((2, 3))).shape == (2, 3)
    assert Poly.constant(2.0).deriv()(1.0) == 0.0


def reference_robust_keep(t, y, degree, rounds=3, k_mad=3.5):
    """robust_fit's rule written with np.polyfit and np.median."""
    keep = np.ones(len(t), bool)
    coef = np.polyfit(t, y, degree)
    for _ in range(rounds):
        res = y - np.polyval(coef, t)
        mad = 1.4826 * np.median(np.abs(res[keep] - np.median(res[keep]))) + 1e-3
        new = np.abs(res) <= k_mad * mad + 0.05
        if new.sum() <= degree + 1 or (new == keep).all():
            break
        keep = new
        coef = np.polyfit(t[keep], y[keep], degree)
    return keep


def test_robust_fit_rejects_outliers_and_matches_the_median_rule():
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 120.0)
    y = 40.0 + 0.25 * t + rng.normal(0, 0.2, len(t))
    y[[10, 50, 90]] += np.array([15.0, -20.0, 9.0])   # outliers
    poly, keep = robust_fit(t, y, 1)
    assert not keep[[10, 50, 90]].any() and keep.sum() >= 110
    np.testing.assert_allclose(poly.coef[0] / poly.ts, 0.25, atol=0.01)
    ref_keep = reference_robust_keep(t, y, 1)
    np.testing.assert_array_equal(keep, ref_keep)
    for n in (4, 5):                                   # even and odd sample counts
        p, _ = robust_fit(t[:n], y[:n], 0, rounds=1)
        assert p(0.0) == pytest.approx(y[:n].mean())


def test_curve_extrapolates_along_the_end_slopes():
    s_poly = Poly.fit(np.array([0.0, 50.0, 100.0]), np.array([10.0, 20.0, 30.0]), 1)
    d_poly = Poly.fit(np.array([0.0, 100.0]), np.array([40.0, 50.0]), 1)
    c = BranchCurve(0, True, (0.0, 100.0), s_poly, d_poly, 3.0, 3, d_end_slopes=(0.5, -1.0))
    np.testing.assert_allclose(c.s_at([-10.0, 50.0, 110.0]), [8.0, 20.0, 32.0])
    np.testing.assert_allclose(c.d_at([-10.0, 50.0, 110.0]), [35.0, 45.0, 40.0])
    np.testing.assert_allclose(c.uv_at([50.0]), [[20.0, 50.0]])
    assert c.uvd(step_px=25.0).shape == (5, 3)
    assert np.isnan(c.s_at([np.nan])).all()


def test_end_slopes_are_line_fits_near_each_end():
    t = np.arange(0.0, 200.0)
    y = np.where(t < 100, 2.0 * t, 200.0 - 0.5 * (t - 100))
    a, b = end_slopes(t, y, reach=60.0)
    assert a == pytest.approx(2.0) and b == pytest.approx(-0.5)


def test_one_point_gives_bit_for_bit_the_value_of_many():
    rng = np.random.default_rng(11)
    for degree in (0, 1, 2, 3):
        p = Poly(rng.normal(0, 5, degree + 1), t0=float(rng.uniform(0, 500)), ts=float(rng.uniform(1, 300)))
        t = rng.uniform(-200, 900, 50)
        many = p(t)
        assert [p(t[i:i + 1])[0] for i in range(len(t))] == many.tolist()
        assert [p.at(float(x)) for x in t] == many.tolist()
        c = BranchCurve(0, True, (100.0, 600.0), p, p, 2.0, 10, d_end_slopes=(0.3, -0.7))
        for f in (c.s_at, c.d_at):
            assert [f(t[i:i + 1])[0] for i in range(len(t))] == f(t).tolist()
            assert [f(float(x))[0] for x in t] == f(t).tolist()


def test_median_is_numpys_bit_for_bit():
    rng = np.random.default_rng(5)
    for n in range(1, 40):
        a = rng.normal(0, 10, n)
        assert median(a) == np.median(a)
        a_copy = a.copy()
        median(a)
        np.testing.assert_array_equal(a, a_copy)          # input untouched
    assert np.isnan(median(np.zeros(0)))


def test_robust_fit_of_groups_is_robust_fit_of_each_group():
    """Several pieces at once: the same inliers, degrees and values as fitting each alone
    (an empty group and repeated parameters included)."""
    rng = np.random.default_rng(3)
    ts, ys, degrees = [], [], [3, 0, 2, 1, 2]
    for k, degree in enumerate(degrees):
        t = np.sort(rng.choice(np.arange(1000.0), 40 + 30 * k, replace=False))
        if k == 3:
            t = np.r_[t, t[:10]]                          # repeated rows (edge samples)
        y = 5.0 + 0.01 * t + 2e-5 * t ** 2 + rng.normal(0, 0.3, len(t))
        y[:: 9] += 12.0                                   # outliers
        ts.append(t), ys.append(y)
    ts.insert(2, np.zeros(0)), ys.insert(2, np.zeros(0)), degrees.insert(2, 1)
    g = np.repeat(np.arange(len(ts)), [len(t) for t in ts])
    polys, keep = robust_fit_groups(np.concatenate(ts), np.concatenate(ys), g, len(ts), np.array(degrees))
    for k, (t, y, degree) in enumerate(zip(ts, ys, degrees)):
        if not len(t):
            continue
        p, kk = robust_fit(t, y, degree)
        np.testing.assert_array_equal(keep[g == k], kk)
        assert len(polys.poly(k).coef) == len(p.coef)
        np.testing.assert_allclose(polys(g[g == k], t), p(t), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(polys.deriv()(g[g == k], t), p.deriv()(t), rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(GroupPolys.of([polys.poly(k)])(np.zeros(len(t), int), t), polys.poly(k)(t))


def test_spliced_keeps_its_base_inside_and_its_parts_outside():
    base, below, above = Poly(np.array([2.0, 1.0])), Poly(np.array([5.0])), Poly(np.array([-1.0, 50.0]))
    s = Spliced(base, 0.0, 10.0, below, above)
    t = np.array([-3.0, 0.0, 4.0, 10.0, 12.0])
    want = np.array([5.0, 1.0, 9.0, 21.0, 38.0])
    assert np.allclose(s(t), want)
    assert all(s.at(float(x)) == pytest.approx(w) for x, w in zip(t, want))
    assert np.allclose(s.deriv()(t), [0.0, 2.0, 2.0, 2.0, -1.0])
    assert np.allclose(Spliced(base, 0.0, 10.0)(t), base(t))          # no parts: the base everywhere


def test_uvd_samples_are_the_curve_evaluated_along_its_span():
    rng = np.random.default_rng(11)
    for by_row in (True, False):
        t = np.sort(rng.uniform(0, 300, 40))
        s = Poly.fit(t, 0.001 * (t - 150) ** 2 + rng.normal(0, 0.3, 40), 2)
        spliced = Spliced(s, 50.0, 250.0, Poly.fit(t, 0.5 * t, 1), None)
        for s_poly in (s, spliced):
            c = BranchCurve(0, by_row, (float(t[3]), float(t[-2])), s_poly, Poly.fit(t, 200 - 0.1 * t, 1), 4.0, 40,
                            (0.2, -0.3))
            for step in (0.7, 4.0, 1000.0):
                lo, hi = c.t_range
                tt = np.linspace(lo, hi, max(2, int(np.ceil((hi - lo) / step)) + 1))
                assert np.array_equal(c.uvd(step), np.column_stack([c.uv_at(tt), c.d_at(tt)]))


def test_one_parameter_evaluates_alike_whatever_its_form():
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 200, 30))
    c = BranchCurve(0, True, (float(t[2]), float(t[-3])), Poly.fit(t, 0.002 * t ** 2, 2), Poly.fit(t, 150 - 0.2 * t, 1),
                    3.0, 30, (0.1, -0.4))
    for x in (-20.0, 0.0, float(t[2]), 77.7, float(t[-3]), 260.5):
        forms = (x, np.float64(x), np.array([x]), np.array(x), [x], np.array([x], np.float32))
        for f in ("uv_at", "s_at", "d_at"):
            for v in forms:
                want = getattr(c, f)(np.r_[np.asarray(v, float).ravel(), 0.0])[:1]     # the array path
                got = getattr(c, f)(v)
                assert got.shape == want.shape and np.array_equal(got, want), (f, v)


def test_evaluation_beyond_one_end_is_the_clipped_formula():
    rng = np.random.default_rng(8)
    t = np.sort(rng.uniform(0, 300, 40))
    base = Poly.fit(t, 0.001 * (t - 150) ** 3 / 50 + rng.normal(0, 0.2, 40), 3)
    for s_poly in (base, Spliced(base, 60.0, 240.0, Poly.fit(t, 0.3 * t, 1), Poly.fit(t, -0.2 * t, 2))):
        c = BranchCurve(0, False, (50.0, 250.0), s_poly, Poly.fit(t, 120 + 0.05 * t, 1), 3.0, 40, (0.25, -0.75))
        lo, hi = c.t_range
        for tt in (hi + np.arange(0, 30, 0.25), lo - np.arange(0.25, 30, 0.25), lo - np.arange(0, 30, 0.25),
                   np.r_[lo - 3.0, 100.0, hi + 2.0]):
            tc = np.minimum(np.maximum(tt, lo), hi)
            for poly, slopes in ((c.s_poly, (c.s_poly.deriv().at(lo), c.s_poly.deriv().at(hi))),
                                 (c.d_poly, c.d_end_slopes)):
                want = poly(tc) + np.where(tt < lo, slopes[0], slopes[1]) * (tt - tc)
                got = c.s_at(tt) if poly is c.s_poly else c.d_at(tt)
                assert np.array_equal(got, want)


def test_group_angles_and_end_slopes_are_the_per_group_ones():
    rng = np.random.default_rng(7)
    sizes = [2, 5, 40, 130, 9, 300]
    pts = [rng.integers(0, 240, (n, 2)) * 4 + 1.5 for n in sizes]
    g = np.repeat(np.arange(len(sizes)), sizes)
    np.testing.assert_allclose(angle_deg_groups(np.concatenate(pts), g, len(sizes)),
                               [angle_deg(p) for p in pts], rtol=0, atol=1e-9)
    ts = [np.sort(rng.uniform(0, 50 * n, n)) for n in sizes]
    ys = [0.3 * t + rng.normal(0, 1, len(t)) + 0.001 * t ** 2 for t in ts]
    got = end_slopes_groups(np.concatenate(ts), np.concatenate(ys), g, len(sizes) + 1)
    np.testing.assert_allclose(got[:-1], [end_slopes(t, y) for t, y in zip(ts, ys)], rtol=1e-9, atol=1e-12)
    assert (got[-1] == 0).all()                           # a group without samples


def test_percentile_and_solve_are_numpys_bit_for_bit():
    rng = np.random.default_rng(3)
    for n in [1, 2, 3, 4, 7, 10, 61, 200]:
        a = np.round(rng.normal(0, 30, n) * 4) / 4 if n % 2 else rng.normal(0, 30, n)
        for q in (25, 50, 75):
            assert percentile(a, q) == np.percentile(a, q)
    a = rng.normal(size=(5, 4, 4))
    a = a @ a.transpose(0, 2, 1) + np.eye(4)
    b = rng.normal(size=(5, 4, 1))
    assert np.array_equal(_solve(a, b), np.linalg.solve(a, b))
    assert np.array_equal(_solve(a[0], b[0, :, 0]), np.linalg.solve(a[0], b[0, :, 0]))
    with pytest.raises(np.linalg.LinAlgError), pytest.warns(RuntimeWarning):   # (the gufunc warns first)
        _solve(np.zeros((3, 3)), np.ones(3))
