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


def test_colour_recogniser_finds_bark_and_tells_leaves_at_points():
    from appliance.config import load_config
    from appliance.localize.segment import occluder_at, segment_color

    cfg = load_config().localize.segment
    img = np.full((120, 160, 3), (235, 206, 135), np.uint8)     # sky (BGR)
    cv2.rectangle(img, (70, 0), (90, 119), (40, 60, 90), -1)     # brown-grey bark, a vertical branch
    cv2.circle(img, (30, 60), 15, (40, 170, 60), -1)             # a green leaf
    mask, hsv = segment_color(img, cfg)
    assert mask[:, 72:88].all() and not mask[:, :65].any() and not mask[:, 95:].any()
    got = occluder_at(hsv, np.array([[30, 60], [80, 60], [150, 10], [-5, 60], [30, 200]]), cfg)
    assert got.tolist() == [True, False, False, False, False]


def test_reddish_grey_bark_is_bark_but_a_red_apple_is_not():
    """Bark with a little more blue than green (hue ~178, past the wrap) is still bark; a red
    apple of the same hue is far more saturated."""
    from appliance.config import load_config
    from appliance.localize.segment import segment_color

    cfg = load_config().localize.segment
    img = np.full((120, 160, 3), (235, 206, 135), np.uint8)     # sky (BGR)
    cv2.rectangle(img, (70, 0), (90, 119), (80, 76, 125), -1)    # reddish grey bark, B > G
    cv2.circle(img, (30, 60), 15, (30, 30, 180), -1)             # a red apple
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    assert hsv[60, 80, 0] > 170 and hsv[60, 30, 0] < 5          # hues on both sides of the wrap
    mask, _ = segment_color(img, cfg)
    assert mask[:, 72:88].all() and not mask[:, :65].any()
