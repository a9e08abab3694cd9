"""The right view's outline check of a fork whose child leaves the parent at a shallow angle.

``ForkPlacing._outline_agrees`` finds the fork again in the right view from the child's outline
leaving the parent there, on the parent's axis moved by the parent's disparity, and asks that it lie
within ``tol`` px (1.6 px or 0.9 %) of the left fork so moved. A child at another depth by D px of
disparity crosses the parent ``D |e2_y| / sin(a)`` px further along it in the right view (``e2``: the
child's direction, ``a``: its angle to the parent's axis; ``|e2_y| / sin(a)``: the gain). Each view's
place is the child's outline line carried back to the parent's axis: an error ``n`` of that line across
itself moves the place by ``n / sin(a)`` along the parent, so at a shallow angle (a thick parent, a
child leaving at 25-35 deg) two correct places lie 2-3 px apart along the parent. Where the gain exceeds
1 the check is also made in disparity: the place's offset along the parent divided by the gain within
``SHALLOW_D_PX``, the offset across the parent's axis within ``tol``, for gains up to ``SHALLOW_MAX_GAIN``
(issue 5: seed 120's fork, 2.4 px apart along a parent 29 px thick, 1.0 px of depth difference). Measured
on the 60 scenes and seeds 260-483, true forks so tested lie 0.6-1.3 px of depth difference apart, false
junctions 0.6-1.35 px (junctions of branches at about the parent's depth): 1.2 px and a gain of at most 4
admitted five true forks and no false one there; the margins are thin (docs/localize-forkrec19.md).

The gain holds only where the parent's line the outline used is the parent's axis at the fork: the line
through both parent sides must run within ``SHALLOW_MAX_TURN_DEG`` of it (true forks so admitted: 0-6 deg;
junctions where the outline's line is one bent side or the wrong pair of pieces: 12 and 67 deg, seed 114's
node 42 px from any fork and seed 304's false fork, whose child ran along the side the outline used).
"""

from __future__ import annotations

import math

import numpy as np

SHALLOW_D_PX = 1.2          # the depth difference (px of disparity) the two places may tell at most
SHALLOW_MIN_GAIN = 1.0      # ... where a px of depth difference moves the right view's place by more than this
SHALLOW_MAX_GAIN = 4.0      # ... and by at most this (a child within ~14 deg of the parent: each view's place
                            # is off by 4+ times its outline line's error, too loose to tell anything)
SHALLOW_MAX_TURN_DEG = 10.0  # ... and the parent's line runs within this of the line through both its sides


def shallow_outline_agrees(off_px: np.ndarray, er: np.ndarray, e1: np.ndarray, e_sides: np.ndarray,
                           e2: np.ndarray, tol_px: float) -> bool:
    """Whether a right-view fork place ``off_px`` (2,) px from where the left fork lies (moved by the
    parent's disparity) tells the child at the parent's depth, judged in disparity.

    Parameters
    ----------
    off_px : ndarray (2,)
        The right view's fork place minus the left fork moved by the parent's disparity (px).
    er : ndarray (2,)
        The parent's unit axis direction in the right view.
    e1 : ndarray (2,)
        The parent's line the left fork was placed against (unit direction, left view).
    e_sides : ndarray (2,)
        The unit direction of the line through both parent sides next to the junction (left view).
    e2 : ndarray (2,)
        The child's unit direction (either sense).
    tol_px : float
        The place tolerance of the ordinary check (px): the offset across the parent's axis must keep it.

    Returns
    -------
    bool
        True if ``e1`` and ``e_sides`` lie within ``SHALLOW_MAX_TURN_DEG``, the gain ``|e2_y| / sin(a)``
        (``a``: the child's angle to ``er``) exceeds ``SHALLOW_MIN_GAIN`` and is at most ``SHALLOW_MAX_GAIN``,
        the offset along ``er`` is at most ``SHALLOW_D_PX`` times the gain and the offset across it at most
        ``tol_px``; False otherwise.
    """
    er, e1, e_sides, e2, off = (np.asarray(v, float) for v in (er, e1, e_sides, e2, off_px))
    if abs(float(e1 @ e_sides)) < math.cos(math.radians(SHALLOW_MAX_TURN_DEG)):
        return False
    sin_a = abs(float(er[0] * e2[1] - er[1] * e2[0]))
    gain = abs(float(e2[1])) / max(sin_a, 1e-6)          # px of place along the parent per px of depth difference
    if not SHALLOW_MIN_GAIN < gain <= SHALLOW_MAX_GAIN:
        return False
    along = float(off @ er)
    across = float(off[0] * er[1] - off[1] * er[0])
    return abs(across) <= tol_px and abs(along) <= SHALLOW_D_PX * gain
