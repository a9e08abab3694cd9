"""The right view's outline check of a fork whose child leaves the parent at a shallow angle.

``ForkPlacing._outline_agrees`` finds the fork again in the right view from the child's outline
leaving the parent there, on the parent's axis moved by the parent's disparity, and asks that it lie
within ``tol`` px (1.6 px or 0.9 %) of the left fork so moved. A child at another depth by D px of
disparity crosses the parent ``D |e2_y| / sin(a)`` px further along it in the right view (``e2``: the
child's direction, ``a``: its angle to the parent's axis). Each view's place is the child's outline
line carried back to the parent's axis: an error ``n`` of that line across itself moves the place by
``n / sin(a)`` along the parent, so at a shallow angle (a thick parent, a child leaving at 25-35 deg)
two correct places lie 2-3 px apart along the parent while a child at the parent's depth moves nothing.
There the check is made in disparity: the place's offset along the parent divided by
``|e2_y| / sin(a)`` (the px of place per px of depth difference) within ``SHALLOW_D_PX``, where that
ratio exceeds 1 (the depth signal is amplified at least as much as the place error) and the offset
across the parent's axis stays within ``tol`` (issue 5: seeds 120 and 142's forks, 2.4 / 2.1 px apart
along a parent 29-33 px thick, 1.0 / 1.3 px of depth difference; the nearest false junction of the 60
scenes so tested, 1.7 px).
"""

from __future__ import annotations

import numpy as np

SHALLOW_D_PX = 1.4          # the depth difference (px of disparity) the two places may tell at most
SHALLOW_MIN_GAIN = 1.0      # ... where a px of depth difference moves the right view's place by more than this


def shallow_outline_agrees(off_px: np.ndarray, er: np.ndarray, e1: np.ndarray, e2: np.ndarray, tol_px: float) -> bool:
    """Whether a right-view fork place ``off_px`` (2,) px from where the left fork lies (moved by the
    parent's disparity) tells the child at the parent's depth, judged in disparity.

    Parameters
    ----------
    off_px : ndarray (2,)
        The right view's fork place minus the left fork moved by the parent's disparity (px).
    er : ndarray (2,)
        The parent's unit axis direction in the right view.
    e1 : ndarray (2,)
        The parent's unit axis direction in the left view. The gain is the smaller of the two
        directions' (a parent whose disparity changes fast along it turns in the right view: there the
        right view's direction alone can make a child at right angles look shallow; seed 304's false
        fork, a flat parent at 82 deg to the child in the left view, 14 deg in the right one).
    e2 : ndarray (2,)
        The child's unit direction (either sense).
    tol_px : float
        The place tolerance of the ordinary check (px): the offset across the parent's axis must keep it.

    Returns
    -------
    bool
        True if ``|e2_y| / sin(a)`` (``sin(a)``: the larger of the child's with ``er`` and ``e1``) exceeds ``SHALLOW_MIN_GAIN`` and the offset along the parent is at most
        ``SHALLOW_D_PX`` times it; False otherwise.
    """
    er = np.asarray(er, float)
    e1 = np.asarray(e1, float)
    e2 = np.asarray(e2, float)
    off = np.asarray(off_px, float)
    sin_a = max(abs(float(er[0] * e2[1] - er[1] * e2[0])), abs(float(e1[0] * e2[1] - e1[1] * e2[0])))
    gain = abs(float(e2[1])) / max(sin_a, 1e-6)          # px of place along the parent per px of depth difference
    if gain <= SHALLOW_MIN_GAIN:
        return False
    along = float(off @ er)
    across = float(off[0] * er[1] - off[1] * er[0])
    return abs(across) <= tol_px and abs(along) <= SHALLOW_D_PX * gain
