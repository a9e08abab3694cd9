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
    # (compiled, patch by patch; main 41599e4's summed-area table is the reference in test_kernels_points.py)
    return kernels_points.inside_fractions(np.ascontiguousarray(mask), np.ascontiguousarray(uv), int(hh),
                                           int(hw))


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
