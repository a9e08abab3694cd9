"""forkcross.py: a thin branch crossing in front of a thick one, taken for a fork (docs/localize-cross28.md)."""

import pytest
from appliance.localize import forkcross
from appliance.localize.forkcross import crossing_in_front, front_step_px

F_PX = 1452.0       # the rig's focal length (fixtures/rig.yaml)


@pytest.mark.parametrize("z_mm, r_mm", [(837.0, 20.8), (500.0, 10.0), (1400.0, 40.0)])
def test_the_front_step_is_the_disparity_of_the_surface_one_radius_nearer_than_the_axis(z_mm, r_mm):
    # d = f b / Z; the front surface at Z - R; the branch's radius in the image r = f R / Z
    fb = F_PX * 60.0
    d_axis, d_front = fb / z_mm, fb / (z_mm - r_mm)
    step = front_step_px(d_axis, F_PX * r_mm / z_mm, F_PX)
    # first order in R / Z: the exact step is larger by the factor Z / (Z - R)
    assert step == pytest.approx(d_front - d_axis, rel=1.05 * r_mm / z_mm)
    assert step < d_front - d_axis


def test_seed_910_t10s_node_is_a_crossing_in_front():
    # seed 910's node 6 (exact masks): trunk pieces of radius 34 and 36 px straight through (cos -0.99), the thin
    # branch 8.5 px, the fork at the trunk's 204.39 px, the thin branch's curve there 207.52 px (+3.13: 0.62 of the
    # trunk's front step 5.07 px); the true fork 209.32 px
    assert crossing_in_front((34.0, 36.0), -0.99, 8.5, 204.39, 207.52, F_PX)
    # seed 132's node 6 (a false fork of the same kind): +3.44 px, trunk 38.3 px
    assert crossing_in_front((35.2, 38.3), -1.0, 7.9, 205.91, 209.35, F_PX)


@pytest.mark.parametrize("d_child", [None, 204.39, 205.2, 214.0])
def test_a_thin_child_whose_curve_meets_the_parents_axis_or_runs_wild_is_a_fork(d_child):
    # at the parent's disparity, 0.8 px in front (under 0.4 of the step and ... ), 9.6 px in front (over 1.5 steps:
    # seed 538 T3's child curve carried wild, +65 px, a correct fork), or no curve: no crossing read
    assert not crossing_in_front((34.0, 36.0), -0.99, 8.5, 204.39, d_child, F_PX)


def test_behind_the_parent_is_no_crossing_in_front():
    assert not crossing_in_front((34.0, 36.0), -0.99, 8.5, 204.39, 204.39 - 3.13, F_PX)


@pytest.mark.parametrize("r_sides, cos_sides, r_child", [
    ((34.0, 36.0), -0.90, 8.5),          # the parent bends at the node
    ((26.0, 36.0), -0.99, 7.0),          # unlike sides (a thick piece ending at a thinner one)
    ((34.0, 36.0), -0.99, 11.0),         # the child a third of the parent: seed 538 T3's 0.33, seed 139's 0.36
])
def test_a_node_without_the_crossings_geometry_is_not_read(r_sides, cos_sides, r_child):
    assert not crossing_in_front(r_sides, cos_sides, r_child, 204.39, 207.52, F_PX)


def test_the_step_shares_bound_the_front_reading(monkeypatch):
    step = front_step_px(204.39, 36.0, F_PX)
    for share, expected in [(0.39, False), (0.41, True), (1.49, True), (1.51, False)]:
        assert crossing_in_front((34.0, 36.0), -0.99, 8.5, 204.39, 204.39 + share * step, F_PX) is expected
    # a thin parent: the step under MIN_FRONT_PX / MIN_STEP_SHARE, the px floor rules
    assert not crossing_in_front((10.0, 10.0), -1.0, 2.5, 150.0, 150.9, F_PX)
    monkeypatch.setattr(forkcross, "MIN_FRONT_PX", 0.5)
    assert crossing_in_front((10.0, 10.0), -1.0, 2.5, 150.0, 150.9, F_PX)
