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

import math

import numpy as np
from appliance.localize.curves import BranchCurve
from appliance.localize.graph import ENDPOINT
from appliance.localize.texture import nearer_in_front
from appliance.localize.tips import MAX_CAP_BACK, MIN_CAP_BACK, cap_shape, silhouette_offset_px

# place the tips merged with another branch in the left view (merged_tips, called by
# dense.match_dense): off, as on the 28 rendered scenes it gains no true tip (it would cost ~0.2 ms)
LEFT_MERGED = False
# the right view's end may run on past the left's by at most this many radii (the left view still
# shows the tip's centre, one radius back from the cap's end; the walks' scatter on top)
MAX_SHIFT_RADII = 1.6


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


def merged_left_tip(b, c: BranchCurve, t_right: float, sign: float) -> np.ndarray | None:
    """The tip (u, v, d) from the right view's round cap where the left view's outline runs on
    past it (the tip merged in the left image with another branch it touches or overlaps), or None.

    The right cap must read round (strictly), its rows' edges give the tip's disparity against
    the left runs (a merged left row keeps its clean side) agreeing with the curve's
    (:data:`MAX_D_GAP_PX`), the tip must lie inside the left outline, and beyond the right cap
    lies the background."""
    if not c.by_row:
        return None
    r = max(c.radius_px, 1.0)
    uv = c.uv_at(t_right)[0]
    step = c.uv_at(t_right + sign)[0] - uv
    speed = max(float(np.hypot(*step)), 1e-9)
    out = step / speed
    sm = b.sm
    h, w = sm.left_mask.shape
    on = np.rint(uv + MIN_MERGED_SHIFT_PX * out).astype(int)
    if not (0 <= on[0] < w and 0 <= on[1] < h) or sm.left_mask[on[1], on[0]] < 128:
        return None                                      # the left view's outline does not run on
    uv_r = uv - (float(c.d_at(t_right)[0]), 0.0)
    past = np.rint(uv_r + 2.0 * out).astype(int)
    if not (0 <= past[0] < w and 0 <= past[1] < h) or sm.right_mask[past[1], past[0]] >= 128:
        return None                                      # (the walk never left the right mask)
    if not _left_runs_into_other(b, c, t_right, sign, r):
        return None
    tip_r = uv_r - r * out
    d_curve = float(c.d_at(tip_r[1])[0])
    d = _right_cap_edges(b, c, float(tip_r[1]), t_right, d_curve)
    if len(d) < 3:
        return None
    d_tip = float(np.median(d))
    if abs(d_tip - d_curve) > MAX_D_GAP_PX:
        return None
    tip = np.array([tip_r[0] + d_tip, tip_r[1], d_tip])
    q = np.rint(tip[:2]).astype(int)
    if not (0 <= q[0] < w and 0 <= q[1] < h and sm.left_mask[q[1], q[0]] >= 128):
        return None
    half = max(4, int(round(r)))
    probe_r = uv_r + out * (half * (abs(out[0]) + abs(out[1])) + 2)
    probe_l = probe_r + (d_tip, 0.0)
    for p in (probe_l, probe_r):
        if not (half <= p[0] < w - half and half <= p[1] < h - half):
            return None
    pl = np.rint(probe_l).astype(int)
    if sm.valid_left is not None and not sm.valid_left[pl[1], pl[0]]:
        return None
    if not strict_round(cap_shape(sm.right_mask, uv_r, out, r)):
        return None
    if _in_front_right(sm, probe_r, d_tip, half):
        return None
    return tip


# the left view's outline must run on past the right's end by this much (px) to be merged
MIN_MERGED_SHIFT_PX = 1.5
# the tip's disparity from the right cap's rows must agree with the curve's there (px)
MAX_D_GAP_PX = 1.0
# a cap row's edge disparity is the cap's when within this of the curve's (px)
EDGE_WINDOW_PX = 2.5


def _right_cap_edges(b, c: BranchCurve, t_tip: float, t_edge: float, d_prior: float) -> np.ndarray:
    """Disparities (K,) of the right cap's rows' edges within :data:`EDGE_WINDOW_PX` of
    ``d_prior``: the rows from the cap's centre ``t_tip`` to its end ``t_edge`` whose right run
    is about symmetric (1.5 px) about the carried centre line, each edge against the left run's
    on the centre line (a merged side is off by far), taken back to the middle's disparity
    (:func:`tips.silhouette_offset_px`) and to the cap centre's depth (:func:`ends.cap_row_scale`)."""
    from appliance.localize.ends import cap_row_scale

    sm = b.sm
    a, z = sorted((int(np.rint(t_tip)), int(np.rint(t_edge))))
    a, z = max(a, 0), min(z, sm.left_mask.shape[0] - 1)
    rows = np.arange(a, z + 1)
    s = c.s_at(rows)
    dd = c.d_at(rows)
    ir = b.runs_r.find(rows, s - dd)
    il = b.runs_l.find(rows, s)
    ok = (ir >= 0) & (il >= 0)
    rows, s, dd, ir, il = rows[ok], s[ok], dd[ok], ir[ok], il[ok]
    lo_r, hi_r = b.runs_r.left_px[ir], b.runs_r.right_px[ir]
    sym = np.abs((s - dd - lo_r) - (hi_r - s + dd)) <= 1.5
    rows, s, ir, il = rows[sym], s[sym], ir[sym], il[sym]
    if not len(rows):
        return np.zeros(0)
    lo_r, hi_r = b.runs_r.left_px[ir], b.runs_r.right_px[ir]
    half = 0.5 * (hi_r - lo_r)
    cx = 0.5 * (sm.left_mask.shape[1] - 1)
    scale = cap_row_scale(rows, t_tip, 0.5 * (sm.left_mask.shape[0] - 1), sm.f_px)
    de = []
    for e_l, e_r, side in ((b.runs_l.left_px[il], lo_r, -1.0), (b.runs_l.right_px[il], hi_r, 1.0)):
        dx = e_l - e_r
        de.append((dx - silhouette_offset_px(s, dx, half, side, sm.f_px, cx)) * scale)
    de = np.concatenate(de)
    return de[np.abs(de - d_prior) <= EDGE_WINDOW_PX]


def _left_runs_into_other(b, c: BranchCurve, t_right: float, sign: float, r: float) -> bool:
    """Whether the left view's outline past the right view's end is something other than the
    piece running on: on the rows one to two radii past it, the left run on the centre line
    is clearly wider than the piece (1.6 times, as :meth:`ends.EndPlacer._wider_on_right`) or
    its middle lies off the centre line by more than half a radius (on most rows)."""
    rows = np.rint(t_right + sign * np.arange(max(1.0, r), max(2.0 * r, 3.0))).astype(int)
    rows = rows[(rows >= 0) & (rows < b.sm.left_mask.shape[0])]
    if len(rows) == 0:
        return False
    lo, hi = c.t_range
    slope = float(np.hypot(1.0, c.s_poly.deriv()(np.minimum(np.maximum(rows, lo), hi)).mean()))
    s = c.s_at(rows)
    il = b.runs_l.find(rows, s)
    on = il >= 0
    i = np.maximum(il, 0)
    other = on & ((b.runs_l.span_px[i] > 1.6 * 2 * r * slope + 2) | (np.abs(b.runs_l.centre_px[i] - s) > 0.5 * r))
    return bool(other.mean() >= 0.8)


def merged_tips(b, segs) -> dict:
    """Tips merged with another branch in the left view, standing free in the right one
    (:func:`merged_left_tip`), at the ends of the steep pieces ``segs`` not placed as tips.

    The walks along each end's centre line out of both masks are read at once (the same
    samples as :meth:`ends.EndPlacer._walk_out`); only the ends whose right walk leaves its mask
    :data:`MIN_MERGED_SHIFT_PX` or more before the left one are read further. A right cap that
    another tip placed already ends (within a radius) is that tip's. Returns ``{(piece, node):
    (u, v, d)}``.
    """
    from appliance.localize.ends import WALK_EDGE_BIAS, EndPlacer, walk_edges

    g = b.g
    todo, vals, n = [], [], []
    for s in segs:
        c = b.curves.get(s)
        if c is None or not c.by_row:
            continue
        for node in g.seg_nodes[s]:
            if node < 0 or (node in b.uvd and node not in b.hidden and int(g.node_kind[node]) == ENDPOINT):
                continue
            lo, hi = c.t_range
            t_node = b.node_xy[node][1]
            k = 1 if abs(t_node - hi) <= abs(t_node - lo) else 0
            start, sign = (hi, 1.0) if k else (lo, -1.0)
            n_t = math.ceil((3 * c.radius_px + 3 * g.scale + 4) / 0.25)
            if n_t < 2:
                continue
            d_slope = c.d_end_slopes[k] if c.d_end_slopes is not None else c.d_poly.deriv().at(start)
            todo.append((s, node, c, sign))
            vals.append((start, sign, c.s_poly.at(start), c.s_poly.deriv().at(start), c.d_poly.at(start), d_slope))
            n.append(n_t)
    if not todo:
        return {}
    # every walk's samples beyond one end of its span: that end's values and slopes (BranchCurve._eval)
    start, sign, s0, ds, d0, dd = (np.repeat(np.array(v), n) for v in zip(*vals))
    ends = np.cumsum(n)
    t_all = start + sign * 0.25 * (np.arange(ends[-1]) - (ends - n).repeat(n))
    bounds = np.r_[0, ends]
    uv = np.column_stack([s0 + ds * (t_all - start) - (d0 + dd * (t_all - start)), t_all])
    ir, cr = walk_edges(b.sm.right_mask, uv, bounds)
    placed_r = np.array([(u - d, v) for n, (u, v, d) in b.uvd.items()
                         if n < len(g.node_kind) and int(g.node_kind[n]) == ENDPOINT and n not in b.hidden]).reshape(-1, 2)
    # the left view's outline must run on past the right view's end (the walks' lines, carried
    # MIN_MERGED_SHIFT_PX further out; merged_left_tip reads it again on the curve)
    k = np.flatnonzero(cr)
    if not len(k):
        return {}
    first = bounds[k]
    t_r = t_all[first] + sign[first] * (0.25 * ir[k] + WALK_EDGE_BIAS)          # (EndPlacer._walk_t)
    step = np.column_stack([ds[first] * sign[first], sign[first]])
    step /= np.hypot(step[:, 0], step[:, 1])[:, None]
    uv_on = np.column_stack([s0[first] + ds[first] * (t_r - start[first]), t_r]) + MIN_MERGED_SHIFT_PX * step
    k = k[EndPlacer._on_mask(uv_on, b.sm.left_mask)]
    out = {}
    for k in k.tolist():
        s, node, c, sign_k = todo[k]
        t_right = b._walk_t(t_all[bounds[k]:bounds[k + 1]], sign_k, ir[k], True)
        tip = merged_left_tip(b, c, t_right, sign_k)
        if tip is None:
            continue
        if len(placed_r) and np.hypot(*(placed_r - (tip[0] - tip[2], tip[1])).T).min() < c.radius_px:
            continue
        out[(s, int(node))] = tip
    return out
