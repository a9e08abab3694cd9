"""forkends: the helpers of ForkPlacing that need no scene."""

import numpy as np
import pytest

from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.forkends import walk_reach_t


@pytest.mark.parametrize("by_row", [True, False])
@pytest.mark.parametrize("deg", [0.0, 24.0, 60.0])
def test_a_hidden_ends_walk_reaches_its_px_along_the_branch_whatever_its_slant(by_row, deg):
    # a straight piece at `deg` to its parameter's axis (rows of a steep piece, columns of a flat one),
    # walked out past either end: the walk's length in the image is the reach in px, not in rows
    t = np.linspace(100.0, 300.0, 21)
    s_poly = Poly.fit(t, 50.0 + np.tan(np.radians(deg)) * t, 1)
    c = BranchCurve(0, by_row, (100.0, 300.0), s_poly, Poly.fit(t, 150.0 + 0.0 * t, 1), 5.0, 21)
    for t_edge, sign in ((300.0, 1.0), (100.0, -1.0)):
        reach_t = walk_reach_t(c, t_edge, sign, 80.0)
        uv = c.uv_at(np.array([t_edge, t_edge + sign * reach_t]))
        assert np.hypot(*(uv[1] - uv[0])) == pytest.approx(80.0, abs=1e-6)
        assert reach_t == pytest.approx(80.0 * np.cos(np.radians(deg)), abs=1e-6)
