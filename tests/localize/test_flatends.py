"""A short flat piece's texture line (issue 5, docs/localize-flatends.md)."""

import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer


def test_a_clean_short_line_is_told_from_a_curving_one():
    # seed 415's piece 20 (34 px, 6 patches, 156.34 -> 153.91 px: max residual 0.18 px) against seed 119's
    # piece 6 (46 px, U-shaped 158.46 .. 158.07 .. 160.65 px) and one patch unmatched
    from appliance.localize.dense import _short_line_clean
    u = np.arange(900.0, 931.0, 6.0)
    d = np.array([156.34, 156.02, 155.48, 154.84, 154.15, 153.91])
    assert _short_line_clean(d, np.full(6, 0.99), u)
    u2 = np.arange(329.0, 372.0, 6.0)
    d2 = np.array([158.46, 158.34, 158.07, 158.29, 158.66, 158.96, 159.62, 160.65])
    assert not _short_line_clean(d2, np.full(8, 0.97), u2)
    d3 = d.copy()
    d3[2] = np.nan
    assert not _short_line_clean(d3, np.full(6, 0.99), u)


@pytest.mark.parametrize("short_line_px", [100.0, 30.0])
def test_a_fork_at_the_end_of_a_short_piece_turning_in_depth(rendered_scene, monkeypatch, short_line_px):
    # seed 415's fork 9 (Z 1144 mm, colour masks): its parent piece (34 px) reads 156.3 -> 153.9 px along its
    # bark; its constant disparity (the rule off) put the fork +1.0 px, 6.6 mm too near. Its line (level
    # beyond the piece's span) puts it within 1 mm.
    import appliance.localize.dense as dense
    from appliance.synth.evaluate import score_result
    monkeypatch.setattr(dense, "SHORT_LINE_MIN_PX", short_line_px)
    left, right, truth, calib = rendered_scene(415)
    res = Localizer(calib, load_config().localize).localize(left, right)
    row = next(r for r in score_result(res, truth).rows if r.truth_index == 9)
    assert row.kind == "bifurcation" and row.result_id >= 0
    if short_line_px < 100:
        assert abs(row.dz_mm) <= 1.0
    else:
        assert row.dz_mm <= -5.0
