"""forkvouch.py: a parent side known at a fork only by _reach's 12 px floor does not override the fork's disparity."""

from appliance.localize.forkvouch import known_side_stands, none_vouched, vouched_by_span


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
