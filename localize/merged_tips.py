"""Tips whose cap is whole in one view only: placed from the other view's round cap.

A steep piece's tip is withheld when the two views' outlines end at different places along the
branch (:meth:`ends.EndPlacer._tip_place`, the end shift): an occluder or another branch touches
the cap in one view only. The fitted curve (:class:`curves.BranchCurve`) gives the centre line
``u(v)`` and the disparity ``d(v)``; rectified rows correspond, so a round cap ending the piece
in the right view at row ``v`` places the tip in the left image on the same row.

:func:`right_cap_tip` takes the right view's end when it runs further along the branch than the
left's (the left cap cut by a thing in front of it in the left view only) and reads as a round
cap (strictly: both sides, :func:`tips.cap_shape`), the left's does not, the two ends lie less
than a cap's length apart (the left view still shows the tip's centre), and beyond the right cap
lies the background (nothing in front: :func:`texture.nearer_in_front` read from the right view
into the left). The converse (the right view's end cut, the left's round) and the tips merged
with another branch in the left view with the right view's end first were measured too and gain
no true tip for many false ones (docs/localize-merged-tips.md).
"""

from __future__ import annotations

import numpy as np
from appliance.localize.curves import BranchCurve
from appliance.localize.texture import nearer_in_front
from appliance.localize.tips import MAX_CAP_BACK, MIN_CAP_BACK, cap_shape

# the right view's end may run on past the left's by at most this many radii (the left view still
# shows the tip's centre, one radius back from the cap's end; the walks' scatter on top)
MAX_SHIFT_RADII = 1.6

# fresh31 (docs/localize-fresh31.md): the tip takes the piece's fitted disparity, which the left view's crossings set;
# where the left runs over the 2 radii of rows before the left end are narrower than the right's (at the curve's
# disparity) by more than LEFT_NARROW_SHARE of the right's width and LEFT_NARROW_MIN_PX, the left outline is cut along
# the body too (not only at the cap) and the crossings' middles, so the curve, are off: no tip. Seed 1122 T10, colour
# masks: a dark leaf beside the branch in the left view takes half its width out of the colour mask over its last rows
# (left 7.3 px, right 14.0 px, median of 10 rows): the curve +5.22 px, -27.88 mm. The tips this rule placed on the 60
# scenes: right minus left -0.76 .. +0.52 px (seeds 115 T12, 146 T14, both masks), kept. None: off.
LEFT_NARROW_SHARE = 0.25
LEFT_NARROW_MIN_PX = 2.0


def strict_round(shapes: list | None) -> bool:
    """Whether :func:`tips.cap_shape`'s first reading has both sides between a round cap's bounds
    (no side touched, nothing unread: the cap is whole in that view)."""
    if shapes is None or shapes[0] is None:
        return False
    lo, hi = sorted(shapes[0][1:])
    return MIN_CAP_BACK <= lo and hi <= MAX_CAP_BACK


def right_cap_tip(b, c: BranchCurve, t_left: float, t_right: float, sign: float) -> np.ndarray | None:
    """The tip (u, v, d) in the rectified left image from the right view's cap, or None.

    Parameters
    ----------
    b : ends.EndPlacer
    c : BranchCurve
        The steep piece ending there.
    t_left, t_right : float
        Rows where the centre line leaves the left and the right mask (:meth:`ends.EndPlacer._walk_out`).
    sign : float
        Direction (+-1) of the rows going out of the piece.
    """
    if not c.by_row:
        return None
    r = max(c.radius_px, 1.0)
    uv = c.uv_at(t_right)[0]
    step = c.uv_at(t_right + sign)[0] - uv
    speed = max(float(np.hypot(*step)), 1e-9)
    shift = sign * (t_right - t_left) * speed            # > 0: the right view runs further
    if not 0.0 < shift <= MAX_SHIFT_RADII * r:
        return None
    out = step / speed
    sm = b.sm
    if LEFT_NARROW_SHARE is not None and _left_narrowed(b, c, t_left, sign, r):
        return None
    h, w = sm.left_mask.shape
    uv_r = uv - (float(c.d_at(t_right)[0]), 0.0)
    tip_r = uv_r - r * out
    d = float(c.d_at(tip_r[1])[0])
    tip = np.array([tip_r[0] + d, tip_r[1], d])
    q = np.rint(tip[:2]).astype(int)
    if not (0 <= q[0] < w and 0 <= q[1] < h and sm.left_mask[q[1], q[0]] >= 128):
        return None                                      # the tip's centre is not seen in the left view
    # beyond the right cap: inside both views, and the background (nothing at the branch's depth
    # or nearer: a leaf's or an apple's edge ending the branch in both views reads round by chance)
    half = max(4, int(round(r)))
    probe_r = uv_r + out * (half * (abs(out[0]) + abs(out[1])) + 2)
    probe_l = probe_r + (d, 0.0)
    for p in (probe_l, probe_r):
        if not (half <= p[0] < w - half and half <= p[1] < h - half):
            return None
    pl = np.rint(probe_l).astype(int)
    if sm.valid_left is not None and not sm.valid_left[pl[1], pl[0]]:
        return None
    if not strict_round(cap_shape(sm.right_mask, uv_r, out, r)):
        return None
    if strict_round(cap_shape(sm.left_mask, c.uv_at(t_left)[0], out, r)):
        return None                                      # (both whole: the end shift is not the cap's)
    if _in_front_right(sm, probe_r, d, half):
        return None
    return tip


def _left_narrowed(b, c: BranchCurve, t_left: float, sign: float, r: float) -> bool:
    """Whether the left runs of piece ``c`` on the rows within 2 radii ``r`` before its left end ``t_left`` (inside its
    fitted span; ``sign`` the rows' direction out of the piece) are narrower than the right view's runs there (at the
    curve's disparity) by more than ``LEFT_NARROW_SHARE`` of the right's width and ``LEFT_NARROW_MIN_PX`` (medians over
    at least 3 rows found in both views)."""
    lo, hi = c.t_range
    rows = np.rint(t_left - sign * np.arange(1.0, max(2.0 * r, 4.0) + 1.0)).astype(int)
    rows = rows[(rows >= lo) & (rows <= hi)]
    if len(rows) < 3:
        return False
    u, d = c.s_at(rows), c.d_at(rows)
    il, ir = b.runs_l.find(rows, u), b.runs_r.find(rows, u - d)
    ok = (il >= 0) & (ir >= 0)
    if np.count_nonzero(ok) < 3:
        return False
    wl, wr = b.runs_l.span_px[il[ok]], b.runs_r.span_px[ir[ok]]
    w_right = float(np.median(wr))
    return float(np.median(wr - wl)) > max(LEFT_NARROW_MIN_PX, LEFT_NARROW_SHARE * w_right)


def _in_front_right(sm, uv_r: np.ndarray, d_branch_px: float, half: int) -> bool:
    """:func:`texture.nearer_in_front` of the right view's patch at ``uv_r`` searched along the
    left view's row (the pair mirrored: only the strip it reads)."""
    u, v = (int(x) for x in np.rint(uv_r))
    w = sm.left_mask.shape[1]
    x1 = min(int(u + np.ceil(sm.d_range_px[1])) + half + 1, w)
    right = np.ascontiguousarray(sm.right_gray[v - half:v + half + 1, u - half:x1][:, ::-1])
    left = np.ascontiguousarray(sm.left_gray[v - half:v + half + 1, u - half:x1][:, ::-1])
    # mirrored, the right patch sits at column x1 - 1 - u of the strips; the left view's columns
    # u + d lie at x1 - 1 - u - d: the usual disparity
    uv = np.array([[x1 - 1 - u, half]], float)
    return bool(nearer_in_front(right, left, uv, np.array([d_branch_px]), np.array([half]), sm.d_range_px[1])[0])
