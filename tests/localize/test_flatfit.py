"""Trust checks on a flat piece's texture line (localize/flatfit.py)."""
import cv2
import numpy as np

from appliance.localize.flatfit import at_window_edge_dropped, line_supported, scatter_ok
from appliance.localize.texture import surface_disparity


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


def test_disparities_at_the_search_windows_ends_are_dropped():
    # the fine search around a prior of 209.6 px runs over whole px 203 ... 216
    d = np.array([203.0, 204.5, 210.47, 216.0, 215.99, np.nan])
    out = at_window_edge_dropped(d, (203.6, 215.6))
    assert np.isnan(out[[0, 3, 5]]).all()
    assert np.allclose(out[[1, 2, 4]], [204.5, 210.47, 215.99])


def test_a_texture_search_whose_peak_lies_beyond_the_window_is_dropped():
    # a real search: bark shifted by 20 px, searched over 8 ... 14 px: the best is the window's end
    rng = np.random.default_rng(3)
    left = cv2.GaussianBlur(rng.uniform(0, 255, (40, 200)).astype(np.float32), (0, 0), 6) * 20   # smooth bark
    right = np.roll(left, -20, axis=1)
    uv = np.array([[100.0, 20.0], [120.0, 20.0]])
    window = (8.0, 14.0)
    d, _ = surface_disparity(left, right, uv, np.array([5, 5]), window, half_w_px=12)
    assert np.allclose(d, 14.0)                     # (clamped to the window's end)
    assert np.isnan(at_window_edge_dropped(d, window)).all()
    d_ok, _ = surface_disparity(left, right, uv, np.array([5, 5]), (16.0, 24.0), half_w_px=12)
    assert np.allclose(at_window_edge_dropped(d_ok, (16.0, 24.0)), 20.0, atol=0.05)


def test_a_line_from_few_patches_scattered_over_px_is_not_trusted():
    # seed 149 colour piece 12's kind: 7 patches 205-212 px about a line (MAD ~1.3-2 px)
    r = np.array([-2.1, 1.8, -1.5, 2.4, -0.4, 1.6, -2.6])
    assert not scatter_ok(r, 1)
    assert scatter_ok(0.2 * r, 1)                    # bark matched to 0.3 px: fine
    assert scatter_ok(np.tile(r, 4), 1)              # 28 patches: the line's own bend, not judged


def test_a_constant_from_three_patches_px_apart_is_not_trusted():
    assert not scatter_ok(np.array([-4.0, 0.5, 4.6]), 0)
    assert scatter_ok(np.array([-0.4, 0.1, 0.5]), 0)
    assert scatter_ok(np.array([-4.0, 0.5, 4.6, -3.0, 3.5, 0.0, 2.8]), 0)   # 7 patches: not judged
