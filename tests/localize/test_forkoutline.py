"""forkoutline: the right view's outline check of a shallow child, made in disparity."""

import math

import numpy as np
from appliance.localize.forkoutline import SHALLOW_D_PX, shallow_outline_agrees


def _dirs(parent_deg: float, child_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (x, y) of a parent axis and a child at the given image angles (deg from the rows)."""
    a, b = math.radians(parent_deg), math.radians(child_deg)
    return np.array([math.cos(a), math.sin(a)]), np.array([math.cos(b), math.sin(b)])


def _moved_by_depth(er: np.ndarray, e2: np.ndarray, d_px: float) -> np.ndarray:
    """Where a child at ``d_px`` of disparity from the parent crosses the parent's axis in the right view,
    from the parent's own fork place: the child's line moved along the rows by ``d_px`` meets the axis
    ``d_px |e2_y| / sin(a)`` further along it."""
    # the child's line through (-d, 0) with direction e2 meets the parent's line t er at t:
    # t er = (-d, 0) + s e2 -> t (er x e2) = (-d, 0) x e2
    t = (-d_px * e2[1]) / (er[0] * e2[1] - er[1] * e2[0])
    return t * er


def test_a_shallow_child_at_the_parents_depth_agrees_though_its_places_lie_px_apart():
    er, e2 = _dirs(95.0, 121.0)          # a near-vertical parent, the child leaving it at 26 deg
    sin_a = abs(er[0] * e2[1] - er[1] * e2[0])
    assert sin_a < 0.45
    # each view's place is off by a ~0.45 px error of the child's line carried back at 1 / sin: ~2 px
    # apart along the parent (the ordinary 1.6 px check refuses), no depth difference
    off = 2.0 * er
    assert np.hypot(*off) > 1.6
    assert shallow_outline_agrees(off, er, er, er, e2, 1.6)


def test_a_shallow_child_at_another_depth_is_refused():
    er, e2 = _dirs(95.0, 121.0)
    # a branch 1 px of disparity off the parent's depth passes; 2 px and more do not (both senses)
    assert shallow_outline_agrees(_moved_by_depth(er, e2, 1.0), er, er, er, e2, 1.6)
    for d in (2.0, -2.0, 5.0, -12.0):
        assert not shallow_outline_agrees(_moved_by_depth(er, e2, d), er, er, er, e2, 1.6)
    assert SHALLOW_D_PX < 2.0


def test_a_child_nearly_along_its_parent_keeps_the_ordinary_check():
    # at 12 deg a px of depth moves the place ~5 px, but so does a 1 px error of the child's outline line
    er, e2 = _dirs(95.0, 107.0)
    assert abs(e2[1]) / abs(er[0] * e2[1] - er[1] * e2[0]) > 4.0
    assert not shallow_outline_agrees(2.5 * er, er, er, er, e2, 1.6)


def test_the_offset_across_the_parent_keeps_the_ordinary_tolerance():
    er, e2 = _dirs(95.0, 121.0)
    across = np.array([er[1], -er[0]])
    assert shallow_outline_agrees(1.0 * er + 1.2 * across, er, er, er, e2, 1.6)
    assert not shallow_outline_agrees(1.0 * er + 2.0 * across, er, er, er, e2, 1.6)


def test_a_steep_angle_or_a_child_near_the_rows_keeps_the_ordinary_check():
    # a child leaving at 80 deg: a px of depth moves the place by about |e2_y| px, no more: no second check
    er, e2 = _dirs(90.0, 10.0)
    assert abs(e2[1]) / abs(er[0] * e2[1] - er[1] * e2[0]) <= 1.0
    assert not shallow_outline_agrees(0.5 * er, er, er, er, e2, 1.6)
    # a child along the rows on a steep parent: its depth barely moves its place (refused before this)
    er, e2 = _dirs(80.0, 5.0)
    assert not shallow_outline_agrees(0.3 * er, er, er, er, e2, 1.6)


def test_a_parent_line_off_the_line_through_both_sides_keeps_the_ordinary_check():
    # the outline's parent line is one bent side (or the wrong pair of pieces): 12 deg off the line
    # through both sides, the gain is not the fork's
    er, e2 = _dirs(95.0, 121.0)
    off = 2.0 * er
    assert shallow_outline_agrees(off, er, er, _dirs(101.0, 0.0)[0], e2, 1.6)       # 6 deg: stands
    assert not shallow_outline_agrees(off, er, er, _dirs(107.0, 0.0)[0], e2, 1.6)   # 12 deg
    assert not shallow_outline_agrees(off, er, er, _dirs(28.0, 0.0)[0], e2, 1.6)    # 67 deg
