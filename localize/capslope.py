"""A steep tip's cap disparity on a piece inclined in depth (tipturn20, issue 5).

:meth:`tipends.TipPlacing._cap_disparity` reads the rows about the cap's centre ``P`` placed one *piece*
radius ``r`` back from where the centre line leaves the mask. On a tapering branch ``r`` is ~1.14 times
the tip's own radius (median; up to 1.4), so ``P`` lies behind the true centre ``C`` and the rows
between them cross the branch's body rather than its round cap. The body's depth there is not the
cap's where the piece is inclined in depth: those rows' middles carry the body's disparity, ``g`` px per
px of image behind ``C`` (``g`` the disparity's gradient along the piece, outward). On 316 rendered
scenes (60 + seeds 260-515) the steep tips' disparity error follows ``-0.29 g (r - rho)`` (exact masks;
-0.18 colour; rho the true tip radius) and not ``g rho`` (coefficient ~0): the bias is the misplaced
centre's, not the cap's own outline.

:func:`slope_corrected` takes the reading back along the piece's own gradient (from its fitted curve)
by a share :data:`SLOPE_SHARE` of the distance between ``P`` and the centre read from the cap's own
width (:func:`tips.cap_centre`). Tips on pieces of constant depth, or whose cap's radius is the piece's,
keep their reading.
"""

from __future__ import annotations

import numpy as np

# the share of the gradient times the distance P - C taken off the cap's reading (the rows between the
# two are about half the rows ahead of P's row; fitted -0.29 / -0.18 on exact / colour masks, tested
# 0.2, 0.3, 0.5: 0.5 overshoots with colour masks)
SLOPE_SHARE = 0.3

# gradients below this (px of disparity per px of image) leave the reading as it is (no mask read)
MIN_SLOPE = 0.005


def curve_slope(d_at, t_edge: float, t_range: tuple, sign: float, r: float, px_per_t: float) -> float | None:
    """The disparity's gradient along a piece at its tip, outward (px of disparity per px of image).

    Parameters
    ----------
    d_at : callable
        The fitted curve's disparity at parameters t (array in, (N,) out).
    t_edge : float
        The tip's parameter (where the centre line leaves the mask).
    t_range : (float, float)
        The curve's parameter range; ``sign`` (+1 / -1) the direction of t going out of the piece.
    r : float
        The piece's radius, px: the gradient is read over ``max(r, 3)`` of t behind the tip (less on a
        shorter piece).
    px_per_t : float
        Image px per unit of t along the centre line.

    Returns
    -------
    float or None
        None where the piece is shorter than one unit of t.
    """
    lo, hi = t_range
    t0 = min(max(float(t_edge), lo), hi)
    t1 = min(max(t0 - sign * min(max(r, 3.0), hi - lo), lo), hi)
    if abs(t1 - t0) < 1.0:
        return None
    d0, d1 = d_at(np.array([t0, t1]))
    return float(d0 - d1) / (abs(t0 - t1) * px_per_t)


def slope_corrected(d_cap: float, slope: float, r: float, centre_back_px: float) -> float:
    """A cap reading ``d_cap`` (px) taken back to the cap's own centre.

    Parameters
    ----------
    d_cap : float
        The disparity read about ``P``, ``r`` px back from the walk's edge.
    slope : float
        :func:`curve_slope` (px per px, outward).
    r : float
        The piece radius used to place ``P``, px.
    centre_back_px : float
        How far back from the walk's edge the cap's own centre lies, px (its radius plus the walk's edge
        bias).

    Returns
    -------
    float
        ``d_cap + SLOPE_SHARE * slope * (r - centre_back_px)`` where ``P`` lies behind that centre,
        else ``d_cap``.
    """
    delta = r - centre_back_px
    if not delta > 0.0:
        return d_cap
    return d_cap + SLOPE_SHARE * slope * delta
