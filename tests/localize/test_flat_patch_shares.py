"""A flat piece's own texture patches are read only where they hold the same share of branch in both views
(dense.FLAT_MAX_SHARE_DIFF, dense._two_view_patches; docs/localize-gross19b.md): constructed masks. The rendered
scene that showed the rule's effect (seed 353's tip 15), with the rule off and on: test_tip_rules.py."""

from types import SimpleNamespace

import numpy as np
from appliance.localize import dense


def _masks(d_px: int = 20):
    """A level branch 16 rows thick (rows 92-107) over columns 100-300 of the left view, the same at ``d_px``
    in the right view."""
    left = np.zeros((200, 400), np.uint8)
    left[92:108, 100:300] = 255
    return left, np.roll(left, -d_px, axis=1)


U = np.arange(130.0, 271.0, 6.0)
UV = np.column_stack([U, np.full(len(U), 100.0)])
RADIUS = 8.0                                            # patches 2 x 4 + 1 = 9 rows high, 25 columns wide


def _piece_line(u: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The piece's disparity (N,) px at the columns ``u`` (N,) px: the Theil-Sen line through the readings
    ``d`` (N,) px (the median of the pairwise slopes, the median intercept: a few stray readings do not
    move it; the median for one reading). (kernels_patchshare.flat_share_dropped's line, by numpy: the reference.)"""
    i, j = np.triu_indices(len(u), 1)
    du = u[j] - u[i]
    keep = du != 0
    k = float(np.median((d[j] - d[i])[keep] / du[keep])) if keep.any() else 0.0
    return float(np.median(d - k * u)) + k * u


def test_the_piece_line_is_not_moved_by_stray_readings():
    d = 20.0 + 0.01 * (U - 130.0)
    d_bad = d.copy()
    d_bad[[2, 3, 9]] += [6.0, -8.0, 15.0]
    assert np.allclose(_piece_line(U, d_bad), d, atol=1e-9)
    assert np.allclose(_piece_line(U[:1], d[:1]), d[:1])


def test_a_leaf_over_a_flat_piece_in_one_view_drops_the_patches_it_covers(monkeypatch):
    left, right = _masks()
    left[88:104, 180:215] = 0                           # a leaf over the upper half of the piece, left view only
    sm = SimpleNamespace(left_mask=left, right_mask=right)
    d = np.full(len(U), 20.0)
    d[(U >= 170) & (U <= 225)] = 19.1                   # the leaf pulls the readings it covers
    out = dense._two_view_patches(sm, UV, d, RADIUS)
    dropped = ~np.isfinite(out)
    # the leaf takes 8 of a patch's 9 rows over the columns it shares with columns 180-214
    lost = np.clip(np.minimum(U + 12, 214) - np.maximum(U - 12, 180) + 1, 0, 25) / 25 * 8 / 9
    assert 5 <= dropped.sum() < len(U) - 5 and np.all(dropped == (lost > dense.FLAT_MAX_SHARE_DIFF))
    assert np.all(out[~dropped] == d[~dropped])
    # the same hole in both views (at the branch's disparity: a gap in the branch itself): kept
    right2 = right.copy()
    right2[88:104, 160:195] = 0
    assert np.array_equal(dense._two_view_patches(SimpleNamespace(left_mask=left, right_mask=right2), UV, d, RADIUS),
                          d)
    # the rule off: kept
    monkeypatch.setattr(dense, "FLAT_MAX_SHARE_DIFF", None)
    assert dense._two_view_patches(sm, UV, d, RADIUS) is d


def test_a_short_piece_keeps_its_few_patches():
    # three patches, one under the leaf: dropping it would leave two, too few to read the piece (seed 134 T9)
    left, right = _masks()
    left[88:104, 160:175] = 0
    uv = UV[2:5]                                        # columns 142, 148, 154
    d = np.full(3, 20.0)
    sm = SimpleNamespace(left_mask=left, right_mask=right)
    assert np.array_equal(dense._two_view_patches(sm, uv, d, RADIUS), d)
    # the same with a fourth patch clear of the leaf: three stay, the one under it is dropped
    uv4, d4 = UV[1:5], np.full(4, 20.0)
    assert np.array_equal(np.isfinite(dense._two_view_patches(sm, uv4, d4, RADIUS)), [True, True, True, False])


def test_the_compiled_drop_equals_the_numpy_shares():
    # kernels_patchshare.flat_share_dropped against _piece_line (above) + patchmask.share_difference on random masks
    from appliance.localize.kernels_patchshare import flat_share_dropped
    from appliance.localize.patchmask import share_difference
    rng = np.random.default_rng(5)
    for _ in range(30):
        left = (rng.uniform(0, 1, (60, 120)) < 0.7).astype(np.uint8) * 255
        right = (rng.uniform(0, 1, (60, 120)) < 0.7).astype(np.uint8) * 255
        n = int(rng.integers(1, 15))
        u = np.sort(rng.uniform(-5, 125, n))
        v = rng.uniform(-5, 65, n)
        d = rng.uniform(5, 15, n)
        hh = int(rng.integers(1, 5))
        diff = share_difference(left, right, np.column_stack([u, v]), _piece_line(u, d), hh, 12)
        want = diff > 0.15
        if not want.any() or n - want.sum() < 3:
            want[:] = False
        assert np.array_equal(flat_share_dropped(left, right, u, v, d, hh, 12, 0.15, 3), want)
