"""A fork's pieces next to its junction (kernels_forknear.near_or_nearest) against the steps it replaced in
ForkPlacing.fork (kernels_forkglue.near_piece, then numpy's 15 nearest by np.argsort), bit for bit (atol 0 px)."""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels_forkglue, kernels_forknear

from .test_kernels_forkglue import _near_piece_new as _former   # ForkPlacing.fork's former steps


def _now(pts, p, r):
    """fork's steps now: the kernel, numpy's steps where it leaves the order to numpy's sort."""
    near, dist, u, ok = kernels_forknear.near_or_nearest(pts, float(p[0]), float(p[1]), float(r))
    if not ok:
        near = pts[np.argsort(dist)[:15]]
        v = near.sum(0) / len(near) - p
        u = v / max(np.hypot(*v), 1e-9)
    return near, u, ok


def _grid(rng, n, scale):
    """Skeleton pixels' centres (SkeletonGraph.to_full: half-px multiples)."""
    return np.ascontiguousarray((rng.integers(0, 300, (n, 2)) + 0.5) * scale - 0.5, float)


def test_near_or_nearest_is_the_former_steps_bit_for_bit():
    rng = np.random.default_rng(20)
    n_fallback = n_kernel_fallback = 0
    for trial in range(1500):
        few = trial % 2 == 0            # (a short piece inside the junction's blob: the 15-nearest fallback)
        n = int(rng.integers(1, 40)) if few else int(rng.integers(2, 400))
        if trial % 3 == 0:
            pts = _grid(rng, n, float(rng.choice([1, 2, 3])))
        elif trial % 3 == 1:            # a fitted curve's points
            t = np.linspace(0, rng.uniform(5, 300), n)
            pts = np.column_stack([rng.uniform(0, 600) + rng.normal(0, 30) * np.sin(t / 50), rng.uniform(0, 400) + t])
        else:                           # a short run of pixels along a line from near the junction
            pts = np.cumsum(rng.integers(-1, 2, (n, 2)), 0) + rng.integers(0, 300, 2) + 0.5
        pts = np.ascontiguousarray(pts, float)
        if trial % 4 < 2:
            pts.setflags(write=False)
        p = pts[int(rng.integers(n))] + (np.round(rng.normal(0, 3, 2)) if trial % 5 == 0 else rng.normal(0, 5, 2))
        r = float(rng.uniform(20, 80)) if few else float(rng.uniform(0.5, 20))
        a, ua = _former(pts, p, r)
        b, ub, ok = _now(pts, p, r)
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(ua, ub)
        if len(kernels_forkglue.near_piece(pts, float(p[0]), float(p[1]), float(r))[0]) < 3:
            n_fallback += 1
            n_kernel_fallback += ok
    assert n_fallback > 500 and n_kernel_fallback > 0.3 * n_fallback     # (both paths)
    assert n_kernel_fallback < n_fallback


def test_ties_leave_the_order_to_numpy_where_it_matters():
    p = np.array([100.0, 100.0])
    # a tie at the cut (the 15th and 16th nearest at one distance): numpy's sort picks the points
    ring = np.array([[100.0 + k, 100.0] for k in range(1, 15)] + [[100.0, 115.0], [115.0, 100.0]])
    sel, dist, u, ok = kernels_forknear.near_or_nearest(ring, float(p[0]), float(p[1]), 80.0)
    assert not ok
    # ties inside the 15, even on the half-pixel grid: the points' order (their lines' sums) is numpy's sort's
    grid = np.array([[100.0 + k, 100.0] for k in range(1, 8)] + [[100.0, 100.0 + k] for k in range(1, 8)] + [[90.5, 90.5]])
    assert kernels_forknear.near_or_nearest(grid, float(p[0]), float(p[1]), 80.0)[3] is False
    # no tie: compiled, numpy's points in numpy's order
    line = np.array([[100.0 + k, 100.0 + 0.5 * k] for k in range(1, 25)])[::-1].copy()
    near, u_ref = _former(line, p, 80.0)
    sel, dist, u, ok = kernels_forknear.near_or_nearest(line, float(p[0]), float(p[1]), 80.0)
    assert ok and len(sel) == 15
    np.testing.assert_array_equal(sel, near)
    np.testing.assert_array_equal(u, u_ref)
    # a NaN point: numpy's
    nan = grid.copy()
    nan[3] = np.nan
    assert kernels_forknear.near_or_nearest(nan, float(p[0]), float(p[1]), 80.0)[3] is False


def test_the_ring_keeps_near_piece():
    rng = np.random.default_rng(21)
    for _ in range(200):
        pts = np.ascontiguousarray(rng.uniform(0, 200, (int(rng.integers(3, 200)), 2)))
        p, r = rng.uniform(50, 150, 2), float(rng.uniform(1, 15))
        a, da, ua = kernels_forkglue.near_piece(pts, float(p[0]), float(p[1]), r)
        b, db, ub, ok = kernels_forknear.near_or_nearest(pts, float(p[0]), float(p[1]), r)
        assert ok or len(a) < 3
        np.testing.assert_array_equal(da, db)
        if len(a) >= 3:
            np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(ua, ub)


def _patch_loop_ref(left, right, uv, hh, hw, lo, hi):
    """forkdisp._patch_disparity's former loop (d8a16ad): per patch minMaxLoc, ncc_scores, the parabola."""
    import cv2
    from appliance.localize import kernels_ncc
    h, w = left.shape
    n = len(uv)
    d_out, score = np.full(n, np.nan), np.full(n, -1.0)
    ui = np.rint(uv).astype(int)
    y0, y1 = int(ui[:, 1].min()) - hh, int(ui[:, 1].max()) + hh + 1
    x0, x1 = int(ui[:, 0].min()) - hw, int(ui[:, 0].max()) + hw + 1
    if y0 < 0 or y1 > h or x0 - hi < 0 or x1 - lo > w or x0 < 0 or x1 > w:
        return d_out, score
    lbox = np.asarray(left[y0:y1, x0:x1])
    rbox = np.asarray(right[y0:y1, x0 - hi:x1 - lo])
    for i, (u, v) in enumerate(ui.tolist()):
        tmpl = lbox[v - hh - y0:v + hh + 1 - y0, u - hw - x0:u + hw + 1 - x0]
        lo_v, hi_v = cv2.minMaxLoc(tmpl)[:2]
        if hi_v - lo_v < 2.0:
            continue
        strip = rbox[v - hh - y0:v + hh + 1 - y0, u - hw - x0:u + hw + 1 - x0 + hi - lo]
        cc = kernels_ncc.ncc_scores(np.ascontiguousarray(strip), np.ascontiguousarray(tmpl))
        k = int(cc.argmax())
        off = 0.0
        if 0 < k < len(cc) - 1:
            den = float(cc[k - 1] - 2 * cc[k] + cc[k + 1])
            off = 0.5 * float(cc[k - 1] - cc[k + 1]) / den if den < 0 else 0.0
        d_out[i] = hi - (k + off)
        score[i] = float(cc[k])
    return d_out, score


def test_patch_disparity_is_the_former_loop_bit_for_bit():
    from appliance.localize.forkdisp import _patch_disparity
    rng = np.random.default_rng(22)
    n_found = n_flat = 0
    for trial in range(150):
        h, w = 120, 200
        base = rng.integers(0, 256, (h, w + 40)).astype(float)
        base = cv2_blur(base, int(rng.integers(1, 4)))
        if trial % 5 == 0:                  # flat stretches (no texture: patches skipped)
            base[:, : int(rng.integers(20, 200))] = float(rng.integers(0, 256))
        left = np.clip(base[:, 20:20 + w] + rng.normal(0, 2, (h, w)), 0, 255).astype(np.uint8)
        shift = int(rng.integers(5, 18))
        right = np.clip(base[:, 20 + shift:20 + shift + w] + rng.normal(0, 2, (h, w)), 0, 255).astype(np.uint8) \
            if trial % 3 else np.clip(np.roll(base, shift, 1)[:, 20:20 + w], 0, 255).astype(np.uint8)
        n = int(rng.integers(1, 7))
        uv = np.column_stack([rng.uniform(20, 190, n), rng.uniform(5, 115, n)])
        if trial % 4 == 0:
            uv = np.round(uv) + 0.5            # (halves: rint's ties to even)
        hh, hw = int(rng.integers(1, 8)), int(rng.choice([5, 7, 12]))
        lo = int(rng.integers(0, 12))
        hi = lo + int(rng.integers(0, 12))
        a = _patch_loop_ref(left, right, uv, hh, hw, lo, hi)
        b = _patch_disparity(left, right, uv, hh, hw, lo, hi)
        np.testing.assert_array_equal(a[0], b[0])           # (atol 0 px)
        np.testing.assert_array_equal(a[1], b[1])
        n_found += int(np.isfinite(a[0]).sum())
        n_flat += int((~np.isfinite(a[0])).sum())
    assert n_found > 100 and n_flat > 10


def cv2_blur(img, k):
    """A box blur of ``k`` px (1: none)."""
    import cv2
    return img if k <= 1 else cv2.blur(img, (k, k))


def test_depth_fraction_is_patch_depth_fraction_bit_for_bit():
    from appliance.localize.texture import patch_depth_fraction
    rng = np.random.default_rng(23)
    radii = np.concatenate([rng.uniform(0.5, 60, 2000), np.arange(1, 40) * 0.5, [1e-12, 0.0]])
    for r in radii:
        r = float(r)
        for hh in {max(1, int(0.6 * r)), int(rng.integers(1, 80))}:      # (the callers' half height; up to 161 rows)
            assert kernels_forknear.depth_fraction(r, hh) == float(patch_depth_fraction(r, hh)), (r, hh)   # atol 0
