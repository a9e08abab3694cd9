"""Sub-pixel outlines (appliance.localize.subpixel): drawn anti-aliased bars, binary and soft masks."""

import cv2
import numpy as np
from appliance.localize.edges import find_runs
from appliance.localize.subpixel import grey_weight, refine_boundaries, refine_runs, whole_pixel_share

H, W = 120, 240
TEXTURE = 12.0          # grey levels: the grey step's error ~0.1 px, as measured on the rendered scenes


def _bar(x0_px: float, slope: float, width_px: float, ss: int = 8):
    """Coverage (H, W) of a bar between x = x0 + slope * y and that + width (pixel centres at
    integers), from ``ss`` x ``ss`` samples per pixel, and the true left/right crossing of each row."""
    off = (np.arange(ss) + 0.5) / ss - 0.5
    ys = (np.arange(H)[:, None] + off).ravel()
    xs = (np.arange(W)[:, None] + off).ravel()
    left = x0_px + slope * ys[:, None]
    inside = (xs[None, :] >= left) & (xs[None, :] <= left + width_px)
    cover = inside.reshape(H, ss, W, ss).mean(axis=(1, 3))
    rows = np.arange(H)
    return cover, x0_px + slope * rows, x0_px + slope * rows + width_px


def _grey(cover: np.ndarray, seed: int = 0, texture: float = 0.0) -> np.ndarray:
    """A camera's view of it: bark 180 on background 60 (each varying by ``texture`` grey levels
    (sd) over ~1 px), optics blur, noise, 8 bits."""
    rng = np.random.default_rng(seed)
    tex = cv2.GaussianBlur(rng.normal(0, 1.0, cover.shape).astype(np.float32), (0, 0), 0.7)
    tex *= texture / max(float(tex.std()), 1e-6)
    g = cv2.GaussianBlur((60.0 + 120.0 * cover + tex).astype(np.float32), (0, 0), 0.55)
    return np.clip(np.rint(g + rng.normal(0, 1.0, g.shape)), 0, 255).astype(np.uint8)


def _errors(runs, t_left, t_right):
    """|boundary - truth| (px) of both boundaries of every run (one run per row)."""
    return np.abs(np.r_[runs.left_px - t_left[runs.row], runs.right_px - t_right[runs.row]])


def test_a_binary_masks_outline_goes_to_the_grey_step():
    # a bar 17 deg from vertical: the binary mask's crossings are whole pixels (off by up to 0.5 px)
    cover, tl, tr = _bar(60.3, 0.3, 14.4)
    mask = (cover >= 0.5).astype(np.uint8) * 255
    runs = find_runs(mask, soft=True)
    assert len(runs.row) == H
    assert whole_pixel_share(_grey(cover), np.r_[runs.row, runs.row], np.r_[runs.left_px, runs.right_px]) > 0.9
    before = _errors(runs, tl, tr)
    after = _errors(refine_runs(runs, _grey(cover), mask), tl, tr)
    assert np.median(before) > 0.15
    assert np.median(after) < 0.06
    assert np.percentile(after, 90) < 0.12


def test_a_soft_masks_outline_is_mixed_with_the_grey_step():
    # a soft mask (a segmenter's share of bark per outline pixel, with its own error) and the grey
    # step (textured bark and background, as in the rendered scenes: ~0.1 px) err about equally:
    # the mix is better than either alone
    cover, tl, tr = _bar(60.3, 0.3, 14.4)
    rng = np.random.default_rng(3)
    edge = (cover > 0) & (cover < 1)
    soft = np.where(edge, cover + rng.normal(0, 0.12, cover.shape), cover)
    mask = np.clip(np.rint(255 * soft), 0, 255).astype(np.uint8)
    grey = _grey(cover, seed=1, texture=TEXTURE)
    runs = find_runs(mask, soft=True)
    row, x = np.r_[runs.row, runs.row], np.r_[runs.left_px, runs.right_px]
    assert whole_pixel_share(grey, row, x) < 0.5
    mixed = _errors(refine_runs(runs, grey, mask), tl, tr)
    grey_alone = np.abs(refine_boundaries(grey, row, x) - np.r_[tl, tr][np.r_[runs.row, runs.row + H]])
    mask_alone = _errors(runs, tl, tr)
    assert np.mean(mixed) < 0.9 * min(np.mean(grey_alone), np.mean(mask_alone))


def test_an_outline_40_deg_from_vertical_is_refined():
    # tan 40 deg = 0.84: refined along the row (STEEP_TAN: 45 deg)
    cover, tl, tr = _bar(10.2, 0.84, 30.0)
    mask = (cover >= 0.5).astype(np.uint8) * 255
    runs = find_runs(mask, soft=True)
    ok = (runs.x0 > 3) & (runs.x1 < W - 4)
    before = _errors(runs, tl, tr)[np.r_[ok, ok]]
    after = _errors(refine_runs(runs, _grey(cover), mask), tl, tr)[np.r_[ok, ok]]
    assert np.median(after) < 0.6 * np.median(before)


def test_the_grey_weight_follows_the_masks_scatter():
    rng = np.random.default_rng(0)
    grey_sd = 0.1
    # differences of a mask with sd 0.1 (as good as the grey step): about half
    w = grey_weight(rng.normal(0, np.hypot(0.1, grey_sd), 4000), grey_sd)
    assert 0.4 < w < 0.6
    # a mask scattering 0.3 px: mostly the grey step
    assert 0.85 < grey_weight(rng.normal(0, np.hypot(0.3, grey_sd), 4000), grey_sd) < 0.95
    # a mask no worse than the grey step's own error: the mask
    assert grey_weight(rng.normal(0, 0.05, 4000), grey_sd) == 0.0


def test_a_binary_mask_is_told_from_a_soft_one_through_the_rectification():
    # the rig's remap tables move and distort: the binary mask's remapped outline still crosses
    # one half on the original's pixel boundaries, a soft one's does not
    from pathlib import Path

    from appliance.calibrate.model import load_calibration
    from appliance.localize.rectify import LazyRectified, Rectifier

    calib = load_calibration(Path(__file__).resolve().parents[2] / "fixtures" / "rig.yaml")
    rect = Rectifier.from_calibration(calib)
    w, h = calib.image_size
    off = (np.arange(4) + 0.5) / 4 - 0.5
    ys, xs = (np.arange(h)[:, None] + off).ravel(), (np.arange(w)[:, None] + off).ravel()
    left = 600.3 + 0.2 * (ys - h / 2)
    cover = ((xs[None, :] >= left[:, None]) & (xs[None, :] <= left[:, None] + 20.0)).reshape(h, 4, w, 4).mean(axis=(1, 3))
    grey = LazyRectified(rect, cv2.cvtColor(_grey(cover), cv2.COLOR_GRAY2BGR), 0)
    rng = np.random.default_rng(5)
    soft = np.clip(np.rint(255 * (cover + rng.normal(0, 0.08, cover.shape) * ((cover > 0) & (cover < 1)))), 0, 255)
    shares = []
    for m in ((cover >= 0.5).astype(np.uint8) * 255, soft.astype(np.uint8)):
        runs = find_runs(rect.rectify(m, 0, fast=True), soft=True)
        shares.append(whole_pixel_share(grey, np.r_[runs.row, runs.row], np.r_[runs.left_px, runs.right_px]))
    assert shares[0] > 0.6
    assert shares[1] < 0.4
