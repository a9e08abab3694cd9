"""The skeleton as a graph: nodes (endpoints, merged junctions) joined by pixel segments.

Skan-like and vectorised: node pixels are classified by neighbour count (1: endpoint,
>= 3: junction, 8-connected junction pixels merged into one node), the remaining path
pixels fall apart into connected components, one per segment, and segments are joined
to the nodes their pixels touch.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from appliance.localize import kernels_graph, kernels_points
from appliance.localize.skeleton import (
    Skeleton,
    binary,
    neighbour_tables,
)

ENDPOINT, JOINT, JUNCTION = 1, 2, 3


@dataclass(frozen=True, eq=False)
class SkeletonGraph:
    """Nodes and segments of a skeleton.

    Coordinates ``*_yx`` are skeleton pixels (row, col) at the skeleton's resolution;
    :meth:`to_full` converts to full-resolution (x, y).

    Attributes
    ----------
    shape : (int, int)
        Skeleton image shape.
    scale : int
        Full-resolution pixels per skeleton pixel.
    node_yx : ndarray, shape (K, 2), float
        Node positions (junction clusters: centroid).
    node_kind : ndarray, shape (K,), int
        ENDPOINT (1 neighbour), JUNCTION (>= 3) or JOINT (an endpoint joined by a bridge).
    node_pixels : list of ndarray (n, 2) int
        The pixels of each node.
    seg_nodes : ndarray, shape (S, 2), int
        Node index at each end of each segment, -1 where there is none (closed loop).
    seg_yx : list of ndarray (n, 2) int
        The pixels of each segment (unordered; empty for two adjacent nodes).
    seg_length_px : ndarray, shape (S,)
        Length along the pixel path, full-resolution px.
    seg_recovered : ndarray, shape (S,), bool
        Segment bridged across an occlusion rather than seen.
    """

    shape: tuple[int, int]
    scale: int
    node_yx: np.ndarray
    node_kind: np.ndarray
    node_pixels: list
    seg_nodes: np.ndarray
    seg_yx: list
    seg_length_px: np.ndarray
    seg_recovered: np.ndarray = field(default=None)

    def __post_init__(self):
        if self.seg_recovered is None:
            object.__setattr__(self, "seg_recovered", np.zeros(len(self.seg_yx), bool))

    @property
    def node_degree(self) -> np.ndarray:
        """Number of segment ends at each node, shape (K,)."""
        ends = self.seg_nodes[self.seg_nodes >= 0]
        return np.bincount(ends, minlength=len(self.node_kind))

    def to_full(self, yx: np.ndarray) -> np.ndarray:
        """Skeleton (row, col) -> full-resolution (x, y), shape (N, 2) float."""
        a = np.asarray(yx)
        if a.dtype == np.int64 or a.dtype == np.float64:     # (compiled: the same values, no temporaries)
            return kernels_points.skeleton_to_full(np.ascontiguousarray(a.reshape(-1, 2)), float(self.scale))
        yx = np.asarray(yx, np.float64).reshape(-1, 2)
        return (yx[:, ::-1] + 0.5) * self.scale - 0.5

    def image(self) -> np.ndarray:
        """The skeleton pixels of all nodes and seen segments, uint8 0/1."""
        img = np.zeros(self.shape, np.uint8)
        for yx in [p for p in self.node_pixels] + [p for p, r in zip(self.seg_yx, self.seg_recovered) if not r]:
            if len(yx):
                img[yx[:, 0], yx[:, 1]] = 1
        return img

    def with_segments(self, nodes: np.ndarray, pixels: list, lengths_px: np.ndarray, joints: np.ndarray) -> SkeletonGraph:
        """A copy with extra recovered segments, and the nodes ``joints`` turned into JOINTs."""
        kind = self.node_kind.copy()
        kind[np.asarray(joints, int)] = JOINT
        return replace(
            self, node_kind=kind,
            seg_nodes=np.vstack([self.seg_nodes, np.asarray(nodes, int).reshape(-1, 2)]),
            seg_yx=list(self.seg_yx) + list(pixels),
            seg_length_px=np.concatenate([self.seg_length_px, np.asarray(lengths_px, float)]),
            seg_recovered=np.concatenate([self.seg_recovered, np.ones(len(pixels), bool)]),
        )


def _group(labels: np.ndarray, yx: np.ndarray, n: int) -> list:
    """Pixels (N, 2) grouped by their label 1..n (row-major order kept), as a list of n arrays (the numpy
    graph of tests/localize/test_kernels.py; build_graph groups them compiled)."""
    order = np.argsort(labels, kind="stable")
    counts = np.bincount(labels, minlength=n + 1)[1:]
    if not n:
        return []
    srt, ends = yx[order], np.cumsum(counts).tolist()       # (slices: np.split's arrays, without its overhead)
    return [srt[a:b] for a, b in zip([0] + ends[:-1], ends)]


def build_graph(skel: Skeleton) -> SkeletonGraph:
    """The graph of a skeleton (see module docstring); works at the skeleton pixels only (compiled in
    one call: :func:`kernels_graph.graph_arrays`, around :func:`kernels_graph.graph_core`, whose labels are
    ``cv2.connectedComponents``' own)."""
    image = np.asarray(skel.image)
    if image.dtype != np.uint8:
        image = binary(image)
    h, w = image.shape
    if w % 8 or not image.flags.c_contiguous:               # (rows of whole 8-pixel words)
        padded = np.zeros((h, -(-w // 8) * 8), np.uint8)
        padded[:, :w] = image
        image = padded
    count, _, _ = neighbour_tables()
    node_px, node_start, node_yx, n_j, seg_px, seg_start, seg_nodes, length = kernels_graph.graph_arrays(
        image, image.view(np.uint64), w, count, skel.scale)
    ns, ss = node_start.tolist(), seg_start.tolist()
    node_pixels = [node_px[a:b] for a, b in zip(ns[:-1], ns[1:])]
    seg_yx = [seg_px[a:b] for a, b in zip(ss[:-1], ss[1:])]
    node_kind = np.full(len(node_yx), ENDPOINT)
    node_kind[:n_j] = JUNCTION
    return SkeletonGraph((h, w), skel.scale, node_yx, node_kind, node_pixels, seg_nodes, seg_yx, length)
