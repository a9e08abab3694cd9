"""Tips of short isolated stubs (localize/stubtips.py; drawn masks): a stub with one round end gets
its tip at its cap's centre with the right disparity; a disc, a piece cut at both ends, a stub whose
right view ends elsewhere and a component already holding a piece get none. Each with the components
searched from the block mask (the localizer's) and from the whole mask's labelling (no block mask)."""

import cv2
import numpy as np
import pytest
from appliance.localize.stubtips import stub_components, stub_tips, taken_points

from .shapes import end_placer

H, W, R = 200, 480, 6.0
SHIFT = 4                                   # sub-pixel drawing: coordinates in 1/16 px
NONE = np.zeros((0, 2))


def _stub(mask: np.ndarray, cap: tuple, direction: tuple, length: float, r: float, round_cap: bool = True) -> None:
    """A straight piece of half width ``r`` from its cut end ``length`` px behind ``cap`` (the cap's
    centre) to ``cap``, closed there by a half disc (or cut straight too)."""
    s = 1 << SHIFT
    out = np.array(direction, float) / np.hypot(*direction)
    n = np.array([-out[1], out[0]])
    c = np.array(cap, float)
    base = c - length * out
    quad = np.array([base + r * n, c + r * n, c - r * n, base - r * n])
    cv2.fillPoly(mask, [np.rint(quad * s).astype(np.int32)], 255, cv2.LINE_AA, SHIFT)
    if round_cap:
        cv2.circle(mask, tuple(int(round(v * s)) for v in c), int(round(r * s)), 255, -1, cv2.LINE_AA, SHIFT)


def _pair(cap: tuple, direction: tuple, length: float, d: float, right_length: float | None = None,
          right_cap_shift: float = 0.0, round_cap: bool = True, block: bool = True):
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _stub(left, cap, direction, length, R, round_cap)
    out = np.array(direction, float) / np.hypot(*direction)
    cap_r = np.array(cap, float) - (d, 0.0) + right_cap_shift * out
    _stub(right, tuple(cap_r), direction, (length if right_length is None else right_length) + right_cap_shift, R,
          round_cap)
    b, _, _ = end_placer(left, right, block=block)
    return b


@pytest.mark.parametrize("block", [True, False])
def test_a_steep_and_a_flat_stub_get_their_tips_at_the_caps(block):
    d = 180.3
    for cap, direction in (((240.4, 60.2), (0.25, -1.0)), ((300.3, 100.6), (1.0, 0.12))):
        b = _pair(cap, direction, 20.0, d, block=block)
        assert (b.sm.left_block is not None) == block
        tips = stub_tips(b, NONE)
        assert len(tips) == 1
        u, v, dd, rho = tips[0]
        assert np.hypot(u - cap[0], v - cap[1]) < 1.0
        assert abs(dd - d) < 0.3
        assert abs(rho - R) < 1.0


@pytest.mark.parametrize("block", [True, False])
def test_no_tip_where_no_round_end_or_a_taken_piece(block):
    d = 180.3
    # a disc (a branch seen end-on): no end to tell from the other (both read round, and it is short)
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    cv2.circle(left, (240, 100), 7, 255, -1, cv2.LINE_AA)
    cv2.circle(right, (60, 100), 7, 255, -1, cv2.LINE_AA)
    assert stub_tips(end_placer(left, right, block=block)[0], NONE) == []
    # a piece cut straight at both ends (a branch between two leaves)
    assert stub_tips(_pair((240.4, 60.2), (0.25, -1.0), 26.0, d, round_cap=False, block=block), NONE) == []
    # the right view's piece ends 2.5 px further along its axis (its cap still fits along the rows)
    assert stub_tips(_pair((240.4, 60.2), (0.25, -1.0), 20.0, d, right_cap_shift=2.5, block=block), NONE) == []
    # a component that holds a matched piece's point is that piece's
    b = _pair((240.4, 60.2), (0.25, -1.0), 20.0, d, block=block)
    assert len(stub_tips(b, NONE)) == 1
    assert stub_tips(b, np.array([[237.0, 72.0]])) == []


def test_the_block_mask_search_reads_the_same_components_as_the_whole_masks():
    """stub_components with the block mask (one cell per 4 x 4 px) and without it (the whole mask labelled):
    the same components, pixels and order, on a mask of stubs, a long branch, specks and a stub whose tail
    runs thin beyond its block component (its window grown); a taken point drops its component in both."""
    left = np.zeros((H, W), np.uint8)
    _stub(left, (240.4, 60.2), (0.25, -1.0), 20.0, R)
    _stub(left, (100.3, 150.6), (1.0, 0.12), 16.0, 4.0)
    _stub(left, (400.0, 40.0), (0.0, 1.0), 14.0, 3.6)
    cv2.line(left, (400, 28), (440, 8), 255, 1)                      # a 1-px tail off the last stub's base
    cv2.line(left, (20, 190), (470, 120), 255, 9, cv2.LINE_AA)      # a long branch: too large
    left[5:190:7, 300:470:9] = 255                                   # specks: too small
    with_block, _, _ = end_placer(left, left, block=True)
    without, _, _ = end_placer(left, left, block=False)
    for taken in (NONE, np.array([[102.0, 150.0]])):
        a = stub_components(with_block.sm, 4, taken)
        b = stub_components(without.sm, 4, taken)
        assert len(a) == len(b) == (3 if taken is NONE else 2)
        for (ya, xa), (yb, xb) in zip(a, b):
            assert np.array_equal(ya, yb) and np.array_equal(xa, xb)
    assert max(int(xs.max()) for _, xs in a) >= 438                 # the tail's far end: read whole


def test_taken_points_are_the_matched_pieces_pixels_and_the_placed_nodes():
    """taken_points: the matched segments' skeleton pixels at full resolution, then the placed nodes' (u, v)."""
    b, segments, _ = end_placer(*([_mask_with_branch()] * 2))
    g = b.g
    uvd = {0: np.array([10.5, 20.25, 150.0]), 3: np.array([1.0, 2.0, 3.0])}
    pts = taken_points(g, {s: None for s in segments}, uvd)
    want = np.vstack([g.to_full(g.seg_yx[s]) for s in segments] + [[[10.5, 20.25], [1.0, 2.0]]])
    assert len(segments) >= 1 and np.array_equal(pts, want)
    assert taken_points(g, {}, {}).shape == (0, 2)


def _mask_with_branch() -> np.ndarray:
    m = np.zeros((H, W), np.uint8)
    cv2.line(m, (40, 100), (400, 60), 255, 11, cv2.LINE_AA)
    cv2.line(m, (200, 80), (230, 180), 255, 9, cv2.LINE_AA)
    return m


def test_a_stub_thicker_than_a_twigs_end_gets_no_tip():
    """With the rig's baseline known, a stub whose cap is over MAX_RADIUS_MM at its depth is a limb's piece
    between two occluders (seed 609): the same drawn stub (6 px at 180.3 px) is 4.0 mm with a 120 mm
    baseline (found) and 8.3 mm with a 250 mm one (none)."""
    from dataclasses import replace

    from appliance.localize.stubtips import MAX_RADIUS_MM
    b = _pair((240.4, 60.2), (0.25, -1.0), 20.0, 180.3)
    for baseline, n in ((120.0, 1), (250.0, 0)):
        assert (R * baseline / 180.3 > MAX_RADIUS_MM) == (n == 0)
        b.sm = replace(b.sm, baseline_mm=baseline)
        assert len(stub_tips(b, NONE)) == n
