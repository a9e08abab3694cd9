"""Whether a texture patch holds the same share of branch in both views (issue 5, seed 454 T11).

A patch matched along the rows reads the disparity of whatever it holds: where a leaf in front of the
branch covers part of it in the left view, the leaf (at its own depth, shifted by its own disparity in
the right view) pulls the reading (454 T11: a flat fork side read 2.1 px low, +10.6 mm). The branch's own
outline in a patch (a side's centre line carried off the branch next to a fork) is at the branch's depth:
the same share of the patch lies on the branch in the right view at the branch's disparity, and the
reading holds (seed 273 T14). So a patch counts only where the two shares agree
(:func:`share_difference`).
"""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels_points


def inside_fraction(mask: np.ndarray, uv: np.ndarray, hh: int, hw: int) -> np.ndarray:
    """The fraction (N,) of each (2 hh + 1) x (2 hw + 1) patch centred on ``uv`` (N, 2) px (rounded) that
    lies where ``mask`` (H, W, coverage 0-255) is >= 128; the part outside the image counts as outside.

    Parameters
    ----------
    mask : ndarray (H, W) uint8
        Left branch coverage.
    uv : ndarray (N, 2) float
        Patch centres (column, row) px.
    hh, hw : int
        Half height and half width px.

    Returns
    -------
    ndarray (N,) float
        Fractions in [0, 1] (0 for non-finite centres).
    """
    uv = np.asarray(uv, float).reshape(-1, 2)
    if mask.dtype == np.uint8 and mask.ndim == 2:      # (compiled: the same counts, patch by patch)
        return kernels_points.inside_fractions(np.ascontiguousarray(mask), np.ascontiguousarray(uv), int(hh), int(hw))
    out = np.zeros(len(uv))
    ok = np.isfinite(uv).all(1)
    if not ok.any():
        return out
    h, w = mask.shape[:2]
    c = np.rint(uv[ok]).astype(np.int64)
    # the patches' box, read once; the inside count of each patch by a summed-area table of that box
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


def share_difference(left_mask: np.ndarray, right_mask: np.ndarray, uv: np.ndarray, d_px: np.ndarray, hh: int,
                     hw: int) -> np.ndarray:
    """``|left share - right share|`` (N,) of each patch: :func:`inside_fraction` of the left mask at
    ``uv`` (N, 2) and of the right mask at ``uv`` moved left by ``d_px`` (N,) (the branch's disparity
    there); 1 for a non-finite disparity."""
    uv = np.asarray(uv, float).reshape(-1, 2)
    d = np.asarray(d_px, float).reshape(-1)
    fl = inside_fraction(left_mask, uv, hh, hw)
    fr = inside_fraction(right_mask, uv - np.column_stack([d, np.zeros_like(d)]), hh, hw)
    return np.where(np.isfinite(d), np.abs(fl - fr), 1.0)
