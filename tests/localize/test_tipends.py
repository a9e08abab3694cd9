"""A flat tip's run-end disparity (appliance.localize.tipends.TipPlacing): the rows' interquartile mean
(``END_ROWS_MEAN``) and its cap's own silhouette offset (``_cap_radius_silhouette``), on drawn ends."""

from types import SimpleNamespace

import cv2
import numpy as np
from appliance.localize import tipends
from appliance.localize.edges import find_runs
from appliance.localize.tipends import TipPlacing
from appliance.localize.tips import silhouette_radius_shift

H, W, F = 200, 1280, 1450.0


def _branch(x0: float, x1: float, y: float, rho: float) -> np.ndarray:
    """A horizontal branch of radius ``rho`` (px) from column ``x0`` to its round cap centred at ``x1`` on row
    ``y``, drawn as a soft mask (0-255, the half-coverage crossing on the outline)."""
    yy, xx = np.mgrid[0:H, 0:W].astype(float)
    t = np.clip(xx, x0, x1)
    dist = np.hypot(xx - t, yy - y)
    return np.rint(255 * np.clip(rho + 0.5 - dist, 0.0, 1.0)).astype(np.uint8)


def _corrected(mask: np.ndarray, x1: float, rho: float, r: float, d_end: float) -> float:
    sm = SimpleNamespace(left_mask=mask, f_px=F)
    uv_edge, out = np.array([x1 + rho, 100.0]), np.array([1.0, 0.0])
    return TipPlacing._cap_radius_silhouette(SimpleNamespace(sm=sm), uv_edge, out, r, d_end)


def test_a_tapering_flat_tip_takes_the_silhouette_offset_of_its_caps_own_radius():
    # the cap (radius 6 px) far right of the image's middle, its piece's radius read as 9 px: the run end's
    # disparity (taken less the offset of 9 px) moves nearer by the offsets' difference for the cap's width
    mask = _branch(700.0, 1100.0, 100.0, 6.0)
    d_end = 150.0
    got = _corrected(mask, 1100.0, 6.0, 9.0, d_end)
    want = silhouette_radius_shift(1106.0, d_end, 9.0, 6.0, 1.0, F, 0.5 * (W - 1))
    assert want > 0.05                                            # (a real effect)
    assert abs((got - d_end) - want) <= 0.15 * want               # the cap's width read within ~0.5 px
    # where the piece radius is the cap's, nothing moves
    assert abs(_corrected(mask, 1100.0, 6.0, 6.0, d_end) - d_end) <= 0.1 * want


def test_a_flat_tip_whose_caps_width_cannot_be_read_keeps_its_run_end():
    # no mask behind the end (the lines across it never start on the branch): the kernel's value stands
    mask = np.zeros((H, W), np.uint8)
    assert _corrected(mask, 1100.0, 6.0, 9.0, 150.0) == 150.0


def test_a_flat_ends_disparity_is_the_interquartile_mean_of_its_rows(monkeypatch):
    # a flat branch ending in a round cap, 150 px apart in the two views; the right view's run ends on the 9 rows
    # across the cap (half the radius each side of its centre's row) moved by a few tenths of a px each, as the
    # outline's noise does: the end's disparity is 150 less the middle half's mean of those moves
    # (tipends.END_ROWS_MEAN), not their median
    d, r = 150.0, 8.0
    left = np.zeros((200, 600), np.uint8)
    cv2.line(left, (200, 100), (392, 100), 255, int(2 * r))
    cv2.circle(left, (392, 100), int(r), 255, -1)
    right = np.roll(left, -int(d), axis=1)
    moves = np.array([0.0, 0.3, -0.1, 0.25, -0.2, 0.2, 0.6, -0.15, 0.35])      # rows 96-104
    uv_edge, out = np.array([400.0, 100.0]), np.array([1.0, 0.0])
    sm = SimpleNamespace(left_mask=left, f_px=3000.0, d_range_px=(50.0, 300.0), valid_right=None)
    got = {}
    for rule in (True, False):
        monkeypatch.setattr(tipends, "END_ROWS_MEAN", rule)
        runs_r = find_runs(right)
        for row, m in zip(range(96, 105), moves):
            runs_r.right_px[runs_r.row == row] += m
        placer = SimpleNamespace(sm=sm, runs_l=find_runs(left), runs_r=runs_r)
        got[rule] = TipPlacing._end_disparity(placer, uv_edge, out, d + 1.0, r)
    s_m = np.sort(moves)
    assert abs(got[False] - got[True] - (s_m[2:7].mean() - np.median(moves))) <= 1e-3
    assert abs(s_m[2:7].mean() - np.median(moves)) > 0.05                     # (the two differ here)
    assert abs(got[True] - (d - s_m[2:7].mean())) <= 0.1
