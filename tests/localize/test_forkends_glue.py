"""The tenth pass's fork glue (speedF, localize/forkends.py) against the code it replaces: a curve's
parameter at one point as a Python float (``_t_at``, the curves' one-point path) and the cached piece
table of hidden forks (``ForkPlacing._curve_table``'s cheaper cache key). Both bit for bit."""

from __future__ import annotations

import numpy as np
from appliance.localize import forkends
from appliance.localize.curves import BranchCurve, Poly


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


def _table_reference(curves: dict):
    """``_curve_table`` as it was (cache key ``tuple(curves.items())``)."""
    key = tuple(curves.items())
    cv = [c for _, c in key]
    n = len(cv)
    coef, dcoef = np.zeros((n, 4)), np.zeros((n, 4))
    n_coef, n_dcoef = np.zeros(n, np.int64), np.zeros(n, np.int64)
    poly, t0, ts = np.zeros(n, bool), np.zeros(n), np.ones(n)
    for j, c in enumerate(cv):
        p = c.s_poly
        if type(p) is Poly and len(p.coef) <= 4:
            poly[j] = True
            n_coef[j], n_dcoef[j] = len(p.coef), len(p._deriv.coef)
            coef[j, :n_coef[j]], dcoef[j, :n_dcoef[j]] = p.coef, p._deriv.coef
            t0[j], ts[j] = p.t0, p.ts
    table = (np.array([c.by_row for c in cv], bool), np.array([c.t_range[0] for c in cv], float),
             np.array([c.t_range[1] for c in cv], float), np.array([c.radius_px for c in cv], float),
             poly, coef, n_coef, dcoef, n_dcoef, t0, ts)
    return {s: j for j, (s, _) in enumerate(key)}, key, table


def _check(fp, curves):
    row, pieces, table = fp._curve_table()
    row_ref, pieces_ref, table_ref = _table_reference(curves)
    assert row == row_ref and pieces == pieces_ref
    assert all(isinstance(p, tuple) and p[1] is curves[p[0]] for p in pieces)
    for a, b in zip(table, table_ref, strict=True):
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
