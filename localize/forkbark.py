"""A fork's steep parent side read by its bark texture next to the fork.

A steep side's disparity comes from its rows' crossings in the two views; where the side is not read next to the
fork (``forkdisp.side_disparity_near`` finds no crossings there it can use), the fork takes its curve carried from
its fitted span, and a fit whose last rows bend (the crossings next to the fork's blob or an occluder) carries its
end slope into the fork (seed 657's fork 7, exact masks: a 94-row quadratic whose end slope is 2.6 times the
truth's, carried 16.5 rows to 1.47 px under it). Its bark texture there reads it independently: patches on the
side's centre line from clear of the child outwards, narrow across the branch (``texture.surface_disparity``
along the rows, moved onto the axis by ``texture.surface_to_axis``), and the straight line through them at the
fork's row.
"""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels_forknear
from appliance.localize.texture import axis_to_surface, surface_disparity, surface_to_axis

BARK_REACH_PX = 40.0         # patches over this many rows of the side ...
BARK_STEP_PX = 4.0           # ... this many rows apart, from clear of the child
BARK_HALF_ROWS = 4           # a patch's half height (rows)
BARK_ACROSS = 0.6            # ... and half width: this many radii (at least 2 px)
BARK_SEARCH_PX = 8.0         # each patch searched within this of the side's curve there (surface disparity)
BARK_MIN_SCORE = 0.7         # a patch correlating less gives no reading
BARK_MIN_PATCHES = 5         # the line needs at least this many readings ...
BARK_MAX_RES_PX = 0.3        # ... none off it by more than this (px)


def steep_side_bark(left_gray, right_gray, curve, t_fork: float, s0_px: float, f_px: float,
                    offset_px: float = 0.0) -> float | None:
    """The bark texture's disparity of a steep parent side at the fork's row, or None.

    Parameters
    ----------
    left_gray, right_gray : array-like (H, W)
        Rectified grey images.
    curve : curves.BranchCurve
        The side (by row).
    t_fork : float
        The fork's row (px).
    s0_px : float
        Rows from the fork to the first patch, towards the side's fitted span (clear of the child).
    f_px, offset_px : float
        Focal length and the rectified principal-point difference (px).

    Returns
    -------
    float or None
        The straight line through the patches' axis disparities (``BARK_MIN_PATCHES`` correlating at
        ``BARK_MIN_SCORE``, not at their search's ends, none off the line by more than ``BARK_MAX_RES_PX``) at
        ``t_fork``, px; None where fewer read or they do not lie on a line.
    """
    lo, hi = curve.t_range
    sign = 1.0 if abs(hi - t_fork) > abs(lo - t_fork) else -1.0      # (towards the span)
    ts = t_fork + sign * (s0_px + np.arange(0.0, BARK_REACH_PX + 1e-9, BARK_STEP_PX))
    uv = curve.uv_at(ts)
    r = float(curve.radius_px)
    hw = max(2, int(BARK_ACROSS * r))
    frac = np.float64(kernels_forknear.depth_fraction(r, hw))
    d_s = axis_to_surface(curve.d_at(ts), r, f_px, offset_px, frac)     # (the curve's, on the surface)
    d, score = surface_disparity(left_gray, right_gray, uv, np.full(len(ts), BARK_HALF_ROWS),
                                 (float(d_s.min()) - BARK_SEARCH_PX, float(d_s.max()) + BARK_SEARCH_PX), half_w_px=hw)
    ok = np.isfinite(d) & (score >= BARK_MIN_SCORE) & (np.abs(d - d_s) < BARK_SEARCH_PX - 0.5)
    if int(np.count_nonzero(ok)) < BARK_MIN_PATCHES:
        return None
    t, y = ts[ok], surface_to_axis(d[ok], r, f_px, offset_px, depth_fraction=frac)
    slope, off = np.polyfit(t, y, 1)
    if float(np.abs(y - (slope * t + off)).max()) > BARK_MAX_RES_PX:
        return None
    return float(slope * t_fork + off)
