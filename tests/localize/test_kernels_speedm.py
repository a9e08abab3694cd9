"""The match stage's kernels of the fourth numba pass (localize/kernels.py, block "speedm") against the
numpy / OpenCV code they replace."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize import kernels
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
        got = kernels.ncc_peaks(left, right, ty, tx, hh, hw, sx0, sx1, min_std)
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
        got = kernels.ncc_scores(strip, tmpl)
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
        got = kernels.masked_sqdiff(strip, patch, half)
        ref = cv2.matchTemplate(strip.astype(np.float32), patch.astype(np.float32), cv2.TM_SQDIFF,
                                mask=half.astype(np.float32))[0]
        n = float(half.sum()) * 255.0 ** 2
        assert got.shape == ref.shape
        assert np.abs(got - ref).max() / n < 1e-4                  # OpenCV's float32 rounding
        # exact: the sums of squared integer differences
        assert got[0] == float(((strip[:, :nw].astype(np.int64) - patch) ** 2 * half).sum())


def test_refine_steps_is_refine_boundaries_numpy_steps():
    from appliance.localize.subpixel import refine_boundaries
    rng = np.random.default_rng(8)
    moved = 0
    for _ in range(30):
        h, w = 40, 200
        img = np.zeros((h, w), np.float32)
        for _ in range(8):                                         # blurred bars at sub-pixel positions
            x0, x1 = sorted(rng.uniform(0, w, 2))
            img[:, int(x0):int(x1)] += rng.uniform(-120, 120)
        img = cv2.GaussianBlur(img, (0, 0), rng.uniform(0.5, 2.0)) + 120 + rng.normal(0, rng.uniform(0, 8), img.shape)
        gray = np.clip(np.rint(img), 0, 255).astype(np.uint8)
        gray[:, 50:60] = 0                                         # steps into black / flat
        k = 400
        row = rng.integers(0, h, k)
        x = rng.uniform(-3, w + 3, k)
        x[:20] = np.rint(x[:20])                                   # on whole pixels (d == 0)
        for kw in ({}, {"min_step": 5.0, "min_share": 0.1, "max_shift_px": 2.0}):
            got = refine_boundaries(gray, row, x, **kw)            # (uint8: kernels.refine_steps)
            ref = refine_boundaries(gray.astype(np.float32), row, x, **kw)     # (float32: the numpy steps)
            assert got.dtype == ref.dtype and np.array_equal(got, ref)
            moved += int((got != x).sum())
    assert moved > 2000


def _vote_by_numpy(cand_t, cand_d, slopes, tm, tol_px):
    """single_edge.edge_consensus' former vote (numpy)."""
    d0 = slopes[:, None] * (cand_t - tm)
    np.subtract(cand_d, d0, out=d0)
    lo = float(d0.min())
    d0 -= lo
    d0 /= tol_px
    bins = d0.astype(np.intp)
    nb = int(bins.max()) + 2
    bins += np.arange(len(slopes))[:, None] * nb
    votes = np.bincount(bins.ravel(), minlength=len(slopes) * nb).reshape(len(slopes), nb)
    window = votes[:, :-1] + votes[:, 1:]
    k_s, k_b = np.unravel_index(int(window.argmax()), window.shape)
    return lo, int(k_s), int(k_b)


def test_line_vote_is_the_numpy_vote():
    rng = np.random.default_rng(9)
    slopes = np.linspace(-0.25, 0.25, 21)
    for _ in range(300):
        n = int(rng.integers(1, 400))
        t = np.sort(rng.integers(0, 900, n)).astype(float)
        d = rng.uniform(100, 300, n)
        if rng.random() < 0.7:                                     # a line through some of them
            on = rng.random(n) < rng.uniform(0.2, 0.9)
            d[on] = 180 + rng.uniform(-0.2, 0.2) * (t[on] - t.mean()) + rng.normal(0, 0.3, on.sum())
        if rng.random() < 0.2:
            d = np.round(d)                                        # ties between bins and windows
        tm = float(t.mean())
        tol = float(rng.choice([1.0, 0.5, 1.5]))
        assert kernels.line_vote(t, d, slopes, tm, tol) == _vote_by_numpy(t, d, slopes, tm, tol)


def test_warm_up_compiles_the_signatures_these_kernels_get():
    """After a Localizer is built, localizing (colour and exact masks, scenes with caps and flat pieces)
    compiles none of these kernels again (warm_up passes the same array layouts as the callers)."""
    from pathlib import Path

    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer
    from appliance.synth.truth import load_truth

    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    loc = Localizer(load_calibration(fixtures / "rig.yaml"), load_config().localize)
    mine = [kernels.ncc_search, kernels.ncc_peaks, kernels.ncc_scores, kernels.masked_sqdiff, kernels.refine_steps,
            kernels.line_vote, kernels.centre_line]
    before = [len(f.signatures) for f in mine]
    for n in ("01", "03"):
        left, right = (cv2.imread(str(fixtures / "scenes" / f"{s}_{n}.png")) for s in ("left", "right"))
        truth = load_truth(fixtures / "scenes" / f"truth_{n}.json")
        loc.localize(left, right)
        loc.localize(left, right, mask_left=truth.mask_left, mask_right=truth.mask_right)
    assert [len(f.signatures) for f in mine] == before and all(before)


def _centre_guess_by_numpy(pts, axis, scale):
    """single_edge.centre_guess' numpy steps (bincount means, np.interp)."""
    t, s = pts[:, axis], pts[:, 1 - axis]
    k = (t * 2.0).astype(np.int64)
    k0 = int(k.min())
    k -= k0
    count = np.bincount(k)
    nz = np.flatnonzero(count)
    uniq = (nz + k0) / 2.0
    s_mean = np.bincount(k, s)[nz] / count[nz]
    half = (scale - 1) / 2
    ts = np.arange(np.ceil(uniq[0] - half), np.floor(uniq[-1] + half) + 1)
    return ts, np.interp(ts, uniq, s_mean)


def test_centre_line_is_centre_guess_numpy_steps():
    from appliance.localize.single_edge import centre_guess
    rng = np.random.default_rng(10)
    for trial in range(500):
        n = int(rng.integers(1, 300))
        scale = int(rng.choice([1, 2, 4]))
        t = np.sort(rng.integers(0, 900, n)) / (2.0 if trial % 2 else 1.0)      # whole or half pixels
        s = np.cumsum(rng.normal(0, 1.5, n)) + rng.uniform(0, 1000)
        if trial % 7 == 0:
            s = np.round(s)
        pts = np.column_stack([s, t]) if trial % 3 else np.column_stack([t, s])
        axis = 1 if trial % 3 else 0
        ok, ts, xs = kernels.centre_line(np.ascontiguousarray(pts[:, axis]), np.ascontiguousarray(pts[:, 1 - axis]),
                                         (scale - 1) / 2)
        assert ok
        ref = _centre_guess_by_numpy(pts, axis, scale)
        assert np.array_equal(ts, ref[0]) and np.array_equal(xs, ref[1])
        got = centre_guess(pts, axis, scale)
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
    # other positions (not whole or half pixels), or sparse ones: the numpy path
    assert not kernels.centre_line(np.array([0.25, 3.0]), np.zeros(2), 0.0)[0]
    assert not kernels.centre_line(np.array([0.0, 1e6]), np.zeros(2), 0.0)[0]
    ts, xs = centre_guess(np.array([[0.0, 0.25], [2.0, 3.0]]), 1, 1)
    assert np.array_equal(ts, [1.0, 2.0, 3.0])


def test_ncc_scores_of_big_patches_do_not_overflow():
    rng = np.random.default_rng(11)
    strip = np.full((190, 260), 255, np.uint8)
    strip[:, ::2] = rng.integers(200, 256, (190, 130)).astype(np.uint8)
    tmpl = strip[:, 30:220].copy()                                # 190 x 190 px: int32 sums would overflow
    got = kernels.ncc_scores(strip, tmpl)
    ref = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]
    assert got[30] == 1.0 and np.abs(got - ref).max() < 1e-3
