"""How much of each texture patch lies on the branch in the left view (issue 5, seed 454 T11).

A patch matched along the rows reads the disparity of whatever it holds: where a leaf covers part of it
in the left view, the leaf (at its own depth, shifted differently in the right view) pulls the reading.
The callers keep a patch only where nearly all of it lies inside the left branch mask.
"""

from __future__ import annotations

import numpy as np


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
