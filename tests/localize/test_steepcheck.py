"""Short steep pieces checked by their bark texture against the right-view run they were matched to.

Constructed case: two parallel vertical bars with their own bark texture. Bar A (the piece) is at
u = 150 in the left view and d = 40 px; bar B (the decoy) is at u = 120 in the left view and
d = 30 px, so its right run (u = 90) is where A's would be at d = 60 px: a run of the same width
in A's disparity range. A's short piece fitted to its own run keeps its curve; fitted to the
decoy's run it is withheld.
"""

import cv2
import numpy as np
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.matching import StereoMasks
from appliance.localize.steepcheck import (
    MAX_ROWS,
    _scores,
    check_piece,
    withheld_segments,
)

H, W = 200, 300
R_PX = 6.0
D_A, D_B = 40.0, 30.0
U_A, U_B = 150, 120


def _bark(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """A bark-like texture: smoothed noise, 60-200 grey levels."""
    t = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.2)
    t = (t - t.min()) / (t.max() - t.min())
    return 60 + 140 * t


def _scene() -> StereoMasks:
    rng = np.random.default_rng(7)
    bg_l = _bark(rng, H, W) * 0.3 + 90            # faint background texture, its own in each view
    bg_r = _bark(rng, H, W) * 0.3 + 90
    left, right = bg_l.copy(), bg_r.copy()
    mask_l, mask_r = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    half = int(R_PX)
    for u, d, tex in ((U_A, D_A, _bark(rng, H, 2 * half + 1)), (U_B, D_B, _bark(rng, H, 2 * half + 1))):
        ur = int(u - d)
        left[:, u - half:u + half + 1] = tex
        right[:, ur - half:ur + half + 1] = tex     # the same bark, shifted by its disparity
        mask_l[:, u - half:u + half + 1] = 255
        mask_r[:, ur - half:ur + half + 1] = 255
    return StereoMasks(mask_l, mask_r, np.clip(left, 0, 255).astype(np.uint8),
                       np.clip(right, 0, 255).astype(np.uint8), None, (20.0, 80.0), 1450.0)


def _piece(d_px: float, rows: tuple[float, float] = (80.0, 96.0), segment: int = 3) -> BranchCurve:
    """A steep piece along bar A's centre line with a constant disparity."""
    return BranchCurve(segment, True, rows, Poly(np.array([float(U_A)])), Poly(np.array([d_px])), R_PX,
                       int(rows[1] - rows[0]) + 1)


def test_the_piece_on_its_own_run_keeps_its_curve():
    sm = _scene()
    r = check_piece(_piece(D_A), sm)
    assert r is not None and not r.withheld
    assert r.own > 0.9                                # the same bark in both views


def test_the_piece_on_the_decoys_run_is_withheld():
    sm = _scene()
    wrong = D_A + (U_A - U_B) - (D_A - D_B)           # = 60 px: bar B's right run seen from A's rows
    assert abs((U_A - wrong) - (U_B - D_B)) < 1e-9
    r = check_piece(_piece(wrong), sm)
    assert r is not None and r.withheld
    assert r.own < 0.45                               # another bark: no correlation
    curves = {3: _piece(wrong), 4: _piece(D_A, segment=4)}
    assert list(withheld_segments(curves, sm)) == [3]


def test_a_long_piece_or_a_stub_is_not_judged():
    sm = _scene()
    assert check_piece(_piece(60.0, rows=(40.0, 40.0 + MAX_ROWS + 5)), sm) is None
    assert check_piece(_piece(60.0, rows=(80.0, 82.0)), sm) is None


def test_scores_are_matchtemplates():
    sm = _scene()
    us, vs = [U_A, U_A, U_B], [60, 90, 120]
    for los, his in (([35, 38, 20], [45, 42, 50]), ([30, 30, 30], [50, 50, 50])):   # own windows; one for all
        got = _scores(sm.left_gray, sm.right_gray, us, vs, los, his, 4)
        for u, v, lo, hi, g in zip(us, vs, los, his, got):
            tm = sm.left_gray[v - 3:v + 4, u - 4:u + 5].astype(np.float32)
            strip = sm.right_gray[v - 3:v + 4, u - hi - 4:u - lo + 5].astype(np.float32)
            assert abs(cv2.matchTemplate(strip, tm, cv2.TM_CCOEFF_NORMED).max() - g) < 1e-4
