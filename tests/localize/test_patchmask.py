import cv2
import numpy as np
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.forkdisp import flat_side_near
from appliance.localize.patchmask import inside_fraction

H, W = 400, 320


def test_inside_fraction_counts_the_mask_and_the_image_edge_as_outside():
    mask = np.zeros((50, 60), np.uint8)
    mask[10:30, 10:40] = 255
    uv = np.array([[25.0, 20.0], [10.0, 20.0], [2.0, 2.0], [np.nan, 5.0]])
    f = inside_fraction(mask, uv, 3, 5)
    assert f[0] == 1.0                                  # wholly inside
    assert abs(f[1] - 6 / 11) < 1e-9                    # columns 5-15: 10-15 inside
    assert f[2] == 0.0 and f[3] == 0.0                  # outside / past the image's corner; no centre


def _bark(rng, h, w):
    img = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.5)
    return cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)


def test_a_leaf_over_the_flat_side_next_to_the_fork_is_not_read():
    # a flat side at disparity 20 along row 200; a leaf (its own texture, disparity 22) covers its upper
    # half over columns 140-200 in the left view, next to the fork at column 150
    rng = np.random.default_rng(5)
    left = _bark(rng, H, W)
    right = np.roll(left, -20, axis=1)
    leaf = _bark(rng, 12, 60)
    left[190:202, 140:200] = leaf
    right[190:202, 118:178] = leaf
    mask = np.full((H, W), 255, np.uint8)
    mask[190:202, 140:200] = 0
    t = np.arange(200.0, 301.0)
    c = BranchCurve(0, False, (200.0, 300.0), Poly.fit(t, np.full_like(t, 200.0), 1), Poly.constant(20.0),
                    8.0, len(t))
    read = flat_side_near(c, left, right, 150.0, f_px=1e9)
    assert read is not None and abs(read.d_px - 20.0) > 1.0        # the leaf pulls the patches' reading
    assert flat_side_near(c, left, right, 150.0, f_px=1e9, left_mask=mask) is None
    # the same side without the leaf, its mask whole: read as without a mask
    left[190:202, 140:200] = np.roll(right, 20, axis=1)[190:202, 140:200]
    clear = flat_side_near(c, left, right, 150.0, f_px=1e9, left_mask=np.full((H, W), 255, np.uint8))
    assert clear is not None and abs(clear.d_px - 20.0) <= 0.1
