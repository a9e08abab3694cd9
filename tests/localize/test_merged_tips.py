"""Tips whose cap is whole in one view only (appliance.localize.merged_tips), on drawn stereo pairs."""

import cv2
import numpy as np
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.localize.merged_tips import strict_round
from appliance.localize.tips import cap_shape

from .shapes import ideal_rig

CFG = load_config().localize
TOP, BOTTOM, R = (300.0, 60.0), (260.0, 420.0), 6.0


def _rod_pair(calib, depth_mm: float, cut_left_y: float | None, cut_right_y: float | None = None,
              bar_left: bool = False, right_top_y: float | None = None):
    """A steep rod (radius ``R``, round cap centred on ``TOP``) at one depth in both views; its cap
    cut in a view above row ``cut_*_y`` by a grey thing in front (not branch: outside the mask);
    ``bar_left``: a crossing bar overlapping the cap in the left view only (not drawn in the right);
    ``right_top_y``: the rod ends in a round cap further down in the right view."""
    d = calib.f_px * calib.baseline_mm / depth_mm
    w, h = calib.image_size
    ss = 4
    views = []
    for shift, cut in ((0.0, cut_left_y), (d, cut_right_y)):
        big = np.full((h * ss, w * ss), 40, np.uint8)

        def px(p):
            return round((p[0] - shift + 0.5) * ss - 0.5), round((p[1] + 0.5) * ss - 0.5)
        top = TOP
        if right_top_y is not None and shift:
            top = (TOP[0] + (BOTTOM[0] - TOP[0]) * (right_top_y - TOP[1]) / (BOTTOM[1] - TOP[1]), right_top_y)
        cv2.line(big, px(top), px(BOTTOM), 200, int(round(2 * R * ss)))
        if cut is not None:            # a leaf's edge, slightly oblique, in front of the cap
            poly = np.array([px((TOP[0] - 30, cut - 2)), px((TOP[0] + 30, cut + 2)), px((TOP[0] + 30, 0)),
                             px((TOP[0] - 30, 0))], np.int32)
            cv2.fillPoly(big, [poly], 90)
        if bar_left and shift == 0.0:
            cv2.rectangle(big, px((TOP[0] - 60, TOP[1] - 4)), px((TOP[0] + 60, TOP[1] - 20)), 200, -1)
        g = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
        views += [cv2.cvtColor(g, cv2.COLOR_GRAY2BGR), ((g.astype(int) - 40) > 80).astype(np.uint8) * 255]
    left, ml, right, mr = views
    return left, right, ml, mr, d


def _tips(res):
    return [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 200]


def test_a_tip_cut_in_the_left_view_only_is_placed_from_the_right_views_cap():
    calib = ideal_rig()
    left, right, ml, mr, d = _rod_pair(calib, 900.0, cut_left_y=57.0)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = _tips(res)
    assert len(tips) == 1
    assert np.hypot(*np.subtract(tips[0].left_px, TOP)) <= 1.5
    assert abs((tips[0].left_px[0] - tips[0].right_px[0]) - d) <= 0.5


def test_a_tip_cut_in_both_views_is_no_tip():
    # the same thing in front cuts the cap in both views (the right view's edge a little further
    # out): neither end is round, no tip
    calib = ideal_rig()
    left, right, ml, mr, _ = _rod_pair(calib, 900.0, cut_left_y=59.0, cut_right_y=56.0)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert not _tips(res)


def test_a_cut_beyond_the_tips_centre_is_not_placed_from_the_right_view():
    # the left view's outline ends before the tip's centre: the left view does not see the tip
    calib = ideal_rig()
    left, right, ml, mr, _ = _rod_pair(calib, 900.0, cut_left_y=70.0)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert not _tips(res)


def test_strict_round_wants_both_sides_of_a_whole_cap():
    calib = ideal_rig()
    _, _, ml, mr, d = _rod_pair(calib, 900.0, cut_left_y=57.0)
    out = np.array([TOP[0] - BOTTOM[0], TOP[1] - BOTTOM[1]])
    out /= np.hypot(*out)
    edge = np.array(TOP) + R * out
    assert strict_round(cap_shape(mr, edge - (d, 0.0), out, R))
    assert not strict_round(cap_shape(ml, edge, out, R))
    assert not strict_round(None)


def _narrowed(calib, depth_mm: float, narrow_to_y: float):
    """``_rod_pair`` with its left cap cut (as placed from the right view's cap) and, in the left view only, the rod's
    left half covered by a grey thing in front (not branch) from the cap down to row ``narrow_to_y``."""
    left, right, ml, mr, d = _rod_pair(calib, depth_mm, cut_left_y=57.0)
    ys = np.arange(0, int(narrow_to_y) + 1)
    xs = TOP[0] + (BOTTOM[0] - TOP[0]) * (ys - TOP[1]) / (BOTTOM[1] - TOP[1])      # the rod's axis on each row
    for y, x in zip(ys, xs):
        x0 = int(np.floor(x - R - 3))
        x1 = int(np.floor(x))                      # up to the axis: the left half hidden
        left[y, x0:x1] = 90
        ml[y, x0:x1] = 0
    return left, right, ml, mr, d


def test_a_left_outline_narrowed_along_the_body_gives_no_tip_from_the_right_cap(monkeypatch):
    # fresh31 (seed 1122 T10, colour masks: a leaf beside the branch took half its width out of the left mask over
    # its last rows; the tip placed from the right cap took the curve's disparity, +5.22 px): the left runs over the
    # two radii of rows before the left end half the right's width: no tip (merged_tips.LEFT_NARROW_SHARE)
    from appliance.localize import merged_tips
    calib = ideal_rig()
    left, right, ml, mr, d = _narrowed(calib, 900.0, narrow_to_y=85.0)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert not _tips(res)
    monkeypatch.setattr(merged_tips, "LEFT_NARROW_SHARE", None)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert len(_tips(res)) == 1
