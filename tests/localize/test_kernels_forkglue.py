"""kernels_forkglue (speedfork): each kernel against the numpy / Python steps it replaces, bit for bit."""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels, kernels_forkglue, kernels_forks
from appliance.localize.curves import BranchCurve, Poly


def _near_piece_ref(pts, p, r):
    """ForkPlacing.fork's former steps: EndPlacer._near_points, then the direction from the junction."""
    sel, dist = kernels.near_points(pts, float(p[0]), float(p[1]), float(1.6 * r), float(1.6 * r + max(40.0, 4 * r)))
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
        checked_few += len(kernels.near_points(pts, float(p[0]), float(p[1]), 1.6 * r, 1.6 * r + max(40.0, 4 * r))[0]) < 3
    assert checked_few > 20 and checked_many > 100          # both paths exercised


def test_tls_line_pair_is_tls_line_of_the_concatenation():
    rng = np.random.default_rng(6)
    for _ in range(500):
        a = rng.normal(0, rng.uniform(0.1, 50), (int(rng.integers(1, 60)), 2)) + rng.uniform(0, 800, 2)
        b = rng.normal(0, rng.uniform(0.1, 50), (int(rng.integers(1, 60)), 2)) + rng.uniform(0, 800, 2)
        if rng.integers(2):
            a.setflags(write=False)
        c0, e0 = kernels_forks.tls_line(np.concatenate([a, b]))
        c1, e1 = kernels_forkglue.tls_line_pair(a, b)
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


def test_warm_up_compiles_the_localizer_s_signatures():
    """The fork and tip glue pass the signatures warm_up compiles: localizing a fixture adds none."""
    from pathlib import Path

    from appliance.commands.common import effective_config
    from appliance.commands.localize import load_inputs
    from appliance.localize import Localizer
    kernels_forkglue.warm_up()
    ks = (kernels_forkglue.near_piece, kernels_forkglue.tls_line_pair, kernels_forkglue.edge_frame)
    before = [len(k.signatures) for k in ks]
    root = Path(__file__).resolve().parents[2]
    cal, (left, right), _ = load_inputs(root / "fixtures/rig.yaml", root / "fixtures/scenes/left_03.png",
                                        root / "fixtures/scenes/right_03.png", None, None)
    Localizer(cal, effective_config(None).localize, "improved").localize(left, right)
    assert [len(k.signatures) for k in ks] == before
    assert all(n >= 1 for n in before)
