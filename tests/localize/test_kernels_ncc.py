"""The patch comparisons (localize/kernels_ncc.py: NCC searches and scores, masked squared differences)
against the numpy / OpenCV code they replace."""

from __future__ import annotations

import cv2
import numpy as np

from appliance.localize import kernels_ncc
from appliance.localize.texture import _flat


def _peaks_by_opencv(left, right, ty, tx, hh, hw, sx0, sx1, min_std):
    """texture._search's former loop: cv2.matchTemplate per patch, the float32 parabola."""
    n = len(ty)
    ok, ks, offs, best = np.zeros(n, bool), np.zeros(n, int), np.zeros(n), np.full(n, -1.0)
    for i in range(n):
        tmpl = left[ty[i] - hh[i]:ty[i] + hh[i] + 1, tx[i] - hw:tx[i] + hw + 1]
        if _flat(tmpl, min_std):
            continue
        strip = right[ty[i] - hh[i]:ty[i] + hh[i] + 1, sx0[i]:sx1[i]]
        if strip.shape[1] < tmpl.shape[1] + 2:
            continue
        c = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]
        k = int(c.argmax())
        off = 0.0
        if 0 < k < len(c) - 1:
            denom = c[k - 1] - 2 * c[k] + c[k + 1]
            off = 0.5 * (c[k - 1] - c[k + 1]) / denom if denom < 0 else 0.0
        ok[i], ks[i], offs[i], best[i] = True, k, off, c[k]
    return ok, ks, offs, best


def test_ncc_peaks_is_opencvs_search():
    rng = np.random.default_rng(5)
    n_peaks = 0
    for trial in range(40):
        h, w = 60, 320
        left = cv2.GaussianBlur(rng.integers(0, 256, (h, w)).astype(np.uint8), (0, 0), rng.uniform(0.6, 3.0))
        d = rng.uniform(5, 60)
        m = np.float32([[1, 0, d], [0, 1, 0]])
        right = cv2.warpAffine(left, m, (w, h), flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP,
                               borderMode=cv2.BORDER_REFLECT)
        right = np.clip(right + rng.normal(0, rng.uniform(0, 6), right.shape), 0, 255).astype(np.uint8)
        left[:, 200:240] = 77                                       # flat patches
        left[10:20, 40:60] = left[10:20, 40:60] // 64 * 64 + 1      # near flat
        right[:, 100:130] = 90                                      # windows without variance
        n = 30
        hh = rng.integers(1, 10, n)
        hw = int(rng.integers(1, 13))
        ty = rng.integers(hh, h - hh)
        tx = rng.integers(hw, w - hw, n)
        sx0 = rng.integers(0, w - 4, n)
        sx1 = np.minimum(sx0 + rng.integers(0, 280, n), w)
        min_std = float(rng.choice([1.0, 2.0]))
        got = kernels_ncc.ncc_peaks(left, right, ty, tx, hh, hw, sx0, sx1, min_std)
        ref = _peaks_by_opencv(left, right, ty, tx, hh, hw, sx0, sx1, min_std)
        ok, k, off, best = got
        assert (ok == ref[0]).all()
        # the scores agree to OpenCV's float32 rounding (its correlation by DFT: up to ~1e-4); the best
        # position too, but for near ties
        assert np.abs(best[ok] - ref[3][ok]).max(initial=0) < 1e-3
        same = k[ok] == ref[1][ok]
        assert same.mean() > 0.97
        assert np.abs(off[ok][same] - ref[2][ok][same]).max(initial=0) < 0.02
        n_peaks += int(ok.sum())
    assert n_peaks > 500


def test_ncc_scores_is_matchtemplate():
    rng = np.random.default_rng(6)
    for _ in range(60):
        nh, nw = rng.integers(1, 20, 2)
        strip = cv2.GaussianBlur(rng.integers(0, 256, (nh, int(rng.integers(1, 300)))).astype(np.uint8), (0, 0), 1.5)
        strip[:, 20:40] = 50                                        # windows without variance
        tmpl = strip[:, 5:5 + nw].copy() if strip.shape[1] >= 5 + nw else \
            rng.integers(0, 256, (nh, nw)).astype(np.uint8)
        if rng.random() < 0.1:
            tmpl[:] = 7                                             # a constant template: 1 everywhere
        got = kernels_ncc.ncc_scores(strip, tmpl)
        if strip.shape[1] < nw:
            assert got.shape == (0,)
            continue
        ref = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]
        assert got.shape == ref.shape
        assert np.abs(got - ref).max() < 1e-3                      # OpenCV's float32 (DFT) rounding


def test_masked_sqdiff_is_matchtemplates():
    rng = np.random.default_rng(7)
    for _ in range(60):
        nh, nw = rng.integers(3, 30, 2)
        strip = cv2.GaussianBlur((rng.random((nh, int(rng.integers(nw, 300)))) < 0.5).astype(np.uint8) * 255,
                                 (0, 0), 1.0)
        patch = strip[:, :nw].copy() if rng.random() < 0.5 else rng.integers(0, 256, (nh, nw)).astype(np.uint8)
        half = (rng.random((nh, nw)) < 0.6).astype(np.uint8)
        got = kernels_ncc.masked_sqdiff(strip, patch, half)
        ref = cv2.matchTemplate(strip.astype(np.float32), patch.astype(np.float32), cv2.TM_SQDIFF,
                                mask=half.astype(np.float32))[0]
        n = float(half.sum()) * 255.0 ** 2
        assert got.shape == ref.shape
        assert np.abs(got - ref).max() / n < 1e-4                  # OpenCV's float32 rounding
        # exact: the sums of squared integer differences
        assert got[0] == float(((strip[:, :nw].astype(np.int64) - patch) ** 2 * half).sum())


def test_ncc_scores_of_big_patches_do_not_overflow():
    rng = np.random.default_rng(11)
    strip = np.full((190, 260), 255, np.uint8)
    strip[:, ::2] = rng.integers(200, 256, (190, 130)).astype(np.uint8)
    tmpl = strip[:, 30:220].copy()                                # 190 x 190 px: int32 sums would overflow
    got = kernels_ncc.ncc_scores(strip, tmpl)
    ref = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]
    assert got[30] == 1.0 and np.abs(got - ref).max() < 1e-3
