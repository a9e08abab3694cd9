"""The forks' kernels of the seventh numba pass (localize/kernels_forks.py, speedK) against the numpy
code they replace."""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels_forks
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
