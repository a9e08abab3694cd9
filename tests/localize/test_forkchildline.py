"""The fork from the child's outline middles (``EndPlacer._fork_from_child_outline``): a straight child
meets the parent's axis at its fork. (A child turning near the parent is placed 3-6 px off by the
turn; a curve through three middles was measured and not kept: docs/localize-forkplace.md, second
pass.)"""

import cv2
import numpy as np
import pytest
from appliance.localize.ends import EndPlacer


def _bent_y(r_par: float, r_child: float, angle_deg: float, turn_deg_per_px: float, fork=(200.0, 260.0)):
    """A binary mask (400 x 400) of a straight upright parent with a child leaving the fork at
    ``angle_deg`` from it and turning away from it by ``turn_deg_per_px`` per px of its axis over its
    first 40 px (then straight); returns (mask, fork, parent dir, child dir 60 px out, a point there)."""
    ss = 4
    f = np.asarray(fork, float)
    e_par = np.array([0.0, -1.0])
    a = np.radians(angle_deg) + np.radians(turn_deg_per_px) * np.minimum(np.arange(0.0, 200.0), 40.0)
    steps = np.stack([np.sin(a), -np.cos(a)], 1)
    axis = f + np.vstack([[0.0, 0.0], np.cumsum(steps, 0)])
    big = np.zeros((400 * ss, 400 * ss), np.uint8)
    px = lambda p: (int(round((p[0] + 0.5) * ss - 0.5)), int(round((p[1] + 0.5) * ss - 0.5)))
    cv2.line(big, px(f - 300 * e_par), px(f + 300 * e_par), 255, int(round(2 * r_par * ss)))
    cv2.polylines(big, [np.array([px(p) for p in axis], np.int32)], False, 255, int(round(2 * r_child * ss)))
    grey = cv2.resize(big, (400, 400), interpolation=cv2.INTER_AREA)
    return ((grey >= 128) * 255).astype(np.uint8), f, e_par, steps[60], axis[60]


@pytest.mark.parametrize("r_par, r_child, angle_deg", [(22.0, 9.0, 40.0), (26.0, 10.0, 30.0), (18.0, 8.0, 60.0)])
def test_a_straight_child_meets_the_parent_at_its_fork(r_par, r_child, angle_deg):
    mask, f, e_par, e_ch, c2 = _bent_y(r_par, r_child, angle_deg, 0.0)
    xy = EndPlacer._fork_from_child_outline(None, f, e_par, c2, e_ch, f, r_par, r_child, mask)
    assert xy is not None and np.hypot(*(xy - f)) <= 1.0

