"""Colour recogniser clean-up: small components go, branches stay."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.localize.segment import drop_small


@pytest.mark.parametrize("size", [(240, 320), (243, 317)])     # blocks aligned with the image, and not
def test_drop_small_removes_specks_and_keeps_branches(size):
    h, w = size
    m = np.zeros(size, np.uint8)
    cv2.line(m, (10, 10), (w - 20, h - 30), 255, 5)             # a branch: ~1500 px
    cv2.circle(m, (w - 40, 30), 6, 255, -1)                    # a speck: ~110 px
    m[h - 2:, :3] = 255                                        # a speck in the corner
    out = drop_small(m, 400)
    assert out[30, w - 40] == 0 and not out[h - 2:, :3].any()
    branch = m.copy()
    branch[:60, w - 60:] = 0
    branch[h - 2:, :3] = 0
    assert np.array_equal(out, branch)                         # the branch is untouched, pixel for pixel
    assert drop_small(m, 5) is m                               # nothing to drop: the mask itself
