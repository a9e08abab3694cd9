"""Trust checks on a flat piece's texture line (localize/flatfit.py)."""
import numpy as np

from appliance.localize.flatfit import line_supported


def test_a_line_through_three_clustered_patches_is_not_supported():
    # seed 126's case: 21 patches along 122 px, the line kept 3 of them within 12 px
    u = np.arange(0.0, 123.0, 6.0)
    assert not line_supported(u[8:11], len(u), 0.0, 122.0)


def test_a_line_through_six_patches_is_not_supported_even_spread():
    u = np.arange(0.0, 110.0, 6.0)
    assert not line_supported(u[::3][:6], len(u), 0.0, 109.0)


def test_a_line_through_few_patches_bunched_at_one_end_is_not_supported():
    u = np.arange(0.0, 301.0, 6.0)                 # 51 patches
    assert not line_supported(u[:9], len(u), 0.0, 300.0)       # 9 inliers over 48 px of 300


def test_a_line_through_a_third_of_the_patches_spread_out_is_supported():
    # seed 143 colour piece 14's kind: 8 of 33 patches over 22 % of the piece (0 mm off)
    u = np.arange(0.0, 196.0, 6.0)
    assert line_supported(u[10:18], len(u), 0.0, 195.0)
    assert line_supported(u[::2], len(u), 0.0, 195.0)
