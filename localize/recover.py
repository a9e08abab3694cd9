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

    Ends are listed segment by segment; all ends are fitted at once (principal axis of each
    end's nearby segment pixels, from their 2x2 scatter matrix).
    """
    ends = graph.seg_nodes.ravel()
    seg = np.repeat(np.arange(len(graph.seg_nodes)), 2)
    is_end = ends >= 0
    is_end[is_end] = graph.node_kind[ends[is_end]] == ENDPOINT
    ends, seg = ends[is_end], seg[is_end]
    n_px = np.array([len(p) for p in graph.seg_yx], int)
    if len(ends) == 0 or n_px[seg].sum() == 0:
        return EndGeometry(np.zeros(0, int), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, int))
    all_px = graph.to_full(np.concatenate([p for p in graph.seg_yx if len(p)]))
    first = np.r_[0, np.cumsum(n_px)[:-1]]
    # every (end, pixel of its segment) pair
    owner = np.repeat(np.arange(len(ends)), n_px[seg])
    at = np.arange(len(owner)) - np.repeat(np.cumsum(n_px[seg]) - n_px[seg], n_px[seg]) + first[seg][owner]
    p = graph.to_full(graph.node_yx[ends])
    pts = all_px[at]
    near = np.hypot(*(pts - p[owner]).T) <= reach_px
    owner, pts = owner[near], pts[near]
    count = np.bincount(owner, minlength=len(ends))
    c = np.column_stack([np.bincount(owner, pts[:, k], len(ends)) for k in (0, 1)]) / np.maximum(count, 1)[:, None]
    d = pts - c[owner]
    sxx, sxy, syy = (np.bincount(owner, u * v, len(ends)) for u, v in ((d[:, 0], d[:, 0]), (d[:, 0], d[:, 1]),
                                                                        (d[:, 1], d[:, 1])))
    big = (sxx + syy) / 2 + np.hypot((sxx - syy) / 2, sxy)        # larger eigenvalue
    axis = np.where((sxx >= syy)[:, None], np.column_stack([big - syy, sxy]), np.column_stack([sxy, big - sxx]))
    axis /= np.maximum(np.hypot(axis[:, 0], axis[:, 1]), 1e-300)[:, None]
    axis *= np.where(np.einsum("ij,ij->i", axis, p - c) >= 0, 1.0, -1.0)[:, None]
    ok = count >= 2
    xy = p[ok]
    return EndGeometry(ends[ok], xy, axis[ok], radius_at(radius_map, xy), seg[ok])


def _line_pixels(graph: SkeletonGraph, a_xy: np.ndarray, b_xy: np.ndarray) -> np.ndarray:
    """Skeleton pixels (row, col) of the straight line between two full-resolution points."""
    pa, pb = ((np.asarray(p) + 0.5) / graph.scale - 0.5 for p in (a_xy, b_xy))
    n = int(np.ceil(np.abs(pb - pa).max())) + 1
    t = np.linspace(0, 1, n)[:, None]
    pts = np.rint(pa + t * (pb - pa)).astype(int)[:, ::-1]
    srt = pts[np.lexsort((pts[:, 1], pts[:, 0]))]         # np.unique(pts, axis=0), without its overhead
    return srt[np.r_[True, (srt[1:] != srt[:-1]).any(1)]]


def _bridge(graph: SkeletonGraph, ends: EndGeometry, pairs: list[tuple[int, int]]) -> SkeletonGraph:
    if not pairs:
        return graph
    nodes = [(ends.node[i], ends.node[j]) for i, j in pairs]
    pixels = [_line_pixels(graph, ends.xy_px[i], ends.xy_px[j]) for i, j in pairs]
    lengths = [float(np.hypot(*(ends.xy_px[i] - ends.xy_px[j]))) for i, j in pairs]
    return graph.with_segments(np.array(nodes), pixels, np.array(lengths), np.array(nodes).ravel())


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
    gap = ends.xy_px[None, :, :] - ends.xy_px[:, None, :]          # i -> j
    dist = np.hypot(gap[..., 0], gap[..., 1])
    unit = gap / np.maximum(dist, 1e-9)[..., None]
    cos_i = np.einsum("ik,ijk->ij", ends.dir, unit)
    cos_j = -np.einsum("jk,ijk->ij", ends.dir, unit)
    r = np.maximum(ends.radius_px, 0.5)
    ratio = np.maximum(r[:, None], r[None, :]) / np.minimum(r[:, None], r[None, :])
    cos_max = np.cos(np.radians(cfg.max_angle_deg))
    ok = (cos_i >= cos_max) & (cos_j >= cos_max) & (dist <= cfg.max_gap_px) & (ratio <= cfg.max_radius_ratio)
    ok &= ends.segment[:, None] != ends.segment[None, :]
    ok = np.triu(ok, 1)
    cost = (np.arccos(np.clip(cos_i, -1, 1)) + np.arccos(np.clip(cos_j, -1, 1))) + dist / max(cfg.max_gap_px, 1)
    used, pairs = set(), []
    cand = sorted(zip(cost[ok], *np.nonzero(ok)))
    # the long gaps' occluder cover, for all candidates at once (one occluder call)
    long_gap = [(i, j) for _, i, j in cand if dist[i, j] > 4 * (r[i] + r[j]) / 2]
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
