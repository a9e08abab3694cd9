"""Tips of short isolated stubs (localize/stubtips.py; drawn masks): a stub with one round end gets
its tip at its cap's centre with the right disparity; a disc, a piece cut at both ends, a stub whose
right view ends elsewhere and a component already holding a piece get none."""

import cv2
import numpy as np
from appliance.localize.stubtips import stub_tips

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
          right_cap_shift: float = 0.0, round_cap: bool = True):
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _stub(left, cap, direction, length, R, round_cap)
    out = np.array(direction, float) / np.hypot(*direction)
    cap_r = np.array(cap, float) - (d, 0.0) + right_cap_shift * out
    _stub(right, tuple(cap_r), direction, (length if right_length is None else right_length) + right_cap_shift, R,
          round_cap)
    b, _, _ = end_placer(left, right)
    return b


def test_a_steep_and_a_flat_stub_get_their_tips_at_the_caps():
    d = 180.3
    for cap, direction in (((240.4, 60.2), (0.25, -1.0)), ((300.3, 100.6), (1.0, 0.12))):
        tips = stub_tips(_pair(cap, direction, 20.0, d), NONE)
        assert len(tips) == 1
        u, v, dd, rho = tips[0]
        assert np.hypot(u - cap[0], v - cap[1]) < 1.0
        assert abs(dd - d) < 0.3
        assert abs(rho - R) < 1.0


def test_no_tip_where_no_round_end_or_a_taken_piece():
    d = 180.3
    # a disc (a branch seen end-on): no end to tell from the other (both read round, and it is short)
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    cv2.circle(left, (240, 100), 7, 255, -1, cv2.LINE_AA)
    cv2.circle(right, (60, 100), 7, 255, -1, cv2.LINE_AA)
    assert stub_tips(end_placer(left, right)[0], NONE) == []
    # a piece cut straight at both ends (a branch between two leaves)
    assert stub_tips(_pair((240.4, 60.2), (0.25, -1.0), 26.0, d, round_cap=False), NONE) == []
    # the right view's piece ends 2.5 px further along its axis (its cap still fits along the rows)
    assert stub_tips(_pair((240.4, 60.2), (0.25, -1.0), 20.0, d, right_cap_shift=2.5), NONE) == []
    # a component that holds a matched piece's point is that piece's
    b = _pair((240.4, 60.2), (0.25, -1.0), 20.0, d)
    assert len(stub_tips(b, NONE)) == 1
    assert stub_tips(b, np.array([[237.0, 72.0]])) == []
