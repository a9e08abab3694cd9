"""Sub-pixel walks out along a centre line (ends.walk_edges) on drawn binary and soft masks."""

import numpy as np

from appliance.localize.ends import EndPlacer
from appliance.localize.walks import walk_edges


def _cap_coverage(shape, centre, direction, r_px, end_px, n_sub=4):
    """Coverage 0-1 of a branch (a band of radius ``r_px`` along ``direction`` through ``centre``)
    ending in a round cap whose end lies ``end_px`` from ``centre``: the mean over n_sub x n_sub
    supersamples of each pixel (pixel centres at integers)."""
    h, w = shape
    off = (np.arange(n_sub) + 0.5) / n_sub - 0.5
    ys, xs = np.mgrid[0:h, 0:w].astype(float)
    d = np.asarray(direction, float) / np.hypot(*direction)
    cover = np.zeros(shape)
    c_cap = np.asarray(centre, float) + d * (end_px - r_px)        # the cap's centre
    for oy in off:
        for ox in off:
            px, py = xs + ox - c_cap[0], ys + oy - c_cap[1]
            along = px * d[0] + py * d[1]
            across = -px * d[1] + py * d[0]
            inside = (np.abs(across) <= r_px) & (along <= 0) | (px * px + py * py <= r_px * r_px)
            cover += inside
    return cover / n_sub ** 2


def _walk(mask, centre, direction, reach=40.0):
    d = np.asarray(direction, float) / np.hypot(*direction)
    s = np.arange(0, reach, 0.25)
    uv = np.asarray(centre, float) + s[:, None] * d
    idx, crosses = walk_edges(mask, uv, np.array([0, len(s)]))
    assert crosses[0]
    return 0.25 * idx[0]


def test_binary_bar_edge_is_the_pixel_boundary():
    m = np.zeros((20, 40), np.uint8)
    m[8:12, :20] = 255
    assert abs(_walk(m, (10.0, 10.0), (1, 0)) - 9.5) < 0.05        # column 19's far side: u = 19.5


def test_walk_starting_off_or_never_leaving():
    m = np.zeros((20, 40), np.uint8)
    m[8:12, :] = 255
    uv = np.column_stack([np.arange(5, 15, 0.25), np.full(40, 10.0)])
    uv_off = np.column_stack([np.arange(5, 15, 0.25), np.full(40, 2.0)])
    idx, crosses = walk_edges(m, np.vstack([uv, uv_off]), np.array([0, 40, 80]))
    assert not crosses.any()
    assert idx.tolist() == [39, 0]
    # the whole-pixel reads give the same for these
    idx_w, crosses_w = EndPlacer._walk_whole(m, np.vstack([uv, uv_off]), np.array([0, 40, 80]))
    assert idx_w.tolist() == [39, 0] and not crosses_w.any()


def test_round_cap_soft_and_binary_agree():
    """A round cap drawn anti-aliased gives the true end (within 0.1 px) and its binary mask
    nearly the same (within 0.35 px: its outline is whole pixels), at several angles and offsets."""
    for angle_deg, end_px in ((0.0, 20.3), (30.0, 20.6), (63.0, 19.85), (90.0, 20.1), (135.0, 20.45)):
        a = np.radians(angle_deg)
        d = (np.cos(a), np.sin(a))
        centre = (40.2, 40.4)
        cover = _cap_coverage((80, 80), centre, d, 4.0, end_px)
        soft = np.clip(cover * 255 + 0.5, 0, 255).astype(np.uint8)
        binary = np.where(cover >= 0.5, 255, 0).astype(np.uint8)
        e_soft, e_bin = _walk(soft, centre, d), _walk(binary, centre, d)
        assert abs(e_soft - e_bin) <= 0.35, (angle_deg, e_soft, e_bin)   # (the binary one: whole pixels)
        assert abs(e_soft - end_px) <= 0.1, (angle_deg, e_soft, end_px)


def test_area_error_is_the_squared_share_on_binary_masks_and_linear_on_soft():
    from appliance.localize.caps import _area_err

    rng = np.random.default_rng(3)
    strip = (rng.random((9, 40)) > 0.5).astype(np.float32) * 255
    patch = (rng.random((9, 9)) > 0.5).astype(np.float32) * 255
    half = np.ones((9, 9), np.float32)
    offsets = np.array([0, 5, 17, 31])
    sq = np.array([((strip[:, o:o + 9] - patch) ** 2).sum() for o in offsets]) / (81 * 255.0 ** 2)
    assert np.allclose(_area_err(strip, patch, half, offsets), sq)
    # a pixel half covered against an empty one: half a pixel of area differs (squared: a quarter)
    soft = np.zeros((9, 9), np.float32)
    soft[4, 4] = 127.5
    assert np.isclose(_area_err(np.zeros((9, 9), np.float32), soft, half, np.array([0]))[0] * 81, 0.5)


def test_cap_disparity_of_a_drawn_soft_cap():
    """A flat branch's round cap drawn anti-aliased in both views, 40.3 px apart: the cap's fit
    finds that disparity (within 0.15 px) on the soft masks, and (within 0.5 px) on their 0.5 level."""
    from appliance.localize.caps import cap_disparity
    from appliance.localize.matching import StereoMasks

    d_true = 40.3
    left = _cap_coverage((60, 200), (60.0, 30.4), (1, 0), 5.0, 80.2)
    right = _cap_coverage((60, 200), (60.0 - d_true, 30.4), (1, 0), 5.0, 80.2)
    for soft, tol in ((True, 0.15), (False, 0.5)):
        lm, rm = ((np.clip(m * 255 + 0.5, 0, 255) if soft else np.where(m >= 0.5, 255, 0)).astype(np.uint8)
                  for m in (left, right))
        sm = StereoMasks(lm, rm, lm, rm, None, (20.0, 60.0), 1450.0)
        d = cap_disparity(sm, np.array([60.0 + 80.2 - 5.0, 30.4]), 10, np.array([1.0, 0.0]))
        assert d is not None and abs(d - d_true) <= tol, (soft, d)
