"""tipbark.py: a flat tip's run end backed (or not) by the bark next to it, on a constructed textured branch."""

import cv2
import numpy as np
import pytest
from appliance.localize.texture import patch_depth_fraction
from appliance.localize.tipbark import bark_backs_run_end

F_PX, R_PX, Y_C, X_TIP = 1400.0, 10.0, 100.0, 150.0


def flat_tip_pair(d_axis_of_col, textured=True):
    """A branch along the rows (centre row Y_C, radius R_PX) ending in a cap at column X_TIP (its edge;
    the branch runs to the right of it) in a 200 x 600 left image, its bark a random blurred texture or flat
    grey, and the right view: each column moved by the surface disparity of the axis disparity
    ``d_axis_of_col(col)`` (a branch turning in depth along its length)."""
    rng = np.random.default_rng(3)
    h, w = 200, 600
    bark = cv2.GaussianBlur(rng.uniform(40, 200, (h, w)).astype(np.float32), (0, 0), 1.2) if textured \
        else np.full((h, w), 120.0, np.float32)
    left = np.full((h, w), 210.0, np.float32)
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    inside = (np.abs(yy - Y_C) <= R_PX) & (xx >= X_TIP)
    left[inside] = bark[inside]
    frac = patch_depth_fraction(R_PX, max(1, int(0.6 * R_PX)))
    # right(x) = left(x + d_surf(x + d)): the left column u lands at u - d_surf(u) (solved by one fixed-point step)
    d0 = d_axis_of_col(xx) * (1.0 + frac * R_PX / F_PX)
    d_surf = d_axis_of_col(xx + d0) * (1.0 + frac * R_PX / F_PX)
    right = cv2.remap(left, (xx + d_surf).astype(np.float32), yy.astype(np.float32), cv2.INTER_CUBIC,
                      borderMode=cv2.BORDER_REPLICATE)
    return np.clip(left, 0, 255).astype(np.uint8), np.clip(right, 0, 255).astype(np.uint8)


UV_EDGE, OUT = np.array([X_TIP, Y_C]), np.array([-1.0, 0.0])


def test_the_bark_next_to_a_tip_backs_a_run_end_that_reads_its_depth():
    # a branch receding 0.09 px per px away from its tip (seed 686's tip 15): 100 px at the tip's centre
    ramp = lambda x: 100.0 - 0.09 * (x - (X_TIP + R_PX))
    left, right = flat_tip_pair(ramp)
    # the piece's level (its mean, 50 px back: 95.5 px) against the run end's 100.1: the bark 1 radius behind
    # the tip's centre reads ~99.1, nearer the run end
    assert bark_backs_run_end(left, right, UV_EDGE, OUT, R_PX, 95.5, 100.1, F_PX)
    # a run end 6 px off the other way (another thing's outline): the bark does not read it
    assert not bark_backs_run_end(left, right, UV_EDGE, OUT, R_PX, 95.5, 93.0 - 6.0, F_PX)


def test_the_bark_reading_the_level_or_nothing_does_not_back_the_run_end():
    level = lambda x: np.full_like(x, 100.0)
    left, right = flat_tip_pair(level)
    # the texture's level is right there: a run end 6 px off is not the cap's
    assert not bark_backs_run_end(left, right, UV_EDGE, OUT, R_PX, 100.0, 106.0, F_PX)
    assert not bark_backs_run_end(left, right, UV_EDGE, OUT, R_PX, 100.0, 94.0, F_PX)
    # ... but a level carried wrongly 6 px off, the run end right: backed
    assert bark_backs_run_end(left, right, UV_EDGE, OUT, R_PX, 94.0, 100.2, F_PX)
    # no texture: no reading, the run end is not backed
    left, right = flat_tip_pair(level, textured=False)
    assert not bark_backs_run_end(left, right, UV_EDGE, OUT, R_PX, 94.0, 100.2, F_PX)


@pytest.mark.parametrize("out_x", [-1.0, 1.0])
def test_the_patch_lies_behind_the_tip_along_its_piece(out_x):
    # mirrored: the branch to the left of a cap whose edge is at X_TIP, going right
    ramp = lambda x: np.full_like(x, 100.0)
    left, right = flat_tip_pair(ramp)
    if out_x > 0:
        left, right = np.ascontiguousarray(left[:, ::-1]), np.ascontiguousarray(right[:, ::-1])
        # (mirrored columns: right(x') = left(x' - d): the disparity's sign flips; read as the left view
        # of the swapped pair)
        left, right = right, left
        uv = np.array([600 - 1 - X_TIP + 100.0, Y_C])     # (the mirrored edge, moved by the disparity)
        ok = bark_backs_run_end(left, right, uv, np.array([1.0, 0.0]), R_PX, 94.0, 100.2, F_PX)
    else:
        ok = bark_backs_run_end(left, right, UV_EDGE, OUT, R_PX, 94.0, 100.2, F_PX)
    assert ok
