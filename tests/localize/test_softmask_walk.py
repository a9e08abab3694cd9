"""Sub-pixel walks out along a centre line (ends.walk_edges) on drawn binary and soft masks."""

import numpy as np

from appliance.localize.ends import EndPlacer, walk_edges


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
