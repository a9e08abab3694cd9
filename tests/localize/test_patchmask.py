import cv2
import numpy as np
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.forkdisp import flat_side_near
from appliance.localize.patchmask import inside_fraction, share_difference

H, W = 400, 320


def test_inside_fraction_counts_the_mask_and_the_image_edge_as_outside():
    mask = np.zeros((50, 60), np.uint8)
    mask[10:30, 10:40] = 255
    uv = np.array([[25.0, 20.0], [10.0, 20.0], [2.0, 2.0], [np.nan, 5.0]])
    f = inside_fraction(mask, uv, 3, 5)
    assert f[0] == 1.0                                  # wholly inside
    assert abs(f[1] - 6 / 11) < 1e-9                    # columns 5-15: 10-15 inside
    assert f[2] == 0.0 and f[3] == 0.0                  # outside / past the image's corner; no centre


def test_share_difference_compares_the_views_at_the_disparity():
    left = np.zeros((50, 100), np.uint8)
    left[10:30, 40:80] = 255
    right = np.roll(left, -20, axis=1)                 # the same silhouette at disparity 20
    uv = np.array([[40.0, 20.0], [60.0, 12.0]])        # across its left end / its top edge
    same = share_difference(left, right, uv, np.array([20.0, 20.0]), 3, 5)
    assert np.all(same == 0.0) and inside_fraction(left, uv, 3, 5).max() < 1.0
    right[10:20, 10:60] = 0                            # something in front of it in the right view only
    assert share_difference(left, right, uv, np.array([20.0, 20.0]), 3, 5)[1] > 0.5
    assert share_difference(left, right, uv, np.array([np.nan, 20.0]), 3, 5)[0] == 1.0


def _bark(rng, h, w):
    img = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.5)
    return cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)


def test_a_leaf_in_front_of_the_flat_side_next_to_the_fork_is_not_read():
    # a flat side at disparity 20 along row 200; a leaf (its own texture, disparity 22) covers its upper
    # half over columns 140-200 in the left view, next to the fork at column 150; in the right view the
    # branch there is clear (the leaf's own place on the branch is not modelled)
    rng = np.random.default_rng(5)
    left = _bark(rng, H, W)
    right = np.roll(left, -20, axis=1)
    leaf = _bark(rng, 12, 60)
    left[190:202, 140:200] = leaf
    right[190:202, 118:178] = leaf
    mask_l, mask_r = np.full((H, W), 255, np.uint8), np.full((H, W), 255, np.uint8)
    mask_l[190:202, 140:200] = 0
    t = np.arange(200.0, 301.0)
    c = BranchCurve(0, False, (200.0, 300.0), Poly.fit(t, np.full_like(t, 200.0), 1), Poly.constant(20.0),
                    8.0, len(t))
    read = flat_side_near(c, left, right, 150.0, f_px=1e9)
    assert read is not None and abs(read.d_px - 20.0) > 1.0        # the leaf pulls the patches' reading
    assert flat_side_near(c, left, right, 150.0, f_px=1e9, left_mask=mask_l, right_mask=mask_r) is None
    # the same hole in both views at the branch's disparity (its own outline): read as without masks
    mask_r[190:202, 120:180] = 0
    both = flat_side_near(c, left, right, 150.0, f_px=1e9, left_mask=mask_l, right_mask=mask_r)
    assert both is not None and both.d_px == read.d_px
