"""Tips of pieces the dense fit cannot match, found by their round cap (constructed masks)."""

from pathlib import Path

import cv2
import numpy as np
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import Localizer, dense
from appliance.localize.caps import cap_curves, cap_disparity
from appliance.localize.edges import find_runs
from appliance.localize.graph import build_graph
from appliance.localize.matching import StereoMasks
from appliance.localize.radius import ridge_radius_map
from appliance.localize.skeleton import skeletonize
from appliance.synth.evaluate import score_result
from appliance.synth.rig import default_rig
from appliance.synth.scene import make_scene, render

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"

H, W, R = 200, 480, 6.0
SHIFT = 4                                   # sub-pixel drawing: coordinates in 1/16 px
UP = np.array([0.0, -1.0])                  # from the stub's body to its tip


def _capsule(mask: np.ndarray, top: tuple[float, float], bottom: tuple[float, float], r: float) -> None:
    """A round-capped rod (antialiased, sub-pixel) from ``top`` to ``bottom`` (x, y) px."""
    s = 1 << SHIFT
    a = tuple(int(round(v * s)) for v in top)
    b = tuple(int(round(v * s)) for v in bottom)
    cv2.line(mask, a, b, 255, int(round(2 * r)), cv2.LINE_AA, SHIFT)
    cv2.circle(mask, a, int(round(r * s)), 255, -1, cv2.LINE_AA, SHIFT)


def _cut(mask: np.ndarray, y_left: float, y_right: float) -> None:
    """An occluder's oblique edge: everything below the line from (0, y_left) to (W, y_right) goes."""
    pts = np.array([[0, y_left], [W, y_right], [W, H], [0, H]], np.float32)
    cv2.fillPoly(mask, [np.rint(pts * (1 << SHIFT)).astype(np.int32)], 0, cv2.LINE_AA, SHIFT)


def _masks(d_px: float, flat: bool = False, twin_at: float | None = None) -> StereoMasks:
    """A stub whose tip shows in both views, cut by an occluder's edge that lies elsewhere in each."""
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    if flat:
        top, bottom = (300.4, 80.0), (340.4, 84.0)
    else:
        top, bottom = (300.4, 60.0), (306.4, 140.0)
    for m, dx in ((left, 0.0), (right, d_px)):
        _capsule(m, (top[0] - dx, top[1]), (bottom[0] - dx, bottom[1]), R)
    if twin_at is not None:                        # the same cap further along the right rows
        _capsule(right, (top[0] - twin_at, top[1]), (bottom[0] - twin_at, bottom[1]), R)
    if not flat:
        _cut(left, 95.0, 80.0)
        _cut(right, 120.0, 135.0)
    grey = np.zeros((H, W), np.uint8)
    bl = cv2.threshold(left, 127, 255, cv2.THRESH_BINARY)[1]
    return StereoMasks(left, right, grey, grey, ridge_radius_map(bl), (100.0, 300.0), 1450.0)


def test_cap_disparity_of_a_cut_stub():
    for d_true in (130.0, 171.3, 244.6):
        d = cap_disparity(_masks(d_true), np.array([300.4, 64.0]), 9, UP)
        assert d is not None and abs(d - d_true) < 0.3


def test_cap_disparity_refuses_an_ambiguous_or_missing_cap():
    assert cap_disparity(_masks(150.0, twin_at=230.0), np.array([300.4, 64.0]), 9, UP) is None
    sm = _masks(150.0)
    empty = StereoMasks(sm.left_mask, np.zeros_like(sm.right_mask), sm.left_gray, sm.right_gray, sm.radius_map,
                        sm.d_range_px, sm.f_px)
    assert cap_disparity(empty, np.array([300.4, 64.0]), 9, UP) is None
    assert cap_disparity(sm, np.array([3.0, 64.0]), 9, UP) is None          # the patch leaves the image


def _runs(sm):
    return find_runs(sm.left_mask, soft=True), find_runs(sm.right_mask, soft=True)


def test_cap_curves_give_steep_stubs_a_curve_at_the_caps_disparity():
    sm = _masks(171.3)
    graph = build_graph(skeletonize(cv2.threshold(sm.left_mask, 127, 255, cv2.THRESH_BINARY)[1], "fast", 4))
    curves = cap_curves(graph, sm, *_runs(sm), {}, 20.0)
    assert len(curves) == 1
    (c,) = curves.values()
    assert c.by_row
    assert abs(c.d_at(60.0)[0] - 171.3) < 0.3
    assert abs(c.s_at(60.0)[0] - 300.4) < 0.3                     # the stub's own centre line
    assert cap_curves(graph, sm, *_runs(sm), {next(iter(curves)): c}, 20.0) == {}  # pieces with a curve are left alone


def test_cap_curves_leave_flat_stubs_alone():
    sm = _masks(171.3, flat=True)
    graph = build_graph(skeletonize(cv2.threshold(sm.left_mask, 127, 255, cv2.THRESH_BINARY)[1], "fast", 4))
    assert cap_curves(graph, sm, *_runs(sm), {}, 20.0) == {}


def test_stub_tips_past_occluders_are_found_in_a_rendered_scene(monkeypatch):
    # seed 112: the tip of a twig seen only as a short stub above an apple that cuts it obliquely
    # (in the left view more than in the right): no row matches densely, the cap does
    calib = load_calibration(FIXTURES / "rig.yaml")
    left, right, truth = render(make_scene(112), default_rig(), seed=112)
    loc = Localizer(calib, load_config().localize)
    kw = dict(mask_left=truth.mask_left, mask_right=truth.mask_right)

    def tip_row(score):
        (row,) = [r for r in score.rows if r.truth_index == 2]
        return row

    monkeypatch.setattr(dense, "STUB_TIPS", False)         # (the isolated stubs' own rule: below)
    with_caps = score_result(loc.localize(left, right, **kw), truth)
    monkeypatch.setattr(dense, "cap_curves", lambda *a, **k: {})
    without = score_result(loc.localize(left, right, **kw), truth)
    assert truth.features.kind[2] == "endpoint"
    assert tip_row(without).result_id < 0
    # the stub is alone in the left mask (its base behind the apple): stubtips.py finds its tip too
    monkeypatch.setattr(dense, "STUB_TIPS", True)
    stub = tip_row(score_result(loc.localize(left, right, **kw), truth))
    assert stub.result_id >= 0 and stub.disparity_err_px < 0.2
    assert tip_row(with_caps).result_id >= 0 and tip_row(with_caps).disparity_err_px < 0.2
    assert with_caps.n_found >= without.n_found + 1
    assert with_caps.n_result - with_caps.n_correct <= without.n_result - without.n_correct   # no false one more
