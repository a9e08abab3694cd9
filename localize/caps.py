"""Tips of steep pieces the dense fit could not match, found by their round cap.

A branch's end often shows only as a short stub past a leaf or an apple, cut obliquely by
it, or as a piece whose rows are all cut or merged on one side in one view: no row has two
crossings of the same width in both views, so :func:`dense.fit_steep_many` finds nothing.
Its round cap, though, is seen whole in both views when the tip is: the left mask's patch
around the cap, slid along the rows of the right mask across the working disparity range,
fits in one place. That disparity (good to a pixel or two) and the straight centre line of the
piece's last few radii make a short curve, on which :meth:`ends.EndPlacer.tip` places the tip
and checks it like any other (the cap's rows refine the disparity; an end cut by an occluder,
whose outline differs between the views, is hidden).
"""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize import kernels_tips
from appliance.localize.curves import BranchCurve, Poly, angle_deg
from appliance.localize.edges import Runs
from appliance.localize.graph import ENDPOINT, SkeletonGraph
from appliance.localize.matching import StereoMasks
from appliance.localize.radius import radius_at

# the cap's best fit: at most this share of the compared pixels differ
MAX_FIT_ERROR = 0.15
# another fit elsewhere along the rows within this share of the best: ambiguous
MIN_FIT_MARGIN = 0.15
# the far fits (by squared difference) whose differing area is compared with the best's
FAR_CANDIDATES = 4
# an ambiguous cap (other fits within the margin) stands at the fit the grey images prefer: their
# normalised cross-correlation of the square patch there at least this ...
GREY_MIN_NCC = 0.7
# ... and at least this much above every other of those fits
GREY_MIN_LEAD = 0.15
# a stub's width read behind its cap whose crossings spread more than this share of their median
# is not the stub's alone (the stub runs into the limb it grows from): the radius map's stands
WIDTH_SPREAD = 0.3


def cap_disparity(sm: StereoMasks, centre_xy: np.ndarray, half_px: int, out: np.ndarray,
                  min_margin: float = MIN_FIT_MARGIN) -> float | None:
    """Disparity (px) at which the left mask's square patch around ``centre_xy`` (x, y) fits the
    right mask best along the same rows, within the working range; None when it fits nowhere
    well (:data:`MAX_FIT_ERROR`), or about as well at another place (``min_margin``, by default
    :data:`MIN_FIT_MARGIN`) unless the grey images tell those fits apart (:func:`_grey_choice`:
    then the fit they prefer), or where the rectified right view's edge (``sm.valid_right``) crosses
    the fitted half. Sub-pixel by a parabola through the fit and its neighbours.

    Only the patch's half towards ``out`` (unit (x, y), from the piece to its end) counts: the
    cap and the background beyond it, alike in both views at a tip, while the piece behind it
    may be cut differently by an occluder in each. The fit's error is the share of that half's
    pixels that differ (coverage 0-255 compared as a fraction).
    """
    # (the patch, its outward half, the squared differences along the strip, the best fit and its
    # rivals: one kernel, the same values)
    ok, x0, y0, s0, k, err, rivals, half = kernels_tips.cap_fit(
        np.ascontiguousarray(sm.left_mask), np.ascontiguousarray(sm.right_mask),
        float(centre_xy[0]), float(centre_xy[1]), int(half_px), float(out[0]), float(out[1]), float(sm.d_range_px[0]),
        float(sm.d_range_px[1]), FAR_CANDIDATES, MAX_FIT_ERROR, float(min_margin))
    if not ok:
        return None
    k, x1, y1 = int(k), x0 + 2 * half_px + 1, y0 + 2 * half_px + 1
    if len(rivals):
        k = _grey_choice(sm, (y0, y1, x0, x1), s0, np.concatenate(([k], rivals)), half_px)
        if k is None:
            return None
    if sm.valid_right is not None and not sm.valid_right[y0:y1, s0 + k:s0 + k + x1 - x0][half > 0].all():
        return None                     # the right view's edge cuts the cap there: its fit is the edge's
    off = 0.0
    if 0 < k < len(err) - 1:
        a, b, c = (float(v) for v in err[k - 1:k + 2])
        den = a - 2 * b + c
        off = 0.5 * (a - c) / den if den > 0 else 0.0
    return float(x0 - (s0 + k + off))


def _grey_choice(sm: StereoMasks, box: tuple, s0: int, offsets: np.ndarray, half_px: int) -> int | None:
    """Which of the cap's mask fits ``offsets`` (strip offsets whose fits are about as good, the
    best first) the grey images tell apart, or None: a small cap's outline is repeated along the
    rows by other caps and branch sides, its shading and the background around it are not. The
    left grey square patch ``box`` (y0, y1, x0, x1) is correlated (normalised, mean removed)
    along the right grey strip from column ``s0``: the fit chosen must score
    :data:`GREY_MIN_NCC` and beat every other more than ``half_px`` from it by
    :data:`GREY_MIN_LEAD`. A patch without texture tells nothing (None)."""
    y0, y1, x0, x1 = box
    tmpl = np.asarray(sm.left_gray[y0:y1, x0:x1], np.float32)
    if float(tmpl.std()) < 2.0:
        return None
    a, z = int(offsets.min()), int(offsets.max()) + (x1 - x0)
    strip = np.asarray(sm.right_gray[y0:y1, s0 + a:s0 + z], np.float32)
    ncc = cv2.matchTemplate(strip, tmpl, cv2.TM_CCOEFF_NORMED)[0][offsets - a]
    i = int(np.argmax(ncc))
    far = np.abs(offsets - offsets[i]) > half_px
    lead = ncc[i] - ncc[far].max() if far.any() else 0.0
    return int(offsets[i]) if ncc[i] >= GREY_MIN_NCC and lead >= GREY_MIN_LEAD else None


def _area_err(strip: np.ndarray, patch: np.ndarray, half: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Share (K,) of the masked patch's area (coverage 0-255, weights ``half``) that differs from
    the strip's window at each column offset in ``offsets`` (K,): sum |a - b| half / (sum half 255).
    (The rule :func:`kernels_tips.cap_fit` computes, for uint8 masks; kept as its reference.)"""
    cols = offsets[:, None] + np.arange(patch.shape[1])[None, :]          # (K, w)
    win = strip[:, cols]                                                  # (h, K, w)
    diff = np.abs(win - patch[:, None, :]) * half[:, None, :]
    return diff.sum(axis=(0, 2)) / (float(half.sum()) * 255.0)


def _rows_agree(runs_l: Runs, runs_r: Runs, rows: np.ndarray, u_poly: Poly, d: float, max_width_px: float) -> bool:
    """Whether most (60 %, at least 2) ``rows`` cross the branch at ``u_poly`` in the left view,
    no wider than ``max_width_px``, and at ``d`` px less in the right one with runs of about the
    same width (20 % + 1.5 px): a cap matched against the side of something wider (a trunk) is
    not, nor is a blob much wider than its radius says."""
    u = u_poly(rows)
    il, ir = runs_l.find(rows, u), runs_r.find(rows, u - d)
    both = (il >= 0) & (ir >= 0)
    w_l, w_r = runs_l.span_px[il[both]], runs_r.span_px[ir[both]]
    n = int(((np.abs(w_l - w_r) <= 0.2 * w_l + 1.5) & (w_l <= max_width_px)).sum())
    return n >= max(2, 0.6 * len(rows))


def cap_curves(graph: SkeletonGraph, sm: StereoMasks, runs_l: Runs, runs_r: Runs, curves: dict,
               min_angle_deg: float) -> dict[int, BranchCurve]:
    """Curves (by row) for the pieces without one in ``curves`` that end in a tip whose cap
    :func:`cap_disparity` finds in the right view: the straight centre line of the piece's last
    four radii (its skeleton and end pixels; ``runs_l``'s middles near the end) at the cap's
    disparity, if it is steep (at least ``min_angle_deg`` from the rows) and the rows across
    the cap show it alike in both views (:func:`_rows_agree`).

    Returns
    -------
    dict
        {segment: BranchCurve}; a piece with two such ends takes the first that fits.
    """
    out: dict[int, BranchCurve] = {}
    ends = graph.seg_nodes
    is_end = (ends >= 0) & (graph.node_kind[np.maximum(ends, 0)] == ENDPOINT)
    for s, k in zip(*np.nonzero(is_end)):
        s, node = int(s), int(ends[s, k])
        if s in out or s in curves or graph.seg_recovered[s]:
            continue
        end_xy = graph.to_full(graph.node_yx[node][None])[0]
        r = float(radius_at(sm.radius_map, end_xy[None])[0])
        if r < 1.0:
            continue
        yx = [graph.seg_yx[s].reshape(-1, 2)] + [graph.node_pixels[n] for n in graph.seg_nodes[s] if n >= 0]
        pts = graph.to_full(np.concatenate(yx))
        near = pts[np.hypot(*(pts - end_xy).T) <= 4 * r + graph.scale]
        angle = angle_deg(near)
        if near[:, 1].max() - near[:, 1].min() < 1 or angle < min_angle_deg:     # (np.ptp's value, without its wrapper)
            continue
        out_dir = end_xy - near.mean(0)
        d = cap_disparity(sm, end_xy, max(4, int(round(2 * r))), out_dir / max(float(np.hypot(*out_dir)), 1e-9))
        if d is None:
            continue
        t = near[:, 1].astype(float)
        u_poly = Poly.fit(t, near[:, 0], 1)
        # the coarse skeleton's line moved onto the middles of the left rows within two radii
        # of the end (the cap's and those next to it: whole, as the tip is seen)
        rows = np.arange(np.ceil(end_xy[1] - 2 * r), np.floor(end_xy[1] + 2 * r) + 1)
        il = runs_l.find(rows, u_poly(rows))
        if (il >= 0).sum() >= 3:
            u_poly = Poly.fit(rows[il >= 0], runs_l.centre_px[il[il >= 0]], 1)
        # (a row crosses a piece at angle a over 2 r / sin a: at most half as much again, as in
        # dense.fit_steep_many)
        max_w = 1.5 * (2 * r / max(np.sin(np.radians(angle)), 0.2) + 1) + 2
        if not _rows_agree(runs_l, runs_r, rows[np.abs(rows - end_xy[1]) <= r], u_poly, d, max_w):
            continue
        out[s] = BranchCurve(s, True, (float(t.min()), float(t.max())), u_poly, Poly.constant(d),
                             _width_radius(runs_l, u_poly, end_xy, out_dir, r), len(near), (0.0, 0.0))
    return out


def _width_radius(runs_l: Runs, u_poly: Poly, end_xy: np.ndarray, out_dir: np.ndarray, r: float) -> float:
    """The stub's radius from its width across (px): the median of its left rows' crossings 1-3
    radii behind the skeleton end ``end_xy`` (away from ``out_dir``), each ``2 rho sqrt(1 + u'^2)``
    wide on the line ``u_poly``. The radius map at a skeleton end ``r`` lies inside the round cap,
    short of the branch's radius (a cap curve's tip is placed and its cap rows read with this
    radius); so the reading replaces ``r`` only where it is larger, up to twice ``r`` (a wider
    reading is something else crossing those rows), where at least 3 rows are read and their widths
    agree (:data:`WIDTH_SPREAD`)."""
    back = -1.0 if out_dir[1] > 0 else 1.0
    rows = np.rint(end_xy[1] + back * np.arange(r, 3 * r + 1.0)).astype(int)
    il = runs_l.find(rows, u_poly(rows))
    if (il >= 0).sum() < 3:
        return r
    span = runs_l.span_px[il[il >= 0]]
    if float(span.max() - span.min()) > WIDTH_SPREAD * float(np.median(span)):
        return r
    slope = float(u_poly.deriv().at(float(end_xy[1])))
    rho = float(np.median(span)) * 0.5 / np.sqrt(1.0 + slope * slope)
    return rho if r <= rho <= 2.0 * r else r
