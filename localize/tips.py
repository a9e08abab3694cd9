"""Tips of short flat pieces the bark texture could not match, found by their round cap.

A piece within ``match.max_horizontal_deg`` of the rows gets its disparity from the bark texture
(:func:`dense._flat_curve`); a short fragment (a twig's last few radii past a fork, a leaf or
another branch) often has too little texture and no curve, so its tip was never placed. Its
round cap, though, is the one thing of a flat piece that is well placed along the rows: the
left mask's patch around the end (:func:`caps.cap_disparity`: only its outward half, the cap
and the background beyond it) slid along the right mask's rows fits in one place. That
disparity, checked against the rows across the end (both views' run ends agree row by row)
and against the piece's other end when that is placed, gives a short constant-disparity curve
on which :meth:`ends.EndPlacer.tip` places the tip and checks it like any other flat tip (the
run ends refine the disparity; an end cut obliquely or with something at its depth or nearer
just beyond it is hidden).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from appliance.localize import kernels_endreads, kernels_ncc, kernels_tips, kernels_walks
from appliance.localize.caps import cap_disparity
from appliance.localize.curves import BranchCurve, Poly, angle_deg, median
from appliance.localize.edges import Runs
from appliance.localize.graph import ENDPOINT, JOINT

# the end's disparity may differ from the piece's placed other end by this much (px, or share):
# a short flat piece barely changes depth along its length
MAX_END_GAP_PX = 2.0
MAX_END_GAP_SHARE = 0.03
# another fit of the cap along the rows within this share of the best: ambiguous (a flat cap's patch
# also half fits along the piece's own body, whose outline runs along the rows)
MIN_FIT_MARGIN = 0.08
# a round cap's outline 0.7 radius off the axis ends r (1 - sqrt(1 - 0.7^2)) ~ 0.29 r behind the axis'
# end; both sides must be back by at least this share of that (an apple's or a leaf's edge cutting
# the piece runs straight or bulges into it)
MIN_ROUNDNESS = 0.2
# the probe beyond a tip: a match within this (px of disparity) in front of the branch is an occluder
# near it; one further in front must be found again by the next patch out, within CONFIRM_PX
NEAR_FRONT_PX = 30.0
CONFIRM_PX = 3.0
# a tip's end read against a round cap (cap_shape): each side at least this share of a round cap's
# setback, and at most MAX_CAP_BACK (a pointed end: a leaf's tip)
MIN_CAP_BACK = 0.2
MAX_CAP_BACK = 3.0
TOUCH_BACK = -5.0
# a cap row whose two edges' disparities (each taken back to the middle's) differ by more than this
# (px) has one edge cut or merged in one view only (or, on an oblique cap, the piece's body)
SPLIT_ROW_PX = 1.0
# a steep cap's outline counts as the cap's up to this share of the radius behind its centre (where
# the body's outline, tangent to the cap there, still has the centre's depth)
CAP_EDGE_BACK = 0.2
# a tip's own radius (cap_centre) is read across the branch this many of the piece's radii behind
# its end (where cap_shape reads the width), and stands within this range of the piece's radius
CAP_WIDTH_BACK = 1.5
CAP_RADIUS_RANGE = (0.5, 2.0)
# features this close to the view's edge (px, plus the skeleton's scale for tips) are left out
# (dense.match_dense's border_px): a tip's move onto its cap's centre does not take it there
VIEW_EDGE_PX = 3.0


def flat_cap_curves(b, segs: list, runs_lt: Runs) -> dict[int, BranchCurve]:
    """Curves (by column) for flat pieces ``segs`` without one that end in a tip whose round
    cap fits in the right view (:func:`caps.cap_disparity`).

    Parameters
    ----------
    b : ends.EndPlacer
        The placer of the graph (its mask runs, placed forks and joints).
    segs : list of int
        Flat pieces (within ``match.max_horizontal_deg`` of the rows) without a curve.
    runs_lt : Runs
        Runs of the transposed left mask (columns), for the piece's centre line and radius.

    Returns
    -------
    dict
        {segment: BranchCurve}: the straight centre line v(u) of the piece's last four radii
        (middles of the left mask's columns), at the cap's constant disparity; a piece with two
        such ends takes the first that fits.
    """
    g, sm = b.g, b.sm
    out: dict[int, BranchCurve] = {}
    dmin, dmax = sm.d_range_px
    for s in segs:
        if g.seg_recovered[s]:
            continue
        for k in (0, 1):
            node = int(g.seg_nodes[s][k])
            if node < 0 or g.node_kind[node] != ENDPOINT:
                continue
            c = _flat_cap_curve(b, s, node, runs_lt)
            if c is None or not dmin <= c.d_poly.at(c.t_range[0]) <= dmax:
                continue
            # the other end joined across a gap to the same branch (a joint) has its depth; a fork
            # there may be a crossing with another branch at another depth: no check
            other = int(g.seg_nodes[s][1 - k])
            if other >= 0 and other in b.uvd and g.node_kind[other] == JOINT:
                d_o, d = float(b.uvd[other][2]), c.d_poly.at(c.t_range[0])
                if abs(d - d_o) > max(MAX_END_GAP_PX, MAX_END_GAP_SHARE * d_o):
                    continue
            out[s] = c
            b.cap_segments.add(s)
            break
    return out


def _flat_cap_curve(b, s: int, node: int, runs_lt: Runs) -> BranchCurve | None:
    """The curve of flat piece ``s`` from its end ``node``'s cap (see :func:`flat_cap_curves`)."""
    g, sm = b.g, b.sm
    end_xy = b.node_xy[node]
    yx = [g.seg_yx[s].reshape(-1, 2), g.node_pixels[node]]
    pts = g.to_full(np.concatenate(yx))
    r0 = float(b._node_radius(node))
    if r0 < 1.0:
        return None
    near = pts[np.hypot(*(pts - end_xy).T) <= max(4 * r0, 12.0) + g.scale]
    if len(near) < 2 or np.ptp(near[:, 0]) < 2 or angle_deg(near) >= b.cfg.max_horizontal_deg:
        return None
    v_poly = Poly.fit(near[:, 0].astype(float), near[:, 1].astype(float), 1)
    lo, hi = float(near[:, 0].min()), float(near[:, 0].max())
    c = BranchCurve(s, False, (lo, hi), v_poly, Poly.constant(0.0), r0, len(near), (0.0, 0.0))
    t_edge, sign = b._walk_out(c, node)
    # the line moved onto the middles of the left mask's columns behind the cap (the skeleton's
    # end lies inside the cap; the cap's own columns are shorter)
    cols = t_edge - sign * np.arange(r0 + 2.0, r0 + 2.0 + max(3 * r0, 10.0))
    it = runs_lt.find(np.rint(cols).astype(int), v_poly(cols))
    # a column crosses a piece within max_horizontal_deg of the rows over at most 2 r / cos: one
    # much longer is something the stub touches (the limb it grows from or crosses), not its width
    max_span = 1.5 * (2 * r0 / np.cos(np.radians(b.cfg.max_horizontal_deg)) + 1) + 2
    ok = (it >= 0) & (runs_lt.span_px[np.maximum(it, 0)] <= max_span)
    if ok.sum() < 3:
        return None
    cols = np.rint(cols[ok])
    v_poly = Poly.fit(cols, runs_lt.centre_px[it[ok]], 1)
    slope = v_poly.deriv().at(float(cols.mean()))
    r = float(median(0.5 * runs_lt.span_px[it[ok]] / np.sqrt(1.0 + slope * slope)))
    if r < 1.0:
        return None
    # the span: from the end back past the skeleton's last points (the end's walk starts at the
    # span's end nearer the node: on a short stub the span reaches back at least as far behind the
    # node as the cap's edge lies ahead of it, else the walks would leave from the far end)
    t_node = float(end_xy[0])
    lo, hi = ((min(float(cols.min()), lo, 2 * t_node - t_edge - 1.0), t_edge) if sign > 0 else
              (t_edge, max(float(cols.max()), hi, 2 * t_node - t_edge + 1.0)))
    c = BranchCurve(s, False, (lo, hi), v_poly, Poly.constant(0.0), r, int(ok.sum()), (0.0, 0.0))
    t_edge, sign = b._walk_out(c, node)
    uv_edge = c.uv_at(t_edge)[0]
    direction = c.uv_at(t_edge + sign)[0] - uv_edge
    direction /= max(float(np.hypot(*direction)), 1e-9)
    if not round_end(b.runs_l, uv_edge, sign, r):     # (the cheap test first)
        return None
    # the cap's centre, one radius back from where the centre line leaves the mask
    d = cap_disparity(sm, uv_edge - r * direction, max(4, int(round(2 * r))), direction, MIN_FIT_MARGIN)
    if d is None:
        return None
    # the rows across the end end alike in both views at that disparity (a round cap; a right
    # run merging there with something else does not)
    if not b._end_outline_agrees(uv_edge, direction, d, r):
        return None
    return BranchCurve(s, False, (lo, hi), v_poly, Poly.constant(d), r, int(ok.sum()), (0.0, 0.0))


def round_end(runs_l: Runs, uv_edge: np.ndarray, sign: float, r: float) -> bool:
    """Whether the end of a flat piece at ``uv_edge`` (x, y; the centre line's last point on the
    mask, the piece running towards ``sign`` (+-1) along the rows) is a round cap of radius ``r``
    (px): on the rows 0.7 r above and below the axis the mask ends at least
    :data:`MIN_ROUNDNESS` of a circle's ``0.29 r`` behind the axis row's end."""
    rows = np.rint(uv_edge[1] + np.array([0.0, -0.7 * r, 0.7 * r])).astype(int)
    il = runs_l.find(rows, np.full(3, uv_edge[0] - sign * r))
    if (il < 0).any():
        return False
    ends = runs_l.right_px[il] if sign > 0 else runs_l.left_px[il]
    back = sign * (ends[0] - ends[1:])
    return bool((back >= MIN_ROUNDNESS * (1.0 - np.sqrt(0.51)) * r).all())


def front_disparity(left: np.ndarray, right: np.ndarray, uv_px: np.ndarray, d_branch_px: float, half_px: int,
                    d_max_px: float, margin_px: float = -3.0, min_score: float = 0.7,
                    min_lead: float = 0.1) -> float | None:
    """Disparity (px) of the patch at ``uv_px`` (x, y) when it lies in front of the branch, as
    :func:`texture.nearer_in_front` decides it (best match in front scoring ``min_score`` or more
    and ``min_lead`` above every match behind); None when it does not (or has no texture, or
    leaves the image)."""
    h, w = left.shape
    u, v = (int(x) for x in np.rint(uv_px))
    hh = int(half_px)
    if v - hh < 0 or v + hh + 1 > h or u - hh < 0 or u + hh + 1 > w:
        return None
    x0 = max(int(u - np.ceil(d_max_px)) - hh, 0)
    tmpl = np.ascontiguousarray(left[v - hh:v + hh + 1, u - hh:u + hh + 1])
    strip = np.ascontiguousarray(right[v - hh:v + hh + 1, x0:u + hh])
    if strip.shape[1] <= tmpl.shape[1] or float(tmpl.std()) < 2.0:
        return None
    if strip.dtype == np.uint8 and tmpl.dtype == np.uint8:     # exact sums (kernels_ncc.ncc_scores): OpenCV's
        c = kernels_ncc.ncc_scores(strip, tmpl)                       # float32 scores up to ~5e-4
    else:
        c = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0]
    d = u - (x0 + np.arange(len(c)) + hh)
    front = d > d_branch_px + margin_px
    if not front.any():
        return None
    k = int(np.argmax(np.where(front, c, -np.inf)))
    best_behind = float(c[~front].max()) if (~front).any() else -1.0
    if c[k] < min_score or c[k] < best_behind + min_lead:
        return None
    return float(d[k])


def occluder_confirmed(sm, uv_edge: np.ndarray, out: np.ndarray, d_branch_px: float, half_px: int) -> bool:
    """Whether something found in front of a tip by the probe just beyond it (the square patch
    of half size ``half_px`` clear of the cap, as in :meth:`ends.EndPlacer.tip`) is an occluder.

    A thing hiding a branch's end (a leaf, an apple, a twig) lies near the branch, within
    :data:`NEAR_FRONT_PX` of its disparity; a match much further in front is taken only if
    the next patch out along the branch finds the same disparity (:data:`CONFIRM_PX`): smooth,
    blurred background behind a true tip matches by chance somewhere along the rows.
    """
    step = half_px * (abs(out[0]) + abs(out[1]))
    p1 = uv_edge + out * (step + 2)
    d1 = front_disparity(sm.left_gray, sm.right_gray, p1, d_branch_px, half_px, sm.d_range_px[1])
    if d1 is None or d1 - d_branch_px <= NEAR_FRONT_PX:
        return True                      # (as texture.nearer_in_front decided: near the branch)
    d2 = front_disparity(sm.left_gray, sm.right_gray, uv_edge + out * (3 * step + 3), d_branch_px, half_px,
                         sm.d_range_px[1])
    return d2 is not None and abs(d2 - d1) <= CONFIRM_PX


def silhouette_offset_px(u_px, d_px, half_width_px, side, f_px: float, cx_px: float):
    """Disparity (px) of a round outline's extreme along the row (its left edge, ``side`` -1, or
    right edge, +1) less that of the middle it is round about (a cap's centre, a branch's axis).

    Each camera sees the outline's extreme where its own ray grazes the round surface, and the
    two rays graze it at different points: a sphere (or a row's section of a branch) of radius
    ``rho`` around ``(X, Z)`` has its extreme at ``f tan(phi + side asin(rho / D))`` in each view
    (``phi``, ``D``: the centre's direction and distance from that camera), whose difference exceeds
    the centre's disparity by about ``side rho f b (X - b / 2) / (D Z^2)``: up to ~0.3 px for a
    6 px radius at the image's side. An outline pointing away from the middle between the
    cameras is seen nearer than it is. Exact for a sphere, in units of the centre's depth
    (``X / Z = (u - cx) / f``, ``rho / Z = w / f``, ``b / Z = d / f``).

    Parameters
    ----------
    u_px, d_px, half_width_px : float or ndarray
        The middle's column and disparity, and the outline's half width, px (rectified).
    side : float or ndarray
        -1 for a left edge or an end pointing left (-u), +1 for a right one.
    f_px, cx_px : float
        Rectified focal length and principal point column (the image's middle column is close
        enough: 20 px off moves the result by ~1 %).
    """
    if np.ndim(u_px) == 0 and np.ndim(d_px) == 0 and np.ndim(half_width_px) == 0 and np.ndim(side) == 0:
        x_l = (float(u_px) - cx_px) / f_px         # (one point: the same sums in Python floats)
        x_r = x_l - float(d_px) / f_px
        rho = float(half_width_px) / f_px
        e_l = math.tan(math.atan(x_l) + side * math.asin(min(rho / math.hypot(x_l, 1.0), 1.0)))
        e_r = math.tan(math.atan(x_r) + side * math.asin(min(rho / math.hypot(x_r, 1.0), 1.0)))
        return f_px * (e_l - e_r - (x_l - x_r))
    x_l = (np.asarray(u_px, float) - cx_px) / f_px
    x_r = x_l - np.asarray(d_px, float) / f_px
    rho = np.asarray(half_width_px, float) / f_px
    ext_l = np.tan(np.arctan(x_l) + side * np.arcsin(np.minimum(rho / np.hypot(x_l, 1.0), 1.0)))
    ext_r = np.tan(np.arctan(x_r) + side * np.arcsin(np.minimum(rho / np.hypot(x_r, 1.0), 1.0)))
    return f_px * (ext_l - ext_r - (x_l - x_r))


def _last_on(mask: np.ndarray, starts: np.ndarray, directions: np.ndarray, s: np.ndarray,
             n_s: np.ndarray | None = None) -> np.ndarray:
    """Where each line ``starts[k] + s directions[k]`` (s ascending, evenly spaced) last has the
    soft ``mask`` at or above one half, interpolated between samples (K,); NaN where a line
    starts off the mask or never leaves it. One bilinear read of all lines. ``n_s`` (K,): each
    line's own number of samples (its first ``n_s[k]`` of ``s``; all by default): the samples past
    them read as on the mask, so each line's result is that of reading it alone."""
    if mask.dtype == np.uint8 and len(s) >= 2 and len(starts):       # compiled: the same values
        n = np.full(len(starts), len(s), np.int64) if n_s is None else np.ascontiguousarray(n_s, np.int64)
        return kernels_walks.last_on(np.ascontiguousarray(mask), np.ascontiguousarray(starts, float), np.ascontiguousarray(directions, float),
                               np.ascontiguousarray(s, float), np.minimum(n, len(s)))
    return _last_on_np(mask, starts, directions, s, n_s)


def _last_on_np(mask: np.ndarray, starts: np.ndarray, directions: np.ndarray, s: np.ndarray,
                n_s: np.ndarray | None = None) -> np.ndarray:
    """:func:`_last_on` by one cv2.remap of all lines (the reference of :func:`kernels_walks.last_on`)."""
    s32 = s.astype(np.float32)
    mx = starts[:, :1].astype(np.float32) + directions[:, :1].astype(np.float32) * s32      # (K, S)
    my = starts[:, 1:].astype(np.float32) + directions[:, 1:].astype(np.float32) * s32
    v = cv2.remap(mask, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    if n_s is not None:
        v[np.arange(len(s))[None, :] >= np.asarray(n_s)[:, None]] = 255
    on = v >= 128
    k = on.argmin(axis=1)                                # the first sample off (0 if all on)
    rows = np.arange(len(starts))
    a = v[rows, k - 1].astype(np.float32)                # (k = 0: a line starting off, or never off)
    b = v[rows, k]
    x = s[k - 1] + (a - 127.5) / np.maximum(a - b, 1e-6) * (s[1] - s[0])
    x[(k == 0) | ~on[:, 0]] = np.nan
    return x


def cap_shape(mask: np.ndarray, uv_edge: np.ndarray, out: np.ndarray, r: float) -> list | None:
    """A branch end's outline against a round cap's, from the soft mask (sub-pixel).

    Read along lines at 0.5 px steps, the half-coverage crossing interpolated between samples.
    The branch's radius ``rho`` is half its width across, 1.5 ``r`` behind the end (``uv_edge``,
    where the centre line leaves the mask going ``out``, unit (x, y)); the lines 0.7 ``rho`` to
    either side of the centre line leave the mask ``back`` behind where it does. A round cap gives
    ``back = (1 - sqrt(1 - 0.7^2)) rho ~ 0.29 rho`` on both sides; an occluder's edge that ends
    the branch (straight, or an apple's or a leaf's outline bulging into it) gives ~0 or less on
    at least one side. The width there may itself be merged on one side with something touching
    the branch: the second reading takes the shorter side's reach from the fitted centre line as
    the radius, about that line.

    Returns
    -------
    list of two (rho, back_a, back_b) or None, or None
        The two readings (across the width; the shorter side's): ``rho`` px, each side's ``back``
        as a share of a round cap's (1 = round; -inf where that side runs on past the reach, 2 rho
        beyond the middle's end at least); None where the outline cannot be read (the width; a
        reading's centre-line end).
    """
    return cap_shapes(mask, [(uv_edge, out, r)])[0]


def cap_shapes(mask: np.ndarray, ends: list) -> list:
    """:func:`cap_shape` of several ends ``(uv_edge, out, r)`` at once: each end's own lines and
    samples (the same values as reading it alone), read by one bilinear read per stage."""
    return cap_shapes_offsets(mask, ends)[0]


def cap_shapes_offsets(mask: np.ndarray, ends: list) -> tuple[list, np.ndarray]:
    """:func:`cap_shapes`, and how far the middle of each end's width across lies from its centre
    line (K,) px, towards ``(-out_y, out_x)`` (NaN where a side is not read). Compiled
    (:func:`kernels_tips.cap_shapes_offsets`: each end's lines read up to where they leave the mask)."""
    if not ends:
        return [], np.zeros(0)
    arr = np.empty((len(ends), 5))
    for i, (uv_edge, out, r) in enumerate(ends):
        arr[i, :2], arr[i, 2:4], arr[i, 4] = uv_edge, out, r
    offsets, shapes, status = kernels_tips.cap_shapes_offsets(np.ascontiguousarray(mask), arr)
    out_shapes = [None if st[0] < 0 else [tuple(sh[v].tolist()) if st[v] else None for v in (0, 1)]
                  for sh, st in zip(shapes, status.tolist())]
    return out_shapes, offsets


def round_cap(mask: np.ndarray, uv_edge: np.ndarray, out: np.ndarray, r: float) -> bool:
    """Whether a branch end reads as a round cap (:func:`cap_shape`, either reading): both sides
    between :data:`MIN_CAP_BACK` and :data:`MAX_CAP_BACK` of a round cap's, or one side so and the
    other running on far past the end (:data:`TOUCH_BACK`: something touches the cap there, as a
    twig or a leaf's stalk; an occluder's oblique edge moves the two sides about alike, one back
    and one on); an end that cannot be read counts as round (no evidence against it)."""
    return _is_round(cap_shape(mask, uv_edge, out, r))


def round_caps(mask: np.ndarray, ends: list) -> list[bool]:
    """:func:`round_cap` of several ends ``(uv_edge, out, r)`` at once (:func:`cap_shapes`)."""
    return [_is_round(shapes) for shapes in cap_shapes(mask, ends)]


def _is_round(shapes: list | None) -> bool:
    """:func:`round_cap`'s rule on :func:`cap_shape`'s readings."""
    if shapes is None or shapes[0] is None:
        return True
    for shape in shapes:
        if shape is None:
            return True
        lo, hi = sorted(shape[1:])
        if MIN_CAP_BACK <= hi <= MAX_CAP_BACK and (lo >= MIN_CAP_BACK or lo <= TOUCH_BACK):
            return True
    return False

def at_view_edge(rows: np.ndarray, x_px: np.ndarray, side: float, valid: np.ndarray | None,
                 width_px: int | None = None) -> np.ndarray:
    """Whether each run boundary ``x_px`` (N,) of ``rows`` (N,) lies at the view's edge: the pixel
    just beyond it (``side`` -1 left, +1 right; scalar or (N,)) is outside the image or, with ``valid`` (H, W)
    bool (where the rectified view sees the scene), outside that. Such an end is the view's, not
    the branch's outline. ``width_px`` is the image width when ``valid`` is None."""
    w = valid.shape[1] if valid is not None else int(width_px)
    # (a boundary refined to the grey image may lie up to ~0.6 px inside its run's end pixel)
    xb = np.rint(np.asarray(x_px, float) + 0.9 * np.asarray(side, float)).astype(int)
    out = (xb < 0) | (xb >= w)
    if valid is not None:
        inside = ~out
        out[inside] = ~valid[np.asarray(rows, int)[inside], xb[inside]]
    return out


def split_row_disparity(mid: np.ndarray, e_lo: np.ndarray, e_hi: np.ndarray, d_prior: float,
                        split_px: float = SPLIT_ROW_PX) -> np.ndarray:
    """Disparity (N,) of a cap's rows from their middles ``mid`` and their two edges' own
    disparities ``e_lo``, ``e_hi`` (N,) px, silhouette-corrected; ``inf`` where an edge is unusable).

    A row whose edges agree (within ``split_px``) keeps its middle (the two edges' errors
    partly cancel there). A row whose edges disagree has one of them cut or merged in one view
    only (a leaf, a branch touching the cap in one view), or on an oblique cap the piece's body:
    it takes whichever of its middle and its two edges lies nearest the agreeing rows' median
    (``d_prior`` with fewer than 3 of them).
    """
    mid = np.asarray(mid, float)
    split = ~(np.abs(e_lo - e_hi) <= split_px)
    if not split.any():
        return mid
    good = ~split & (np.abs(mid - d_prior) <= 2.0)
    d_ref = float(median(mid[good])) if good.sum() >= 3 else float(d_prior)
    cand = np.stack([mid, e_lo, e_hi])
    pick = np.abs(cand - d_ref).argmin(axis=0)
    return np.where(split, cand[pick, np.arange(len(mid))], mid)



def cap_radius(mask: np.ndarray, uv_edge: np.ndarray, out: np.ndarray, r: float) -> float | None:
    """A branch's own radius (px) at its end, read on the soft left mask (:func:`cap_centre` of
    :func:`cap_shapes_offsets`; the end ``uv_edge``, where the centre line going ``out``, unit
    (x, y), leaves the mask; ``r`` the piece's radius, px)."""
    shapes, offsets = cap_shapes_offsets(mask, [(uv_edge, out, r)])
    centre = cap_centre(shapes[0], float(offsets[0]), r)
    return None if centre is None else centre[2]


def cap_centre(shapes: list | None, offset_px: float, r: float) -> tuple[float, float, float] | None:
    """Where a branch end's round cap has its centre, from :func:`cap_shape`'s readings and the
    offset of the width's middle from the centre line (:func:`cap_shapes_offsets`).

    The cap's radius ``rho`` is the branch's own: half its width across, :data:`CAP_WIDTH_BACK`
    ``r`` behind the end (``shapes[0][0]``). A tapering branch's piece radius ``r`` (its median
    along the piece) is 1.1 (median) to 1.4 (p95) times the radius at the tip on rendered scenes;
    this reading is 1.04 / 1.02 (median) of it (exact / colour masks), p95 |error| 0.66 / 0.49 px.
    The centre lies ``offset_px`` across from the fitted centre line (often 20-60 % of the radius
    off the middle there), so the line leaves the cap's outline ``sqrt(rho^2 - offset^2)`` beyond
    the centre's foot on it. Where the lines about that middle do not read a round cap (both
    sides' setbacks within :data:`MIN_CAP_BACK` ... :data:`MAX_CAP_BACK` of a round cap's), the
    width is merged on one side with something touching the branch (running on past the cap, or
    ending at it): the shorter side's reach from the fitted line is the radius (``shapes[1][0]``),
    about that line.

    Returns
    -------
    (back_px, across_px, rho_px) or None
        The centre is ``back_px`` back along the line from where it leaves the mask and
        ``across_px`` towards ``(-out_y, out_x)``; ``rho_px`` the cap's radius. None where the
        width cannot be read or is not within :data:`CAP_RADIUS_RANGE` of ``r``.
    """
    if shapes is None or shapes[0] is None or not np.isfinite(offset_px):
        return None
    rho, across = shapes[0][0], float(offset_px)
    if not MIN_CAP_BACK <= min(shapes[0][1:]) <= max(shapes[0][1:]) <= MAX_CAP_BACK:
        if shapes[1] is None:
            return None
        rho, across = shapes[1][0], 0.0
    lo, hi = CAP_RADIUS_RANGE
    if not lo * r <= rho <= hi * r:
        return None
    return math.sqrt(max(rho * rho - across * across, 0.0)), across, rho


def reads_round(shapes: list | None) -> bool:
    """:func:`round_cap`'s rule on :func:`cap_shape`'s readings ``shapes``."""
    return _is_round(shapes)


# a flat tip's run end moved > 2 px off its texture stands only if the right view's flanks beside the end
# (the bands 1.3-2.3 radii each side of the centre line, from one radius back to the end) hold no more
# than this share of mask more than the left's: a round cap leaves its flanks empty, a branch touching it
# in the right view only fills them there (seed 340 T13: 0.50 against 0.00; at the texture's disparity 0.05)
FLANK_SHARE = 0.25


def right_flanks_filled(left_mask: np.ndarray, right_mask: np.ndarray, uv_edge: np.ndarray, out: np.ndarray,
                        d_px: float, r: float) -> bool:
    """Whether the right view has clearly more mask than the left beside a tip's end at disparity ``d_px``.

    Parameters
    ----------
    left_mask, right_mask : (H, W) uint8 masks (>= 128: branch), rectified.
    uv_edge : (2,) left px where the centre line leaves the mask; ``out`` its unit direction outwards.
    d_px : the end's disparity (px); r : the piece's radius (px).

    Returns
    -------
    bool
        True when the right flanks' mask share exceeds the left's by more than :data:`FLANK_SHARE`
        (something touches the cap in the right view only: its run end is not the cap's).
    """
    # (compiled: the same offsets, products, comparisons and counts as the numpy selection, kernels_endreads)
    share = kernels_endreads.flank_shares(np.ascontiguousarray(left_mask), np.ascontiguousarray(right_mask),
                                        float(uv_edge[0]), float(uv_edge[1]), float(out[0]), float(out[1]),
                                        float(d_px), float(r))
    return bool(share[1] - share[0] > FLANK_SHARE)
