"""What a matcher returns: features and branch pieces in rectified (u, v, disparity)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class FeatureUVD:
    """A matched feature: graph node, kind, rectified left (u, v), disparity d, radius (px)."""

    node: int
    kind: str
    u: float
    v: float
    d: float
    radius_px: float


@dataclass(frozen=True, eq=False)
class PieceUVD:
    """A matched branch piece: samples (N, 3) of (u, v, d) along its axis, radius px, flags."""

    segment: int
    uvd: np.ndarray
    radius_px: float
    recovered: bool
    nodes: tuple[int, int]


@dataclass(frozen=True, eq=False)
class Matching:
    """Everything matched in one pair (rectified frame)."""

    features: list = field(default_factory=list)
    pieces: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)
