"""forkvouch.py: a parent side known at a fork only by _reach's 12 px floor does not override the fork's disparity."""

import pytest
from appliance.localize.flatfit import FEW_PATCHES
from appliance.localize.forkvouch import (CARRIED_ACROSS_PX, SHORT_SIDE_ROWS, UNREAD_AGREE_PX, carried_side_outvoted, child_outline_consensus,
                                          few_patch_constant, known_side_stands, lone_carried_median, none_vouched,
                                          outvoted, scattered_read_contradicted, short_side_unconfirmed,
                                          vouched_by_span)


def test_a_span_vouches_for_half_its_length_past_either_end():
    assert vouched_by_span((732.0, 745.0), 740.0)          # inside
    assert vouched_by_span((732.0, 745.0), 725.5)          # 6.5 rows past a 13-row span
    assert not vouched_by_span((732.0, 745.0), 722.5)      # 9.5 rows past (seed 512's fork 9)
    assert not vouched_by_span((100.0, 120.0), 131.0)      # past the far end
    assert vouched_by_span((100.0, 300.0), 10.0)


def test_the_short_sides_disparity_does_not_stand_the_others_do():
    sides = {24: (178.78, (732.0, 745.0), 722.5), 23: (189.48, (707.0, 710.0), 722.5)}
    assert not known_side_stands(178.78, sides)            # the short side carried 9.5 rows
    assert known_side_stands(183.63, sides)                # the median of three: not one of these sides
    long_side = {9: (148.87, (400.0, 497.0), 357.8)}       # 42 rows past a 97-row span
    assert known_side_stands(148.87, long_side)


def test_none_vouched_unless_one_piece_is_known_by_its_span_or_read_next_to_the_fork():
    pieces = {23: ((707.0, 710.0), 722.5), 24: ((732.0, 745.0), 722.5), 25: ((748.0, 791.0), 722.5)}
    assert none_vouched(pieces, read_near=False)           # seed 512's fork 9: 12.5, 9.5, 25.5 rows carried
    assert not none_vouched(pieces, read_near=True)
    assert not none_vouched({**pieces, 25: ((740.0, 791.0), 722.5)}, read_near=False)   # 17.5 of 51 rows


def test_a_lone_flat_side_is_outvoted_only_by_a_child_and_outline_that_agree_on_the_same_side():
    assert outvoted(139.88, 140.84, 140.74)                # seed 378's fork 11
    assert outvoted(231.13, 230.39, 230.16)                # seed 144's fork 8: the other way
    assert not outvoted(139.88, 140.84, 140.20)            # the outline within 0.5 px of the side
    assert not outvoted(139.88, 141.10, 140.55)            # the two 0.55 px apart
    assert not outvoted(139.88, 140.84, 138.90)            # on either side
    assert not outvoted(186.54, 213.26, 212.89)            # seed 298: another branch crossing 27 px nearer


def test_a_scattered_read_far_from_the_outline_is_contradicted_a_tight_one_is_not():
    assert scattered_read_contradicted(201.62, 0.50, 199.04, False)      # seed 528's fork 14 (colour)
    assert not scattered_read_contradicted(137.17, 0.06, 139.23, False)  # seed 478's fork 10: 5 patches within 0.06
    assert not scattered_read_contradicted(201.62, 0.50, 199.04, True)   # the child's curve confirms the read
    assert not scattered_read_contradicted(201.62, 0.50, 200.00, False)  # the outline within 2 px
    assert not scattered_read_contradicted(201.62, 0.50, None, False)    # no outline


def test_a_carried_side_gives_way_only_when_the_child_and_its_outline_both_confirm_the_read_side():
    assert carried_side_outvoted(164.91, 166.25, 164.80, 164.85)          # seed 556's fork 10 (exact masks)
    assert carried_side_outvoted(164.91, 163.50, 165.30, 164.50)          # the carried side low, both within 0.5
    assert not carried_side_outvoted(164.91, 165.30, 164.80, 164.85)      # the sides within 0.5 px: their mean
    assert not carried_side_outvoted(164.91, 166.25, 165.50, 164.85)      # the child 0.59 px off the read side
    assert not carried_side_outvoted(164.91, 166.25, 164.80, 166.00)      # the outline with the carried side


def test_a_lone_carried_side_gives_way_to_the_middle_of_the_three_readings():
    assert lone_carried_median(155.76, 155.59, 155.49) == 155.59         # seed 515's fork 16 (exact masks): the child
    assert lone_carried_median(146.00, 145.62, 145.86) == 145.86         # seed 511's fork 12 (colour): the outline
    assert lone_carried_median(146.00, 145.96, 144.40) == 145.96         # an outline 1.6 px off is left out
    assert lone_carried_median(160.54, 160.45, 161.63) == 160.54         # the side in the middle stands
    assert lone_carried_median(160.54, 167.00, 161.63) == 161.63         # another branch's curve never taken


def test_unread_sides_apart_take_the_child_and_its_outline_only_where_they_agree():
    # seed 607's fork 7: colour masks, the child 147.61 and the outline 148.14 agree: their mean
    assert child_outline_consensus(147.61, 148.14) == pytest.approx(147.875)
    # exact masks: the child 146.29 and the outline 148.30, 2.0 px apart: nothing to tell the fork's depth
    assert child_outline_consensus(146.29, 148.30) is None
    assert child_outline_consensus(146.29, None) is None
    assert child_outline_consensus(150.0, 150.0 - UNREAD_AGREE_PX + 1e-6) is not None     # either side
    assert child_outline_consensus(150.0, 150.0 + UNREAD_AGREE_PX + 1e-3) is None


def test_only_a_flat_constant_from_few_patches_is_a_few_patch_constant():
    assert few_patch_constant(False, 1, 5)                 # seed 607's fork 9: a 25-column piece, 5 patches
    assert few_patch_constant(False, 1, 0)                 # a constant taken from the forks at its ends
    assert not few_patch_constant(False, 1, FEW_PATCHES + 1)   # seed 476's fork 9: 8-10 patches
    assert not few_patch_constant(False, 2, 3)             # a texture line
    assert not few_patch_constant(True, 1, 3)              # a steep piece (its row crossings)



def test_a_short_side_is_unconfirmed_by_a_child_carried_across_a_px_of_disparity():
    # seed 650's fork 3 (exact masks): a 16-row side, the child carried 63 rows from 162.47 to 170.92 px
    assert short_side_unconfirmed((505.0, 521.0), 170.92, 162.47)
    # a child carried as far along a flat line confirms it (seed 508's fork 3), so does a child read at the fork
    assert not short_side_unconfirmed((505.0, 515.0), 135.8, 135.8)
    assert not short_side_unconfirmed((505.0, 521.0), 150.0 + CARRIED_ACROSS_PX - 0.01, 150.0)
    assert short_side_unconfirmed((505.0, 521.0), 150.0 - CARRIED_ACROSS_PX - 0.01, 150.0)
    # a side fitted on SHORT_SIDE_ROWS rows or more stands on such a child (the rule of sides carried far decides)
    assert not short_side_unconfirmed((505.0, 505.0 + SHORT_SIDE_ROWS), 170.92, 162.47)
    assert short_side_unconfirmed((505.0, 505.0 + SHORT_SIDE_ROWS - 0.5), 170.92, 162.47)


def test_a_short_flat_side_carried_past_its_span_and_turning_is_no_reading():
    from appliance.localize.forkvouch import SHORT_FLAT_COLS, short_turning_flat_side
    # seed 772 T9 (colour masks): fitted on columns 446-453, the fork at column 435.3 (10.7 px past), turning
    assert short_turning_flat_side((446.0, 453.0), 435.3, True)
    assert not short_turning_flat_side((446.0, 453.0), 435.3, False)       # flat in depth: its constant stands
    assert not short_turning_flat_side((446.0, 453.0), 443.0, True)        # within half its span of the fork
    lo = 453.0 - SHORT_FLAT_COLS                                            # as long as the limit: a reading
    assert not short_turning_flat_side((lo, 453.0), lo - 20.0, True)
    assert short_turning_flat_side((lo + 0.5, 453.0), lo - 20.0, True)
