"""The parent's axis at a fork from its cross-sections (appliance.localize.forkplace), and the fork
placed against it."""

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.localize.ends import EndPlacer
from appliance.localize.forkplace import parent_axis

from .shapes import ideal_rig, y_pair

CFG = load_config().localize


def _y_mask(r_par: float, r_child: float, angle_deg: float, fork=(200.0, 260.0), tilt_deg: float = 8.0):
    """A binary mask (400 x 400) of a straight parent (tilted ``tilt_deg`` from the columns) with a
    child leaving it at ``angle_deg`` from the fork ``fork``; returns (mask, fork, parent dir, child dir)."""
    ss = 4
    f = np.asarray(fork, float)
    t = np.radians(tilt_deg)
    e_par = np.array([np.sin(t), -np.cos(t)])                   # upwards
    a = t + np.radians(angle_deg)
    e_ch = np.array([np.sin(a), -np.cos(a)])
    big = np.zeros((400 * ss, 400 * ss), np.uint8)
    px = lambda p: (int(round((p[0] + 0.5) * ss - 0.5)), int(round((p[1] + 0.5) * ss - 0.5)))
    cv2.line(big, px(f - 300 * e_par), px(f + 300 * e_par), 255, int(round(2 * r_par * ss)))
    cv2.line(big, px(f), px(f + 200 * e_ch), 255, int(round(2 * r_child * ss)))
    grey = cv2.resize(big, (400, 400), interpolation=cv2.INTER_AREA)
    return ((grey >= 128) * 255).astype(np.uint8), f, e_par, e_ch


@pytest.mark.parametrize("r_par, r_child, angle_deg", [(26.0, 10.0, 30.0), (30.0, 14.0, 40.0)])
def test_a_fork_on_a_thick_parent_is_placed_at_the_axes_meeting_point(r_par, r_child, angle_deg):
    # the parent's line taken near the crotch is pulled towards the child (here: 3 px and 3 deg);
    # the child's outline against it places the fork several px off along the parent; against
    # the axis from the parent's cross-sections clear of the crotch, within 1 px
    mask, f, e_par, e_ch = _y_mask(r_par, r_child, angle_deg)
    n = np.array([-e_par[1], e_par[0]])
    n = n if n @ e_ch > 0 else -n
    turn = np.radians(3.0)
    e_bad = np.cos(turn) * e_par + np.sin(turn) * n
    c_bad = f + 3.0 * n - 40.0 * e_bad
    c2 = f + 60.0 * e_ch
    xy_bad = EndPlacer._fork_from_child_outline(None, c_bad, e_bad, c2, e_ch, c_bad, r_par, r_child, mask)
    assert xy_bad is not None and np.hypot(*(xy_bad - f)) > 3.0
    ax = parent_axis(mask, xy_bad, e_bad, e_ch, r_par, r_par, r_child)
    assert ax is not None
    c, e = ax
    assert abs((f - c) @ np.array([-e[1], e[0]])) <= 0.3            # the true axis through the fork
    assert abs(e[0] * e_par[1] - e[1] * e_par[0]) <= np.sin(np.radians(0.5))
    xy = EndPlacer._fork_from_child_outline(None, c, e, c2, e_ch, c, r_par, r_child, mask)
    assert xy is not None and np.hypot(*(xy - f)) <= 1.0


def test_a_parent_axis_needs_sections_of_the_parents_own_width():
    # sections of another width than the parent's (here the parent's radius read 1.75 times too
    # large, as next to a crotch): none counts, no axis is made
    mask, f, e_par, e_ch = _y_mask(20.0, 10.0, 40.0)
    assert parent_axis(mask, f, e_par, e_ch, 35.0, 35.0, 10.0) is None


def test_a_drawn_y_with_a_thick_parent_and_a_shallow_child_has_its_fork_within_1_px():
    calib = ideal_rig()
    left, right, ml, mr, fork, d = y_pair(calib, 1000.0, 35.0, parent_radius_px=28.0, child_radius_px=14.0,
                                          fork=(250.0, 330.0))
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    forks = [f for f in res.features if f.kind == "bifurcation"]
    assert len(forks) == 1
    assert np.hypot(*np.subtract(forks[0].left_px, fork)) <= 1.0
    assert abs((forks[0].left_px[0] - forks[0].right_px[0]) - d) <= 0.3
