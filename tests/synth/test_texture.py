"""synth.texture.lookup: more points than one cv2.remap call takes are looked up in pieces, the same values."""

import numpy as np
from appliance.synth.texture import lookup


def test_lookup_in_pieces_gives_the_same_values():
    rng = np.random.default_rng(3)
    tex = rng.random((64, 96, 3)).astype(np.float32)
    u, v = rng.uniform(-200, 300, 5000), rng.uniform(-100, 150, 5000)
    whole = lookup(tex, u, v)
    assert whole.shape == (5000, 3)
    pieces = lookup(tex, u, v, max_rows=2)           # 2048 points per remap call: 3 calls
    np.testing.assert_array_equal(pieces, whole)
    # wrapping bilinear lookup: a texel centre gives the texel
    assert np.allclose(lookup(tex, np.array([5.0 + 96]), np.array([7.0 - 64])), tex[7, 5])
