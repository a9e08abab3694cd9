"""The worst features of seeds 292-323 (issue 5, docs/localize-gross308.md)."""

import pytest
from appliance.config import load_config
from appliance.localize import Localizer


@pytest.fixture
def scene_308(rendered_scene):
    """Rendered scene 308 (the benchmark's seed) and the rig's calibration."""
    return rendered_scene(308)


@pytest.mark.parametrize("masks", ["true", "colour"])
@pytest.mark.parametrize("lone_taper", [False, True])
def test_a_fork_on_a_lone_flat_side_reads_its_texture_with_the_radius_at_the_fork(scene_308, monkeypatch, masks,
                                                                                  lone_taper):
    # seed 308's fork 12: a flat parent tapering 14.7 -> 4.5 mm, fitted on one side of the fork only (the
    # other, thicker side without a curve); its bark texture next to the fork was moved back to the axis
    # with the fitted side's mean radius (15.9 px) where the parent is 22 px thick: +1.0 px (-4.4 mm), and
    # with the colour masks the child's right outline then took the fork to +2.2 px (-9.2 mm). With the
    # radius tapered towards the other side's (measured next to the fork) the texture reads +0.15 px.
    import appliance.localize.forkends as forkends
    from appliance.synth.evaluate import score_result
    monkeypatch.setattr(forkends, "LONE_TAPER", lone_taper)
    left, right, truth, calib = scene_308
    kw = dict(mask_left=truth.mask_left, mask_right=truth.mask_right) if masks == "true" else {}
    res = Localizer(calib, load_config().localize).localize(left, right, **kw)
    row = next(r for r in score_result(res, truth).rows if r.truth_index == 12)
    assert row.kind == "bifurcation" and row.result_id >= 0
    if lone_taper:
        assert abs(row.dz_mm) <= 1.5
    else:
        assert row.dz_mm <= -3.5


@pytest.mark.parametrize("towards_child", [False, True])
def test_a_flat_parents_fork_takes_its_childs_right_outline_only_towards_the_childs_curve(scene_308, monkeypatch,
                                                                                          towards_child):
    # the same fork with the lone side's taper off (its texture +1.0 px): with the colour masks the child's
    # right outline (+2.2 px) was taken over it, though further than the parent's reading from the child's
    # own curve (-0.7 px); with the outline rule bound towards the child it stays at the texture's +1.0 px
    import appliance.localize.forkends as forkends
    from appliance.synth.evaluate import score_result
    monkeypatch.setattr(forkends, "LONE_TAPER", False)
    monkeypatch.setattr(forkends, "OUTLINE_TOWARDS_CHILD", towards_child)
    # (the texture read next to the fork now keeps the outline off whatever the child: test_fork356)
    monkeypatch.setattr(forkends, "OUTLINE_NOT_OVER_TEXTURE", False)
    left, right, truth, calib = scene_308
    res = Localizer(calib, load_config().localize).localize(left, right)
    row = next(r for r in score_result(res, truth).rows if r.truth_index == 12)
    assert row.kind == "bifurcation"
    if towards_child:
        assert row.result_id < 0 or abs(row.dz_mm) <= 5.0
    else:
        assert row.result_id >= 0 and row.dz_mm <= -8.0
