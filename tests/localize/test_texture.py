"""Texture disparities (localize/texture.py) on images shifted by known amounts."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.localize.texture import (
    _c_writable,
    _flat,
    nearer_in_front,
    surface_disparity,
    surface_disparity_many,
    surface_to_axis,
)


def textured(h: int = 120, w: int = 400, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.integers(0, 256, (h, w)).astype(np.uint8), (5, 5), 1.2)


def shifted(img: np.ndarray, d_px: float) -> np.ndarray:
    """The right view of a plane at disparity ``d_px``: right(x) = left(x + d)."""
    m = np.float32([[1, 0, d_px], [0, 1, 0]])
    return cv2.warpAffine(img, m, (img.shape[1], img.shape[0]), flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP,
                          borderMode=cv2.BORDER_REFLECT)


@pytest.mark.parametrize("d_true", [40.0, 57.3])
def test_surface_disparity_finds_the_shift(d_true):
    left = textured()
    right = shifted(left, d_true)
    uv = np.array([[150.0, 60.0], [250.4, 50.0], [390.0, 60.0], [200.0, 2.0]])
    d, score = surface_disparity(left, right, uv, np.array([4, 4, 4, 4]), (20.0, 80.0), half_w_px=12)
    assert np.abs(d[:2] - d_true).max() < 0.15 and (score[:2] > 0.95).all()
    assert np.isnan(d[2:]).all() and (score[2:] == -1).all()     # patch leaves the image
    # a narrow range around the answer gives the same disparities
    d2, _ = surface_disparity(left, right, uv[:2], np.array([4, 4]), (d_true - 6, d_true + 6), half_w_px=12)
    assert np.abs(d2 - d_true).max() < 0.15


def test_surface_disparity_at_the_left_border_and_on_flat_patches():
    left = textured()
    right = shifted(left, 30.0)
    left[:, 300:340] = 90                                         # no texture there
    uv = np.array([[45.0, 60.0], [320.0, 60.0]])                  # strip starts at column 0 / flat patch
    d, score = surface_disparity(left, right, uv, np.array([3, 3]), (10.0, 60.0), half_w_px=12)
    assert abs(d[0] - 30.0) < 0.15
    assert np.isnan(d[1]) and score[1] == -1
    d, score = surface_disparity(left, right, np.zeros((0, 2)), np.zeros(0, int), (10.0, 60.0))
    assert d.shape == score.shape == (0,)


def test_flat_agrees_with_the_standard_deviation():
    rng = np.random.default_rng(3)
    for _ in range(3000):
        h, w = rng.integers(1, 12, 2)
        spread = int(rng.integers(0, 40))
        p = (100 + rng.integers(0, spread + 1, (h, w)) * rng.integers(0, 2, (h, w))).astype(np.uint8)
        for min_std in (1.0, 2.0):
            assert _flat(p, min_std) == bool(p.std() < min_std)
    two = np.array([[0, 2] * 4], np.uint8)                       # std exactly 1
    assert _flat(two, 1.0) == bool(two.std() < 1.0)


def test_nearer_in_front_tells_an_occluder_from_the_background():
    left = textured(seed=1)
    near, far = shifted(left, 45.0), shifted(left, 5.0)
    uv = np.array([[200.0, 60.0]])
    half = np.array([6])
    assert nearer_in_front(left, near, uv, np.array([44.0]), half, 80.0)
    assert not nearer_in_front(left, far, uv, np.array([44.0]), half, 80.0)
    flat = np.full_like(left, 120)
    assert not nearer_in_front(flat, near, uv, np.array([44.0]), half, 80.0)


def test_surface_to_axis_moves_back_by_one_radius():
    d = surface_to_axis(np.array([100.0]), radius_px=10.0, f_px=1000.0, depth_fraction=1.0)
    assert d[0] == pytest.approx(100.0 / 1.01)
    assert surface_to_axis(np.array([50.0]), 0.0, 1000.0, offset_px=3.0)[0] == pytest.approx(50.0)


def test_patches_searched_together_score_as_one_by_one():
    # a short search over whole strips runs all patches at once: the same disparities and scores
    # as matchTemplate patch by patch (one patch per call), a flat patch left out alike
    left = textured(160, 500, seed=3)
    left[100:130, 300:340] = 90                                  # no texture there
    right = np.roll(left, -41, axis=1)
    rng = np.random.default_rng(5)
    uv = np.column_stack([rng.integers(60, 480, 25), rng.integers(20, 140, 25)]).astype(float)
    uv[0] = (320, 115)
    hh = np.full(len(uv), 6)
    d, s = surface_disparity(left, right, uv, hh, (35, 47), half_w_px=12)
    for i in range(len(uv)):
        d1, s1 = surface_disparity(left, right, uv[i:i + 1], hh[i:i + 1], (35, 47), half_w_px=12)
        assert np.isnan(d[i]) == np.isnan(d1[0])
        if not np.isnan(d1[0]):
            assert abs(d[i] - d1[0]) < 1e-3 and abs(s[i] - s1[0]) < 1e-4
    assert np.isnan(d[0]) and np.nanmax(np.abs(d - 41)) < 0.05


def test_searches_run_together_give_each_search_its_own_results():
    # several searches (their own images, patch heights and ranges) run as one batch where they
    # share a patch size and number of positions: each search's values as when run alone
    jobs = []
    for seed, d_true, hh, rng_d in ((3, 41, 6, (35, 47)), (4, 52.5, 6, (46.5, 58.5)), (5, 30, 4, (24, 36)),
                                    (6, 44, 6, (38.2, 50.2))):
        left = textured(160, 500, seed=seed)
        right = shifted(left, d_true)
        rng = np.random.default_rng(seed)
        uv = np.column_stack([rng.integers(60, 480, 9), rng.integers(20, 140, 9)]).astype(float)
        jobs.append((left, right, uv, np.full(len(uv), hh), rng_d, 12))
    together = surface_disparity_many(jobs)
    for job, (d, s) in zip(jobs, together):
        d1, s1 = surface_disparity(*job)
        assert np.array_equal(d, d1, equal_nan=True) and np.array_equal(s, s1)
    assert np.nanmax(np.abs(together[1][0] - 52.5)) < 0.15


def test_c_writable_is_np_require():
    """``_c_writable`` gives ``np.require(a, None, ["C", "W"])``: the array itself when C-contiguous and writable,
    else a C-contiguous writable copy with the same values (a strided view, a read-only array, a Fortran one)."""
    img = textured(40, 60, seed=3)
    assert _c_writable(img) is img
    ro = img.copy()
    ro.setflags(write=False)
    for a in (img[:, ::2], img[5:20, 3:40], ro, np.asfortranarray(img[:, :30]), img[::3, ::-1]):
        got, ref = _c_writable(a), np.require(a, None, ["C", "W"])
        assert (got is a) == (ref is a)
        assert got.flags.c_contiguous and got.flags.writeable
        assert got.dtype == ref.dtype and np.array_equal(got, ref)
    box = img[5:20, 3:40]
    assert _c_writable(box) is not box and np.shares_memory(np.require(box, None, ["C", "W"]), box) is False
