"""The paper's removal of false branches (spurs), repeated until stable."""

from __future__ import annotations

import numpy as np
from appliance.localize import kernels_graph
from appliance.localize.graph import ENDPOINT, SkeletonGraph, build_graph
from appliance.localize.radius import RadiusMap
from appliance.localize.skeleton import Skeleton, remove_corners

_NO_RADIUS = np.zeros((1, 1), np.float32)


def spur_ids(graph: SkeletonGraph, min_length_px: float, radius_factor: float = 0.0,
             radius_map: np.ndarray | None = None, keep_border: bool = False) -> np.ndarray:
    """Segments from an endpoint to a junction shorter than the threshold.

    The threshold is ``max(min_length_px, radius_factor * r)`` with ``r`` the radius at the
    junction (full-resolution px, from ``radius_map``): a bump of a thick branch's outline
    makes a spur about as long as the radius.

    With ``keep_border``, a spur whose endpoint lies within one skeleton pixel of the image's
    edge is kept when it is its junction's only such spur: a branch leaving the view just past
    a fork (its spur is short because the view cuts it), not a bump. Two such spurs at one
    junction are the two corners of a thick branch cut by the edge, and go.
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
    return np.flatnonzero(spur)


def prune(skel: Skeleton, min_length_px: float, radius_factor: float = 0.0,
          radius_map: np.ndarray | None = None, max_rounds: int = 20,
          keep_border: bool = False) -> tuple[Skeleton, SkeletonGraph]:
    """Remove spurs (see :func:`spur_ids`) and rebuild, until no spur is left.

    Returns
    -------
    (Skeleton, SkeletonGraph)
        The pruned skeleton and its graph.
    """
    graph = build_graph(skel)
    for _ in range(max_rounds):
        ids = spur_ids(graph, min_length_px, radius_factor, radius_map, keep_border)
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
