from appliance.acquire.pairing import StampPairer

MS = 1_000_000


def feed(pairer, left_ms, right_ms):
    """Push stamps in arrival order (merged by time) and collect the pairs."""
    events = sorted([(t, 0) for t in left_ms] + [(t, 1) for t in right_ms])
    pairs = []
    for t, side in events:
        pairer.push(side, int(t * MS), f"{'LR'[side]}{t}")
        pairs += [(a[1], b[1]) for a, b in pairer.pop()]
    return pairs


def test_equal_rates_pair_one_to_one():
    pairer = StampPairer(5 * MS)
    pairs = feed(pairer, [0, 33, 66, 100], [1, 34, 68, 99])
    assert pairs == [("L0", "R1"), ("L33", "R34"), ("L66", "R68"), ("L100", "R99")]
    assert pairer.dropped == 0


def test_a_lost_image_drops_its_partner_and_never_pairs_wrong():
    pairer = StampPairer(5 * MS)
    pairs = feed(pairer, [0, 33, 66, 100], [1, 67, 99])  # right lost its 34 ms image
    assert pairs == [("L0", "R1"), ("L66", "R67"), ("L100", "R99")]
    assert pairer.dropped == 1


def test_skew_beyond_limit_is_dropped_and_counted():
    pairer = StampPairer(5 * MS)
    pairs = feed(pairer, [0, 33, 66], [10, 43, 76])  # 10 ms apart: never a pair
    assert pairs == []
    assert pairer.dropped >= 4 and pairer.dropped_in_row == pairer.dropped


def test_nearest_partner_wins_when_both_are_known():
    pairer = StampPairer(20 * MS)
    for side, t in [(0, 0), (0, 12), (1, 10)]:
        pairer.push(side, t * MS, t)
    assert [(a[1], b[1]) for a, b in pairer.pop()] == [(12, 10)]
    assert pairer.dropped == 1


def test_faster_camera_drops_its_extra_images():
    pairer = StampPairer(5 * MS)
    pairs = feed(pairer, range(0, 200, 20), range(0, 200, 40))  # 50 Hz against 25 Hz
    assert pairs == [(f"L{t}", f"R{t}") for t in range(0, 200, 40)]
    assert pairer.dropped == 4  # L20 L60 L100 L140 (L180 still waits)


def test_start_up_backlog_is_not_counted():
    pairer = StampPairer(5 * MS)
    # the left camera started 100 ms earlier: its first images can never pair, and are not errors
    pairs = feed(pairer, range(0, 200, 20), range(101, 200, 20))
    assert pairs == [(f"L{t}", f"R{t + 1}") for t in range(100, 200, 20)]
    assert pairer.dropped == 0 and pairer.dropped_in_row == 0
