"""A tip's disparity from its cap's own outline (appliance.localize.ends._cap_disparity and the
helpers in appliance.localize.tips), on constructed cases."""

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.localize.tips import at_view_edge, split_row_disparity

from .shapes import ideal_rig

CFG = load_config().localize


def test_a_split_row_takes_the_value_nearest_the_agreeing_rows():
    mid = np.array([100.0, 100.1, 99.9, 100.6, 99.4])
    e_lo = np.array([100.0, 100.2, 99.8, 100.1, 98.0])
    e_hi = np.array([100.0, 100.0, 100.0, 101.2, 100.8])
    d = split_row_disparity(mid, e_lo, e_hi, d_prior=100.3)
    # the first three agree (their middles stand); the fourth's edges are 1.1 px apart: its low
    # edge is nearest the agreeing rows' median (100.0); the fifth's middle is
    assert np.allclose(d, [100.0, 100.1, 99.9, 100.1, 99.4])
    # with fewer than 3 agreeing rows the prior is the reference
    d = split_row_disparity(mid[3:], e_lo[3:], e_hi[3:], d_prior=101.0)
    assert np.allclose(d, [101.2, 100.8])


def test_a_run_ending_at_the_view_edge_is_cut_there():
    rows = np.array([5, 5, 6, 6])
    x = np.array([-0.4, 639.4, 300.5, 20.5])      # (a refined boundary may lie inside its end pixel)
    assert at_view_edge(rows, x[:2], -1.0, None, 640).tolist() == [True, False]
    assert at_view_edge(rows[:2], x[:2], 1.0, None, 640).tolist() == [False, True]
    valid = np.ones((10, 640), bool)
    valid[6, :21] = False                          # the rectified view's black corner
    assert at_view_edge(rows[2:], x[2:], -1.0, valid).tolist() == [False, True]
    assert at_view_edge(rows[2:], x[2:], 1.0, valid).tolist() == [False, False]


def _capsule_cover(shape, a, b, r, ss=6):
    """Share (H, W) of each pixel within ``r`` of the segment ``a``-``b`` (px; pixel centres at
    integers), from ``ss`` x ``ss`` samples per pixel near it."""
    h, w = shape
    cover = np.zeros((h, w))
    x0, x1 = max(int(min(a[0], b[0]) - r - 2), 0), min(int(max(a[0], b[0]) + r + 3), w)
    y0, y1 = max(int(min(a[1], b[1]) - r - 2), 0), min(int(max(a[1], b[1]) + r + 3), h)
    off = (np.arange(ss) + 0.5) / ss - 0.5
    ys = (np.arange(y0, y1)[:, None] + off[None, :]).ravel()
    xs = (np.arange(x0, x1)[:, None] + off[None, :]).ravel()
    px, py = np.meshgrid(xs, ys)
    ab = np.subtract(b, a)
    t = np.clip(((px - a[0]) * ab[0] + (py - a[1]) * ab[1]) / (ab @ ab), 0.0, 1.0)
    inside = np.hypot(px - a[0] - t * ab[0], py - a[1] - t * ab[1]) <= r
    cover[y0:y1, x0:x1] = inside.reshape(y1 - y0, ss, x1 - x0, ss).mean(axis=(1, 3))
    return cover


def _inclined_pair(calib, tip, base, d_tip, d_base, r):
    """A branch from ``tip`` to ``base`` (left px, radius ``r``, a round cap) whose disparity
    changes linearly from ``d_tip`` to ``d_base`` along it, drawn anti-aliased in both views:
    left image, left mask, right image, right mask."""
    w, h = calib.image_size
    views = []
    for dt, db in ((0.0, 0.0), (d_tip, d_base)):
        cover = _capsule_cover((h, w), (tip[0] - dt, tip[1]), (base[0] - db, base[1]), r)
        g = np.rint(40 + 160 * cover).astype(np.uint8)
        views += [cv2.cvtColor(g, cv2.COLOR_GRAY2BGR), (cover >= 0.5).astype(np.uint8) * 255]
    return views


# the drawn right view is the left one moved along the rows, without the perspective of a real
# round outline (tips.silhouette_offset_px): a long focal length and a short baseline make that
# offset negligible (~0.02 px) for these tests
RIG = dict(f_px=3000.0, baseline_mm=20.0)


@pytest.mark.parametrize("base_x", [300.0, 470.0])
def test_an_inclined_branchs_tip_takes_its_caps_disparity(base_x):
    # a branch coming nearer towards its base (disparity +35 px over ~370 px), upright or at
    # ~25 deg: on the oblique one each row across the cap has one edge on the cap and the other
    # on the body; the tip is the cap's centre and has its disparity
    calib = ideal_rig(**RIG)
    d_tip = calib.f_px * calib.baseline_mm / 900.0
    tip, base, r = (300.0, 90.0), (base_x, 440.0), 8.0
    left, ml, right, mr = _inclined_pair(calib, tip, base, d_tip, d_tip + 35.0, r)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 200]
    assert len(tips) == 1
    assert np.hypot(*np.subtract(tips[0].left_px, tip)) <= 1.0
    assert abs((tips[0].left_px[0] - tips[0].right_px[0]) - d_tip) <= 0.1


def test_a_cap_running_out_of_the_view_on_one_side_takes_its_other_edges():
    # the cap's right side reaches the view's last column on the rows around its centre: those
    # rows' right ends are the view's, not the branch's (their middles were 0.13 px off)
    calib = ideal_rig(**RIG)
    d_tip = calib.f_px * calib.baseline_mm / 900.0
    tip, r = (632.0, 90.0), 8.0
    left, ml, right, mr = _inclined_pair(calib, tip, (572.0, 440.0), d_tip, d_tip + 10.0, r)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 200]
    assert len(tips) == 1
    assert np.hypot(*np.subtract(tips[0].left_px, tip)) <= 1.0
    assert abs((tips[0].left_px[0] - tips[0].right_px[0]) - d_tip) <= 0.08


def test_a_cap_merged_with_something_in_the_right_view_only_takes_its_free_edges():
    # a bar at another depth touches the cap's right side in the right view only: the right runs
    # across the cap run on into it (their middles ~10 px off); their left edges are the cap's
    calib = ideal_rig(**RIG)
    d_tip = calib.f_px * calib.baseline_mm / 900.0
    tip, r = (300.0, 90.0), 8.0
    left, ml, right, mr = _inclined_pair(calib, tip, (330.0, 440.0), d_tip, d_tip + 10.0, r)
    bar = np.zeros(mr.shape, bool)
    x0 = int(round(tip[0] - d_tip + r - 1.0))
    bar[78:104, x0:x0 + 20] = True
    mr = np.where(bar, 255, mr).astype(np.uint8)
    right = np.where(bar[..., None], 200, right).astype(np.uint8)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 200]
    assert len(tips) == 1
    assert np.hypot(*np.subtract(tips[0].left_px, tip)) <= 1.0
    assert abs((tips[0].left_px[0] - tips[0].right_px[0]) - d_tip) <= 0.1


def test_a_flat_end_whose_right_run_is_cut_elsewhere_keeps_its_run_end_disparity():
    # a flat branch ending in a round cap; in the right view an occluder cuts the piece 60 px
    # behind the end, so the right run there is much shorter than the left: its end is still the
    # cap's (the ends agree row by row); with something slanting across the cap in the right view
    # they do not, and the end gives no disparity
    from types import SimpleNamespace

    from appliance.localize.edges import find_runs
    from appliance.localize.ends import EndPlacer

    d, r = 150.0, 8.0
    left = np.zeros((200, 600), np.uint8)
    cv2.line(left, (200, 100), (392, 100), 255, int(2 * r))
    cv2.circle(left, (392, 100), int(r), 255, -1)
    right = np.roll(left, -int(d), axis=1)
    right[:, 170:180] = 0                                # the occluder's gap, 60 px behind the end
    touched = right.copy()
    cv2.line(touched, (214, 60), (294, 140), 255, 8)     # slanting across the cap's end
    uv_edge, out = np.array([400.0, 100.0]), np.array([1.0, 0.0])
    sm = SimpleNamespace(left_mask=left, f_px=3000.0, d_range_px=(50.0, 300.0), valid_right=None)
    for mask_r, expect in ((right, d), (touched, None)):
        placer = SimpleNamespace(sm=sm, runs_l=find_runs(left), runs_r=find_runs(mask_r))
        placer._end_outline_agrees = lambda *a, p=placer: EndPlacer._end_outline_agrees(p, *a)
        got = EndPlacer._end_disparity(placer, uv_edge, out, d + 1.0, r)
        if expect is None:
            assert got is None
        else:
            assert got is not None and abs(got - expect) <= 0.1


def test_a_flat_ends_rows_outvote_a_bulge_on_its_axis_row(monkeypatch):
    # a flat branch ending in a round cap, alike in both views 150 px apart; in the right view the outline bulges
    # 2 px past the end on the axis row and the next (a colour mask taking in background: seed 787's tip 4): the
    # axis row's run end agrees with too few rows, and the rows within half a radius, agreeing among themselves,
    # give the end's disparity (tipends.END_ROWS_OUTVOTE); without the rule the bulge's stood. A bulge on most of
    # the rows is the end's outline: it stands either way (no majority against it)
    from types import SimpleNamespace

    from appliance.localize import tipends
    from appliance.localize.edges import find_runs
    from appliance.localize.ends import EndPlacer

    d, r = 150.0, 8.0
    left = np.zeros((200, 600), np.uint8)
    cv2.line(left, (200, 100), (392, 100), 255, int(2 * r))
    cv2.circle(left, (392, 100), int(r), 255, -1)
    right = np.roll(left, -int(d), axis=1)
    end_r = int(np.flatnonzero(right[100])[-1])
    bulged, wide = right.copy(), right.copy()
    bulged[100:102, end_r + 1:end_r + 3] = 255          # the axis row and the next: 2 px further out
    cv2.circle(wide, (392 - int(d) + 2, 100), int(r), 255, -1)   # the whole cap 2 px further out: the end's outline
    uv_edge, out = np.array([400.0, 100.0]), np.array([1.0, 0.0])
    sm = SimpleNamespace(left_mask=left, f_px=3000.0, d_range_px=(50.0, 300.0), valid_right=None)
    for rule, mask_r, expect in ((True, right, d), (True, bulged, d), (False, bulged, d - 2.0), (True, wide, d - 2.0)):
        monkeypatch.setattr(tipends, "END_ROWS_OUTVOTE", rule)
        placer = SimpleNamespace(sm=sm, runs_l=find_runs(left), runs_r=find_runs(mask_r))
        got = EndPlacer._end_disparity(placer, uv_edge, out, d + 1.0, r)
        assert got is not None and abs(got - expect) <= 0.1, (rule, got, expect)


def test_a_flat_ends_soft_outline_off_the_grey_step_takes_the_grey_steps_end():
    # a flat branch ending in a round cap, alike in both views 150 px apart; the runs on the grey step whole (a soft
    # mask's, tipends.TIP_GREY_END: dense.match_dense's placer.runs_grey_end) end 0.8 px further in on the right
    # view's cap than the mixed runs (a colour outline taking in a dark background behind the cap in that view only:
    # seed 942's tip 11): the end reads the grey runs' disparity; 0.3 px apart (GREY_END_MIN_PX 0.5), or no grey
    # runs (a binary mask), the mixed runs' stands
    import dataclasses
    from types import SimpleNamespace

    from appliance.localize.edges import find_runs
    from appliance.localize.ends import EndPlacer
    from appliance.localize.tipends import GREY_END_MIN_PX

    d, r = 150.0, 8.0
    left = np.zeros((200, 600), np.uint8)
    cv2.line(left, (200, 100), (392, 100), 255, int(2 * r))
    cv2.circle(left, (392, 100), int(r), 255, -1)
    right = np.roll(left, -int(d), axis=1)
    uv_edge, out = np.array([400.0, 100.0]), np.array([1.0, 0.0])
    sm = SimpleNamespace(left_mask=left, f_px=3000.0, d_range_px=(50.0, 300.0), valid_right=None)
    runs_l, runs_r = find_runs(left), find_runs(right)
    plain = SimpleNamespace(sm=sm, runs_l=runs_l, runs_r=runs_r)
    d_mix = EndPlacer._end_disparity(plain, uv_edge, out, d + 1.0, r)
    assert d_mix is not None and abs(d_mix - d) <= 0.1
    assert GREY_END_MIN_PX < 0.8
    for shift, expect in ((0.8, d_mix + 0.8), (0.3, d_mix), (-0.8, d_mix - 0.8)):
        grey_r = dataclasses.replace(runs_r, right_px=runs_r.right_px - shift)      # the right runs' ends moved in
        placer = SimpleNamespace(sm=sm, runs_l=runs_l, runs_r=runs_r, runs_grey_end=(runs_l, grey_r))
        got = EndPlacer._end_disparity(placer, uv_edge, out, d + 1.0, r)
        assert got is not None and abs(got - expect) <= 1e-3, (shift, got, expect)


def test_a_cap_whose_rows_agree_among_themselves_keeps_its_own_depth_off_the_prior():
    # an upright piece ending in a round cap, drawn alike in both views 150 px apart; the prior (the
    # piece's curve carried to the tip) reads 3 px nearer, beyond the rows' 2.5 px window: the cap's
    # whole rows, agreeing among themselves, give its depth (tipends.OWN_CAP_ROWS; seed 704's tip 14).
    # With one side of the cap widened in the right view on some rows (split rows) they do not: None
    from appliance.localize import kernels_tips
    from appliance.localize.edges import find_runs
    from appliance.localize.tipends import (CAP_SPLIT_PX, CAP_SPLIT_SHARE, OWN_CAP_PX, OWN_CAP_ROWS, OWN_EDGE_PX,
                                            OWN_EDGE_ROWS, OWN_EDGE_SHARE, OWN_EDGE_WIDTH)
    from appliance.localize.tips import CAP_EDGE_BACK, SPLIT_ROW_PX

    d, r, f_px = 150.0, 6.0, 3000.0
    tip, base = (300.3, 60.4), (300.3, 20.0)                   # the cap's centre, going down (+v)
    h, w = 100, 400
    left = np.rint(255 * _capsule_cover((h, w), tip, base, r)).astype(np.uint8)
    right = np.rint(255 * _capsule_cover((h, w), (tip[0] - d, tip[1]), (base[0] - d, base[1]), r)).astype(np.uint8)
    widened = right.copy()
    widened[58:66, int(tip[0] - d + r):int(tip[0] - d + r) + 3] = 255       # the cap's right side, 3 px wider
    out = np.array([0.0, 1.0])
    rows = np.arange(int(np.ceil(tip[1] - r)), int(np.floor(tip[1] + r)) + 1)
    s = np.full(len(rows), tip[0])
    rl = kernels_tips.runs_tables(find_runs(left, soft=True))
    valid = kernels_tips.valid_table(None)

    def read(mask_r, own_rows, edge_rows=0):          # (the edge rows' rule, tipends.OWN_EDGE_ROWS, off)
        rr = kernels_tips.runs_tables(find_runs(mask_r, soft=True))
        return kernels_tips.cap_disparity(rows, s, rl, rr, valid, valid, tip[0], tip[1], out[0], out[1], r, d + 3.0,
                                          f_px, h, w, CAP_EDGE_BACK, SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE,
                                          own_rows, OWN_CAP_PX, edge_rows, OWN_EDGE_PX, OWN_EDGE_SHARE, OWN_EDGE_WIDTH)

    status, got = read(right, OWN_CAP_ROWS)
    assert status == 1 and abs(got - d) <= 0.1
    assert read(right, 0)[0] == 0                              # the rule off: no depth (the prior stood)
    assert read(widened, OWN_CAP_ROWS)[0] == 0
    status, got = kernels_tips.cap_disparity(rows, s, rl, kernels_tips.runs_tables(find_runs(right, soft=True)), valid,
                                             valid, tip[0], tip[1], out[0], out[1], r, d + 1.0, f_px, h, w,
                                             CAP_EDGE_BACK, SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE,
                                             OWN_CAP_ROWS, OWN_CAP_PX, OWN_EDGE_ROWS, OWN_EDGE_PX, OWN_EDGE_SHARE,
                                             OWN_EDGE_WIDTH)
    assert status == 1 and abs(got - d) <= 0.1               # within the window: as before


def test_an_oblique_caps_edge_rows_agreeing_among_themselves_outvote_a_far_prior():
    # a piece 30 deg off the rows ending in a round cap, drawn alike in both views 150 px apart: each row crosses
    # one edge of the cap (the other is the body's), so no row has both edges on the cap; the prior (the piece's
    # curve carried to the tip) reads 9 px nearer (seed 881's tip 13: the piece mismatched in the right view where
    # it crosses a branch behind it). The cap's edge rows, agreeing among themselves, give its depth
    # (tipends.OWN_EDGE_ROWS); without the rule none (the prior stood). A right cap cut by a straight edge across
    # it (something in front in the right view only) reads a depth per row: none
    from appliance.localize import kernels_tips
    from appliance.localize.edges import find_runs
    from appliance.localize.tipends import (CAP_SPLIT_PX, CAP_SPLIT_SHARE, OWN_CAP_PX, OWN_CAP_ROWS, OWN_EDGE_PX,
                                            OWN_EDGE_ROWS, OWN_EDGE_SHARE, OWN_EDGE_WIDTH)
    from appliance.localize.tips import CAP_EDGE_BACK, SPLIT_ROW_PX

    d, r, f_px = 150.0, 10.0, 3000.0
    out = np.array([np.cos(np.pi / 6), np.sin(np.pi / 6)])
    tip = np.array([300.3, 60.4])                               # the cap's centre
    base = tip - 80.0 * out
    h, w = 120, 400
    left = np.rint(255 * _capsule_cover((h, w), tip, base, r)).astype(np.uint8)
    right = np.rint(255 * _capsule_cover((h, w), tip - (d, 0), base - (d, 0), r)).astype(np.uint8)
    yy, xx = np.mgrid[0:h, 0:w]
    cut = right.copy()
    cut[(xx - (tip[0] - d)) + 0.7 * (yy - tip[1]) > -2.0] = 0     # a straight edge across the right cap
    rows = np.arange(int(np.ceil(tip[1] - r)), int(np.floor(tip[1] + r)) + 1)
    s = tip[0] + (rows - tip[1]) * out[0] / out[1]
    rl = kernels_tips.runs_tables(find_runs(left, soft=True))
    valid = kernels_tips.valid_table(None)

    def read(mask_r, edge_rows, d_prior=d + 9.0):
        rr = kernels_tips.runs_tables(find_runs(mask_r, soft=True))
        return kernels_tips.cap_disparity(rows, s, rl, rr, valid, valid, tip[0], tip[1], out[0], out[1], r, d_prior,
                                          f_px, h, w, CAP_EDGE_BACK, SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE,
                                          OWN_CAP_ROWS, OWN_CAP_PX, edge_rows, OWN_EDGE_PX, OWN_EDGE_SHARE, OWN_EDGE_WIDTH)

    status, got = read(right, OWN_EDGE_ROWS)
    assert status == 1 and abs(got - d) <= 0.3
    assert read(right, 0)[0] == 0                              # the rule off: no depth (the prior stood)
    assert read(cut, OWN_EDGE_ROWS, d - 9.0)[0] == 0             # (a prior none of the cut rows lies near)
    status, got = read(right, 0, d + 1.0)                      # within the window: as before, the rule aside
    assert status == 1 and abs(got - d) <= 0.3

    # a piece ending inside something twice its width, alike in both views (seed 464: a piece inside a trunk): its
    # rows' edges, one side's straight and agreeing among themselves, are that thing's outline, not the cap's: none
    wide_l, wide_r = left.copy(), right.copy()
    for img, shift in ((wide_l, 0.0), (wide_r, d)):
        cv2.rectangle(img, (int(tip[0] - shift - 3 * r), int(tip[1] - 2 * r)), (int(tip[0] - shift + 3 * r), int(tip[1] + 4)),
                      255, -1)
    rl_w = kernels_tips.runs_tables(find_runs(wide_l, soft=True))
    rr_w = kernels_tips.runs_tables(find_runs(wide_r, soft=True))
    status, _ = kernels_tips.cap_disparity(rows, s, rl_w, rr_w, valid, valid, tip[0], tip[1], out[0], out[1], r, d + 9.0,
                                           f_px, h, w, CAP_EDGE_BACK, SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE,
                                           OWN_CAP_ROWS, OWN_CAP_PX, OWN_EDGE_ROWS, OWN_EDGE_PX, OWN_EDGE_SHARE, 100.0)
    assert status == 1                                        # (without the width's bound its edges gave a depth)
    assert kernels_tips.cap_disparity(rows, s, rl_w, rr_w, valid, valid, tip[0], tip[1], out[0], out[1], r, d + 9.0,
                                      f_px, h, w, CAP_EDGE_BACK, SPLIT_ROW_PX, *CAP_SPLIT_PX, CAP_SPLIT_SHARE,
                                      OWN_CAP_ROWS, OWN_CAP_PX, OWN_EDGE_ROWS, OWN_EDGE_PX, OWN_EDGE_SHARE,
                                      OWN_EDGE_WIDTH)[0] == 0


@pytest.mark.parametrize("rule", [True, False])
def test_a_cap_hidden_in_the_right_view_behind_something_wider_is_no_tip(monkeypatch, rule):
    # a branch coming nearer towards its base; in the right view a wide bar covers its cap and runs on past
    # it (the branch's tip behind a nearer branch there, seed 723's tip 6): the right view runs on wider past
    # the end (the end-shift check waived) and no row of the cap reads a depth near the piece's (the bar's
    # edges are the rows' edges): hidden (tipends.WIDER_RIGHT_NEEDS_CAP); without the rule the piece's line
    # carried to the tip stood as its depth. (The bar also fills the right cap's flanks: WIDER_BESIDE_NEEDS_CAP,
    # off here, withholds it too, so that this rule is tested alone.)
    from appliance.localize import tipends
    monkeypatch.setattr(tipends, "WIDER_RIGHT_NEEDS_CAP", rule)
    monkeypatch.setattr(tipends, "WIDER_BESIDE_NEEDS_CAP", False)
    calib = ideal_rig(**RIG)
    d_tip = calib.f_px * calib.baseline_mm / 900.0
    tip, r = (300.0, 90.0), 8.0
    left, ml, right, mr = _inclined_pair(calib, tip, (330.0, 440.0), d_tip, d_tip + 10.0, r)
    bar = np.zeros(mr.shape, bool)
    x_r = int(round(tip[0] - d_tip))
    bar[40:104, x_r - 45:x_r + 12] = True
    mr = np.where(bar, 255, mr).astype(np.uint8)
    right = np.where(bar[..., None], 200, right).astype(np.uint8)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 200]
    if rule:
        assert tips == []
    else:
        assert len(tips) == 1 and np.hypot(*np.subtract(tips[0].left_px, tip)) <= 2.0


def test_an_end_whose_walk_never_leaves_the_mask_is_no_tip():
    # a piece's skeleton ends on row 150 while its branch runs on down the mask (a trunk whose skeleton a leaf cut,
    # seed 890): the walk out along its centre line reaches its end (3 radii and more) still on the mask, so a cap
    # placed one radius back from there is a point on the body; it is hidden (tipends.TIP_MASK_RUNS_ON). A rod
    # ending 20 px past the piece is walked off its cap as before
    from types import SimpleNamespace

    from appliance.localize import tipends
    from appliance.localize.curves import BranchCurve, Poly
    from appliance.localize.ends import EndPlacer

    assert tipends.TIP_MASK_RUNS_ON
    r = 6.0
    c = BranchCurve(0, True, (60.0, 150.0), Poly.constant(300.0), Poly.constant(100.0), r, 40)

    def placer(last_row):
        mask = np.zeros((400, 600), np.uint8)
        cv2.line(mask, (300, 50), (300, last_row), 255, int(2 * r))
        p = EndPlacer.__new__(EndPlacer)
        p.__dict__.update(_walk_cache={}, node_xy=np.array([[300.0, 150.0], [300.0, 60.0]]),
                          g=SimpleNamespace(scale=2, seg_nodes=[(1, 0)]), sm=SimpleNamespace(left_mask=mask, valid_left=None),
                          incident=[[0], [0]], curves={0: c}, hidden=set(), uvd={}, radius={})
        return p

    ends, runs_on, cap_past_reach = placer(170), placer(390), placer(174)
    assert not EndPlacer._walk_runs_on(ends, c, 0)
    assert EndPlacer._walk_runs_on(runs_on, c, 0)
    # a cap whose end lies just past the walk's reach (28 rows: 3 r + 3 graph px + 4; seed 554's tip 17, exact masks):
    # the walk ends on the cap, but the mask ends within a radius past it: a tip
    t_cap, _ = EndPlacer._walk_out(cap_past_reach, c, 0)
    assert t_cap == EndPlacer._walk_t(cap_past_reach._walk_cache[0, id(c)][1], 1.0, 111, False)   # (no crossing)
    assert not EndPlacer._walk_runs_on(cap_past_reach, c, 0)
    assert abs(EndPlacer._walk_out(ends, c, 0)[0] - 170 - r) <= 1.0        # (the rod's cap: its last row + r)
    assert EndPlacer._tip_place(runs_on, 0) is None and runs_on.hidden == {0}
    assert abs(runs_on.uvd[0][1] - (150.0 + 3 * r + 6 + 4 - r)) <= 1.0     # (the piece's end: the walk's reach, less r)
