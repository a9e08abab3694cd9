"""A parent side's disparity at a fork from its own crossings nearest it (appliance.localize.forkdisp)."""

import math

import numpy as np
import pytest
from appliance.localize import forkdisp
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.edges import find_runs
from appliance.localize.forkdisp import (
    bent_sides_apply, flat_side_near, line_carry_var, perspective_width_ratio, side_carry_var, side_disparity_near,
    taper_radius, weigh_bent_sides, weigh_sides,
)
from appliance.localize.texture import patch_depth_fraction

H, W = 400, 320
FORK_ROW = 150.0


def u_axis(v):
    return 150.0 + 0.1 * v


def d_axis(v):                        # the parent leans in depth: 0.01 px of disparity per row
    return 40.0 + 0.01 * v


def band(shift_px, child_px: float = 0.0) -> np.ndarray:
    """A steep parent (half width 10 px) as coverage 0-255, moved left by ``shift_px(v)``; rows within
    15 of the fork's widened by ``child_px`` on the left (a child leaving there)."""
    v = np.arange(H, dtype=float)[:, None]
    u = np.arange(W, dtype=float)[None, :]
    c = u_axis(v) - shift_px(v)
    lo = c - 10.0 - np.where(np.abs(v - FORK_ROW) <= 15, child_px, 0.0)
    cov = np.clip(np.minimum(u - lo, c + 10.0 - u) + 0.5, 0.0, 1.0)
    return np.rint(255 * cov).astype(np.uint8)


def curve(d_slope_err: float) -> BranchCurve:
    """The parent's piece fitted on rows 200-300 only (its rows near the junction left out), its
    disparity's slope off by ``d_slope_err`` px per row (0 at row 250)."""
    t = np.arange(200.0, 301.0)
    return BranchCurve(0, True, (200.0, 300.0), Poly.fit(t, u_axis(t), 1),
                       Poly.fit(t, d_axis(t) + d_slope_err * (t - 250.0), 1), 10.0, len(t))


def test_a_side_carried_to_the_fork_is_read_from_its_own_rows_there():
    left = band(lambda v: 0.0 * v, child_px=8.0)
    right = band(d_axis, child_px=8.0)
    runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    c = curve(0.01)
    carried = float(c.d_at(np.array([FORK_ROW]))[0])
    assert abs(carried - d_axis(FORK_ROW)) >= 0.9            # the fit carried 50 rows: 1 px off
    near = side_disparity_near(c, runs_l, runs_r, FORK_ROW)
    assert near is not None
    assert abs(near.d_px - d_axis(FORK_ROW)) <= 0.05
    # the rows the child widens are not the parent's alone: left out, so the line stops short of them
    assert near.nearest_px >= 15.0
    assert near.gap_px == 50 and 20 <= near.n_gap_rows <= 35


def test_rows_the_child_widens_alike_in_both_views_count_up_to_the_fork(monkeypatch):
    # the child joins the parent's outline 4 px wide on the rows within 15 of the fork (beyond the width
    # check's 10 % + 1.5 px of a 20 px crossing), at the parent's depth: as much wider in both views, the
    # crossings' middles moved alike; the plain read stops 15 rows short, the crotch's rows (within half a
    # width of the fork's) bring it to the fork's row
    c = curve(0.01)
    both = [find_runs(band(f, child_px=4.0), soft=True) for f in (lambda v: 0.0 * v, d_axis)]
    near = side_disparity_near(c, *both, FORK_ROW)
    assert near is not None and near.nearest_px <= 1.0
    assert abs(near.d_px - d_axis(FORK_ROW)) <= 0.05
    # widened in the left view only (the right crossing not as much wider): those rows are not the parent's
    one = [find_runs(band(lambda v: 0.0 * v, child_px=4.0), soft=True), find_runs(band(d_axis), soft=True)]
    assert side_disparity_near(c, *one, FORK_ROW).nearest_px >= 15.0
    # widened beyond 20 % + 2.5 px (8 px): left out as before
    wide = [find_runs(band(f, child_px=8.0), soft=True) for f in (lambda v: 0.0 * v, d_axis)]
    assert side_disparity_near(c, *wide, FORK_ROW).nearest_px >= 15.0
    # the rule off: the widened rows left out, the line stops short of them
    monkeypatch.setattr(forkdisp, "SIDE_GROWN_FRAC", 0.0)
    monkeypatch.setattr(forkdisp, "SIDE_GROWN_PX", 0.0)
    assert side_disparity_near(c, *both, FORK_ROW).nearest_px >= 15.0


def test_a_fork_within_the_span_or_a_flat_side_keeps_the_fit():
    left, right = band(lambda v: 0.0 * v), band(d_axis)
    runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    c = curve(0.01)
    assert side_disparity_near(c, runs_l, runs_r, 195.0) is None       # 5 rows past the span: read there
    flat = BranchCurve(0, False, c.t_range, c.s_poly, c.d_poly, 10.0, 101)
    assert side_disparity_near(flat, runs_l, runs_r, FORK_ROW) is None


def test_a_parent_hidden_in_the_right_view_near_the_fork_gives_nothing_from_there():
    # the right view shows the parent only on the fitted rows: the carried fit is all there is
    # beyond them, and the line through the span's rows next to its end is read (no gap rows)
    left = band(lambda v: 0.0 * v)
    right = band(d_axis)
    right[:200] = 0
    runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    near = side_disparity_near(curve(0.01), runs_l, runs_r, FORK_ROW)
    assert near is not None and near.n_gap_rows == 0
    assert abs(near.d_px - d_axis(FORK_ROW)) <= 0.1
    # a short span (50 rows) is already fitted by a line through those rows: its fit stays
    c = curve(0.01)
    short = BranchCurve(0, True, (200.0, 250.0), c.s_poly, c.d_poly, 10.0, 51)
    assert side_disparity_near(short, runs_l, runs_r, FORK_ROW) is None


def oblique(centre, slope: float, width: int = 700, height: int = 300, half_px: float = 8.0) -> np.ndarray:
    """A straight piece (half width ``half_px`` across it) whose centre column is ``centre(v)``, at
    ``slope`` columns per row, as coverage 0-255 (its row crossings 2 half_px sqrt(1 + slope^2) wide)."""
    v = np.arange(height, dtype=float)[:, None]
    u = np.arange(width, dtype=float)[None, :]
    cov = np.clip(half_px - np.abs(u - centre(v)) / np.hypot(1.0, slope) + 0.5, 0.0, 1.0)
    return np.rint(255 * cov).astype(np.uint8)


def test_an_oblique_side_turning_in_depth_is_read_at_each_views_slope():
    # a parent at 1.6 columns per row whose disparity grows 0.15 px per row: in the right view its
    # slope is 1.75, so every row crosses it ~2 px wider there than in the left view; the rows are
    # still the parent's alone (compared at each view's slope), and read
    u_ax = lambda v: 600.0 - 1.6 * v
    d_ax = lambda v: 40.0 + 0.15 * v
    left = oblique(u_ax, -1.6)
    right = oblique(lambda v: u_ax(v) - d_ax(v), -1.75)
    runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    t = np.arange(200.0, 281.0)
    c = BranchCurve(0, True, (200.0, 280.0), Poly.fit(t, u_ax(t), 1),
                    Poly.fit(t, d_ax(t) + 0.01 * (t - 240.0), 1), 8.0, len(t))
    assert abs(float(c.d_at(np.array([150.0]))[0]) - d_ax(150.0)) >= 0.5      # the fit carried 50 rows
    near = side_disparity_near(c, runs_l, runs_r, 150.0)
    assert near is not None and near.n_gap_rows >= 40
    assert abs(near.d_px - d_ax(150.0)) <= 0.1


def test_a_side_inclined_steeply_in_depth_is_read_from_the_span_rows_next_to_its_end(monkeypatch):
    # an oblique parent whose disparity grows 0.2 px per row over the fork's 12 rows of gap and the span's first
    # 20 rows, and 0.12 px per row further into the span (it turns in depth; at ~78 px of disparity and f 1450 px
    # ~3.7 mm of depth per mm along its rows): a line through the span's 40 rows takes the far rows' slope and is
    # off at the fork; with the 20 rows next to the span's end it is not
    u_ax = lambda v: 600.0 - 1.6 * v
    d_ax = lambda v: 40.0 + 0.2 * np.minimum(v, 220.0) + 0.12 * np.maximum(v - 220.0, 0.0)
    left = oblique(u_ax, -1.6)
    right = oblique(lambda v: u_ax(v) - d_ax(v), -1.76)
    runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    t = np.arange(200.0, 281.0)
    c = BranchCurve(0, True, (200.0, 280.0), Poly.fit(t, u_ax(t), 1), Poly.fit(t, d_ax(t), 1), 8.0, len(t))
    fork, f = 188.0, 1450.0
    monkeypatch.setattr(forkdisp, "SIDE_TURN_QUAD", False)       # (the line through the 20 rows: the parabola's fallback)
    near = side_disparity_near(c, runs_l, runs_r, fork, f_px=f)
    assert near is not None and abs(near.slope) * f >= forkdisp.SIDE_TURN_MIN_INCLINE * near.d_px
    assert abs(near.d_px - d_ax(fork)) <= 0.1
    monkeypatch.setattr(forkdisp, "SIDE_TURN_SHORT", False)
    long = side_disparity_near(c, runs_l, runs_r, fork, f_px=f)
    assert long is not None and abs(long.d_px - d_ax(fork)) >= 0.2
    monkeypatch.setattr(forkdisp, "SIDE_TURN_SHORT", True)
    # the same side seen further (f / d four times smaller: inclined 0.9 mm per mm) keeps the span's 40 rows
    far = side_disparity_near(c, runs_l, runs_r, fork, f_px=f / 4.0)
    assert far is not None and far.d_px == long.d_px and far.n_rows == long.n_rows
    # a side inclined gently keeps them too: the rule off or on alike
    d_slow = lambda v: 40.0 + 0.02 * np.minimum(v, 220.0) + 0.012 * np.maximum(v - 220.0, 0.0)
    runs_r = find_runs(oblique(lambda v: u_ax(v) - d_slow(v), -1.62), soft=True)
    c = BranchCurve(0, True, (200.0, 280.0), Poly.fit(t, u_ax(t), 1), Poly.fit(t, d_slow(t), 1), 8.0, len(t))
    on = side_disparity_near(c, runs_l, runs_r, fork, f_px=f)
    monkeypatch.setattr(forkdisp, "SIDE_TURN_SHORT", False)
    off = side_disparity_near(c, runs_l, runs_r, fork, f_px=f)
    assert off is not None and on is not None and abs(on.slope) * f < forkdisp.SIDE_TURN_MIN_INCLINE * on.d_px
    assert on.d_px == off.d_px and on.n_rows == off.n_rows


def test_a_side_turning_steadily_in_depth_is_read_with_a_parabola(monkeypatch):
    # an oblique parent whose disparity slope falls steadily from 0.2 px per row at the fork to 0.12 at the
    # span's far end 92 rows on (a parent bending in depth, ~3.7 mm of depth per mm along its rows at the fork):
    # a line through the span's 40 rows, or its 20 rows next to its end, takes the slope of rows further in and
    # is off at the fork; a parabola through the 40 rows is not (SIDE_TURN_QUAD). The crotch's 12 rows between the
    # fork and the span are not read (blank in both views: the read is carried from the span, as 980 T13's)
    fork, f = 188.0, 1450.0
    u_ax = lambda v: 600.0 - 1.6 * v
    d_ax = lambda v: 77.6 + 0.2 * (v - fork) - 4.35e-4 * (v - fork) ** 2
    left = oblique(u_ax, -1.6)
    right = oblique(lambda v: u_ax(v) - d_ax(v), -1.76)
    left[int(fork):200] = 0
    right[int(fork):200] = 0
    runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    t = np.arange(200.0, 281.0)
    c = BranchCurve(0, True, (200.0, 280.0), Poly.fit(t, u_ax(t), 1), Poly.fit(t, d_ax(t), 1), 8.0, len(t))
    quad = side_disparity_near(c, runs_l, runs_r, fork, f_px=f)
    assert quad is not None and abs(quad.d_px - d_ax(fork)) <= 0.1
    monkeypatch.setattr(forkdisp, "SIDE_TURN_QUAD", False)
    short = side_disparity_near(c, runs_l, runs_r, fork, f_px=f)
    assert short is not None and abs(short.d_px - d_ax(fork)) >= 0.15
    monkeypatch.setattr(forkdisp, "SIDE_TURN_SHORT", False)
    long = side_disparity_near(c, runs_l, runs_r, fork, f_px=f)
    assert long is not None and abs(long.d_px - d_ax(fork)) >= 0.3
    # seen further (f / d four times smaller: under SIDE_TURN_MIN_INCLINE) the side keeps its line
    monkeypatch.setattr(forkdisp, "SIDE_TURN_QUAD", True)
    monkeypatch.setattr(forkdisp, "SIDE_TURN_SHORT", True)
    far = side_disparity_near(c, runs_l, runs_r, fork, f_px=f / 4.0)
    assert far is not None and far.d_px == long.d_px and far.n_rows == long.n_rows


def test_a_fork_reads_its_parent_side_carried_past_its_span(monkeypatch):
    # a drawn Y at 30 deg: the child's blob keeps the upper side's fit ~50 rows short of the fork;
    # that side is read from its own rows there, and the fork keeps the parent's disparity
    import appliance.localize.forkends as forkends
    from appliance.config import load_config
    from appliance.localize import Localizer

    from .shapes import ideal_rig, y_pair

    read = []

    def spy(*args, **kwargs):
        out = side_disparity_near(*args, **kwargs)
        read.append(out)
        return out

    monkeypatch.setattr(forkends, "side_disparity_near", spy)
    calib = ideal_rig()
    left, right, ml, mr, fork, d = y_pair(calib, 1000.0, 30.0)
    res = Localizer(calib, load_config().localize).localize(left, right, mask_left=ml, mask_right=mr)
    sides = [r for r in read if r is not None]
    assert sides and all(s.gap_px >= 6 and abs(s.d_px - d) <= 0.1 for s in sides)
    forks = [f for f in res.features if f.kind == "bifurcation"]
    assert len(forks) == 1 and abs((forks[0].left_px[0] - forks[0].right_px[0]) - d) <= 0.1


def textured_pair(d_of_u, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Bark-like texture (blurred noise, 0-255) in the left view; the right view the same texture
    moved left by ``d_of_u(u)`` (a flat branch leaning in depth along its columns)."""
    import cv2
    rng = np.random.default_rng(seed)
    left = cv2.GaussianBlur(rng.uniform(0, 255, (H, W)).astype(np.float32), (0, 0), 1.5)
    left = cv2.normalize(left, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    u = np.arange(W, dtype=np.float32)[None, :].repeat(H, 0)
    v = np.arange(H, dtype=np.float32)[:, None].repeat(W, 1)
    # right(u_r) = left(u_r + d): d taken at u_r + d's first guess (d varies slowly)
    map_x = (u + d_of_u(u + d_of_u(u))).astype(np.float32)
    right = cv2.remap(left, map_x, v, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    return left, right


def flat_d(u):                          # the flat parent leans in depth: 0.02 px of disparity per column
    return 20.0 + 0.02 * u


def test_a_flat_side_is_read_from_its_texture_next_to_the_fork():
    left, right = textured_pair(flat_d)
    t = np.arange(200.0, 301.0)
    # a short flat piece's texture fit is a constant over its span (columns 200-300): 1 px off at
    # column 150, where the fork is
    c = BranchCurve(0, False, (200.0, 300.0), Poly.fit(t, np.full_like(t, 200.0), 1),
                    Poly.constant(float(flat_d(t).mean())), 8.0, len(t))
    fork_u = 150.0
    assert abs(float(c.d_at(np.array([fork_u]))[0]) - flat_d(fork_u)) >= 0.9
    near = flat_side_near(c, left, right, fork_u, f_px=1e9)       # (f: no surface-to-axis shift)
    assert near is not None
    # the patches 0-24 px along the side from the fork: their median is the disparity ~12 px in
    assert abs(near.d_px - flat_d(fork_u + 12.0)) <= 0.1
    assert near.nearest_px == 0.0 and near.n_rows >= 3


def test_a_flat_side_without_texture_or_a_steep_side_gives_none():
    left, right = textured_pair(flat_d)
    t = np.arange(200.0, 301.0)
    c = BranchCurve(0, False, (200.0, 300.0), Poly.fit(t, np.full_like(t, 200.0), 1),
                    Poly.constant(float(flat_d(t).mean())), 8.0, len(t))
    grey = np.full((H, W), 128, np.uint8)
    assert flat_side_near(c, grey, grey, 150.0, f_px=1e9) is None
    steep = BranchCurve(0, True, c.t_range, c.s_poly, c.d_poly, 8.0, len(t))
    assert flat_side_near(steep, left, right, 150.0, f_px=1e9) is None


def test_a_flat_side_read_is_carried_to_the_fork_along_its_curves_slope():
    left, right = textured_pair(flat_d)
    t = np.arange(200.0, 301.0)
    # a long piece's line fit with the right slope, 1 px off: the patches' median (~12 px in) is taken
    # back to the fork's column along that slope
    c = BranchCurve(0, False, (200.0, 300.0), Poly.fit(t, np.full_like(t, 200.0), 1),
                    Poly.fit(t, flat_d(t) + 1.0, 1), 8.0, len(t))
    near = flat_side_near(c, left, right, 150.0, f_px=1e9)
    assert near is not None
    assert abs(near.d_px - flat_d(150.0)) <= 0.08


def test_a_flat_side_is_moved_back_onto_the_axis_by_the_parents_radius_at_the_fork():
    # a tapering parent: the side's own radius (8 px, its span's) is less than the parent's at the fork
    # (12 px); the patches see the surface 0.94 of the fork's radius in front of the axis
    f_px, r_fork, axis_d = 200.0, 12.0, 20.0
    surf_d = axis_d * (1.0 + patch_depth_fraction(r_fork, 4) * r_fork / f_px)      # (rows +-int(0.6 * 8))
    left, right = textured_pair(lambda u: np.full_like(u, surf_d))
    t = np.arange(200.0, 301.0)
    c = BranchCurve(0, False, (200.0, 300.0), Poly.fit(t, np.full_like(t, 200.0), 1), Poly.constant(axis_d),
                    8.0, len(t))
    at_fork = flat_side_near(c, left, right, 150.0, f_px=f_px, radius_px=r_fork)
    own = flat_side_near(c, left, right, 150.0, f_px=f_px)
    assert at_fork is not None and own is not None
    assert abs(at_fork.d_px - axis_d) <= 0.08
    assert own.d_px - axis_d >= 0.3            # the side's own thinner radius: the axis read too near


def test_a_tapering_branchs_radius_is_linear_between_its_stretches():
    assert taper_radius(16.0, 30.0, 12.0, 10.0) == 13.0
    assert taper_radius(16.0, 0.0, 12.0, 50.0) == 16.0
    assert taper_radius(10.0, 20.0, 10.0, 80.0) == 10.0


def test_a_line_carried_past_its_rows_is_known_as_least_squares_says():
    # the closed form against the least-squares prediction variance x0^T (X^T X)^-1 x0
    for n, g in ((5, 4), (20, 0), (45, 13), (80, 60)):
        t = np.arange(n, dtype=float)
        x = np.stack([np.ones(n), t], 1)
        x0 = np.array([1.0, n - 1 + g + 0.5])          # (the rows' end at n - 0.5)
        want = float(x0 @ np.linalg.inv(x.T @ x) @ x0)
        assert abs(line_carry_var(n, g) - want) <= 0.05 * want
    assert line_carry_var(5, 4) > 10 * line_carry_var(45, 13)


def test_two_disagreeing_sides_count_by_how_well_each_is_known():
    # a side fitted on 5 rows next to the fork (+1.9 px off) and one read on 45 rows 13 rows away
    # (-0.35): the fork takes nearly the well-known one; two sides alike give their mean
    d = weigh_sides([101.9, 99.65], [(5.0, 4.0), (45.0, 13.0)])
    assert abs(d - 99.65) <= 0.25
    assert abs(weigh_sides([100.3, 99.7], [(40.0, 10.0), (40.0, 10.0)]) - 100.0) <= 1e-9


def _line_at_fork(x, d):
    """A straight line through rows ``x`` (row - fork's row) of disparity ``d``, read at the fork."""
    return float(np.polyfit(x, d, 1)[1])


def test_a_side_carried_past_the_parents_bend_in_depth_counts_less():
    # a parent straight in depth on each side of its fork (disparity linear in the row), but one side
    # turning 10 rows before the fork (0.03 px per row more): that side's rows stop 25 rows short of
    # the fork, the other side's reach it; a line through each side's own rows
    d0, s_a, s_b, s_far = 60.0, -0.02, 0.01, 0.04
    x_a = np.arange(0.0, 60.0)                                  # (rows past the fork, reaching it)
    x_b = np.arange(-85.0, -25.0)                               # (rows before it, 25 short)
    d_a = d0 + s_a * x_a
    d_b = np.where(x_b >= -10.0, d0 + s_b * x_b, d0 - 10.0 * s_b + s_far * (x_b + 10.0))
    sides = [_line_at_fork(x_a, d_a), _line_at_fork(x_b, d_b)]
    assert abs(sides[0] - d0) <= 1e-9 and abs(sides[1] - d0) >= 0.25        # (the premise: the bend missed)
    mean = 0.5 * (sides[0] + sides[1])
    bent = weigh_bent_sides(sides, [(60.0, 0.0), (60.0, 25.0)], False)
    assert abs(bent - d0) <= 0.5 * abs(mean - d0)
    # with the rows' noise counted too (sides apart): still nearer the side that reaches the fork
    bent_rows = weigh_bent_sides(sides, [(60.0, 0.0), (60.0, 25.0)], True)
    assert abs(bent_rows - d0) <= 0.5 * abs(mean - d0)


def test_sides_carried_alike_give_their_plain_mean():
    # both within SIDE_BEND_FREE_PX of the fork (or carried equally far): the plain mean, bit for bit
    for gaps in ((0.0, 1.5), (2.0, 0.0), (17.0, 17.0)):
        d = [100.3, 99.75]
        assert weigh_bent_sides(d, [(50.0, gaps[0]), (50.0, gaps[1])], False) == (d[0] + d[1]) / 2
    # the rows count only where asked: 6 rows against 60, both reaching the fork
    d = [101.0, 100.0]
    assert weigh_bent_sides(d, [(6.0, 0.0), (60.0, 0.0)], False) == 100.5
    assert weigh_bent_sides(d, [(6.0, 0.0), (60.0, 0.0)], True) < 100.5


def test_only_sides_read_on_enough_rows_or_fitted_on_a_long_span_are_weighed_by_their_carry():
    n_read, n_span = forkdisp.SIDE_BENT_MIN_ROWS, forkdisp.SIDE_BENT_MIN_SPAN
    assert n_read < n_span
    assert bent_sides_apply([(n_read, 20.0), (n_span, 0.0)], [True, False])
    assert bent_sides_apply([(60.0, 30.0), (55.0, 1.0)], [True, True])
    # a read on too few rows, or a short span's curve (even reaching the fork): today's rule
    assert not bent_sides_apply([(n_read - 1, 0.0), (60.0, 0.0)], [True, True])
    assert not bent_sides_apply([(60.0, 0.0), (n_span - 1, 0.0)], [True, False])
    # (a span is counted in rows of the piece's fit, not of a read: as many rows as a read's fail as a span)
    assert not bent_sides_apply([(60.0, 0.0), (n_read, 0.0)], [True, False])


def test_a_sides_variance_grows_with_its_carry_past_the_free_rows():
    v = [side_carry_var(50.0, g, False) for g in (0.0, 2.0, 6.0, 20.0, 40.0)]
    assert v[0] == v[1] == forkdisp.SIDE_OFFSET_VAR
    assert v[1] < v[2] < v[3] < v[4]
    assert abs(v[3] - v[0] - (forkdisp.SIDE_BEND_PX_PER_ROW * 18.0) ** 2) <= 1e-12
    assert side_carry_var(50.0, 20.0, True) == pytest.approx(v[3] + forkdisp.SIDE_ROW_VAR * line_carry_var(50.0, 20.0))


@pytest.mark.parametrize("z_mm, x_mm", [(600.0, 0.0), (900.0, 250.0), (1200.0, -300.0), (1400.0, 500.0)])
def test_the_width_ratio_is_a_cylinders_silhouette_seen_from_both_cameras(z_mm, x_mm):
    # a vertical cylinder (radius 20 mm) at (x, z): each camera's silhouette spans the two tangents from its
    # centre; the right camera is 120 mm to the right (rectified, principal points 15 px apart)
    f, cx, b, r, offset = 1450.0, 640.0, 120.0, 20.0, 15.0

    def width(xc):
        rho, th = math.hypot(xc, z_mm), math.atan2(xc, z_mm)
        a = math.asin(r / rho)
        return f * (math.tan(th + a) - math.tan(th - a)), f * xc / z_mm

    w_l, u_l = width(x_mm)
    w_r, _ = width(x_mm - b)
    u = u_l + cx
    d = f * b / z_mm + offset
    assert perspective_width_ratio(u, d, f, cx, offset) == pytest.approx(w_r / w_l, rel=2e-3)


def turning_d(u):                       # a flat parent turning in depth: 0.15 px of disparity per column
    return 40.0 - 0.15 * (u - 150.0)


def test_a_flat_side_turning_in_depth_faster_than_a_patch_can_read_is_not_read(monkeypatch):
    # seed 821 T11 (exact masks): a side turning 0.19 px per px, its patches 25 px along the rows spanning ~5 px of
    # disparity each and searched within 3 px of the curve's value at the fork, read 1.3 px off where its curve was
    # 0.34 px off; a side turning 0.02 px per px is read (above), one turning 0.15 px per px is not
    left, right = textured_pair(turning_d)
    t = np.arange(200.0, 301.0)
    c = BranchCurve(0, False, (200.0, 300.0), Poly.fit(t, np.full_like(t, 200.0), 1), Poly.fit(t, turning_d(t), 1),
                    8.0, len(t))
    assert forkdisp.turns_in_depth(c, 150.0)
    assert not forkdisp.turns_in_depth(c, 150.0, max_slope=0.25)
    assert flat_side_near(c, left, right, 150.0, f_px=1e9) is None
    monkeypatch.setattr(forkdisp, "FLAT_NEAR_MAX_SLOPE", None)        # (the rule off: read as any flat side)
    assert not forkdisp.turns_in_depth(c, 150.0)
    assert flat_side_near(c, left, right, 150.0, f_px=1e9) is not None
    gentle = BranchCurve(0, False, c.t_range, c.s_poly, Poly.fit(t, flat_d(t), 1), 8.0, len(t))
    monkeypatch.setattr(forkdisp, "FLAT_NEAR_MAX_SLOPE", 0.12)
    assert not forkdisp.turns_in_depth(gentle, 150.0)


def test_a_read_pivoted_on_one_crossing_far_from_the_span_is_read_from_the_span_alone(monkeypatch):
    # the right view shows the parent on its fitted rows (their middles scattered 0.3 px) and on one row
    # between the span and the fork only, that row's middle 1 px off (772 T9, colour masks: a crossing the
    # merging outline widened, still within the width check): the line is carried to the fork through it
    noise = np.random.default_rng(5).normal(0.0, 0.3, H)

    def pair(lone_row: int | None, shift_px: float = 0.0):
        right = band(lambda v: d_axis(v) + noise[np.asarray(v, int)])
        right[:200] = 0
        if lone_row is not None:
            right[lone_row] = band(lambda v: d_axis(v) + shift_px)[lone_row]
        return find_runs(band(lambda v: 0.0 * v), soft=True), find_runs(right, soft=True)

    c = curve(0.01)
    span_only = side_disparity_near(c, *pair(None), FORK_ROW)           # no row in the gap at all
    assert span_only is not None and span_only.n_gap_rows == 0
    monkeypatch.setattr(forkdisp, "LONE_GAP_ROW_UNREAD", False)
    off = [side_disparity_near(c, *pair(170, sh), FORK_ROW) for sh in (1.0, -1.0)]
    assert all(v.n_gap_rows == 1 and v.gap_px - v.nearest_px >= 6.0 for v in off)
    assert abs(off[0].d_px - d_axis(FORK_ROW)) >= 0.5                 # pivoted: the row's error carried 20 rows on
    assert abs(off[0].d_px - off[1].d_px) >= 0.5
    monkeypatch.setattr(forkdisp, "LONE_GAP_ROW_UNREAD", True)
    for row, sh in ((170, 1.0), (170, -1.0), (160, 1.0)):
        on = side_disparity_near(c, *pair(row, sh), FORK_ROW)
        assert on is not None and on.n_gap_rows == 0 and on.nearest_px == span_only.nearest_px
        assert on.d_px == pytest.approx(span_only.d_px, abs=1e-9)     # the lone row's error no longer counts
    # a lone row next to the span's end (4 rows) is one of the span's rows: read as before
    near = side_disparity_near(c, *pair(196, 1.0), FORK_ROW)
    assert near is not None and near.n_gap_rows == 1


def test_a_lone_gap_row_is_told_by_its_distance_from_the_span():
    lone = forkdisp.SideNear(190.0, 15, 1, 20, 6.8, 0.2, 0.0)
    assert forkdisp.rests_on_lone_gap_row(lone)                     # 13 rows from the span's end
    assert not forkdisp.rests_on_lone_gap_row(forkdisp.SideNear(190.0, 15, 1, 20, 16.0, 0.2, 0.0))
    assert not forkdisp.rests_on_lone_gap_row(forkdisp.SideNear(190.0, 15, 3, 20, 6.8, 0.2, 0.0))


def bent_d(v):                          # the parent bends in depth about the fork: 0.0002 px per row^2
    return 40.0 + 0.01 * v + 0.0002 * (v - FORK_ROW) ** 2


def test_a_lone_side_read_through_the_fork_puts_the_fork_between_its_rows():
    # the child widens the rows within 15 of the fork by 8 px (left out): the plain read's rows lie on one side
    # of the fork and its line, carried 15 rows, misses the parent's bend; the parent's crossings past the fork
    # (up to 40 rows) put the fork between the line's rows
    left = band(lambda v: 0.0 * v, child_px=8.0)
    right = band(bent_d, child_px=8.0)
    runs_l, runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    c = curve(0.0)
    plain = side_disparity_near(c, runs_l, runs_r, FORK_ROW)
    through = forkdisp.side_through_fork(c, runs_l, runs_r, FORK_ROW, 60.0, H)
    assert plain is not None and through is not None
    assert plain.nearest_px >= 15.0 and through.nearest_px >= 15.0      # (the crotch's rows left out on both sides)
    e_plain, e_through = abs(plain.d_px - bent_d(FORK_ROW)), abs(through.d_px - bent_d(FORK_ROW))
    assert e_plain >= 0.1
    assert e_through <= 0.5 * e_plain
    assert through.n_rows >= plain.n_rows + 20      # (THROUGH_MAX_ROWS = 40 past the fork, 15 of them the crotch's)
    assert through.gap_px == plain.gap_px           # (the rows between the span and the fork, as before)


def test_a_read_through_the_fork_needs_rows_past_it_inside_the_image():
    runs_l, runs_r = find_runs(band(lambda v: 0.0 * v), soft=True), find_runs(band(d_axis), soft=True)
    c = curve(0.0)
    assert forkdisp.side_through_fork(c, runs_l, runs_r, FORK_ROW, 0.0, H) is None        # no piece past the fork
    assert forkdisp.side_through_fork(c, runs_l, runs_r, 1.5, 40.0, H) is None            # the image's first row
    flat = BranchCurve(0, False, c.t_range, c.s_poly, c.d_poly, 10.0, 101)
    assert forkdisp.side_through_fork(flat, runs_l, runs_r, FORK_ROW, 40.0, H) is None
    # the parent ends at the fork in both views: nothing past it, the read is the plain one
    left, right = band(lambda v: 0.0 * v), band(d_axis)
    left[:int(FORK_ROW)] = 0
    right[:int(FORK_ROW)] = 0
    ends = [find_runs(m, soft=True) for m in (left, right)]
    through = forkdisp.side_through_fork(c, *ends, FORK_ROW, 40.0, H)
    plain = side_disparity_near(c, *ends, FORK_ROW)
    assert through is not None and plain is not None and through.n_rows == plain.n_rows
