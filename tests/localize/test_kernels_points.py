"""kernels_points (per-point steps: texture search boxes, patch shares, skeleton to full-size pixels, radius reads)
against the code they replace: the same values, atol 0."""

import cv2
import numpy as np
import pytest


def _boxes_reference(uv_px, hhs, hw, lo, hi, h, w):
    """texture._search's numpy steps as they were (main 41599e4)."""
    uv = np.rint(np.asarray(uv_px, float).reshape(-1, 2)).astype(int)
    by0, by1 = max(int((uv[:, 1] - hhs).min()), 0), min(int((uv[:, 1] + hhs).max()) + 1, h)
    lx0, lx1 = max(int(uv[:, 0].min()) - hw, 0), min(int(uv[:, 0].max()) + hw + 1, w)
    rx0, rx1 = max(int(uv[:, 0].min()) - hi - hw, 0), min(int(uv[:, 0].max()) - lo + hw + 1, w)
    return uv, by0, by1, lx0, lx1, rx0, rx1


def test_search_boxes_equals_numpy_steps():
    from appliance.localize import kernels_points
    rng = np.random.default_rng(24)
    for it in range(3000):
        n = int(rng.integers(1, 30))
        h, w = int(rng.integers(20, 1000)), int(rng.integers(20, 1300))
        uv = np.column_stack([rng.uniform(-40, w + 40, n), rng.uniform(-20, h + 20, n)])
        if it % 3 == 0:
            uv = np.round(uv * 2) / 2                                       # halves: rint's ties to even
        hh = rng.integers(0, 15, n).astype(np.int64)
        hw = int(rng.integers(0, 15))
        lo = int(rng.integers(-10, 300))
        hi = lo + int(rng.integers(0, 300))
        got = kernels_points.search_boxes(uv, hh, hw, lo, hi, h, w)
        ref = _boxes_reference(uv, hh, hw, lo, hi, h, w)
        np.testing.assert_array_equal(got[0], ref[0])
        assert got[0].dtype == ref[0].dtype
        assert tuple(got[1:]) == tuple(ref[1:])
    bad = np.array([[3.0, 4.0], [np.nan, 2.0]])
    assert kernels_points.search_boxes(bad, np.ones(2, np.int64), 1, 0, 5, 10, 10)[0] is None


@pytest.mark.filterwarnings("ignore:invalid value encountered in cast")     # (numpy's, on the NaN centre, as before)
def test_surface_disparity_with_nan_centre_keeps_numpy_path():
    from appliance.localize.texture import surface_disparity
    rng = np.random.default_rng(25)
    left = cv2.GaussianBlur(rng.integers(0, 256, (80, 200), dtype=np.uint8), (3, 3), 0.8)
    right = np.roll(left, -17, axis=1)
    uv = np.array([[100.0, 40.0], [120.4, 41.6], [np.nan, 40.0]])
    d, s = surface_disparity(left, right, uv, np.array([4, 4, 4]), (5.0, 30.0), 6)
    np.testing.assert_allclose(d[:2], 17.0, atol=0.05)                    # px
    assert np.isnan(d[2])


def _inside_reference(mask, uv, hh, hw):
    """patchmask.inside_fraction as it was (main 41599e4): a summed-area table of the patches' box."""
    uv = np.asarray(uv, float).reshape(-1, 2)
    out = np.zeros(len(uv))
    ok = np.isfinite(uv).all(1)
    if not ok.any():
        return out
    h, w = mask.shape[:2]
    c = np.rint(uv[ok]).astype(np.int64)
    x0, x1 = int(c[:, 0].min()) - hw, int(c[:, 0].max()) + hw + 1
    y0, y1 = int(c[:, 1].min()) - hh, int(c[:, 1].max()) + hh + 1
    box = np.zeros((y1 - y0, x1 - x0), np.int64)
    sy0, sy1, sx0, sx1 = max(y0, 0), min(y1, h), max(x0, 0), min(x1, w)
    if sy1 > sy0 and sx1 > sx0:
        box[sy0 - y0:sy1 - y0, sx0 - x0:sx1 - x0] = mask[sy0:sy1, sx0:sx1] >= 128
    sat = np.zeros((box.shape[0] + 1, box.shape[1] + 1), np.int64)
    sat[1:, 1:] = box.cumsum(0).cumsum(1)
    ty, tx = c[:, 1] - hh - y0, c[:, 0] - hw - x0
    by, bx = ty + 2 * hh + 1, tx + 2 * hw + 1
    n = sat[by, bx] - sat[ty, bx] - sat[by, tx] + sat[ty, tx]
    out[ok] = n / float((2 * hh + 1) * (2 * hw + 1))
    return out


def test_inside_fraction_equals_summed_area_table():
    from appliance.localize.patchmask import inside_fraction
    rng = np.random.default_rng(26)
    for it in range(400):
        h, w = int(rng.integers(5, 120)), int(rng.integers(5, 160))
        mask = cv2.GaussianBlur(((rng.random((h, w)) < rng.random()) * 255).astype(np.uint8), (5, 5), 1.2)
        n = int(rng.integers(1, 25))
        uv = np.column_stack([rng.uniform(-20, w + 20, n), rng.uniform(-20, h + 20, n)])
        if it % 3 == 0:
            uv = np.round(uv * 2) / 2                                       # halves: rint's ties to even
        if it % 5 == 0:
            uv[rng.integers(0, n)] = np.nan
        if it % 17 == 0:
            uv[:] = np.inf                                                  # no finite centre
        hh, hw = int(rng.integers(0, 10)), int(rng.integers(0, 14))
        np.testing.assert_array_equal(inside_fraction(mask, uv, hh, hw), _inside_reference(mask, uv, hh, hw))


def test_spliced_deriv_made_once_with_the_same_values():
    from appliance.localize.curves import Poly, Spliced
    rng = np.random.default_rng(27)
    base, below = Poly(rng.normal(size=4), 3.0, 20.0), Poly(rng.normal(size=3), -30.0, 10.0)
    sp = Spliced(base, -10.0, 25.0, below, None)
    d = sp.deriv()
    assert d is sp.deriv()                                            # made once
    fresh = Spliced(base.deriv(), -10.0, 25.0, below.deriv(), None)
    t = np.linspace(-60, 60, 241)
    np.testing.assert_array_equal(d(t), fresh(t))                     # atol 0
    assert [d.at(float(x)) for x in t] == [fresh.at(float(x)) for x in t]


def test_to_full_equals_numpy_steps():
    from appliance.localize.graph import SkeletonGraph
    rng = np.random.default_rng(28)
    for scale in (1, 2, 4, 3):
        g = SkeletonGraph.__new__(SkeletonGraph)
        object.__setattr__(g, "scale", scale)
        for yx in (rng.integers(0, 2000, (50, 2)), rng.uniform(-5, 2000, (7, 2)), rng.integers(0, 300, (1, 2)),
                   rng.integers(0, 300, 2), np.zeros((0, 2), np.int64), rng.integers(0, 300, (9, 2)).astype(np.int32),
                   rng.integers(0, 300, (6, 4))[:, ::2], [[3, 4], [5, 6]]):
            ref = (np.asarray(yx, np.float64).reshape(-1, 2)[:, ::-1] + 0.5) * scale - 0.5
            got = g.to_full(yx)
            assert got.dtype == np.float64 and got.shape == ref.shape
            np.testing.assert_array_equal(got, ref)                   # atol 0 px


def test_radius_at_equals_numpy_steps():
    from appliance.localize.radius import RadiusMap, radius_at
    rng = np.random.default_rng(29)
    for it in range(500):
        scale = int(rng.integers(1, 5))
        img = rng.uniform(0, 30, (int(rng.integers(1, 60)), int(rng.integers(1, 80)))).astype(np.float32)
        h, w = img.shape
        xy = np.column_stack([rng.uniform(-30, w * scale + 30, 20), rng.uniform(-30, h * scale + 30, 20)])
        if it % 2:
            xy = np.round(xy * 2 * scale) / (2 * scale)                       # on the rounding's halves
        ref_xy = np.rint((xy + 0.5) / scale - 0.5).astype(int)
        ref = img[np.clip(ref_xy[:, 1], 0, h - 1), np.clip(ref_xy[:, 0], 0, w - 1)].astype(float)
        got = radius_at(RadiusMap(img, scale), xy)
        assert got.dtype == np.float64
        np.testing.assert_array_equal(got, ref)                             # atol 0 px
    img = np.ones((4, 4), np.float32)
    with np.errstate(invalid="ignore"):
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            got = radius_at(RadiusMap(img, 2), np.array([[np.nan, 1.0], [2.0, 2.0]]))   # numpy's path
    assert got.shape == (2,) and got[1] == 1.0
