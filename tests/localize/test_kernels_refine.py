"""The runs' sub-pixel refinement kernels (localize/kernels_refine.py) against the numpy code they replaced (kept
here as the reference)."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from appliance.localize import dense, subpixel
from appliance.localize.curves import median
from appliance.localize.edges import find_runs


def _refine_runs_numpy(runs, gray, mask=None, only=None, max_tan=1.0, max_dev_px=0.6, min_moved=50,
                       grey_sd_px=0.10, **kw):
    """subpixel.refine_runs before the twelfth pass."""
    n = len(runs.row)
    if n == 0:
        return runs
    row, x = np.concatenate([runs.row, runs.row]), np.concatenate([runs.left_px, runs.right_px])
    todo = np.arange(2 * n) if only is None else np.flatnonzero(np.concatenate([only, only]))
    if mask is not None:
        todo = todo[subpixel.steep_boundaries(mask, row[todo], x[todo], max_tan)]
    xr = subpixel.refine_boundaries(gray, row[todo], x[todo], **kw)
    moved = xr != x[todo]
    todo, xr = todo[moved], xr[moved]
    weight = 1.0
    if len(todo) >= min_moved:
        inward = np.where(todo < n, 1.0, -1.0)
        dev = (xr - x[todo]) * inward
        bias = float(median(dev))
        if subpixel.whole_pixel_share(gray, row[todo], x[todo]) < subpixel.WHOLE_PIXEL_SHARE:
            weight = subpixel.grey_weight(dev - bias, grey_sd_px)
        x[:n] += bias
        x[n:] -= bias
    xt = x[todo]
    xg = np.minimum(np.maximum(xr, xt - max_dev_px), xt + max_dev_px)
    x[todo] = xg if weight == 1.0 else xt + weight * (xg - xt)
    centre = runs.centre_px
    left, right = np.minimum(x[:n], centre), np.maximum(x[n:], centre)
    x0, x1 = runs.x0, runs.x1
    gap = np.empty(n + 1, np.int64)
    gap[[0, -1]] = 1 << 40
    np.subtract(x0[1:], x1[:-1], out=gap[1:-1])
    gap[1:-1][runs.row[1:] != runs.row[:-1]] = 1 << 40
    x0 = np.where((gap[:-1] >= 3) & (x0 > 0) & (left < x0 - 0.5), x0 - 1, x0)
    x1 = np.where((gap[1:] >= 3) & (x1 < runs.width - 1) & (right > x1 + 0.5), x1 + 1, x1)
    return dataclasses.replace(runs, x0=x0, x1=x1, left_px=left, right_px=right)


def _scene(rng, h=120, w=160, binary=False):
    """A grey image with blurred tilted bars and the bars' soft (or binary) mask."""
    yy, xx = np.mgrid[0:h, 0:w].astype(float)
    cover = np.zeros((h, w))
    for _ in range(rng.integers(1, 6)):
        x0, slope, half = rng.uniform(0, w), rng.uniform(-1.5, 1.5), rng.uniform(0.8, 12)
        dist = np.abs(xx - (x0 + slope * (yy - h / 2))) / np.sqrt(1 + slope ** 2)
        cover = np.maximum(cover, np.clip(half - dist + 0.5, 0, 1))
    shift = rng.uniform(-1.2, 1.2)       # the mask off the grey outline (a segmenter's bias)
    mask = np.clip(np.roll(cover, int(round(shift)), axis=1), 0, 1)
    mask = (mask > 0.5).astype(np.uint8) * 255 if binary else np.rint(mask * 255).astype(np.uint8)
    grey = 60 + 120 * cover + rng.normal(0, rng.uniform(0, 6), (h, w))
    return np.clip(np.rint(grey), 0, 255).astype(np.uint8), mask


@pytest.mark.parametrize("seed", range(12))
def test_refine_runs_kernels_equal_numpy_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    for case in range(8):
        grey, mask = _scene(rng, binary=case % 2 == 1)
        runs = find_runs(mask, soft=True)
        only = None if case % 4 < 2 else rng.random(len(runs.row)) < rng.uniform(0.1, 0.9)
        kw = dict(mask=None if case % 3 == 0 else mask, only=only, min_moved=int(rng.choice([0, 1, 10, 50])),
                  max_dev_px=float(rng.uniform(0.2, 1.0)))
        a = _refine_runs_numpy(runs, grey, **kw)
        b = subpixel.refine_runs(runs, grey, **kw)
        for f in ("x0", "x1", "left_px", "right_px"):           # atol 0 px: bit for bit
            assert getattr(a, f).dtype == getattr(b, f).dtype
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)


def test_refine_runs_moves_boundaries_and_takes_pixels():
    """The constructed case the kernels must not lose: a binary mask 1 px off a blurred bar moves."""
    rng = np.random.default_rng(5)
    grey, mask = _scene(rng, binary=True)
    runs = find_runs(mask, soft=True)
    out = subpixel.refine_runs(runs, grey, mask)
    assert np.abs(out.left_px - runs.left_px).max() > 0.2
    assert (out.left_px <= 0.5 * (runs.left_px + runs.right_px)).all()
    ref = _refine_runs_numpy(runs, grey, mask)
    np.testing.assert_array_equal(out.left_px, ref.left_px)
    np.testing.assert_array_equal(out.x0, ref.x0)


def test_refine_stats_whole_pixel_share_with_a_map():
    """refine_stats' share through a float map equals whole_pixel_share's steps (random maps, columns)."""
    from appliance.localize import kernels_refine as kr
    rng = np.random.default_rng(3)
    for _ in range(50):
        h, w, n = 40, 60, int(rng.integers(60, 700))
        mx = (np.arange(w, dtype=np.float32)[None] * rng.uniform(0.9, 1.1) + rng.uniform(-3, 3, (h, 1))
              + rng.normal(0, 0.3, (h, w))).astype(np.float32)
        row = np.sort(rng.integers(0, h, n)).astype(np.int64)
        lp, rp = rng.uniform(-2, w + 1, n), rng.uniform(-2, w + 1, n)
        todo = np.sort(rng.choice(2 * n, int(rng.integers(1, 2 * n)), replace=False)).astype(np.int64)
        x = np.concatenate([lp, rp])
        xr = x[todo] + np.where(rng.random(len(todo)) < 0.7, rng.normal(0, 0.5, len(todo)), 0.0)
        sel, bias, share, mad = kr.refine_stats(row, lp, rp, todo, xr, mx, True, 0, 256)
        moved = xr != x[todo]
        np.testing.assert_array_equal(sel, np.flatnonzero(moved))
        t = todo[moved]
        dev = (xr[moved] - x[t]) * np.where(t < n, 1.0, -1.0)
        assert bias == float(median(dev))
        step = -(-len(t) // 256)
        r, xs = np.concatenate([row, row])[t][::step], x[t][::step]
        xi = np.minimum(np.maximum(np.floor(xs).astype(np.int64), 0), w - 2)
        f = xs - xi
        frac = (mx[r, xi] * (1.0 - f) + mx[r, xi + 1] * f + 0.5) % 1.0
        assert share == float(np.mean(np.minimum(frac, 1.0 - frac) < 0.1))
        d2 = dev - bias
        assert mad == float(median(np.abs(d2 - median(d2))))


def _short_line_clean_numpy(d_surf, score, u):
    ok = np.isfinite(d_surf) & (score >= 0.6)
    if ok.sum() < 5 or not ok.all():
        return False
    res = d_surf - np.polyval(np.polyfit(u, d_surf, 1), u)
    return bool(np.abs(res).max() <= dense.SHORT_LINE_MAX_RES_PX)


def test_short_line_clean_equals_polyfit():
    """The closed-form line's verdict equals np.polyfit's away from the limit (its max residual within
    1e-9 px of it), on random patches; constructed: a clean line, a kink, a NaN, a low score."""
    rng = np.random.default_rng(7)
    seen = set()
    for _ in range(3000):
        n = int(rng.integers(4, 18))
        u = rng.uniform(-500, 1300) + 6.0 * np.arange(n)
        d = rng.uniform(20, 160) + rng.normal(0, 0.02) * (u - u[0]) + rng.normal(0, 10 ** rng.uniform(-2.5, 0), n)
        s = np.where(rng.random(n) < 0.03, 0.3, 0.9)
        x = u - u.mean()
        y = d - d.mean()
        margin = abs(np.abs(y - (x @ y / (x @ x)) * x).max() - dense.SHORT_LINE_MAX_RES_PX)
        if margin < 1e-9:
            continue
        got = dense._short_line_clean(d, s, u)
        assert got == _short_line_clean_numpy(d, s, u)
        seen.add(got)
    assert seen == {True, False}
    u = 6.0 * np.arange(8)
    assert dense._short_line_clean(40 + 0.05 * u, np.ones(8), u)
    assert not dense._short_line_clean(40 + np.where(u > 20, 1.5, 0.0), np.ones(8), u)
    assert not dense._short_line_clean(np.r_[np.nan, 40 + 0.05 * u[1:]], np.ones(8), u)
    assert not dense._short_line_clean(40 + 0.05 * u, np.r_[0.5, np.ones(7)], u)


def _gather_numpy(gray, row, col):
    """subpixel.gather of a LazyRectified before the twelfth pass (numpy's takes of the map entries)."""
    import cv2
    h, w = gray.shape
    col = np.minimum(np.maximum(col, 0), w - 1)
    m1, m2 = gray.rectifier.maps[gray.side]
    n = col.size
    flat = np.zeros(-(-n // 1024) * 1024, np.int64)
    flat[:n] = (row[:, None] * w + col).ravel()
    flat = flat.reshape(-1, 1024)
    map1 = m1.view(np.int32).reshape(-1).take(flat).view(np.int16).reshape(flat.shape + (2,))
    out = cv2.remap(gray.image, map1, m2.reshape(-1).take(flat), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    if out.ndim == 3:
        out = cv2.cvtColor(out, cv2.COLOR_BGR2GRAY)
    return out.reshape(-1)[:n].reshape(col.shape).astype(np.float32)


def test_gather_remap_tables_equal_numpy_bit_for_bit():
    """subpixel.gather through kernels_refine.remap_tables against numpy's takes: colour and grey sources,
    both views, columns past both image edges, 1-3000 queries (one and several rows of 1024); atol 0."""
    import cv2
    from appliance.localize.rectify import LazyRectified, Rectifier
    from tests.localize.test_rectify import distorted_rig
    w, h = 333, 251
    rect = Rectifier.from_calibration(distorted_rig(w, h))
    rng = np.random.default_rng(8)
    bgr = cv2.GaussianBlur(rng.integers(0, 256, (h, w, 3), dtype=np.uint8), (0, 0), 2)
    for side in (0, 1):
        for src in (bgr, cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)):
            lazy = LazyRectified(rect, src, side)
            for k in (1, 146, 147, 3000):
                row = rng.integers(0, h, k)
                col = rng.integers(-5, w + 5, k)[:, None] + np.arange(-3, 4)
                got = subpixel.gather(lazy, row, col)
                want = _gather_numpy(lazy, row, col)
                assert got.dtype == want.dtype and got.shape == (k, 7)
                np.testing.assert_array_equal(got, want)


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
            got = refine_boundaries(gray, row, x, **kw)            # (uint8: kernels_refine.refine_steps)
            ref = refine_boundaries(gray.astype(np.float32), row, x, **kw)     # (float32: the numpy steps)
            assert got.dtype == ref.dtype and np.array_equal(got, ref)
            moved += int((got != x).sum())
    assert moved > 2000
