"""Run boundaries refined with the grey image (localize/subpixel.py) on anti-aliased synthetic bars."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize.edges import find_runs
from appliance.localize.rectify import LazyRectified, Rectifier
from appliance.localize.subpixel import gather, near_points, refine_boundaries, refine_runs

from tests.localize.test_rectify import distorted_rig


def bar(h: int, w: int, left_px: np.ndarray, right_px: np.ndarray, ss: int = 8,
        inside: float = 60.0, outside: float = 180.0) -> tuple[np.ndarray, np.ndarray]:
    """A dark bar between ``left_px`` and ``right_px`` (per row, pixel centres at integers) on a bright
    background: its coverage from ``ss`` samples per pixel, the grey image (blurred like a lens) and the
    binary mask of pixels more than half covered."""
    xs = np.arange(w)[None, :, None] + (np.arange(ss) + 0.5) / ss - 0.5
    cover = ((xs >= left_px[:, None, None]) & (xs < right_px[:, None, None])).mean(2)
    grey = cv2.GaussianBlur(outside + (inside - outside) * cover, (0, 0), 0.55)
    return np.clip(np.rint(grey), 0, 255).astype(np.uint8), (cover >= 0.5).astype(np.uint8) * 255


def test_refined_boundaries_find_the_outline_to_a_few_hundredths_of_a_pixel():
    h, w = 40, 80
    rows = np.arange(h)
    left, right = 20.0 + 0.37 * rows, 41.3 + 0.29 * rows              # slanted: every sub-pixel phase
    grey, mask = bar(h, w, left, right)
    runs = find_runs(mask, soft=True)
    assert len(runs.row) == h
    ref = refine_runs(runs, grey)
    err_mask = np.abs(np.r_[runs.left_px - left, runs.right_px - right])
    err_ref = np.abs(np.r_[ref.left_px - left, ref.right_px - right])
    assert err_mask.max() > 0.4                  # the mask is good to a pixel only
    assert err_ref.max() < 0.15 and np.median(err_ref) < 0.05


def test_a_biased_mask_is_moved_onto_the_outline_everywhere():
    """A segmenter's mask one pixel narrower each side: every boundary lands on the grey outline, those
    where the step is unclear (a flat patch of the bar's own grey) by the median shift of the others."""
    h, w = 200, 80
    rows = np.arange(h)
    left, right = 20.0 + 0.13 * rows, 45.6 + 0.11 * rows
    grey, mask = bar(h, w, left, right)
    narrow = cv2.erode(mask, np.ones((1, 3), np.uint8))
    grey[150:, :] = 60                                                     # no step below row 150
    ref = refine_runs(find_runs(narrow, soft=True), grey, narrow)
    assert np.abs(ref.left_px[:150] - left[:150]).max() < 0.6              # max_dev_px: at most 0.6 px off
    assert np.median(np.abs(ref.left_px[:150] - left[:150])) < 0.1
    assert np.abs(ref.left_px[150:] - left[150:]).max() < 0.6              # the bias moved them out too
    assert np.abs(np.r_[ref.left_px, ref.right_px] - np.r_[left, right]).mean() < 0.2
    # the widened runs own the first pixel inside their boundary
    assert (ref.find(rows, np.ceil(ref.left_px)) == rows).all()
    assert (ref.find(rows, np.floor(ref.right_px)) == rows).all()


def test_no_step_keeps_the_masks_boundaries():
    h, w = 20, 60
    grey = np.full((h, w), 90, np.uint8)
    mask = np.zeros((h, w), np.uint8)
    mask[:, 20:31] = 255
    runs = find_runs(mask, soft=True)
    ref = refine_runs(runs, grey, mask)
    assert np.array_equal(ref.left_px, runs.left_px) and np.array_equal(ref.right_px, runs.right_px)
    x = refine_boundaries(grey, runs.row, runs.left_px)
    assert np.array_equal(x, runs.left_px)


def test_whole_dev_px_gives_a_soft_masks_runs_on_the_grey_step_and_none_for_a_binary_mask():
    # a binary mask's outline goes to the grey step whole already (subpixel.WHOLE_PIXEL_SHARE): no second runs; a
    # soft mask's (a bar's coverage, every sub-pixel phase; its right outline 0.9 px out on a third of the rows, as a
    # colour outline over a dark background) is mixed with the step, and whole_dev_px gives its runs on the step
    # (tipends.TIP_GREY_END's): on the outline there; the first runs are those of a call without it
    h, w = 200, 80
    rows = np.arange(h)
    left, right = 20.0 + 0.13 * rows, 45.6 + 0.11 * rows
    grey, mask = bar(h, w, left, right)
    binary = find_runs(mask, soft=True)
    got, whole = refine_runs(binary, grey, mask, whole_dev_px=1.5)
    assert whole is None and np.array_equal(got.right_px, refine_runs(binary, grey, mask).right_px)
    cols = np.arange(w)[None, :]
    out = np.where(rows < 60, 0.9, 0.0)[:, None]         # rows 0-59: the right outline 0.9 px out (a background's)
    soft = np.rint(255 * np.clip(cols - left[:, None] + 0.5, 0, 1) * np.clip(right[:, None] + out - cols + 0.5, 0, 1))
    soft = soft.astype(np.uint8)
    runs = find_runs(soft, soft=True)
    mixed = refine_runs(runs, grey, soft)
    got, whole = refine_runs(runs, grey, soft, whole_dev_px=1.5)
    assert whole is not None
    assert np.array_equal(got.left_px, mixed.left_px) and np.array_equal(got.right_px, mixed.right_px)
    assert np.median(np.abs(mixed.right_px - right)[:60]) > 0.3           # the mix keeps part of the 0.9 px
    assert np.abs(whole.right_px - right)[:60].max() < 0.15
    assert np.median(np.abs(whole.right_px - right)[60:]) < 0.1


def test_gather_from_a_lazily_rectified_colour_image_is_the_rectified_grey():
    w, h = 333, 251
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    rng = np.random.default_rng(7)
    bgr = cv2.GaussianBlur(rng.integers(0, 256, (h, w, 3), dtype=np.uint8), (0, 0), 2)
    for side in (0, 1):
        want = rect.rectify(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), side)
        row = rng.integers(0, h, 3000)
        col = rng.integers(-3, w + 3, 3000)[:, None] + np.arange(-3, 4)        # clipped to the image
        got = gather(LazyRectified(rect, bgr, side), row, col)
        exact = gather(want, row, col)
        assert got.shape == (3000, 7)
        assert np.abs(got - exact).max() <= 1.0          # the grey conversion rounds before or after the remap
        grey = gather(LazyRectified(rect, cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), side), row, col)
        assert np.array_equal(grey, exact)               # a grey source: the very same values


def test_near_points_selects_the_runs_around_points_and_their_right_view_places():
    h, w = 300, 400
    mask = np.zeros((h, w), np.uint8)
    mask[:, 50:60] = mask[:, 200:210] = mask[:, 330:340] = 255     # three upright bars
    runs = find_runs(mask, soft=True)
    pt = np.array([[205.0, 150.0]])
    near = near_points(runs, pt, 32)
    assert near[(runs.x0 == 200) & (np.abs(runs.row - 150) <= 32)].all()
    assert not near[(runs.x0 == 200) & (np.abs(runs.row - 150) > 32 + 16 + 16)].any()  # within a cell or two
    assert not near[runs.x0 != 200].any()
    right = near_points(runs, pt, 32, (140.0, 160.0))                  # the point 140-160 px left in the right view
    assert right[(runs.x0 == 50) & (np.abs(runs.row - 150) <= 32)].all()
    assert not right[runs.x0 != 50].any()
    assert not near_points(runs, np.zeros((0, 2)), 32).any()
