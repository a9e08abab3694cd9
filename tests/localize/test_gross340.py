"""The worst features of seeds 324-355 (issue 5, docs/localize-gross340.md)."""

from dataclasses import replace

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.localize.tips import right_flanks_filled


def _capped_branch(shape, y, x_end, r):
    """A horizontal branch (radius ``r`` px) along row ``y`` from column 0 to a round cap ending at ``x_end``."""
    m = np.zeros(shape, np.uint8)
    cv2.rectangle(m, (0, y - r), (x_end - r, y + r), 255, -1)
    cv2.circle(m, (x_end - r, y), r, 255, -1)
    return m


@pytest.mark.parametrize("touching", [False, True])
def test_a_branch_beside_the_cap_in_the_right_view_only_fills_its_flanks(touching):
    # seed 340's tip 13 (drawn): a flat branch's cap, 9 px radius, ending at column 300 (left) and 250 (right,
    # disparity 50); in the right view a nearer upright branch (12 px wide) covers the cap's end: the
    # right row runs end at its far edge, a straight outline 10 px further (the end read 10 px off)
    r, y = 9, 100
    left = _capped_branch((200, 400), y, 300, r)
    right = _capped_branch((200, 400), y, 250, r)
    if touching:
        cv2.rectangle(right, (248, 40), (259, 160), 255, -1)
    d_end = 300.0 - 260.0 if touching else 50.0          # the right run's end: the upright's far edge
    out = np.array([1.0, 0.0])
    assert right_flanks_filled(left, right, np.array([300.0, float(y)]), out, d_end, r) is touching
    # the left view's own flanks filled alike (a branch beside the cap in both views): not the right's alone
    if touching:
        cv2.rectangle(left, (288, 40), (299, 160), 255, -1)
        assert not right_flanks_filled(left, right, np.array([300.0, float(y)]), out, d_end, r)


@pytest.fixture
def scene_340(rendered_scene):
    """Rendered scene 340 (the benchmark's seed) and the rig's calibration."""
    return rendered_scene(340)


@pytest.mark.parametrize("masks", ["true", "colour"])
@pytest.mark.parametrize("flank_check", [False, True])
def test_a_flat_tip_behind_a_branch_in_the_right_view_keeps_no_end_from_it(scene_340, monkeypatch, masks,
                                                                         flank_check):
    # seed 340's tip 13 (Z 820 mm): a short flat piece's texture read the tip right (213.7 px, truth 213.9);
    # in the right view a nearer upright branch covers the cap and its row runs end at the upright's far
    # edge, straight across the rows (the outline check agrees): the run end (202.7 px) replaced the
    # texture's, +45 mm. With the flanks checked the run end is not taken (the tip is withheld: its end
    # in the right view is not its own). The feature check (its wide search) withholds the +45 mm reading
    # too: it is off here, so that this mechanism is tested alone.
    from dataclasses import replace
    import appliance.localize.tips as tips
    from appliance.synth.evaluate import score_result
    if not flank_check:
        monkeypatch.setattr(tips, "FLANK_SHARE", 2.0)
    left, right, truth, calib = scene_340
    kw = dict(mask_left=truth.mask_left, mask_right=truth.mask_right) if masks == "true" else {}
    cfg = load_config().localize
    cfg = replace(cfg, feature_check=replace(cfg.feature_check, enabled=False))
    res = Localizer(calib, cfg).localize(left, right, **kw)
    row = next(r for r in score_result(res, truth).rows if r.truth_index == 13)
    assert row.kind == "endpoint"
    if flank_check:
        assert row.result_id < 0 or abs(row.dz_mm) <= 3.0
    else:
        assert row.result_id >= 0 and row.dz_mm >= 40.0


@pytest.fixture
def scene_355(rendered_scene):
    """Rendered scene 355 (the benchmark's seed) and the rig's calibration."""
    return rendered_scene(355)


@pytest.mark.parametrize("apart_check", [False, True])
def test_a_fork_whose_parent_sides_are_far_apart_in_depth_is_withheld(scene_355, monkeypatch, apart_check):
    # seed 355's fork 7 (Z 763 mm, colour masks): the parent runs in front of a thicker branch whose
    # silhouette holds it; one side is that thicker branch's piece (210 px at the fork), the other a side
    # fitted on 11 rows carried 79 rows (248 px), the child carried 77 px (238): truth 230.5. The median
    # (238) then the one side reaching the fork (210) were taken: +74 mm. Sides 38 px apart, where carrying
    # explains 4 + 0.1 * 79 px: withheld.
    import appliance.localize.forkends as forkends
    from appliance.synth.evaluate import score_result
    monkeypatch.setattr(forkends, "SIDES_APART_WITHHELD", apart_check)
    left, right, truth, calib = scene_355
    res = Localizer(calib, load_config().localize).localize(left, right)
    row = next(r for r in score_result(res, truth).rows if r.truth_index == 7)
    assert row.kind == "bifurcation"
    if apart_check:
        assert row.result_id < 0 or abs(row.dz_mm) <= 3.0
    else:
        assert row.result_id >= 0 and row.dz_mm >= 60.0


@pytest.mark.parametrize("max_shift_px", [3.0, 2.0])
def test_a_flat_parents_fork_is_not_moved_over_2_px_by_its_childs_right_outline(rendered_scene, monkeypatch,
                                                                              max_shift_px):
    # seed 328's fork 14 (Z 1269 mm, colour masks): the flat parent's texture reads 137.35 px (truth 137.88),
    # the child (no curve of its own) leaves it in the right view's outline at 135.05: 2.3 px off the texture,
    # within the old 3 px bound, taken: +27 mm. Bound at 2 px the texture stands (-0.5 px). (With the brown-only
    # colour recogniser the case was found: seggrey's olive and grey tests move this mask and the fork to +4.9 mm
    # under either bound.)
    import appliance.localize.forkends as forkends
    from appliance.synth.evaluate import score_result
    monkeypatch.setattr(forkends, "OUTLINE_MAX_SHIFT_PX", max_shift_px)
    left, right, truth, calib = rendered_scene(328)
    cfg = load_config().localize
    cfg = replace(cfg, segment=replace(cfg.segment, olive_saturation_max=0, grey_chroma_max=0))
    res = Localizer(calib, cfg).localize(left, right)
    row = next(r for r in score_result(res, truth).rows if r.truth_index == 14)
    assert row.kind == "bifurcation"
    if max_shift_px == 2.0:
        assert row.result_id < 0 or abs(row.dz_mm) <= 6.0
    else:
        assert row.result_id >= 0 and row.dz_mm >= 20.0
