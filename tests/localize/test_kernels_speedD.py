"""The dense path's kernels of the seventh numba pass (localize/kernels_dense.py) against the numpy code
they replace (kept here as the reference)."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize import kernels_dense, single_edge
from appliance.localize.curves import median, robust_fit
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
