"""forkbark.py: a steep parent side's bark texture next to a fork, on a constructed textured branch."""

import cv2
import numpy as np
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.forkbark import steep_side_bark

F_PX, R_PX, X_C = 1400.0, 10.0, 300.0


def branch_pair(d_axis, textured=True):
    """A vertical branch (centre column X_C, radius R_PX) in a 320 x 600 left image, its bark random (blurred)
    texture or a flat grey, and the right view: each row moved by the surface disparity of the axis disparity
    ``d_axis(row)``."""
    rng = np.random.default_rng(5)
    h, w = 320, 600
    bark = cv2.GaussianBlur(rng.uniform(40, 200, (h, w)).astype(np.float32), (0, 0), 1.2) if textured \
        else np.full((h, w), 120.0, np.float32)
    left = np.full((h, w), 90.0, np.float32)
    inside = np.abs(np.arange(w) - X_C) <= R_PX
    left[:, inside] = bark[:, inside]
    rows = np.arange(h, dtype=float)
    # (the matched surface lies in front of the axis: ~0.9 radius for patches 0.6 radius wide, as
    # texture.surface_to_axis moves it back)
    d_surf = d_axis(rows) * (1.0 + 0.9 * R_PX / F_PX)
    map_x = (np.arange(w)[None, :] + d_surf[:, None]).astype(np.float32)
    map_y = np.repeat(rows[:, None], w, axis=1).astype(np.float32)
    right = cv2.remap(left, map_x, map_y, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    return np.clip(left, 0, 255).astype(np.uint8), np.clip(right, 0, 255).astype(np.uint8), d_surf


def side_curve(d_end: float, end_slope: float):
    """A steep side fitted on rows 150-290 at X_C, its disparity a line through ``d_end`` at row 150."""
    return BranchCurve(0, True, (150.0, 290.0), Poly(np.array([X_C])), Poly(np.array([end_slope, d_end]), 150.0, 1.0),
                       R_PX, 140)


def test_the_bark_reads_the_side_at_the_fork_where_its_curve_is_carried_off():
    truth = lambda v: 100.0 + 0.03 * v
    left, right, _ = branch_pair(truth)
    # the curve right at its span's end but its end slope 3 times the truth's: carried 30 rows to the fork at row
    # 120 it lands 1.8 px low; the bark next to the fork reads the truth's line there
    c = side_curve(truth(150.0), 0.09)
    assert abs(float(c.d_at(120.0)[0]) - truth(120.0)) > 1.5
    got = steep_side_bark(left, right, c, 120.0, 10.0, F_PX)
    assert got is not None and abs(got - truth(120.0)) < 0.2


def test_a_side_without_bark_texture_gives_no_reading():
    left, right, _ = branch_pair(lambda v: 100.0 + 0.03 * v, textured=False)
    assert steep_side_bark(left, right, side_curve(104.5, 0.03), 120.0, 10.0, F_PX) is None
