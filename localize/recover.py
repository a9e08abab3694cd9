"""Recovery of branches cut by leaves and apples: bridges between segment ends.

``hough`` (paper): straight lines of the skeleton found by the probabilistic Hough
transform and extended through the image, cut back to the gap between two skeleton ends
lying on one line.
``collinear`` (improved): two ends are bridged when each points at the other within
``max_angle_deg``, their radii are similar and the gap is short, or (for a gap longer than
four radii) at least half covered by an occluder.
Bridges become recovered segments of the graph; the ends they join become JOINT nodes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise

import cv2
import numpy as np
from appliance.config.schema import RecoverConfig
from appliance.localize import kernels_graph
from appliance.localize.graph import ENDPOINT, SkeletonGraph
from appliance.localize.radius import radius_at


@dataclass(frozen=True)
class EndGeometry:
    """Skeleton ends: node index, full-resolution position (x, y), outward unit direction, radius px."""

    node: np.ndarray     # (E,)
    xy_px: np.ndarray    # (E, 2)
    dir: np.ndarray      # (E, 2)
    radius_px: np.ndarray  # (E,)
    segment: np.ndarray  # (E,)


def end_geometry(graph: SkeletonGraph, radius_map: np.ndarray, reach_px: float = 20.0) -> EndGeometry:
    """Position, outward direction (line fit to the last ``reach_px`` of its segment) and radius of every endpoint.

    Ends are listed segment by segment; each end's fit is the principal axis of its nearby segment
    pixels, from their 2x2 scatter matrix (compiled: :func:`kernels_graph.end_fit`).
    """
    n_px = np.fromiter((len(p) for p in graph.seg_yx), np.int64, len(graph.seg_yx))
    if len(n_px) == 0 or n_px.sum() == 0:
        return EndGeometry(np.zeros(0, int), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, int))
    seg_px = np.ascontiguousarray(np.concatenate(graph.seg_yx), np.int64)
    seg_start = np.zeros(len(n_px) + 1, np.int64)
    np.cumsum(n_px, out=seg_start[1:])
    node, seg, xy, axis, count = kernels_graph.end_fit(
        np.ascontiguousarray(graph.seg_nodes, np.int64), graph.node_kind == ENDPOINT,
        np.ascontiguousarray(graph.node_yx, np.float64), seg_px, seg_start, float(graph.scale), float(reach_px))
    ok = count >= 2
    xy = xy[ok]
    return EndGeometry(node[ok], xy, axis[ok], radius_at(radius_map, xy), seg[ok])


def _line_pixels(graph: SkeletonGraph, a_xy: np.ndarray, b_xy: np.ndarray) -> np.ndarray:
    """Skeleton pixels (row, col) of the straight line between two full-resolution points, distinct and
    sorted (:func:`kernels_graph.line_pixels` of one line; :func:`_bridge` asks for all its lines at once)."""
    a, b = (np.asarray(p, np.float64).reshape(1, 2) for p in (a_xy, b_xy))
    return kernels_graph.line_pixels(a, b, float(graph.scale))[0]


def _bridge(graph: SkeletonGraph, ends: EndGeometry, pairs: list[tuple[int, int]]) -> SkeletonGraph:
    if not pairs:
        return graph
    i, j = np.array(pairs, np.int64).T
    nodes = np.column_stack([ends.node[i], ends.node[j]])
    a_xy, b_xy = ends.xy_px[i], ends.xy_px[j]
    px, start = kernels_graph.line_pixels(a_xy, b_xy, float(graph.scale))       # (_line_pixels' of each pair)
    st = start.tolist()
    pixels = [px[s:e] for s, e in zip(st[:-1], st[1:])]
    lengths = [float(np.hypot(*(a - b))) for a, b in zip(a_xy, b_xy)]
    return graph.with_segments(nodes, pixels, np.array(lengths), nodes.ravel())


def _covered_many(occluded: Callable[[np.ndarray], np.ndarray] | None, segments: list) -> list[float]:
    """Fraction of each segment (a, b) (full-resolution px) over occluder pixels (1 if unknown);
    the occluder asked once about all their points."""
    if occluded is None or not segments:
        return [1.0] * len(segments)
    a = np.array([s[0] for s in segments], np.float64).reshape(-1, 2)
    ab = np.array([s[1] for s in segments], np.float64).reshape(-1, 2) - a
    n = np.hypot(ab[:, 0], ab[:, 1]).astype(np.int64) + 2            # (int(): truncation)
    # each segment's np.linspace(0, 1, n) at once: k * (1 / (n - 1)), the last exactly 1
    owner = np.repeat(np.arange(len(n)), n)
    ends = np.cumsum(n)
    t = (np.arange(ends[-1]) - np.repeat(ends - n, n)).astype(np.float64) * (1.0 / (n - 1))[owner]
    t[ends - 1] = 1.0
    hit = occluded(a[owner] + t[:, None] * ab[owner])
    return (np.add.reduceat(np.asarray(hit, bool).astype(np.int64), ends - n) / n).tolist()


def recover_collinear(graph: SkeletonGraph, cfg: RecoverConfig, radius_map: np.ndarray,
                      occluded: Callable[[np.ndarray], np.ndarray] | None = None) -> SkeletonGraph:
    """Bridge pairs of ends that point at each other (see module docstring); greedy, best pairs first.

    ``occluded(xy)`` tells for full-resolution points (N, 2) whether an occluder (leaf,
    apple) is seen there; without it every gap counts as covered.
    """
    ends = end_geometry(graph, radius_map)
    if len(ends.node) < 2:
        return graph
    cos_max = np.cos(np.radians(cfg.max_angle_deg))
    i, j, cos_i, cos_j, dist = kernels_graph.bridge_pairs(          # (the pairs that qualify, i < j)
        ends.xy_px, ends.dir, np.ascontiguousarray(ends.radius_px, np.float64), ends.segment, float(cos_max),
        float(cfg.max_gap_px), float(cfg.max_radius_ratio))
    cost = (np.arccos(np.clip(cos_i, -1, 1)) + np.arccos(np.clip(cos_j, -1, 1))) + dist / max(cfg.max_gap_px, 1)
    used, pairs = set(), []
    cand = sorted(zip(cost.tolist(), i.tolist(), j.tolist()))
    r = np.maximum(ends.radius_px, 0.5).tolist()
    gap = dict(zip(zip(i.tolist(), j.tolist()), dist.tolist()))
    # the long gaps' occluder cover, for all candidates at once (one occluder call)
    long_gap = [(i, j) for _, i, j in cand if gap[i, j] > 4 * (r[i] + r[j]) / 2]
    cover = dict(zip(long_gap, _covered_many(occluded, [(ends.xy_px[i], ends.xy_px[j]) for i, j in long_gap])))
    for _, i, j in cand:
        if i in used or j in used:
            continue
        if cover.get((i, j), 1.0) < 0.5:
            continue
        used.update((i, j))
        pairs.append((int(i), int(j)))
    return _bridge(graph, ends, pairs)


def recover_hough(graph: SkeletonGraph, cfg: RecoverConfig, radius_map: np.ndarray) -> SkeletonGraph:
    """The paper's recovery: skeleton ends on one Hough line, with a gap between them, are joined."""
    ends = end_geometry(graph, radius_map)
    if len(ends.node) < 2:
        return graph
    s = graph.scale
    img = graph.image() * 255
    lines = cv2.HoughLinesP(img, 1, np.pi / 180, max(1, int(cfg.hough_threshold / s)),
                            minLineLength=cfg.hough_min_length_px / s, maxLineGap=cfg.max_gap_px / s)
    if lines is None:
        return graph
    used, pairs = set(), []
    for x1, y1, x2, y2 in lines.reshape(-1, 4):
        a, b = graph.to_full(np.array([[y1, x1], [y2, x2]]))
        length = np.hypot(*(b - a))
        if length < 1:
            continue
        u = (b - a) / length
        rel = ends.xy_px - a
        t = rel @ u
        off = np.abs(rel @ np.array([-u[1], u[0]]))
        on = np.flatnonzero(off <= 2.0 * s + 1)   # the line runs through the whole image (paper)
        on = on[np.argsort(t[on])]
        for i, j in pairwise(on):
            gap = t[j] - t[i]
            if (i in used or j in used or ends.segment[i] == ends.segment[j] or gap > cfg.max_gap_px
                    or np.dot(ends.dir[i], u) < 0 or np.dot(ends.dir[j], u) > 0):
                continue
            used.update((i, j))
            pairs.append((int(i), int(j)))
    return _bridge(graph, ends, pairs)


def recover(graph: SkeletonGraph, cfg: RecoverConfig, radius_map: np.ndarray,
            occluded: Callable[[np.ndarray], np.ndarray] | None = None) -> SkeletonGraph:
    """Dispatch on ``cfg.method``: none | hough | collinear."""
    if cfg.method == "hough":
        return recover_hough(graph, cfg, radius_map)
    if cfg.method == "collinear":
        return recover_collinear(graph, cfg, radius_map, occluded)
    return graph
