"""Tips of short flat pieces found by their round cap (localize/tips.py; constructed masks)."""

from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from appliance.localize.edges import find_runs
from appliance.localize.tips import (
    cap_shape, cap_shapes, flat_cap_curves, front_disparity, occluder_confirmed, right_flanks_filled, round_cap, round_end,
    silhouette_offset_px,
)

from .shapes import end_placer

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
    return end_placer(left, right)


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


def _scene(d_occ: float, occ_x: tuple[int, int] = (300, 380)):
    """Grey views: blurred noise background 20 px of disparity away, and a textured occluder
    over columns ``occ_x`` of the left view at disparity ``d_occ`` (whole px)."""
    rng = np.random.default_rng(5)
    bg = cv2.GaussianBlur(rng.uniform(0, 255, (H, W + 450)).astype(np.float32), (0, 0), 2.0)
    occ = cv2.GaussianBlur(rng.uniform(0, 255, (H, W)).astype(np.float32), (0, 0), 1.5)
    left, right = bg[:, 400:400 + W].copy(), bg[:, 420:420 + W].copy()    # right: the same 20 px further left
    a, z = occ_x
    d = int(d_occ)
    left[40:160, a:z] = occ[40:160, a:z]
    right[40:160, a - d:z - d] = occ[40:160, a:z]
    to8 = lambda im: np.clip(im, 0, 255).astype(np.uint8)          # noqa: E731
    return SimpleNamespace(left_gray=to8(left), right_gray=to8(right), d_range_px=(100.0, 300.0))


def test_front_disparity_finds_an_occluder_and_not_the_background():
    sm = _scene(190.0)
    assert abs(front_disparity(sm.left_gray, sm.right_gray, np.array([330.0, 100.0]), 150.0, 8, 300.0) - 190) <= 1
    # behind the branch (the background, 20 px): nothing in front
    assert front_disparity(sm.left_gray, sm.right_gray, np.array([200.0, 100.0]), 150.0, 8, 300.0) is None


def test_an_occluder_far_in_front_must_show_in_the_next_patch_too():
    right_dir = np.array([1.0, 0.0])
    # near the branch's disparity (150): an occluder without more ado
    assert occluder_confirmed(_scene(170.0), np.array([310.0, 100.0]), right_dir, 150.0, 8)
    # far in front (250) and wide: the next patch out finds it again
    assert occluder_confirmed(_scene(250.0), np.array([310.0, 100.0]), right_dir, 150.0, 8)
    # far in front but only as wide as the first patch: the next patch sees the background
    assert not occluder_confirmed(_scene(250.0, (315, 336)), np.array([310.0, 100.0]), right_dir, 150.0, 8)


def test_silhouette_offset_matches_a_spheres_grazing_rays():
    f, b, cx = 1450.0, 120.0, 640.0
    for x_mm, z_mm, rho_mm in ((300.0, 1000.0, 5.0), (-250.0, 700.0, 8.0), (-400.0, 1400.0, 4.0)):
        def extreme(x_cam, side):            # rectified column of the sphere's extreme seen from x_cam
            dist = np.hypot(x_mm - x_cam, z_mm)
            return cx + f * np.tan(np.arctan2(x_mm - x_cam, z_mm) + side * np.arcsin(rho_mm / dist))
        u, d = cx + f * x_mm / z_mm, f * b / z_mm
        half = f * rho_mm / z_mm
        for side in (-1.0, 1.0):
            exact = extreme(0.0, side) - extreme(b, side) - d
            approx = silhouette_offset_px(u, d, half, side, f, cx)
            assert abs(approx - exact) <= 0.02 * abs(exact) + 0.003
            assert abs(exact) > 0.005                                  # (a real effect)



def _rod(square: bool = False, oblique: float = 0.0, touch: bool = False) -> np.ndarray:
    """A vertical rod (radius R) ending at the top at y = 60: round, cut square, cut by an oblique
    edge (``oblique``: the edge's slope), or round and touched on its right by a bar running on past it."""
    m = np.zeros((H, W), np.uint8)
    s = 1 << SHIFT
    pts = np.array([[300 - R, 60.0], [300 + R, 60.0], [300 + R, 180.0], [300 - R, 180.0]])
    cv2.fillPoly(m, [np.rint(pts * s).astype(np.int32)], 255, cv2.LINE_AA, SHIFT)
    if not square and not oblique:
        cv2.circle(m, (300 * s, 60 * s), int(R * s), 255, -1, cv2.LINE_AA, SHIFT)
    if oblique:                                  # everything above the edge through (300, 62) goes
        edge = np.array([[0, 62 - 300 * oblique], [W, 62 + (W - 300) * oblique], [W, 0], [0, 0]])
        cv2.fillPoly(m, [np.rint(edge * s).astype(np.int32)], 0, cv2.LINE_AA, SHIFT)
    if touch:
        cv2.rectangle(m, (int((300 + R - 1) * s), 20 * s), (int((300 + R + 12) * s), 90 * s), 255, -1,
                      cv2.LINE_AA, SHIFT)
    return m


def test_round_caps_and_occluders_edges():
    up = np.array([0.0, -1.0])
    assert round_cap(_rod(), np.array([300.0, 60.5 - R]), up, R)
    shape = cap_shape(_rod(), np.array([300.0, 60.5 - R]), up, R)[0]        # (the reading across the width)
    assert abs(shape[0] - R) < 1.0 and 0.6 < shape[1] < 1.4 and 0.6 < shape[2] < 1.4   # (antialiased rim)
    assert not round_cap(_rod(square=True), np.array([300.0, 60.5]), up, R)
    assert not round_cap(_rod(oblique=0.5), np.array([300.0, 62.5]), up, R)
    assert round_cap(_rod(touch=True), np.array([300.0, 60.5 - R]), up, R)      # touched on one side


def test_cap_shapes_read_together_are_each_ends_own():
    # several ends read at once (each its own lines and samples, of other lengths): the values of
    # reading each alone, unreadable ends included
    m = np.maximum(_rod(), np.roll(_rod(oblique=0.5), 150, axis=1))
    up = np.array([0.0, -1.0])
    ends = [(np.array([300.0, 60.5 - R]), up, R), (np.array([450.0, 62.5]), up, R),
            (np.array([300.0, 60.5 - R]), up, 0.6 * R), (np.array([20.0, 20.0]), up, R),
            (np.array([300.0, 120.0]), np.array([1.0, 0.0]), 2.0 * R)]
    together = cap_shapes(m, ends)
    assert together == [cap_shape(m, *end) for end in ends]
    assert together[0] is not None and together[3] is None


def test_flat_tip_whose_right_cap_is_cut_by_the_right_views_edge_is_hidden():
    """The rectified right view ends (its valid area) across the stub's cap: the right run ends at the
    view's edge, 2-3 px short of the cap, which would give a disparity that far off (seed 201's
    tip: 14.6 mm). The tip's end is not seen in the right view: hidden, not placed."""
    d_true = 150.0
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _stub(left, 0.0, False)
    _stub(right, d_true, False)
    edge = int(CAP[0] - d_true - R + 3)                      # the right view sees columns >= edge
    right[:, :edge] = 0
    valid = np.ones((H, W), bool)
    valid[:, :edge] = False
    for v, placed in ((None, True), (valid, False)):         # (without the valid area: the cut end is taken)
        b, segs, runs_lt = end_placer(left, right, v)
        b.curves.update(flat_cap_curves(b, segs, runs_lt))
        ends = [n for n in range(len(b.g.node_kind)) if np.hypot(*(b.node_xy[n] - CAP)) < 3 * R]
        for n in ends:
            b.tip(n)
        got = [n for n in ends if n in b.uvd and n not in b.hidden]
        assert bool(got) == placed
        if placed:
            assert abs(b.uvd[got[0]][2] - d_true) > 1.5               # the cut end's disparity: px off


def test_a_cap_past_the_right_views_side_edge_has_no_end_seen_there():
    """A cap whose end, moved by its disparity, lies past the right view's left or right edge shows only
    the edge there (seed 233's steep tip was read 3 px off, 9 mm): not seen. One cut by the top or
    bottom edge is cut on the same rows in both views: still seen."""
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _stub(left, 0.0, False)
    _stub(right, 150.0, False)
    valid = np.ones((H, W), bool)
    valid[:3] = False                                   # the rectified view's top strip
    valid[:, :20] = False                               # ... and its left side
    b, _, _ = end_placer(left, right, valid)
    out = np.array([-1.0, 0.0])
    edge = np.array([CAP[0] - R, CAP[1]])
    assert b._beyond_in_right_view(edge, out, 150.0)
    assert not b._beyond_in_right_view(edge, out, CAP[0] - R - 0.5)          # past the image's edge
    assert not b._beyond_in_right_view(edge, out, CAP[0] - R - 1 - 15)       # inside it, not in the valid area
    up = np.array([0.0, -1.0])
    assert b._beyond_in_right_view(np.array([CAP[0], 1.0]), up, 150.0)        # the top strip: rows cut alike


def _capped_branch(shape, y, x_end, r):
    """A horizontal branch (radius ``r`` px) along row ``y`` from column 0 to a round cap ending at ``x_end``."""
    m = np.zeros(shape, np.uint8)
    cv2.rectangle(m, (0, y - r), (x_end - r, y + r), 255, -1)
    cv2.circle(m, (x_end - r, y), r, 255, -1)
    return m


@pytest.mark.parametrize("touching", [False, True])
def test_a_branch_beside_the_cap_in_the_right_view_only_fills_its_flanks(touching):
    # seed 340's tip 13 (drawn): a flat branch's cap, 9 px radius, ending at column 300 (left) and 250 (right,
    # disparity 50); in the right view a nearer upright branch (12 px wide) covers the cap's end: the
    # right row runs end at its far edge, a straight outline 10 px further (the end read 10 px off)
    r, y = 9, 100
    left = _capped_branch((200, 400), y, 300, r)
    right = _capped_branch((200, 400), y, 250, r)
    if touching:
        cv2.rectangle(right, (248, 40), (259, 160), 255, -1)
    d_end = 300.0 - 260.0 if touching else 50.0          # the right run's end: the upright's far edge
    out = np.array([1.0, 0.0])
    assert right_flanks_filled(left, right, np.array([300.0, float(y)]), out, d_end, r) is touching
    # the left view's own flanks filled alike (a branch beside the cap in both views): not the right's alone
    if touching:
        cv2.rectangle(left, (288, 40), (299, 160), 255, -1)
        assert not right_flanks_filled(left, right, np.array([300.0, float(y)]), out, d_end, r)
