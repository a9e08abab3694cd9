"""The fork rules of forkends.py / forkdisp.py / dense.py, each off and on, on the accuracy benchmark's rendered
scene where a gross error showed the need for it (issue 5; each test names its seed, fork and the error it made).
The docs that measured them: docs/localize-gross308.md, -gross340.md, -fork356.md, -gross388.md, -gross19.md,
-forkgross.md."""

import math
from dataclasses import replace

import pytest
from appliance.config import load_config
from appliance.localize import Localizer, dense, featurecheck, forkdisp, forkends
from appliance.synth.evaluate import score_result


def localized(scene, exact: bool, cfg=None):
    """The localizer's result on a rendered scene with its exact masks or the colour recogniser's."""
    left, right, truth, calib = scene
    kw = dict(mask_left=truth.mask_left, mask_right=truth.mask_right) if exact else {}
    return Localizer(calib, cfg or load_config().localize).localize(left, right, **kw)


def score_row(scene, truth_index: int, exact: bool, cfg=None, res=None):
    """The benchmark's score row of true fork ``truth_index`` (None: outside a view and not reported)."""
    res = res if res is not None else localized(scene, exact, cfg)
    row = next((r for r in score_result(res, scene[2]).rows if r.truth_index == truth_index), None)
    assert row is None or row.kind == "bifurcation"
    return row


@pytest.fixture
def no_agreement_net(monkeypatch):
    """The feature check's pieces' agreement off: it withholds several of these forks when their rule is off,
    and the rule is tested on its own."""
    monkeypatch.setattr(featurecheck, "AGREE_PX", math.inf)


# --- a parent side read at the fork, or carried to it


@pytest.mark.parametrize("masks", ["true", "colour"])
@pytest.mark.parametrize("lone_taper", [False, True])
def test_a_fork_on_a_lone_flat_side_reads_its_texture_with_the_radius_at_the_fork(rendered_scene, monkeypatch, masks,
                                                                                  lone_taper):
    # seed 308's fork 12: a flat parent tapering 14.7 -> 4.5 mm, fitted on one side of the fork only (the
    # other, thicker side without a curve); its bark texture next to the fork was moved back to the axis
    # with the fitted side's mean radius (15.9 px) where the parent is 22 px thick: +1.0 px (-4.4 mm), and
    # with the colour masks the child's right outline then took the fork to +2.2 px (-9.2 mm). With the
    # radius tapered towards the other side's (measured next to the fork) the texture reads +0.15 px.
    monkeypatch.setattr(forkends, "LONE_TAPER", lone_taper)
    row = score_row(rendered_scene(308), 12, exact=masks == "true")
    assert row.result_id >= 0
    if lone_taper:
        assert abs(row.dz_mm) <= 1.5
    else:
        assert row.dz_mm <= -3.0        # (colour: -3.45 mm with forkdisp.FLAT_NEAR_SHIFT, its side 0.5+ radius off)


@pytest.mark.parametrize("withheld", [False, True])
def test_a_fork_on_one_side_carried_past_its_span_unread_and_unconfirmed_is_withheld(rendered_scene, monkeypatch,
                                                                                      withheld):
    # seed 264's fork 5 with the colour recogniser's masks: one parent side (its other side and the
    # child without a fitted curve), its fit carried 53 rows past a 97-row span, its own rows next
    # to the fork not read; 0.6 px (2.9 mm) off. Withheld. (Its rows are read since the right
    # crossings' widths allow for perspective, forkdisp.SIDE_WIDTH_PERSPECTIVE: off here; the next test. Reported, it
    # is read through the fork by forkends.THROUGH_FORK, after this rule's decision: 0.76 mm off; off here too.)
    monkeypatch.setattr(forkends, "LONE_SIDE_WITHHELD", withheld)
    monkeypatch.setattr(forkends, "THROUGH_FORK", False)
    monkeypatch.setattr(forkdisp, "SIDE_WIDTH_PERSPECTIVE", False)
    row = score_row(rendered_scene(264), 5, exact=False)
    if withheld:
        assert row.result_id < 0
    else:
        assert row.result_id >= 0 and abs(row.dz_mm) >= 2.0


@pytest.mark.usefixtures("no_agreement_net")
@pytest.mark.parametrize("perspective", [False, True])
def test_a_thick_sides_rows_are_read_where_the_views_cross_it_at_different_widths(rendered_scene, monkeypatch,
                                                                                   perspective):
    # seed 264's fork 5 (colour masks): a lone parent side of radius 25 px, 60 px right of the middle, crossed
    # ~2 % narrower in the right view; without the perspective ratio its rows next to the fork fail the
    # width check (1.2 px), the side is unread and the fork withheld (LONE_SIDE_WITHHELD); with it the rows
    # are read: +0.17 px
    monkeypatch.setattr(forkdisp, "SIDE_WIDTH_PERSPECTIVE", perspective)
    row = score_row(rendered_scene(264), 5, exact=False)
    if perspective:
        assert row.result_id >= 0 and abs(row.disparity_err_px) <= 0.4
    else:
        assert row.result_id < 0


@pytest.mark.parametrize("far_check, crotch_rows", [(False, False), (True, False), (False, True)])
def test_a_lone_side_read_far_off_is_not_confirmed_by_a_child_carried_as_far(rendered_scene, monkeypatch, far_check,
                                                                             crotch_rows):
    # seed 333's fork 1 (Z 1232 mm, exact masks): the fork's one steep parent side is read from its own
    # crossings 82 rows from the fork (141.03 px), the child's curve carried 86 rows to it (140.74): the two
    # agree where both were read, not at the fork (truth 142.09 px), +9.2 mm. With the check the fork is
    # withheld. The side read again with the crotch's rows the child widens alike in both views
    # (forkdisp.SIDE_GROWN_*, docs/localize-forktail23.md) reaches the fork: within 1 mm without the check.
    monkeypatch.setattr(forkends, "LONE_FAR_WITHHELD", far_check)
    if not crotch_rows:
        monkeypatch.setattr(forkdisp, "SIDE_GROWN_SHORT_PX", math.inf)
    if not far_check:            # (the feature check's pieces' agreement withholds it as well)
        monkeypatch.setattr(featurecheck, "AGREE_PX", math.inf)
    row = score_row(rendered_scene(333), 1, exact=True)
    if far_check:
        assert row.result_id < 0 or abs(row.dz_mm) <= 3.0
    elif crotch_rows:
        assert row.result_id >= 0 and abs(row.dz_mm) <= 1.0
    else:
        assert row.result_id >= 0 and row.dz_mm >= 8.0


@pytest.mark.parametrize("withheld", [False, True])
def test_a_fork_whose_lone_read_side_disagrees_with_the_carried_child_is_withheld(rendered_scene, monkeypatch,
                                                                                  withheld):
    # seed 450's fork 1, exact masks: its lone steep parent side read from its own rows 44 px off (175.41 px),
    # the child's curve carried 39 rows to it (173.97 px) taken: +6.3 mm. Withheld.
    monkeypatch.setattr(forkends, "LONE_READ_WITHHELD", withheld)
    row = score_row(rendered_scene(450), 1, exact=True)
    if withheld:
        assert row.result_id < 0
    else:
        assert row.result_id >= 0 and row.dz_mm >= 5.0


@pytest.mark.usefixtures("no_agreement_net")
@pytest.mark.parametrize("capped", [False, True])
def test_a_childs_curve_carried_far_does_not_replace_the_parents_own_rows(rendered_scene, monkeypatch, capped):
    # seed 362's fork 1 (exact masks): the parent side read from its own crossings (-0.0 px); the child's flat
    # curve, fitted on 225 columns, carried 68 to the fork, "known" by half its span: +1.06 px (4.5 mm)
    monkeypatch.setattr(forkends, "KNOWN_VOUCH_CAPPED", capped)
    # (uncapped, LONE_READ_WITHHELD withholds it: the side's read and the fork 1.06 px apart; off here, the cap alone)
    monkeypatch.setattr(forkends, "LONE_READ_WITHHELD", False)
    row = score_row(rendered_scene(362), 1, exact=True)
    assert row.result_id >= 0
    if capped:
        assert abs(row.disparity_err_px) <= 0.3
    else:
        assert abs(row.disparity_err_px) >= 0.9


# --- flat sides: their texture next to the fork


@pytest.mark.usefixtures("no_agreement_net")
@pytest.mark.parametrize("rule", [False, True])
def test_two_flat_sides_far_apart_take_the_one_the_outline_and_the_child_confirm(rendered_scene, monkeypatch, rule):
    # seed 359's fork 11 (colour masks): one flat side +3.0 px (its curve's slope carried past a 66 px span),
    # the other +0.7, the right outline -0.05, the child +0.1; the mean of three was +1.2 px (5.7 mm)
    monkeypatch.setattr(forkends, "FLAT_PICK_ONE", rule)
    row = score_row(rendered_scene(359), 11, exact=False)
    assert row.result_id >= 0
    if rule:
        assert abs(row.disparity_err_px) <= 0.5
    else:
        assert abs(row.disparity_err_px) >= 1.0


@pytest.mark.usefixtures("no_agreement_net")
@pytest.mark.parametrize("vouches", [True, False])
def test_a_scattered_flat_texture_read_does_not_make_its_side_known(rendered_scene, monkeypatch, vouches):
    # seed 364's fork 7 (colour masks): a flat side carried 32 px past a 26 px span, -2.7 px, its 3 patches
    # scattered (MAD 0.5) about the same; the steep side 2 rows past its span +0.4 px; with the read
    # vouching for the flat side the median of three took the child carried 34 rows: -0.9 px (4 mm)
    monkeypatch.setattr(forkends, "FLAT_READ_VOUCHES", vouches)
    row = score_row(rendered_scene(364), 7, exact=False)
    assert row.result_id >= 0
    if vouches:
        assert abs(row.disparity_err_px) >= 0.8
    else:       # (-1.7 mm, ~0.38 px, on the brown-only recogniser's mask; +0.50 px on the olive/grey one's)
        assert abs(row.disparity_err_px) <= 0.6


@pytest.mark.parametrize("rule", [False, True])
def test_a_leaf_in_front_of_a_flat_fork_side_in_one_view_is_not_read(rendered_scene, monkeypatch, rule):
    # seed 454's fork 11, colour masks: a leaf covers the flat parent's top next to the fork in the left
    # view (elsewhere in the right); its texture patches there read the leaf, 2.1 px low: +10.6 mm.
    # Patches whose share on the branch differs between the views are dropped: the curve stands (+0.3 mm)
    monkeypatch.setattr(forkdisp, "FLAT_NEAR_MAX_SHARE_DIFF", 0.15 if rule else None)
    row = score_row(rendered_scene(454), 11, exact=False)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) <= 1.0
    else:
        assert row.dz_mm >= 8.0


# --- the child's outline in the right view


@pytest.mark.parametrize("max_shift_px", [3.0, 2.0])
def test_a_flat_parents_fork_is_not_moved_over_2_px_by_its_childs_right_outline(rendered_scene, monkeypatch,
                                                                              max_shift_px):
    # seed 328's fork 14 (Z 1269 mm, colour masks): the flat parent's texture reads 137.35 px (truth 137.88),
    # the child (no curve of its own) leaves it in the right view's outline at 135.05: 2.3 px off the texture,
    # within the old 3 px bound, taken: +27 mm. Bound at 2 px the texture stands (-0.5 px). (With the brown-only
    # colour recogniser the case was found: the olive and grey bark tests move this mask and the fork to
    # +4.9 mm under either bound.)
    monkeypatch.setattr(forkends, "OUTLINE_MAX_SHIFT_PX", max_shift_px)
    monkeypatch.setattr(forkends, "OUTLINE_NOT_OVER_CONFIRMED", False)   # (the texture read stands under it too)
    cfg = load_config().localize
    cfg = replace(cfg, segment=replace(cfg.segment, olive_saturation_max=0, grey_chroma_max=0))
    row = score_row(rendered_scene(328), 14, exact=False, cfg=cfg)
    if max_shift_px == 2.0:
        assert row.result_id < 0 or abs(row.dz_mm) <= 6.0
    else:
        assert row.result_id >= 0 and row.dz_mm >= 20.0


# --- the right view's edge


@pytest.mark.parametrize("masks", ["true", "colour"])
@pytest.mark.parametrize("right_edge", [False, True])
def test_a_fork_off_the_right_view_is_not_reported(rendered_scene, monkeypatch, masks, right_edge):
    # seed 392's fork 9 (Z 796 mm): in the left view at column 197, in the right view at column -34.5,
    # outside the image. Its pieces' curves (matched where they are in the right view) were carried to it:
    # +4.1 mm (exact masks), +8.7 mm (colour masks); the feature check had no patch inside the right image
    # (no verdict). With the right view's edge checked as the left's, it is not reported.
    monkeypatch.setattr(dense, "RIGHT_VIEW_EDGE", right_edge)
    scene = rendered_scene(392)
    res = localized(scene, exact=masks == "true")
    row = score_row(scene, 9, exact=masks == "true", res=res)
    assert scene[2].features.kind[9] == "bifurcation" and scene[2].features.right_px[9][0] < 0
    if right_edge:                  # (a true feature outside a view is scored only when reported)
        assert row is None or row.result_id < 0
        w = scene[0].shape[1]
        assert all(0 <= f.right_px[0] < w for f in res.features)
    else:
        assert row.result_id >= 0 and row.dz_mm >= 3.5


def test_a_fork_a_few_px_past_the_right_view_is_still_reported(rendered_scene):
    # seed 148's fork 14 (Z 885 mm): true right column -2.3 px (rectified u - d -5.5 px, radius 11 px): its
    # crotch is partly in the right view and its pieces' curves place it within 0.3 mm (exact masks). The
    # right view's edge rule (over a radius past the edge) keeps it; at the left view's margin it was lost.
    scene = rendered_scene(148)
    assert scene[2].features.right_px[14][0] < 0
    row = score_row(scene, 14, exact=True)
    assert row.result_id >= 0 and abs(row.dz_mm) <= 1.5


# --- a short side known only by the 12 px floor (docs/localize-gross20.md)


@pytest.mark.parametrize("rule", [False, True])
def test_a_short_side_carried_past_half_its_span_does_not_replace_the_median(rendered_scene, monkeypatch, rule):
    # seed 512's fork 9, exact masks: a steep-ish parent whose side below the fork is fitted on 13 rows and carried
    # 9.5 rows to it (178.8 px), the side above on 3 rows (189.5), the child 183.6 (truth 182.9). The sides
    # disagree, so the median of three (183.6) was taken, then _known_disparity replaced it with the 13-row side,
    # "known" by _reach's 12 px floor: 4.15 px off, +22.3 mm. With the rule the median stands: -3.7 mm.
    monkeypatch.setattr(forkends, "SHORT_SIDE_NOT_KNOWN", rule)
    monkeypatch.setattr(forkends, "STEEP_NONE_AGREE_WITHHELD", False)     # (it withholds this fork too)
    monkeypatch.setattr(forkends, "NONE_KNOWN_WITHHELD", False)
    row = score_row(rendered_scene(512), 9, exact=True)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 4.0 and abs(row.disparity_err_px) < 0.8
    else:
        assert row.dz_mm > 20.0


@pytest.mark.parametrize("masks", ["true", "colour"])
@pytest.mark.parametrize("rule", [False, True])
def test_a_fork_whose_sides_disagree_with_no_piece_known_there_is_withheld(rendered_scene, monkeypatch, masks, rule):
    # seed 512's fork 9: its two sides (fitted on 3-14 rows, carried 9-13) 4-7 px apart on either side of the
    # truth, the child carried 24-26 rows past its 43-45 row span: the median of three, the child, 0.7 px off
    # (-3.7 mm); no piece is known at the fork. With the rule it is withheld.
    monkeypatch.setattr(forkends, "NONE_KNOWN_WITHHELD", rule)
    monkeypatch.setattr(forkends, "STEEP_NONE_AGREE_WITHHELD", False)     # (it withholds this fork too)
    row = score_row(rendered_scene(512), 9, exact=masks == "true")
    if rule:
        assert row.result_id < 0
    else:
        assert row.result_id >= 0 and 3.0 < abs(row.dz_mm) < 4.5


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_flat_side_outvoted_by_the_child_and_its_outline_gives_way_to_the_mean(rendered_scene, monkeypatch, rule):
    # seed 378's fork 11, exact masks: a flat parent fitted on one side (200 columns, its bark texture 0.78 px
    # low along all of them), the child's curve +0.97 px and its right outline +0.86 px from it: +6.9 mm; the
    # mean of the three +1.5 mm. (Without this rule forkends.LONE_FLAT_CHILD_READ, after every decision, averages
    # the lone side with the child's own rows: +0.8 mm; off here, the rule tested on its own.)
    monkeypatch.setattr(forkends, "LONE_FLAT_OUTVOTED", rule)
    monkeypatch.setattr(forkends, "LONE_FLAT_CHILD_READ", False)
    row = score_row(rendered_scene(378), 11, exact=True)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 2.5
    else:
        assert row.dz_mm > 6.0


@pytest.mark.parametrize("far_px", [math.inf, featurecheck.FAR_PX])
def test_a_fork_one_of_whose_pieces_reads_its_texture_13_px_off_is_withheld(rendered_scene, monkeypatch, far_px):
    # seed 534's fork 11, colour masks: a thin branch behind a trunk (Z 1075 mm) seen leaving the trunk's
    # outline, taken for the trunk's child (an occlusion, not a fork: the true fork is hidden behind the trunk
    # 4 px away). The fork has the trunk's disparity (176.3 px, Z 994); the trunk's two sides read 176.6 in
    # their bark, the child's four patches 163.0 +- 0.1 (the truth 162.97): straddling, the check's least
    # alarming reading is the fork's own. -81 mm; one piece 13 px off withholds it (featurecheck.far_piece).
    monkeypatch.setattr(featurecheck, "FAR_PX", far_px)
    row = score_row(rendered_scene(534), 11, exact=False)
    if math.isfinite(far_px):
        assert row is None or row.result_id < 0          # (None: hidden in the left view and not reported)
    else:
        assert row.result_id >= 0 and row.dz_mm < -60.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_flat_sides_scattered_read_far_from_the_childs_outline_is_withheld(rendered_scene, monkeypatch, rule):
    # seed 528's fork 14, colour masks: a lone flat parent side read next to the fork from 4 patches at 201.62
    # +- 0.50 px (they hold the child's bark, the child leaving towards the camera), the child's right outline
    # 199.04, truth 198.85: -12 mm. With the rule it is withheld.
    monkeypatch.setattr(forkends, "SCATTERED_READ_WITHHELD", rule)
    # (forkdisp.FLAT_NEAR_SHIFT moves the patches onto the fork: reported without the rule at -6.9 mm)
    row = score_row(rendered_scene(528), 14, exact=False)
    if rule:
        assert row is None or row.result_id < 0          # (None: not seen in both views and not reported)
    else:
        assert row.result_id >= 0 and row.dz_mm < -5.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_flat_side_fitted_up_to_the_fork_is_not_outvoted(rendered_scene, monkeypatch, rule):
    # seed 540's fork 14, exact masks: a lone flat side fitted on 144 columns up to the fork, 0.17 px off; the
    # child's curve (carried 27 rows) and its right outline 1.1 / 1.6 px off, agreeing with each other: their
    # mean with the side (LONE_FLAT_OUTVOTED) +9.1 mm. With the rule the side stands and, nothing confirming
    # it, the fork is withheld.
    monkeypatch.setattr(forkends, "REACHED_STANDS", rule)
    row = score_row(rendered_scene(540), 14, exact=True)
    if rule:
        assert row is None or row.result_id < 0 or abs(row.dz_mm) < 3.0
    else:
        assert row.result_id >= 0 and row.dz_mm > 8.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_flat_side_carried_far_gives_way_to_the_side_read_at_the_fork(rendered_scene, monkeypatch, rule):
    # seed 556's fork 10, exact masks: a flat parent, its thick side (r 12.7 px) read next to the fork at 164.91 px,
    # its thin side (r 5.5 px, fitted on 112 columns) carried 54 px to 166.25; the child's curve 164.80 and its
    # right outline 164.85 agree with the read side (truth 164.66). The sides' mean +0.92 px, -6.0 mm; the mean of
    # the read side, the child and the outline (forkvouch.carried_side_outvoted) -1.3 mm.
    monkeypatch.setattr(forkends, "CARRIED_FLAT_OUTVOTED", rule)
    row = score_row(rendered_scene(556), 10, exact=True)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 2.0
    else:
        assert row.dz_mm < -5.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_flat_side_carried_far_to_the_fork_gives_way_to_the_median_of_three(rendered_scene, monkeypatch, rule):
    # seed 515's fork 16, exact masks (Z 1135 mm): a flat parent fitted on one side of the fork, its curve carried
    # 60 px past its span to the fork (its texture there not read apart from it), +0.36 px: -2.7 mm; the child's
    # curve +0.19 px and its right outline +0.10 px. The median of the three (forkvouch.lone_carried_median) takes
    # the child's: -1.4 mm.
    monkeypatch.setattr(forkends, "LONE_CARRIED_MEDIAN", rule)
    row = score_row(rendered_scene(515), 16, exact=True)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 1.8
    else:
        assert row.dz_mm < -2.3


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_flat_side_carried_a_few_px_to_the_fork_is_averaged_with_the_steep_childs_own_rows(
        rendered_scene, monkeypatch, rule):
    # seed 981's fork 10, exact masks (Z 1284 mm): a flat parent fitted on one side of the fork, its level carried 7 px
    # past its span to the fork (its texture next to the fork within FLAT_NEAR_MIN_PX of it), -0.42 px: +3.96 mm; the
    # steep child's own crossings, read as a parent side's from 12 px of the fork, +0.11 px. With the rule
    # (forkends.LONE_FLAT_CHILD_READ) the mean of the two: -0.16 px, +1.46 mm.
    monkeypatch.setattr(forkends, "LONE_FLAT_CHILD_READ", rule)
    row = score_row(rendered_scene(981), 10, exact=True)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 2.0 and abs(row.disparity_err_px) < 0.25
    else:
        assert row.dz_mm > 3.5


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_carried_flat_sides_fork_that_took_the_childs_carried_curve_takes_the_median_of_three(
        rendered_scene, monkeypatch, rule):
    # seed 825's fork 12, exact masks (Z 1280 mm): a flat parent fitted on 19 columns on one side of the fork (a
    # constant), carried 39 px to it, +0.71 px; the child, a 32-row steep fit, carried 25 rows, -0.72 px; its right
    # outline +0.35 px. No piece known at the fork: _known_disparity took the child (carried least far): +6.8 mm.
    # With the rule the median of the three (LONE_CARRIED_MEDIAN's), the outline's: -3.3 mm.
    monkeypatch.setattr(forkends, "CARRIED_CHILD_MEDIAN", rule)
    row = score_row(rendered_scene(825), 12, exact=True)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 4.0 and abs(row.disparity_err_px) < 0.45
    else:
        assert row.dz_mm > 6.0


@pytest.mark.parametrize("masks", ["true", "colour"])
@pytest.mark.parametrize("rule", [False, True])
def test_a_fork_whose_unread_flat_sides_clearly_disagree_rests_on_the_child_and_its_outline(rendered_scene,
                                                                                              monkeypatch, masks, rule):
    # seed 607's fork 7: a thin flat parent turning 0.1 px per px in depth, its two sides constants (83 and 95
    # columns, no clean texture line) carried 24 and 17 px to the fork at 141.4 and 151.7 px, neither read there
    # (their texture searched about the carried constants); the median of three took the child, a 9-row fit carried
    # 24 rows: exact masks 146.29 (truth 148.07, +14.5 mm), colour masks 147.61 (+3.7 mm). The child's right outline
    # reads 148.30 / 148.14. With the rule: exact, child and outline 2.0 px apart, withheld; colour, their mean.
    monkeypatch.setattr(forkends, "UNREAD_SIDES_APART", rule)
    row = score_row(rendered_scene(607), 7, exact=masks == "true")
    if masks == "true":
        if rule:
            assert row.result_id < 0
        else:
            assert row.result_id >= 0 and row.dz_mm > 10.0
    else:
        assert row.result_id >= 0
        if rule:
            assert abs(row.dz_mm) < 2.5
        else:
            assert row.dz_mm > 3.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_hidden_fork_does_not_take_a_few_patch_flat_constant(rendered_scene, monkeypatch, rule):
    # seed 607's fork 9, exact masks: a leaf hides a steep parent's upper end; carried 20 px on it meets a 25-column
    # flat piece (the child and the parent's stub at the view's top edge) whose disparity is a constant from 5 texture
    # patches, 148.26 px (truth 149.43): the hidden fork took it, +9.3 mm. Such a constant is no parent's disparity
    # (forkvouch.few_patch_constant): the end stays hidden.
    monkeypatch.setattr(forkends, "HIDDEN_ON_FEW_PATCHES", rule)
    row = score_row(rendered_scene(607), 9, exact=True)
    if rule:
        assert row.result_id < 0
    else:
        assert row.result_id >= 0 and row.dz_mm > 8.0


def test_unread_sides_apart_leave_a_side_that_agrees_with_the_child(rendered_scene):
    # seed 364's fork 14, exact masks: two flat sides 63 px apart (one another branch), neither read next to the fork,
    # the other side 0.35 px from the child's curve (the median of three, -1.0 mm); the child's outline 1.6 px from
    # both. Two readings agree: UNREAD_SIDES_APART does not apply and the fork stands.
    assert forkends.UNREAD_SIDES_APART
    row = score_row(rendered_scene(364), 14, exact=True)
    assert row.result_id >= 0 and abs(row.dz_mm) < 2.0


@pytest.mark.parametrize("rule", [False, True])
def test_the_outline_does_not_move_a_fork_whose_side_read_confirms_its_curve(rendered_scene, monkeypatch, rule):
    # seed 600's fork 14, colour masks: a lone flat side fitted to 3.4 px from the fork, its bark texture read next
    # to the fork within 0.25 px of its curve (the curve stands: 178.49 px, truth 178.65); the child (a steep fit
    # carried 28 rows) 180.71, its right outline 179.55. The outline, 1.06 px from the side, moved the fork there:
    # -4.9 mm. A side read twice (its fit and its texture at the fork) is not moved by the outline.
    monkeypatch.setattr(forkends, "OUTLINE_NOT_OVER_CONFIRMED", rule)
    row = score_row(rendered_scene(600), 14, exact=False)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 2.0
    else:
        assert row.dz_mm < -4.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_fork_whose_childs_texture_lies_at_another_depth_is_withheld(rendered_scene, monkeypatch, rule):
    # seed 642's fork 7, exact masks: a thin branch (r 6 mm) leaves the trunk and runs beside it in the image, 8-12 px
    # of disparity behind it; its child (no curve) seems to leave the trunk, and the child's right outline happens to
    # leave the trunk where the trunk's disparity puts it: the fork took the trunk's side, 189.8 px (truth 178.4,
    # -59 mm). The child's texture past the trunk's outline reads 167-178 px (forkchild.child_texture_elsewhere).
    monkeypatch.setattr(forkends, "CHILD_ELSEWHERE_WITHHELD", rule)
    row = score_row(rendered_scene(642), 7, exact=True)
    if rule:        # (not reported: the scorer keeps no row for it, or an unmatched one)
        assert row is None or row.result_id < 0
    else:
        assert row.result_id >= 0 and row.dz_mm < -50.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_fork_whose_steep_sides_and_child_all_disagree_is_withheld(rendered_scene, monkeypatch, rule):
    # seed 639's fork 11, exact masks: one steep side read 34 rows from the fork at 139.09 px, the other side another
    # branch (496 px, carried 100 rows), the child's curve carried 49 rows at 143.84: the median of three took the
    # child, the side's read replaced it (truth 136.96: +19 mm). No two of the three readings agree. (The side's read
    # as it was: with forkdisp.SIDE_TURN_SHORT it is read on the span's 20 rows, the fork +12 mm, withheld alike.)
    monkeypatch.setattr(forkends, "STEEP_NONE_AGREE_WITHHELD", rule)
    monkeypatch.setattr(forkdisp, "SIDE_TURN_SHORT", False)
    row = score_row(rendered_scene(639), 11, exact=True)
    if rule:
        assert row is None or row.result_id < 0
    else:
        assert row.result_id >= 0 and row.dz_mm > 15.0


def test_steep_sides_apart_leave_a_child_near_the_read_side(rendered_scene, monkeypatch):
    # seed 100's fork 3, exact masks: one steep side read 25 rows off at 148.87 px (right), the other 138.55, the child
    # 147.70: 1.17 px from the read side, over _agree's 1 px but no clear disagreement (2 px): the fork stands.
    monkeypatch.setattr(forkends, "STEEP_NONE_AGREE_WITHHELD", True)
    row = score_row(rendered_scene(100), 3, exact=True)
    assert row.result_id >= 0 and abs(row.dz_mm) < 1.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_unread_steep_side_carried_far_is_not_confirmed_by_a_child_carried_as_far(rendered_scene, monkeypatch,
                                                                                         rule):
    # seed 630's fork 3, exact masks: a trunk's lone steep side carried 75 rows (not read next to the fork) at
    # 174.80 px, the child's 8-row fit carried 47 rows at 174.67; truth 172.88: -11 mm.
    monkeypatch.setattr(forkends, "LONE_FAR_UNREAD_WITHHELD", rule)
    row = score_row(rendered_scene(630), 3, exact=True)
    if rule:
        assert row is None or row.result_id < 0
    else:
        assert row.result_id >= 0 and row.dz_mm < -9.0



@pytest.mark.parametrize("masks, rule", [("true", False), ("true", True), ("colour", True)])
def test_a_lone_unread_steep_side_carried_off_its_bark_is_withheld(rendered_scene, monkeypatch, masks, rule):
    # seed 657's fork 7, exact masks: a trunk's lone steep side, not read next to the fork, whose 94-row fit curls at
    # its end (end slope 0.077 px per row, truth 0.029), carried 16.5 rows to 147.70 px; its bark next to the fork
    # 149.13, truth 149.17: +11.8 mm. Colour masks: the side's fit carried to 149.20, its bark agreeing: it stands.
    monkeypatch.setattr(forkends, "LONE_BARK_WITHHELD", rule)
    row = score_row(rendered_scene(657), 7, exact=masks == "true")
    if masks == "colour":
        assert row.result_id >= 0 and abs(row.dz_mm) < 1.0
    elif rule:
        assert row is None or row.result_id < 0
    else:
        assert row.result_id >= 0 and row.dz_mm > 10.0


@pytest.mark.parametrize("withheld", [False, True])
def test_a_fork_on_a_lone_flat_side_carried_far_and_contradicted_by_the_outline_is_withheld(rendered_scene,
                                                                                             monkeypatch, withheld):
    # fresh31, seed 1093's fork 5 (exact masks): a flat parent with one fitted side, carried 48 px past its span to the
    # fork (-2.60 px there), not read next to it; the child without a curve; its right outline +1.05 px, 3.65 px from
    # the side (too far to move it: OUTLINE_MAX_SHIFT_PX), yet the fork stood at the side's level: +18.6 mm. Withheld.
    monkeypatch.setattr(forkends, "LONE_CARRIED_CONTRADICTED_WITHHELD", withheld)
    row = score_row(rendered_scene(1093), 5, exact=True)
    if withheld:
        assert row is None or row.result_id < 0 or abs(row.dz_mm) <= 3.0
    else:
        assert row is not None and row.result_id >= 0 and row.dz_mm >= 15.0


@pytest.mark.parametrize("rule", [False, True])
def test_a_lone_side_read_next_to_the_fork_stands_against_a_child_known_only_by_the_floor(rendered_scene, monkeypatch,
                                                                                          rule):
    # seed 1080's fork 13, exact masks (Z 1178 mm): a lone steep parent side (a 26-row fit) read from its own crossings,
    # the nearest 12.7 px from the fork (just beyond the 12 px that make a side known there), -0.03 px; the child's
    # 25-row fit carried 11.3 rows into the crotch, known there by the 12 px floor, -0.86 px: _known_disparity took
    # the child, +6.86 mm. With the rule (forkends.READ_OVER_FLOOR_CHILD) the read stands: +0.3 mm.
    monkeypatch.setattr(forkends, "READ_OVER_FLOOR_CHILD", rule)
    row = score_row(rendered_scene(1080), 13, exact=True)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 1.0
    else:
        assert row.dz_mm > 6.0


@pytest.mark.parametrize("masks", ["true", "colour"])
@pytest.mark.parametrize("rule", [False, True])
def test_a_flat_side_carried_a_few_px_taken_by_the_median_of_three_is_averaged_with_the_childs_rows(
        rendered_scene, monkeypatch, masks, rule):
    # seed 1089's fork 16 (Z 897 mm): the parent's two flat sides clearly apart, one a 26-column constant carried 33 px,
    # +3.1 px; the median of three took the other, a 36-column side carried 7-9 px past its span (its texture next to the
    # fork agreeing with it), +0.60 / +0.68 px: -2.76 / -3.09 mm. The steep child's own rows read 6-8 px from the fork
    # -0.54 / -0.37 px; with the rule (forkends.MEDIAN_FLAT_CHILD_READ) the mean of the two: +0.03 / +0.15 px.
    monkeypatch.setattr(forkends, "MEDIAN_FLAT_CHILD_READ", rule)
    row = score_row(rendered_scene(1089), 16, exact=masks == "true")
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 1.0
    else:
        assert row.dz_mm < -2.5


@pytest.mark.parametrize("rule", [False, True])
def test_a_flat_sides_patches_are_moved_onto_the_fork_its_carried_line_passes_off(rendered_scene, monkeypatch, rule):
    # seed 1074's fork 9, colour masks (Z 1081 mm): side A's flat centre line, carried 31 px from its span, passes the
    # fork 6.2 px off (the parent's radius there 8.9 px): its texture patches lie on the branch's upper part, -0.61 px;
    # the fork the mean of it, side B and the child's right outline, +3.97 mm. With the rule (forkdisp.FLAT_NEAR_SHIFT)
    # the patches are moved onto the fork: -0.44 px, +1.78 mm.
    monkeypatch.setattr(forkdisp, "FLAT_NEAR_SHIFT", rule)
    row = score_row(rendered_scene(1074), 9, exact=False)
    assert row.result_id >= 0
    if rule:
        assert abs(row.dz_mm) < 2.5
    else:
        assert row.dz_mm > 3.5


@pytest.mark.parametrize("rule", [False, True])
def test_a_scattered_read_is_checked_on_the_unmoved_patches_too(rendered_scene, monkeypatch, rule):
    # seed 528's fork 14, colour masks: the lone flat side's patches moved onto the fork (forkdisp.FLAT_NEAR_SHIFT)
    # no longer read scattered; the fork reported at -6.9 mm. With the rule (forkends.FLAT_NEAR_SHIFT_UNMOVED) the
    # scattered-read check runs on the unmoved read too: withheld, as without FLAT_NEAR_SHIFT.
    monkeypatch.setattr(forkends, "FLAT_NEAR_SHIFT_UNMOVED", rule)
    row = score_row(rendered_scene(528), 14, exact=False)
    if rule:
        assert row is None or row.result_id < 0
    else:
        assert row.result_id >= 0 and row.dz_mm < -5.0
