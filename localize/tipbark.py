"""A flat tip's run end read again by its bark texture next to the tip.

A flat piece's disparity comes from its texture; a short one (under ``dense``'s 100 px for a texture line) gets
the mean over the piece, level, carried to its tip. Where the branch turns in depth along the piece, the end of
the tip's row run in both views reads the cap's own depth, several px off that level; it stands only where the
end's outline agrees row by row (``ends.EndPlacer._end_outline_agrees``: 80 % of the rows), and something touching
the cap in one view (an apple) fails that on a few rows. The bark next to the tip is a second, independent
reading: a texture patch one radius behind the tip's centre (``texture.surface_disparity``, moved onto the axis by
``texture.surface_to_axis``) that reads near the run end, and far from the piece's level, backs the run end (seed
686's tip 15, colour masks: the level 259.13 px, the run end 264.94, the patch 263.6, the truth 264.50).
"""

from __future__ import annotations

import numpy as np
from appliance.localize.texture import axis_to_surface, patch_depth_fraction, surface_disparity, surface_to_axis

TIP_BARK_BACK = 2.0          # the patch's centre this many radii behind the tip's edge (one behind its centre)
TIP_BARK_HALF_W = 7          # its half width along the rows (px); half height 0.6 radius (texture's flat patches)
TIP_BARK_SEARCH_PX = 4.0     # searched this far (px) beyond the level's and the run end's surface disparities
TIP_BARK_MIN_SCORE = 0.9     # a patch correlating less gives no reading (bark reading the tip's depth or the level
                             # correlates 0.90-1.0 on the ten sets; seed 536's false end, colour masks: 0.707)
TIP_BARK_SHARE = 0.5         # it backs the run end where it lies nearer it than this share of the run end's distance
                             # from the level


def bark_backs_run_end(left_gray, right_gray, uv_edge: np.ndarray, out: np.ndarray, r: float, d_level: float,
                       d_end: float, f_px: float, offset_px: float = 0.0) -> bool:
    """Whether the bark next to a flat tip reads its run end's disparity rather than its piece's level.

    Parameters
    ----------
    left_gray, right_gray : array-like (H, W)
        Rectified grey images (ndarray or ``rectify.LazyRectified``).
    uv_edge : (2,) left px where the centre line leaves the mask; ``out`` (2,) its unit direction outwards.
    r : the piece's radius (px).
    d_level, d_end : the piece's disparity carried to the tip and the run end's (px, axis).
    f_px : focal length (px); ``offset_px`` the rectified principal-point difference ``cx_left - cx_right``.

    Returns
    -------
    bool
        True when a patch ``TIP_BARK_BACK`` radii behind the edge matches with a correlation of at least
        ``TIP_BARK_MIN_SCORE``, inside its search window, at an axis disparity within ``TIP_BARK_SHARE`` x
        ``|d_end - d_level|`` of ``d_end``.
    """
    hh = max(1, int(0.6 * r))
    frac = patch_depth_fraction(r, hh)
    surf = [axis_to_surface(d, r, f_px, offset_px, frac) for d in (d_level, d_end)]
    lo, hi = min(surf) - TIP_BARK_SEARCH_PX, max(surf) + TIP_BARK_SEARCH_PX
    uv = (np.asarray(uv_edge, float) - TIP_BARK_BACK * r * np.asarray(out, float))[None]
    d, score = surface_disparity(left_gray, right_gray, uv, np.array([hh]), (lo, hi), half_w_px=TIP_BARK_HALF_W)
    if not (np.isfinite(d[0]) and score[0] >= TIP_BARK_MIN_SCORE and lo + 0.5 < d[0] < hi - 0.5):
        return False
    d_axis = float(surface_to_axis(d, r, f_px, offset_px, frac)[0])
    return abs(d_axis - d_end) <= TIP_BARK_SHARE * abs(d_end - d_level)
