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
