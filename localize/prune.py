"""The paper's removal of false branches (spurs), repeated until stable."""

from __future__ import annotations

import numpy as np
from appliance.localize.graph import ENDPOINT, JUNCTION, SkeletonGraph, build_graph
from appliance.localize.radius import radius_at
from appliance.localize.skeleton import Skeleton, remove_corners


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
    ends = graph.seg_nodes
    if len(graph.node_kind) == 0:                   # (loops only: no spur)
        return np.zeros(0, int)
    kind = np.where(ends >= 0, graph.node_kind[np.maximum(ends, 0)], 0)
    spur = ((kind[:, 0] == ENDPOINT) & (kind[:, 1] == JUNCTION)) | ((kind[:, 1] == ENDPOINT) & (kind[:, 0] == JUNCTION))
    if not spur.any():
        return np.zeros(0, int)
    junction = np.where(kind[:, 0] == JUNCTION, ends[:, 0], ends[:, 1])
    if keep_border:
        end = np.where(kind[:, 0] == ENDPOINT, ends[:, 0], ends[:, 1])
        y, x = graph.node_yx[np.maximum(end, 0)].T
        h, w = graph.shape
        out = spur & ((np.minimum(y, x) <= 1) | (y >= h - 2) | (x >= w - 2))
        n_out = np.bincount(junction[out], minlength=len(graph.node_kind))
        spur &= ~(out & (n_out[np.maximum(junction, 0)] == 1))
    limit = np.full(len(ends), float(min_length_px))
    if radius_factor > 0 and radius_map is not None:
        r = radius_at(radius_map, graph.to_full(graph.node_yx[np.maximum(junction, 0)]))
        limit = np.maximum(limit, radius_factor * r)
    return np.flatnonzero(spur & (graph.seg_length_px < limit))


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
