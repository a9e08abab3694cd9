"""Dense matching: flat pieces' texture candidates agree or not."""

import numpy as np
from appliance.localize.dense import _coarse_agree


def test_coarse_texture_disparities_agree_or_not():
    u = np.array([100.0, 130.0, 160.0, 190.0, 220.0, 250.0])
    assert _coarse_agree(u[:1], np.array([150.0]))                    # one: nothing to tell
    assert _coarse_agree(u[:2], np.array([150.0, 154.0]))
    assert not _coarse_agree(u[:2], np.array([150.0, 170.0]))           # two matches far apart
    assert not _coarse_agree(u[:3], np.array([173.7, 193.9, 262.2]))    # fixture 03 piece 15: -107 mm
    assert _coarse_agree(u[:3], np.array([168.0, 168.3, 188.7]))
    # along a long piece the disparity changes: a line through most of them
    assert _coarse_agree(u, 200.0 + 0.2 * (u - 100.0) + np.array([0, 0.5, -0.5, 0, 30.0, 0]))
    assert not _coarse_agree(u, np.array([150.0, 190.0, 160.0, 120.0, 175.0, 260.0]))


def test_flat_piece_with_patches_past_the_views_edge_is_not_an_index_error():
    """A flat piece near the bottom of the view whose line runs past the last row there (a fresh
    rendered scene, seed 181, raised IndexError): patches off the view are not on the right mask."""
    from types import SimpleNamespace
    from appliance.localize.curves import Poly
    from appliance.localize.dense import _flat_finish

    h, w = 96, 128
    sm = SimpleNamespace(right_mask=np.full((h, w), 255, np.uint8), f_px=1000.0, offset_px=0.0)   # (as StereoMasks)
    b = SimpleNamespace(sm=sm, g=SimpleNamespace(seg_nodes={0: [-1, -1]}), uvd={}, place_pending=lambda n: None)
    u = np.arange(10.0, 110.0, 10.0)
    uv = np.stack([u, np.linspace(90.0, 97.0, len(u))], 1)          # the last patches' rows past row 95
    d = np.full(len(u), np.nan)
    d[-3:] = 4.0                                                      # only the patches off the view matched
    score = np.ones(len(u))
    assert _flat_finish(b, 0, Poly.constant(93.0), 3.0, 10.0, 100.0, u, uv, (d, score)) is None
