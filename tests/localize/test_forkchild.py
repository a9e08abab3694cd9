"""forkchild: a child along the rows checked by its bark texture; a branch passing its parent."""

import cv2
import numpy as np
from appliance.localize.forkchild import ELSEWHERE_PX, child_texture_agrees, child_texture_elsewhere, passes_through
from appliance.localize.texture import surface_to_axis

F_PX = 1450.0


def _textured_pair(shift_px: int, radius_px: int = 10, seed: int = 3):
    """Grey images: a horizontal textured child (rows 200 +- radius, from x 300 on) beside a steep
    parent band at x 260-300, over smooth background; the right view is the left moved ``shift_px``
    to the left (the child's surface disparity)."""
    rng = np.random.default_rng(seed)
    h, w = 400, 640
    bark = cv2.GaussianBlur(rng.uniform(40, 160, (h, w)).astype(np.float32), (0, 0), 1.5)
    left = np.full((h, w), 200.0, np.float32)
    left[:, 260:300] = bark[:, 260:300]
    left[200 - radius_px:200 + radius_px + 1, 300:520] = bark[200 - radius_px:200 + radius_px + 1, 300:520]
    right = np.full((h, w), 200.0, np.float32)
    right[:, :w - shift_px] = left[:, shift_px:]
    return left.astype(np.uint8), right.astype(np.uint8)


def test_a_childs_texture_next_to_the_fork_tells_its_depth():
    r = 10
    left, right = _textured_pair(150, r)
    d_axis = float(surface_to_axis(np.array([150.0]), r, F_PX)[0])     # the axis behind the matched surface
    fork, out = np.array([280.0, 200.0]), np.array([1.0, 0.0])
    assert child_texture_agrees(left, right, fork, out, 25.0, d_axis, r, F_PX)
    # a child 4 px of disparity nearer or further is another branch crossing the parent
    assert not child_texture_agrees(left, right, fork, out, 25.0, d_axis + 4.0, r, F_PX)
    assert not child_texture_agrees(left, right, fork, out, 25.0, d_axis - 4.0, r, F_PX)


def test_a_child_without_texture_is_not_confirmed():
    r = 10
    left = np.full((400, 640), 90, np.uint8)                 # bark without texture: no correlation peak
    right = left.copy()
    assert not child_texture_agrees(left, right, np.array([280.0, 200.0]), np.array([1.0, 0.0]), 25.0,
                                    150.0, r, F_PX)


def test_a_childs_texture_at_another_depth_past_the_parent_tells_another_branch():
    r = 10
    left, right = _textured_pair(150, r)
    d_axis = float(surface_to_axis(np.array([150.0]), r, F_PX)[0])
    fork, out = np.array([280.0, 200.0]), np.array([1.0, 0.0])
    # at the fork's depth, or a few px off (a child turning in depth): not elsewhere
    assert not child_texture_elsewhere(left, right, fork, out, 25.0, d_axis, r, F_PX)
    assert not child_texture_elsewhere(left, right, fork, out, 25.0, d_axis + ELSEWHERE_PX - 1.0, r, F_PX)
    # the fork's disparity 12 px over or under the child's texture: another branch's fork
    assert child_texture_elsewhere(left, right, fork, out, 25.0, d_axis + 12.0, r, F_PX)
    assert child_texture_elsewhere(left, right, fork, out, 25.0, d_axis - 12.0, r, F_PX)


def test_a_child_without_texture_is_not_called_elsewhere():
    left = np.full((400, 640), 90, np.uint8)
    assert not child_texture_elsewhere(left, left.copy(), np.array([280.0, 200.0]), np.array([1.0, 0.0]), 25.0,
                                       162.0, 10, F_PX)


def _parent_and(child_sides: str, gap=None) -> np.ndarray:
    """A vertical parent (x 280-320) and a horizontal branch of radius 6 at row 200 on the given sides
    ('r': right only, a fork; 'lr': both, a branch crossing it); ``gap`` (x0, x1) hidden by an occluder."""
    m = np.zeros((400, 640), np.uint8)
    m[:, 280:321] = 255
    if "r" in child_sides:
        m[194:207, 320:520] = 255
    if "l" in child_sides:
        m[194:207, 60:280] = 255
    if gap is not None:
        m[194:207, gap[0]:gap[1]] = 0
    return m


def test_a_branch_running_on_past_the_parent_is_no_fork():
    fork, out, s_far = np.array([300.0, 200.0]), np.array([1.0, 0.0]), 22.0
    assert not passes_through(_parent_and("r"), fork, out, s_far, 6.0)
    assert passes_through(_parent_and("lr"), fork, out, s_far, 6.0)
    # past an apple or a leaf on the far side too
    assert passes_through(_parent_and("lr", gap=(230, 280)), fork, out, s_far, 6.0)
    # something much wider there (another trunk) is not the branch running on
    wide = _parent_and("r")
    wide[150:260, 180:270] = 255
    assert not passes_through(wide, fork, out, s_far, 6.0)
