"""The match stage's kernels of the ninth numba pass (localize/kernels_match.py, speedM) against the
numpy code they replace (kept here as the reference)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
from appliance.localize import dense, kernels_match, tipends
from appliance.localize.curves import BranchCurve, Poly, Spliced, linspace
from appliance.localize.edges import find_runs


def _oriented_numpy(uvd, start, end):
    """dense._oriented (unchanged; the reference's own)."""
    def dist(a, b):
        return math.hypot(float(a[0]) - float(b[0]), float(a[1]) - float(b[1]))
    if start is not None:
        return uvd[::-1] if dist(uvd[-1], start) < dist(uvd[0], start) else uvd
    if end is not None:
        return uvd[::-1] if dist(uvd[0], end) < dist(uvd[-1], end) else uvd
    return uvd


def _piece_uvd_numpy(c, ends, node_xy, reach_px=60.0):
    """dense._piece_uvd before the kernel (88819ff): BranchCurve.uvd, the orientation, the ends."""
    uvd = _oriented_numpy(c.uvd(), *ends)
    ax = 1 if c.by_row else 0
    ends = [e if e is not None and abs(float(e[2]) - c._at(c.d_poly, float(e[ax]), c.d_end_slopes))
            <= max(2.0, 0.03 * float(e[2])) else None for e in ends]
    parts = [uvd]
    for k, (e, xy) in enumerate(zip(ends, node_xy)):
        if e is None:
            if xy is None:
                continue
            t_n = float(xy[ax])
            t_near = float(uvd[0 if k == 0 else -1, ax])
            if abs(t_n - t_near) < 2:
                continue
            t = linspace(t_near, t_near + min(max(t_n - t_near, -reach_px), reach_px), 6)[1:]
            ext = np.column_stack([c.uv_at(t), c.d_at(t)])
            e = ext[::-1] if k == 0 else ext
        else:
            e = e[None]
        parts.insert(0 if k == 0 else len(parts), e)
    return np.concatenate(parts)


def _poly(rng, lo, hi, scale, base):
    deg = int(rng.integers(0, 4))
    coef = rng.normal(0, scale, deg + 1)
    coef[-1] += base
    return Poly(coef, float(0.5 * (lo + hi) + rng.normal(0, 3)), float(max(0.5 * (hi - lo), 1.0)))


def _curve(rng, by_row=None):
    lo = float(rng.uniform(0, 300))
    hi = lo + float(rng.choice([0.0, 0.5, rng.uniform(1, 250)]))
    s = _poly(rng, lo, hi, 8.0, rng.uniform(50, 600))
    d = _poly(rng, lo, hi, 3.0, rng.uniform(20, 90))
    slopes = None if rng.random() < 0.3 else (float(rng.normal(0, 0.1)), float(rng.normal(0, 0.1)))
    return BranchCurve(int(rng.integers(0, 50)), bool(rng.random() < 0.5) if by_row is None else by_row, (lo, hi),
                       s, d, float(rng.uniform(1, 12)), 20, slopes)


def _end(rng, c, t):
    """A placed end near the curve's parameter ``t``: on its disparity (joined) or off it (carried)."""
    uv = c.uv_at(float(t))[0] + rng.normal(0, 2, 2)
    d = float(c.d_at(float(t))[0]) + float(rng.choice([0.0, rng.normal(0, 0.5), rng.uniform(-15, 15)]))
    return np.array([uv[0], uv[1], d])


def test_piece_uvd_is_the_numpy_steps_bit_for_bit():
    """dense._piece_uvd (the kernel for Poly curves) gives the former numpy code's samples exactly, on
    1000 random curves (degrees 0-3, zero-length spans, own and given end slopes, both directions) with
    ends placed on the curve's disparity or off it, absent, near or far beyond the span (carried at most
    60 px), from either end."""
    rng = np.random.default_rng(7)
    n_joined = n_carried = n_flipped = 0
    for _ in range(1000):
        c = _curve(rng)
        lo, hi = c.t_range
        ends, node_xy = [], []
        for k in range(2):
            t = (lo if k == 0 else hi) + rng.choice([-1, 1]) * float(rng.choice([0.0, 1.0, rng.uniform(0, 120)]))
            if rng.random() < 0.5:                  # the orientation: ends swapped now and then
                t = (hi if k == 0 else lo) + rng.normal(0, 5)
            ends.append(_end(rng, c, t) if rng.random() < 0.6 else None)
            node_xy.append(c.uv_at(float(t))[0] + rng.normal(0, 3, 2) if rng.random() < 0.8 else None)
        want = _piece_uvd_numpy(c, ends, node_xy)
        got = dense._piece_uvd(c, ends, node_xy)
        assert got.shape == want.shape
        np.testing.assert_array_equal(got, want)
        n_flipped += bool(want[0, 1 if c.by_row else 0] > want[-1, 1 if c.by_row else 0])
        n_joined += sum(e is not None and any((want == e).all(1)) for e in ends)
        n_carried += len(want) - len(c.uvd()) - sum(e is not None and any((want == e).all(1)) for e in ends)
    assert n_joined > 130 and n_carried > 330 and n_flipped > 130       # every branch ran


def test_piece_uvd_keeps_numpy_for_spliced_curves():
    """A piece carried past an occluder (curves.Spliced) keeps the numpy path: the same samples."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        c = _curve(rng)
        lo, hi = c.t_range
        sp = Spliced(c.s_poly, lo, hi, below=Poly(np.array([0.2, 300.0]), lo, 1.0))
        c2 = BranchCurve(c.segment, c.by_row, c.t_range, sp, c.d_poly, c.radius_px, 20, c.d_end_slopes)
        assert kernels_match.curve_args(c2) is None
        xy = [c.uv_at(lo - 30.0)[0], None]
        np.testing.assert_array_equal(dense._piece_uvd(c2, [None, None], xy), _piece_uvd_numpy(c2, [None, None], xy))


def _wider_numpy(self, c, t_edge, sign, r):
    """tipends.TipPlacing._wider_on_right before the kernel (88819ff)."""
    rows = np.rint(t_edge + sign * np.arange(1.0, max(2 * r, 4.0))).astype(int)
    rows = rows[(rows >= 0) & (rows < self.sm.right_mask.shape[0])]
    if len(rows) == 0:
        return False
    lo, hi = c.t_range
    ds = c.s_poly.deriv()(np.minimum(np.maximum(rows, lo), hi))
    slope = float(np.hypot(1.0, ds.sum() / len(ds)))
    ir = self.runs_r.find(rows, c.s_at(rows) - c.d_at(rows))
    wide = (ir >= 0) & (self.runs_r.span_px[np.maximum(ir, 0)] > 1.6 * 2 * r * slope + 2)
    return bool(np.count_nonzero(wide) / len(wide) >= 0.8)


def test_wider_on_right_is_the_numpy_test():
    """TipPlacing._wider_on_right (the kernel for Poly curves) decides as the former numpy code on 500
    random steep tips over right masks with a wider blob past the end (or not), ends near the image's
    top and bottom (rows cut), radii below 2 px (the 4-row minimum); both answers occur."""
    rng = np.random.default_rng(11)
    h, w = 240, 320
    answers = []
    for i in range(500):
        c = _curve(rng, by_row=True)
        lo, hi = c.t_range
        if i % 2:                       # a gently inclined centre line (most real tips)
            s = Poly(np.array([*rng.normal(0, 0.05, int(rng.integers(0, 2))), rng.normal(0, 0.3), 160.0]), lo, 50.0)
            c = BranchCurve(c.segment, True, c.t_range, s, c.d_poly, c.radius_px, 20, c.d_end_slopes)
        sign = float(rng.choice([-1.0, 1.0]))
        t_edge = float((hi if sign > 0 else lo) + rng.normal(0, 3))
        if i % 5 == 0:
            t_edge = float(rng.choice([1.0, h - 2.0, -3.0, h + 2.0]))
        r = float(rng.choice([rng.uniform(0.5, 2.0), rng.uniform(2, 14)]))
        # the branch in the right view, and past its end (mostly) something wider
        v = np.arange(h, dtype=float)
        u = (c.s_at(v) - c.d_at(v)) % w
        wider = (sign * (v - t_edge) > 0) & (rng.random(h) < 0.7)
        half = r * np.where(wider, rng.uniform(1.7, 4.0, h), rng.uniform(0.5, 1.2, h))
        cols = np.arange(w)[None, :]
        right = ((cols >= np.maximum((u - half).astype(int), 0)[:, None])
                 & (cols <= (u + half).astype(int)[:, None])).astype(np.uint8) * 255
        runs = find_runs(right, soft=True)
        self = SimpleNamespace(sm=SimpleNamespace(right_mask=right), runs_r=runs)
        want = _wider_numpy(self, c, t_edge, sign, r)
        got = tipends.TipPlacing._wider_on_right(self, c, t_edge, sign, r)
        assert got == want
        answers.append(want)
    assert 30 < sum(answers) < 470


def test_prewalk_right_walks_are_walk_outs(monkeypatch):
    """Walks.prewalk's right-view walks (all ends at once) are _walk_out(right=True)'s walk for walk, on
    fixtures 00 and 02 (both mask sources)."""
    from pathlib import Path

    import cv2
    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer, walks
    from appliance.synth.truth import load_truth

    prewalk = walks.Walks.prewalk
    n_walks, n_edge = [0], [0]

    def checked(self, nodes):
        prewalk(self, nodes)
        for (node, _), hit in list(self._walk_cache.items()):
            if (0.0, True) not in hit[5]:
                continue                    # (a walk made before: hidden_fork's)
            got = hit[5].pop((0.0, True))
            assert self._walk_out(hit[0], node, right=True) == got
            n_walks[0] += 1
            n_edge[0] += got[0] != hit[1][-1] + got[1] * 0.5

    monkeypatch.setattr(walks.Walks, "prewalk", checked)
    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    loc = Localizer(load_calibration(fixtures / "rig.yaml"), load_config().localize)
    for n in ("00", "02"):
        left, right = (cv2.imread(str(fixtures / "scenes" / f"{s}_{n}.png")) for s in ("left", "right"))
        truth = load_truth(fixtures / "scenes" / f"truth_{n}.json")
        for masks in ((None, None), (truth.mask_left, truth.mask_right)):
            loc.localize(left, right, mask_left=masks[0], mask_right=masks[1])
    assert n_walks[0] > 30 and n_edge[0] > 20


def _near_points_numpy(runs, xy_px, reach_px, d_range_px=(0.0, 0.0), cell_px=16):
    """subpixel.near_points before the kernel (88819ff)."""
    xy = np.asarray(xy_px, float).reshape(-1, 2)
    if len(xy) == 0 or len(runs.row) == 0:
        return np.zeros(len(runs.row), bool)
    d = np.broadcast_to(np.asarray(d_range_px, float), (len(xy), 2))
    rows, cols = int(runs.row[-1]) // cell_px + 1, runs.width // cell_px + 1
    box = np.column_stack([xy[:, 1] - reach_px, xy[:, 1] + reach_px,
                           xy[:, 0] - d[:, 1] - reach_px, xy[:, 0] - d[:, 0] + reach_px]) // cell_px
    box[:, [0, 2]] = np.maximum(box[:, [0, 2]], 0)
    grid = np.zeros((rows, cols), bool)
    for y0, y1, x0, x1 in box.astype(np.intp).tolist():
        grid[y0:y1 + 1, x0:x1 + 1] = True
    return grid[runs.row // cell_px, np.minimum((runs.x0 + runs.x1) // (2 * cell_px), cols - 1)]


def test_near_points_is_the_numpy_grid():
    """subpixel.near_points (kernels_match.runs_near) selects the former numpy code's runs on 300 random
    masks and point sets, with boxes beyond every side of the grid (numpy's slices: a last cell below -1
    counts from the grid's end) and per-point disparity ranges."""
    from appliance.localize import subpixel

    rng = np.random.default_rng(5)
    n_sel = 0
    for _ in range(300):
        h, w = int(rng.integers(20, 200)), int(rng.integers(20, 300))
        mask = (rng.random((h, w)) < rng.uniform(0.05, 0.5)).astype(np.uint8) * 255
        runs = find_runs(mask, soft=True)
        n = int(rng.integers(0, 12))
        xy = np.column_stack([rng.uniform(-80, w + 80, n), rng.uniform(-80, h + 80, n)])
        d = rng.uniform(-20, 120, (n, 2)) if rng.random() < 0.5 else (float(rng.uniform(0, 30)), float(rng.uniform(30, 120)))
        reach = float(rng.choice([0.0, 10.0, 48.0]))
        want = _near_points_numpy(runs, xy, reach, d)
        got = subpixel.near_points(runs, xy, reach, d)
        np.testing.assert_array_equal(got, want)
        n_sel += int(want.sum())
    assert n_sel > 1000


def test_joint_is_the_curves_one_point_path():
    """EndPlacer.joint in Python floats places a joint as c.uv_at / c.d_at at c.t_of's parameter did
    (bit for bit), inside the span and beyond it (own and given end slopes), both directions."""
    from appliance.localize.ends import EndPlacer

    rng = np.random.default_rng(9)
    for _ in range(300):
        c = _curve(rng)
        lo, hi = c.t_range
        t = float(rng.uniform(lo - 50, hi + 50))
        xy = c.uv_at(t)[0] + rng.normal(0, 2, 2)
        self = SimpleNamespace(incident=[[3]], curves={3: c}, node_xy=np.array([xy]), uvd={}, radius={})
        EndPlacer.joint(self, 0)
        tt = c.t_of(xy)
        want = np.array([*c.uv_at(tt)[0], c.d_at(tt)[0]])
        np.testing.assert_array_equal(self.uvd[0], want)
        assert self.radius[0] == c.radius_px


def _flat_line_numpy(g, rm, runs_lt, s):
    """dense._flat_search before the kernel (88819ff) up to its reads: (v_poly, radius, lo, hi, u, uv, half_h,
    coarse, (y0, y1, u0, u1)) or None."""
    from appliance.localize import kernels_dense
    from appliance.localize.graph import JUNCTION
    from appliance.localize.radius import radius_at
    from appliance.localize.single_edge import centre_guess

    pts = g.to_full(g.seg_yx[s])
    cols, yc = centre_guess(pts, 0, g.scale)
    nodes = g.seg_nodes[s]
    junction = (nodes >= 0) & (g.node_kind[np.maximum(nodes, 0)] == JUNCTION)
    nxy = g.to_full(g.node_yx[np.maximum(nodes, 0)]).astype(float)
    thr = 1.6 * radius_at(rm, nxy) + g.scale + 1
    ok, coef, t0, ts, degree, radius, lo, hi = kernels_dense.flat_line(
        np.ascontiguousarray(cols, float), np.ascontiguousarray(yc, float), junction, nxy, thr,
        runs_lt._find_tables, runs_lt.centre_px, runs_lt.span_px, runs_lt.width)
    if not ok:
        return None
    v_poly = Poly(coef[3 - degree:].copy(), t0, ts)
    u = np.arange(lo, hi + 1, 6.0)
    uv = np.column_stack([u, v_poly(u)])
    half_h = np.full(len(u), max(1, int(0.6 * radius)))
    coarse = np.unique(linspace(0, len(u) - 1, min(6, -(-len(u) // 3))).round().astype(int))
    ui = np.rint(uv).astype(int)
    hh = int(half_h[0])
    box = (int(ui[:, 1].min()) - hh, int(ui[:, 1].max()) + hh + 1, int(ui[:, 0].min()), int(ui[:, 0].max()))
    return v_poly, radius, lo, hi, u, uv, half_h, coarse, box


def test_flat_search_line_is_the_numpy_steps_bit_for_bit():
    """kernels_match.flat_search_line gives _flat_search's former numpy steps exactly (the centre line, the
    patches' columns by np.arange's values, their centres, the coarse patches, the boxes) on 250 random
    flat bands (slopes, bends, radii 1.5-20 px, junctions at either end, skeleton scales 1-4, short pieces
    with one patch), and the caller's None where no line is found."""
    from appliance.localize.graph import ENDPOINT, JUNCTION
    from appliance.localize.radius import RadiusMap

    rng = np.random.default_rng(13)
    h, w = 240, 400
    n_found = n_none = 0
    for _ in range(250):
        scale = int(rng.integers(1, 5))
        r = float(rng.uniform(1.5, 20))
        x0 = float(rng.uniform(-20, 150))
        x1 = x0 + float(rng.choice([rng.uniform(4, 20), rng.uniform(20, 300)]))
        a, b, y0 = rng.normal(0, 0.3), rng.normal(0, 4e-4), rng.uniform(30, 210)
        xs = np.arange(w, dtype=float)
        yc = y0 + a * (xs - x0) + b * (xs - x0) ** 2
        mask = np.zeros((h, w), np.uint8)
        rows = np.arange(h)[:, None]
        band = (np.abs(rows - yc[None, :]) <= r) & (xs[None, :] >= x0) & (xs[None, :] <= x1)
        mask[band] = 255
        runs_lt = find_runs(mask.T, soft=True)
        for arr in runs_lt._find_tables + (runs_lt.centre_px, runs_lt.span_px):
            assert not arr.flags.writeable
        cols = np.arange(max(x0, 0), min(x1, w - 1), scale)
        seg = np.column_stack([np.rint((yc[cols.astype(int)] + 0.5) / scale - 0.5),
                               np.rint((cols + 0.5) / scale - 0.5)]).astype(np.int64)
        if len(seg) < 2:
            continue
        seg = np.unique(seg, axis=0)[np.argsort(np.unique(seg, axis=0)[:, 1], kind="stable")]
        node_yx = np.array([seg[0], seg[-1]], float) + rng.normal(0, 0.3, (2, 2))
        kinds = np.array([rng.choice([ENDPOINT, JUNCTION]), rng.choice([ENDPOINT, JUNCTION])])
        nodes = np.array([0, 1 if rng.random() < 0.8 else -1])
        g = SimpleNamespace(seg_yx=[seg], seg_nodes=np.array([nodes]), node_kind=kinds, node_yx=node_yx, scale=scale,
                            to_full=lambda yx, s=scale: (np.asarray(yx, np.float64).reshape(-1, 2)[:, ::-1] + 0.5) * s - 0.5)
        dist = np.clip(r - np.abs(rows - yc[None, :]), 0, None).astype(np.float32)
        rm = RadiusMap(np.ascontiguousarray(dist[::scale, ::scale]), scale)
        want = _flat_line_numpy(g, rm, runs_lt, 0)
        st, coef, t0, ts, degree, radius, lo, hi, u, uv, half_h, coarse, box = kernels_match.flat_search_line(
            seg, scale, np.ascontiguousarray(node_yx[np.maximum(nodes, 0)]),
            (nodes >= 0) & (kinds[np.maximum(nodes, 0)] == JUNCTION), rm.image, scale, runs_lt._find_tables,
            runs_lt.centre_px, runs_lt.span_px, runs_lt.width, 6.0)
        assert st in (1, 2)
        if want is None:
            assert st == 1
            n_none += 1
            continue
        assert st == 2
        n_found += 1
        vp, rad, lo0, hi0, u0, uv0, hh0, coarse0, box0 = want
        np.testing.assert_array_equal(coef[3 - degree:], vp.coef)
        assert (t0, ts, radius, lo, hi) == (vp.t0, vp.ts, rad, lo0, hi0)
        for x, y in ((u, u0), (uv, uv0), (half_h, hh0), (coarse, coarse0)):
            assert x.shape == y.shape
            np.testing.assert_array_equal(x, y)
        assert tuple(box.tolist()) == box0
    assert n_found > 150 and n_none > 5
