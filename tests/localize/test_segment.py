"""Colour recogniser clean-up: small components go, branches stay."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.localize.segment import drop_small, hsv_bark


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


def _config(**kw):
    import dataclasses

    from appliance.config.load import load_config
    return dataclasses.replace(load_config().localize.segment, **kw)


@pytest.mark.parametrize("hues", [(0, 30), (170, 20)])      # plain, and wrapping past 180
def test_colour_table_at_8_bits_is_the_hsv_rule(hues):
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (200, 300, 3), dtype=np.uint8)
    img[:100] //= 2                                            # plenty of dark, grey-brown (bark-like) colours
    exact = _config(colour_bits=0, hue_min=hues[0], hue_max=hues[1])
    bark0, occ0 = hsv_bark(img, exact)
    assert 0 < np.count_nonzero(bark0) < bark0.size and np.count_nonzero(occ0)
    bark8, occ8 = hsv_bark(img, _config(colour_bits=8, hue_min=hues[0], hue_max=hues[1]))
    assert np.array_equal(bark0, bark8) and np.array_equal(occ0, occ8)
    bark6, occ6 = hsv_bark(img, _config(colour_bits=6, hue_min=hues[0], hue_max=hues[1]))
    assert 0.9 < np.count_nonzero(bark6 == bark0) / bark0.size < 1   # quantised: close, not equal
    assert hsv_bark(img, exact, occluder=False)[1] is None
