"""The paper's removal of false branches (spurs), repeated until stable."""

from __future__ import annotations

import numpy as np
from collections.abc import Callable

from appliance.localize import kernels_graph
from appliance.localize.graph import ENDPOINT, SkeletonGraph, build_graph
from appliance.localize.radius import RadiusMap, radius_at
from appliance.localize.skeleton import Skeleton, remove_corners

_NO_RADIUS = np.zeros((1, 1), np.float32)
OCCLUDED_FAN_DEG = (-30.0, 0.0, 30.0)   # directions asked about past a spur's end (from its own direction) ...
OCCLUDED_STEPS_PX = (2.0, 6.0)          # ... at these distances past the branch's radius plus a skeleton pixel
OCCLUDED_MIN = 3                        # ... of which at least this many on an occluder: the branch runs behind it
OCCLUDED_RADIUS_FACTOR = 1.0            # a spur shorter than this x the radius at its junction goes all the same (a bump)


def occluded_ends(graph: SkeletonGraph, ids: np.ndarray, occluded: Callable[[np.ndarray], np.ndarray],
                  radius_map: RadiusMap) -> np.ndarray:
    """Which spurs ``ids`` end at an occluder: of the points past the spur's endpoint, in its direction (junction
    to end) turned by ``OCCLUDED_FAN_DEG``, at the branch's radius there plus a skeleton pixel plus
    ``OCCLUDED_STEPS_PX`` (full resolution; the skeleton's end lies about a radius inside the mask's), at least
    ``OCCLUDED_MIN`` lie on a leaf or an apple (``occluded``: full-resolution rectified (x, y) (N, 2) -> bool
    (N,), asked once for all spurs).

    A branch cut by a leaf leaves a short spur whose end abuts the leaf; a bump of a thick branch's outline
    ends on open background."""
    if len(ids) == 0:
        return np.zeros(0, bool)
    nodes = graph.seg_nodes[ids]
    first_end = graph.node_kind[np.maximum(nodes[:, 0], 0)] == ENDPOINT
    end = np.where(first_end, nodes[:, 0], nodes[:, 1])
    junction = np.where(first_end, nodes[:, 1], nodes[:, 0])
    xy = graph.to_full(graph.node_yx[end])
    v = xy - graph.to_full(graph.node_yx[junction])
    ang = np.arctan2(v[:, 1], v[:, 0])[:, None] + np.radians(OCCLUDED_FAN_DEG)[None, :]          # (n, fan)
    dist = (radius_at(radius_map, xy) + graph.scale)[:, None] + np.asarray(OCCLUDED_STEPS_PX)[None, :]   # (n, steps)
    pts = (xy[:, None, None, :] + dist[:, None, :, None] * np.stack([np.cos(ang), np.sin(ang)], -1)[:, :, None, :])
    pts = pts.reshape(-1, 2)
    h, w = graph.shape
    inside = (pts[:, 0] >= 0) & (pts[:, 1] >= 0) & (pts[:, 0] <= w * graph.scale - 1) & (pts[:, 1] <= h * graph.scale - 1)
    hit = np.zeros(len(pts), bool)
    if inside.any():
        hit[inside] = np.asarray(occluded(pts[inside]), bool)
    return hit.reshape(len(ids), -1).sum(1) >= OCCLUDED_MIN


def spur_ids(graph: SkeletonGraph, min_length_px: float, radius_factor: float = 0.0,
             radius_map: np.ndarray | None = None, keep_border: bool = False,
             occluded: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """Segments from an endpoint to a junction shorter than the threshold.

    The threshold is ``max(min_length_px, radius_factor * r)`` with ``r`` the radius at the
    junction (full-resolution px, from ``radius_map``): a bump of a thick branch's outline
    makes a spur about as long as the radius.

    With ``keep_border``, a spur whose endpoint lies within one skeleton pixel of the image's
    edge is kept when it is its junction's only such spur: a branch leaving the view just past
    a fork (its spur is short because the view cuts it), not a bump. Two such spurs at one
    junction are the two corners of a thick branch cut by the edge, and go.

    With ``occluded`` (see :func:`occluded_ends`), a spur only the radius rule removes (at least
    ``min_length_px`` long) is kept when its end abuts a leaf or an apple: a branch cut by it.
    """
    if len(graph.node_kind) == 0 or len(graph.seg_nodes) == 0:     # (loops only: no spur)
        return np.zeros(0, int)
    use_radius = radius_factor > 0 and radius_map is not None
    rmap = radius_map if isinstance(radius_map, RadiusMap) or not use_radius else RadiusMap(np.asarray(radius_map))
    h, w = graph.shape
    spur = kernels_graph.spur_mask(
        np.ascontiguousarray(graph.seg_nodes, np.int64), np.ascontiguousarray(graph.node_kind, np.int64),
        np.ascontiguousarray(graph.node_yx, np.float64), np.ascontiguousarray(graph.seg_length_px, np.float64), h, w,
        float(min_length_px), float(radius_factor) if use_radius else 0.0,
        np.ascontiguousarray(rmap.image) if use_radius else _NO_RADIUS, rmap.scale if use_radius else 1,
        int(graph.scale), bool(keep_border))
    if occluded is not None and use_radius:
        short = kernels_graph.spur_mask(
            np.ascontiguousarray(graph.seg_nodes, np.int64), np.ascontiguousarray(graph.node_kind, np.int64),
            np.ascontiguousarray(graph.node_yx, np.float64), np.ascontiguousarray(graph.seg_length_px, np.float64),
            h, w, float(min_length_px), min(OCCLUDED_RADIUS_FACTOR, float(radius_factor)), np.ascontiguousarray(rmap.image),
            rmap.scale, int(graph.scale), bool(keep_border))
        by_radius = np.flatnonzero(spur & ~short)
        spur[by_radius[occluded_ends(graph, by_radius, occluded, rmap)]] = False
    return np.flatnonzero(spur)


def prune(skel: Skeleton, min_length_px: float, radius_factor: float = 0.0,
          radius_map: np.ndarray | None = None, max_rounds: int = 20,
          keep_border: bool = False, occluded: Callable[[np.ndarray], np.ndarray] | None = None
          ) -> tuple[Skeleton, SkeletonGraph]:
    """Remove spurs (see :func:`spur_ids`) and rebuild, until no spur is left.

    Returns
    -------
    (Skeleton, SkeletonGraph)
        The pruned skeleton and its graph.
    """
    graph = build_graph(skel)
    for _ in range(max_rounds):
        ids = spur_ids(graph, min_length_px, radius_factor, radius_map, keep_border, occluded)
        if len(ids) == 0:
            break
        img = skel.image.copy()
        for i in ids:
            yx = graph.seg_yx[i]
            img[yx[:, 0], yx[:, 1]] = 0
            for node in graph.seg_nodes[i]:
                if node >= 0 and graph.node_kind[node] == ENDPOINT:
                    p = graph.node_pixels[node]
                    img[p[:, 0], p[:, 1]] = 0
        skel = Skeleton(remove_corners(img), skel.scale, skel.mask)
        graph = build_graph(skel)
    return skel, graph
