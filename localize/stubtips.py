"""Tips of short isolated stubs: a twig's last few radii seen alone in the left mask.

A twig whose base lies behind a leaf or an apple shows only its end: a small piece of mask, a few
radii long, with a round cap at one end and the occluder's edge at the other. The coarse skeleton
(downscaled) of such a piece is a point or a piece shorter than ``match.min_segment_px``: it gets no
curve and its tip is never placed (docs/localize-tiprec21.md). This module finds such pieces among
the left mask's small connected components that hold no matched piece and no placed feature, and
places the tip of those with exactly one round end (:func:`tips.cap_shapes_offsets`,
:func:`tips.reads_round`): a disc (a branch seen end-on) is not long enough, and a piece cut at both
ends has no round one. The disparity is the cap's (:func:`caps.cap_disparity`: the left mask's patch
around the cap fitted along the right mask's rows), which must also end the piece in the right view
(the same end along the piece's axis within :data:`END_SHIFT_PX`).

The components are not labelled over the whole image (2-5 ms a pair: docs/localize-stubfast22.md) but
found from the fast skeleton's block mask (:func:`stub_components`): a stub's widest disc (radius
>= :data:`MIN_RADIUS_PX`) covers most of one block cell, so its component holds such a cell of a block
component free of taken points; the full mask is labelled in a crop around those components alone.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from appliance.localize import kernels_stubs
from appliance.localize.caps import MIN_FIT_MARGIN, cap_disparity
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.texture import nearer_in_front
from appliance.localize.tips import cap_centre, cap_shapes_offsets, occluder_confirmed, reads_round

MIN_AREA_PX = 60.0         # components smaller than this (px) are specks
MAX_AREA_PX = 900.0        # ... larger than this have pieces of their own (the skeleton's)
MIN_RADIUS_PX = 3.0        # the piece's half width (largest inscribed disc), px
MIN_LENGTH_RADII = 3.2     # its length along its axis, in radii (a disc seen end-on: 2)
MAX_OFF_AXIS_PX = 2.0      # every pixel within the half width plus this of the axis (a straight stub)
END_SHIFT_PX = 1.5         # the cap ends this close (px, along the axis) in both views (tipends' steep shift)
STEP_PX = 0.25             # walk step along the axis, px
MAX_RADIUS_MM = 7.0        # a twig's end; a thicker piece alone is a limb's between two occluders (seed 609: a
                           # limb between a leaf and an apple, 8.3 mm; the stubs' true tips: 4.2-5.1 mm)
MAX_BLOCK_SCALE = 6        # a block mask of larger cells is not searched: the full mask is labelled instead


@lru_cache(maxsize=8)
def min_cell_px(scale: int) -> int:
    """The fewest pixels of one ``scale`` x ``scale`` cell that a disc of the stub test's radius covers
    wherever its centre lies in the cell.

    The radius test reads ``cv2.distanceTransform`` (``DIST_L2``, 5 x 5 mask: chamfer distances) of the
    component: a pixel at distance >= ``MIN_RADIUS_PX + 0.5`` has every pixel nearer than that (in the
    same chamfer metric) in the component; those of its own cell are counted here, for the worst place
    of the centre. (13 of 16 for 4 x 4 cells: more than the block mask's 5, and more than half a cell,
    so one component at most holds that many of a cell.)
    """
    n = 2 * scale + 1
    one = np.ones((2 * n + 1, 2 * n + 1), np.uint8)
    one[n, n] = 0
    near = cv2.distanceTransform(one, cv2.DIST_L2, 5) < MIN_RADIUS_PX + 0.5
    best = scale * scale
    for py in range(scale):
        for px in range(scale):
            best = min(best, int(near[n - py: n - py + scale, n - px: n - px + scale].sum()))
    return best


def taken_points(graph, segments, uvd: dict) -> np.ndarray:
    """The points (N, 2) (x, y) px a stub's component must not hold: the skeleton pixels of the matched
    ``segments`` of ``graph`` (full resolution) and the placed nodes ``uvd`` ({node: (u, v, d)})."""
    pts = [graph.to_full(np.concatenate([graph.seg_yx[s].reshape(-1, 2) for s in segments]))] if segments else []
    if uvd:
        pts.append(np.array(list(uvd.values()), np.float64)[:, :2])
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def _block(sm, scale: int) -> tuple[np.ndarray, int]:
    """The block mask to search and its scale: ``sm.left_block`` (the fast skeleton's, ``scale`` px a cell)
    where it fits, else the full mask itself (1 px a cell: the whole image labelled)."""
    left = sm.left_mask
    h, w = left.shape
    block = getattr(sm, "left_block", None)
    if (block is not None and 1 <= scale <= MAX_BLOCK_SCALE and block.shape == (h // scale, w // scale)
            and block.dtype == np.uint8 and 2 * min_cell_px(scale) > scale * scale):
        return block, scale
    return cv2.threshold(left, 127, 255, cv2.THRESH_BINARY)[1], 1


def stub_components(sm, scale: int, taken: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The left mask's 8-connected components of :data:`MIN_AREA_PX` ... :data:`MAX_AREA_PX` px that hold no
    taken point, do not touch the image's border and may pass the stub's radius test, in the raster order of
    their first pixels: (rows, cols) of each one's pixels, in raster order.

    Searched from the block mask (:func:`_block`): its components free of taken points and their cells
    holding at least :func:`min_cell_px` branch pixels; the full mask's components holding that many pixels
    of one of those cells are filled in a window one cell beyond the block component (grown while one
    reaches its edge): :func:`kernels_stubs.stub_pixels`. A component joined to a taken one in the block
    mask (within about a cell of it) is not searched.

    Parameters
    ----------
    sm : matching.StereoMasks
        The left mask ``left_mask`` and, optionally, the block mask ``left_block``.
    scale : int
        Pixels per cell of ``sm.left_block`` (the skeleton graph's scale).
    taken : ndarray (N, 2)
        Points (x, y) px of matched pieces and placed features (rounded half to even).
    """
    left = sm.left_mask
    block, s = _block(sm, scale)
    n, labels = cv2.connectedComponents(block, connectivity=8)
    taken = np.ascontiguousarray(taken, np.float64).reshape(-1, 2)
    pixels, starts = kernels_stubs.stub_pixels(labels, n, left, s, taken, min_cell_px(s), int(np.ceil(MIN_AREA_PX)),
                                               int(MAX_AREA_PX))
    if len(starts) < 2:
        return []
    first = pixels[starts[:-1]]
    order = np.lexsort((first[:, 1], first[:, 0])).tolist()
    starts = starts.tolist()
    return [(pixels[starts[k]:starts[k + 1], 0], pixels[starts[k]:starts[k + 1], 1]) for k in order]


def _walk_end(mask: np.ndarray, start: np.ndarray, out: np.ndarray, reach_px: float) -> np.ndarray | None:
    """Where the line from ``start`` along ``out`` leaves ``mask`` (>= 128), px (x, y): the last sample
    inside plus half a step; None if it does not leave it within ``reach_px`` or leaves the image
    (:func:`kernels_stubs.walk_end`)."""
    ok, x, y = kernels_stubs.walk_end(mask, float(start[0]), float(start[1]), float(out[0]), float(out[1]),
                                      float(reach_px), STEP_PX)
    return np.array([x, y]) if ok else None


def stub_tips(b, taken: np.ndarray) -> list[tuple[float, float, float, float]]:
    """Tips (u, v, d, radius) px of the left mask's small isolated stubs (module docstring).

    Parameters
    ----------
    b : ends.EndPlacer
        The placer of the graph (its masks ``sm``, mask runs and the tips' disparity readings).
    taken : ndarray (N, 2)
        Points (x, y) px of matched pieces and placed features: a component holding any is not a stub's.

    Returns
    -------
    list of (u, v, d, radius_px)
        The tip's place on its cap's centre in the rectified left image, its disparity and the cap's radius.
    """
    sm = b.sm
    left = sm.left_mask
    found = []
    for ys, xs in stub_components(sm, b.g.scale, taken):
        x0, y0 = int(xs.min()), int(ys.min())
        x1, y1 = int(xs.max()), int(ys.max())
        if sm.valid_left is not None and not sm.valid_left[ys, xs].all():
            continue
        crop = np.zeros((y1 - y0 + 3, x1 - x0 + 3), np.uint8)
        crop[ys - y0 + 1, xs - x0 + 1] = 1
        r = float(cv2.distanceTransform(crop, cv2.DIST_L2, 5).max()) - 0.5
        if r < MIN_RADIUS_PX:
            continue
        pts = np.column_stack([xs, ys]).astype(float)
        mean = pts.mean(axis=0)
        evals, evecs = np.linalg.eigh(np.cov((pts - mean).T))
        axis = evecs[:, 1]
        along = (pts - mean) @ axis
        across = (pts - mean) @ np.array([-axis[1], axis[0]])
        if np.ptp(along) + 1.0 < MIN_LENGTH_RADII * r or np.abs(across).max() > r + MAX_OFF_AXIS_PX:
            continue
        ends = []
        for out in (axis, -axis):
            e = _walk_end(left, mean, out, np.ptp(along) + 2 * r + 4)
            if e is None:
                break
            ends.append((e, out, r))
        if len(ends) < 2:
            continue
        shapes, offsets = cap_shapes_offsets(left, ends)
        round_ = [reads_round(s) for s in shapes]          # (an end that cannot be read: round)
        if sum(round_) != 1:
            continue
        i = round_.index(True)
        uv_edge, out, _ = ends[i]
        d = cap_disparity(sm, uv_edge - r * out, max(4, int(round(2 * r))), out, MIN_FIT_MARGIN)
        if d is None:
            continue
        # the right view's piece ends there too (an occluder's edge, at another depth, would not)
        e_r = _walk_end(sm.right_mask, mean - np.array([d, 0.0]), out, np.ptp(along) + 2 * r + 4)
        if e_r is None or abs(float((e_r + np.array([d, 0.0]) - uv_edge) @ out)) > END_SHIFT_PX:
            continue
        # the cap's outline read as the pieces' tips are (tipends.TipPlacing): a steep stub's rows
        # across its cap, a flat stub's row run ends; the mask fit's disparity stays where they read nothing
        steep = np.degrees(np.arctan2(abs(out[1]), abs(out[0]))) >= b.cfg.max_horizontal_deg
        if steep:
            vv = pts[:, 1]
            c = BranchCurve(-1, True, (float(vv.min()), float(vv.max())),
                            Poly.fit(vv, mean[0] + (vv - mean[1]) * axis[0] / axis[1], 1), Poly.constant(d), r,
                            len(pts), (0.0, 0.0))
            d_read = b._cap_disparity(c, float(uv_edge[1]), uv_edge, out, float(np.sign(out[1])), d, r)
        else:
            d_read = b._end_disparity(uv_edge, out, d, r)
        if d_read is not None and np.isfinite(d_read) and abs(d_read - d) <= 2.0:
            d = float(d_read)
        # something at the stub's depth or nearer just beyond the cap (a leaf's or an apple's edge
        # ending it): not a tip (the probe of tipends.TipPlacing.tips)
        half = max(4, int(round(r)))
        probe = uv_edge + out * (half * (abs(out[0]) + abs(out[1])) + 2)
        if nearer_in_front(sm.left_gray, sm.right_gray, probe[None], np.array([d]), np.array([half]),
                           sm.d_range_px[1]) and occluder_confirmed(sm, uv_edge, out, d, half):
            continue
        centre = cap_centre(shapes[i], float(offsets[i]), r)
        if centre is None:
            continue
        back, across_px, rho = centre
        baseline = getattr(sm, "baseline_mm", None)
        if baseline is not None and d > sm.offset_px and rho * baseline / (d - sm.offset_px) > MAX_RADIUS_MM:
            continue                                # (the cap's radius in mm at the tip's depth)
        normal = np.array([-out[1], out[0]])
        u, v = uv_edge - out * back + normal * across_px
        found.append((float(u), float(v), float(d), float(rho)))
    return found
