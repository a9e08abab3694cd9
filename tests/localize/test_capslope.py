"""capslope.py: a steep tip's cap reading taken back to its cap's centre along the piece's gradient."""

import numpy as np
import pytest
from appliance.localize.capslope import SLOPE_SHARE, curve_slope, slope_corrected


def test_curve_slope_reads_a_linear_disparity_outward_per_image_px():
    def d_at(t):
        return 100.0 - 0.2 * np.asarray(t, float)       # disparity falls as t (the row) grows

    # the tip at t = 50 going out with growing t: -0.2 px per row, rows 1.25 px apart along the line
    assert curve_slope(d_at, 50.0, (0.0, 50.0), 1.0, 6.0, 1.25) == pytest.approx(-0.16)
    # the tip at t = 0 going out with falling t: +0.2 per row outward
    assert curve_slope(d_at, 0.0, (0.0, 50.0), -1.0, 6.0, 1.0) == pytest.approx(0.2)
    # a piece shorter than one row has no gradient
    assert curve_slope(d_at, 10.0, (10.0, 10.5), 1.0, 6.0, 1.0) is None


def test_slope_corrected_moves_only_a_centre_placed_behind_the_caps_own():
    # P 2 px behind the cap's centre on a piece whose disparity falls 0.1 px per px outward: the rows
    # read the body's larger disparity; the reading is taken down by the share of 0.1 * 2
    assert slope_corrected(150.0, -0.1, 8.0, 6.0) == pytest.approx(150.0 - SLOPE_SHARE * 0.2)
    assert slope_corrected(150.0, -0.1, 8.0, 6.0) < 150.0
    # P at or ahead of the cap's centre, or a piece of constant depth: unchanged
    assert slope_corrected(150.0, -0.1, 6.0, 6.5) == 150.0
    assert slope_corrected(150.0, 0.0, 8.0, 6.0) == 150.0
