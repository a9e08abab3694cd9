"""Trust checks for a flat piece's bark-texture disparity line (issue 5: gross errors).

A flat piece of 100 px or more gets a line through its texture patches' disparities
(``dense._flat_finish``). A line through a handful of matches (seed 126: 3 of 21 patches,
0.5 px per px, ~450 mm off; seed 113: 5 of 31) is not a measurement of the branch: such a piece
is withheld (no curve) rather than reported at a wrong depth.
"""
from __future__ import annotations

import numpy as np
from appliance.localize.curves import median

MIN_LINE_INLIERS = 7        # a texture line needs at least this many inlier patches ...
MIN_LINE_SHARE = 0.15       # ... and this share of the piece's patches (6 px apart)
MIN_LINE_SPREAD = 0.2       # ... spread over this share of the piece's length


def line_supported(u_inl_px: np.ndarray, n_patches: int, lo_px: float, hi_px: float) -> bool:
    """Whether a flat piece's texture line is backed by enough patches along it.

    Parameters
    ----------
    u_inl_px : (K,) columns (px) of the patches the line fit kept (inliers).
    n_patches : number of texture patches laid along the piece (all, matched or not).
    lo_px, hi_px : the piece's column range (px).

    Returns
    -------
    True when at least ``max(MIN_LINE_INLIERS, MIN_LINE_SHARE * n_patches)`` inliers span at
    least ``MIN_LINE_SPREAD`` of ``hi_px - lo_px``.
    """
    u = np.asarray(u_inl_px, float)
    if len(u) < max(MIN_LINE_INLIERS, MIN_LINE_SHARE * n_patches):
        return False
    return float(u.max() - u.min()) >= MIN_LINE_SPREAD * (hi_px - lo_px)


def at_window_edge_dropped(d_px: np.ndarray, window_px: tuple[float, float]) -> np.ndarray:
    """Texture disparities (N,) with those at an end of their search window (``window_px``: the
    fine search's (lo, hi), px, widened to whole px as the search does, around the coarse prior) set to NaN: the correlation still rose there,
    so its peak lies outside the window and the value is the window's, not the bark's (seed 149
    colour piece 12: 12 of 19 patches at exactly prior -6 or +6 px)."""
    d = np.asarray(d_px, float)
    lo, hi = np.floor(window_px[0]), np.ceil(window_px[1])        # (the search's whole px)
    edge = (np.abs(d - lo) < 1e-6) | (np.abs(d - hi) < 1e-6)
    return np.where(edge, np.nan, d)


FEW_LINE_PATCHES = 11      # a texture line from this many inliers or fewer scatters (MAD) at most ...
MAX_LINE_MAD_PX = 1.25      # ... this about the line ...
FEW_PATCHES = 5             # ... and a constant from this many patches or fewer at most ...
MAX_FEW_MAD_PX = 2.3        # ... this (good pieces: 0.1-1 px; ambiguous bark matches 1.3-4.6 px)


def scatter_ok(residual_px: np.ndarray, degree: int) -> bool:
    """Whether a flat piece's texture fit's inlier residuals (K,) (px, axis disparity minus the
    fit) are tight enough to be the branch's: their MAD at most ``MAX_LINE_MAD_PX`` for a line
    from at most ``FEW_LINE_PATCHES`` inliers, ``MAX_FEW_MAD_PX`` for a constant from at most
    ``FEW_PATCHES`` (fits from more patches: no limit; seed 110's good line from 28 patches
    scatters 1.2-1.3 px). Seeds 149 (colour p12, 1.28 px), 151 (colour p22, 2.1 px), 142, 146, 126, 115."""
    r = np.asarray(residual_px, float)
    if len(r) == 0:
        return True
    mad = float(median(np.abs(r - median(r))))          # (np.median's values, bit for bit)
    if degree >= 1:
        return len(r) > FEW_LINE_PATCHES or mad <= MAX_LINE_MAD_PX
    return len(r) > FEW_PATCHES or mad <= MAX_FEW_MAD_PX
