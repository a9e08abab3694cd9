"""Tips of short flat pieces found by their round cap (localize/tips.py; constructed masks)."""

import cv2
import numpy as np
from appliance.config import load_config
from appliance.localize.edges import find_runs
from appliance.localize.ends import EndPlacer
from appliance.localize.graph import build_graph
from appliance.localize.matching import StereoMasks
from appliance.localize.radius import ridge_radius_map
from appliance.localize.skeleton import skeletonize
from appliance.localize.tips import flat_cap_curves, round_end

H, W, R = 200, 480, 6.0
SHIFT = 4                                   # sub-pixel drawing: coordinates in 1/16 px
CAP = (300.4, 80.0)                         # the flat stub's tip (its cap's centre), x y px


def _stub(mask: np.ndarray, dx: float, square: bool) -> None:
    """A flat stub from ``CAP`` (moved ``dx`` left) 60 px to the right, its left end round or
    cut square (an apple's or a leaf's straight edge)."""
    s = 1 << SHIFT
    x0, y0 = CAP[0] - dx, CAP[1]
    pts = np.array([[x0, y0 - R], [x0 + 60, y0 - R + 3], [x0 + 60, y0 + R + 3], [x0, y0 + R]])
    cv2.fillPoly(mask, [np.rint(pts * s).astype(np.int32)], 255, cv2.LINE_AA, SHIFT)
    if not square:
        cv2.circle(mask, (int(round(x0 * s)), int(round(y0 * s))), int(round(R * s)), 255, -1, cv2.LINE_AA, SHIFT)


def _placer(d_px: float, square: bool = False):
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _stub(left, 0.0, square)
    _stub(right, d_px, square)
    grey = np.zeros((H, W), np.uint8)
    bl = cv2.threshold(left, 127, 255, cv2.THRESH_BINARY)[1]
    sm = StereoMasks(left, right, grey, grey, ridge_radius_map(bl), (100.0, 300.0), 1450.0)
    graph = build_graph(skeletonize(bl, "fast", 4))
    b = EndPlacer(graph, sm, {}, load_config().localize.match)
    return b, list(range(len(graph.seg_yx))), find_runs(left.T, soft=True)


def test_flat_stub_gets_a_curve_at_its_caps_disparity():
    for d_true in (131.0, 187.6):
        b, segs, runs_lt = _placer(d_true)
        curves = flat_cap_curves(b, segs, runs_lt)
        assert len(curves) == 1
        (c,) = curves.values()
        assert not c.by_row
        assert abs(c.d_at(CAP[0])[0] - d_true) < 0.3
        assert abs(c.s_at(CAP[0])[0] - CAP[1]) < 0.6                 # the stub's centre line
        assert abs(c.radius_px - R) < 1.0                            # (the drawing's antialiased rim)
        assert set(curves) <= b.cap_segments                         # the tip takes its cap's disparity


def test_flat_stub_tip_is_placed_on_its_cap():
    b, segs, runs_lt = _placer(150.0)
    b.curves.update(flat_cap_curves(b, segs, runs_lt))
    ends = [n for n in range(len(b.g.node_kind)) if np.hypot(*(b.node_xy[n] - CAP)) < 3 * R]
    assert len(ends) == 1
    b.tip(ends[0])
    u, v, d = b.uvd[ends[0]]
    assert ends[0] not in b.hidden
    assert np.hypot(u - CAP[0], v - CAP[1]) < 1.5 and abs(d - 150.0) < 0.3


def test_square_cut_end_is_no_cap():
    b, segs, runs_lt = _placer(150.0, square=True)
    assert flat_cap_curves(b, segs, runs_lt) == {}
    runs_l = find_runs(b.sm.left_mask, soft=True)
    edge = np.array([CAP[0] + 0.2, CAP[1]])
    assert not round_end(runs_l, edge, -1.0, R)
    b_round, _, _ = _placer(150.0)
    assert round_end(find_runs(b_round.sm.left_mask, soft=True), np.array([CAP[0] - R + 0.2, CAP[1]]), -1.0, R)
