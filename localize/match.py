"""The paper's feature matching: skeleton endpoints and forks matched between the views.

Constraints (paper): the epipolar line (same rectified row within ``row_tolerance_px``),
the disparity range of the working range, the same number of branches at the point
(``require_same_degree``), uniqueness (mutual best) and ordering along the row. A piece
between two matched features takes their disparities, linearly along it.
"""

from __future__ import annotations

import numpy as np
from appliance.config.schema import MatchConfig
from appliance.localize.graph import ENDPOINT, JOINT, JUNCTION, SkeletonGraph
from appliance.localize.matching import FeatureUVD, Matching, PieceUVD
from appliance.localize.radius import radius_at, segment_radius


def _features(graph: SkeletonGraph) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Feature nodes (endpoints and junctions), their full-resolution (x, y) and degree."""
    nodes = np.flatnonzero(np.isin(graph.node_kind, (ENDPOINT, JUNCTION)))
    return nodes, graph.to_full(graph.node_yx[nodes]), graph.node_degree[nodes]


def match_pairs(xy_l, deg_l, r_l, xy_r, deg_r, r_r, d_range_px, cfg: MatchConfig) -> list[tuple[int, int]]:
    """Index pairs (left, right) of matched features under the paper's constraints."""
    if len(xy_l) == 0 or len(xy_r) == 0:
        return []
    dy = np.abs(xy_l[:, None, 1] - xy_r[None, :, 1])
    d = xy_l[:, None, 0] - xy_r[None, :, 0]
    ok = (dy <= cfg.row_tolerance_px) & (d >= d_range_px[0]) & (d <= d_range_px[1])
    if cfg.require_same_degree:
        ok &= deg_l[:, None] == deg_r[None, :]
    cost = np.where(ok, dy + 0.25 * np.abs(r_l[:, None] - r_r[None, :]), np.inf)
    best_r = np.argmin(cost, axis=1)
    best_l = np.argmin(cost, axis=0)
    pairs = [(i, j) for i, j in enumerate(best_r) if np.isfinite(cost[i, j]) and best_l[j] == i]
    # ordering along the row: drop the match with most order violations until none is left
    while len(pairs) > 1:
        p = np.array(pairs)
        a, b = xy_l[p[:, 0]], xy_r[p[:, 1]]
        same_row = np.abs(a[:, None, 1] - a[None, :, 1]) <= 2 * cfg.row_tolerance_px
        flipped = np.sign(a[:, None, 0] - a[None, :, 0]) * np.sign(b[:, None, 0] - b[None, :, 0]) < 0
        bad = (same_row & flipped).sum(1)
        if bad.max() == 0:
            break
        pairs.pop(int(np.argmax(bad)))
    return pairs


def match_features(left: SkeletonGraph, right: SkeletonGraph, radius_l: np.ndarray, radius_r: np.ndarray,
                   d_range_px: tuple[float, float], cfg: MatchConfig) -> Matching:
    """The paper's variant: features matched, pieces interpolated between them."""
    nl, xy_l, deg_l = _features(left)
    nr, xy_r, deg_r = _features(right)
    r_l, r_r = radius_at(radius_l, xy_l), radius_at(radius_r, xy_r)
    pairs = match_pairs(xy_l, deg_l, r_l, xy_r, deg_r, r_r, d_range_px, cfg)
    uvd = {}
    features = []
    for i, j in pairs:
        node = int(nl[i])
        d = float(xy_l[i, 0] - xy_r[j, 0])
        uvd[node] = np.array([xy_l[i, 0], xy_l[i, 1], d])
        kind = "endpoint" if left.node_kind[node] == ENDPOINT else "bifurcation"
        features.append(FeatureUVD(node, kind, float(xy_l[i, 0]), float(xy_l[i, 1]), d, float(r_l[i])))

    pieces = []
    seg_r = {}
    for s, (a, z) in enumerate(left.seg_nodes):
        if left.seg_recovered[s]:
            continue
        ends = [uvd.get(n) for n in (a, z)]
        known = [e for e in ends if e is not None]
        if not known or len(left.seg_yx[s]) == 0:
            continue
        pts = left.to_full(left.seg_yx[s])
        if len(known) == 2 and np.hypot(*(known[1][:2] - known[0][:2])) > 1:
            axis = known[1][:2] - known[0][:2]
            t = np.clip((pts - known[0][:2]) @ axis / (axis @ axis), 0, 1)
            order = np.argsort(t)
            d = known[0][2] + t[order] * (known[1][2] - known[0][2])
            pts = pts[order]
        else:
            ref = known[0][:2]
            pts = pts[np.argsort(np.hypot(*(pts - ref).T))]
            if ends[0] is None:  # samples run from node a to node z
                pts = pts[::-1]
            d = np.full(len(pts), known[0][2])
        step = max(1, len(pts) // 40)
        samples = np.column_stack([pts, d])[::step]
        seg_r[s] = segment_radius(radius_l, pts)
        parts = ([ends[0][None]] if ends[0] is not None else []) + [samples] + \
                ([ends[1][None]] if ends[1] is not None else [])
        pieces.append(PieceUVD(s, np.vstack(parts), seg_r[s], False, (int(a), int(z))))
    # joints (ends bridged by recovery) take the disparity of the piece they end
    for p in pieces:
        for k, node in enumerate(p.nodes):
            if node >= 0 and left.node_kind[node] == JOINT and node not in uvd:
                uvd[node] = p.uvd[0] if k == 0 else p.uvd[-1]
    for s in np.flatnonzero(left.seg_recovered):
        a, z = left.seg_nodes[s]
        if a in uvd and z in uvd:
            radii = [seg_r[t] for t in seg_r if a in left.seg_nodes[t] or z in left.seg_nodes[t]]
            pieces.append(PieceUVD(int(s), np.vstack([uvd[a], uvd[z]]), float(np.mean(radii)) if radii else np.nan,
                                   True, (int(a), int(z))))
    return Matching(features, pieces, {"left_features": len(nl), "right_features": len(nr), "matched": len(pairs)})
