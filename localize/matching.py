"""What a matcher returns: features and branch pieces in rectified (u, v, disparity)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from appliance.localize.radius import RadiusMap


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


@dataclass(frozen=True, eq=False)
class StereoMasks:
    """The rectified pair as the dense matcher needs it.

    Attributes
    ----------
    left_mask, right_mask : ndarray (H, W) uint8
        Branch coverage 0-255 (binary masks remapped with linear interpolation); branch
        where >= 128.
    left_gray, right_gray : ndarray (H, W) uint8
        Rectified grey images.
    radius_map : RadiusMap
        Left mask's radius map (:func:`radius.ridge_radius_map`).
    d_range_px : (float, float)
        Disparities of the working range.
    f_px, offset_px : float
        Rectified focal length and principal-point difference ``cx_left - cx_right``.
    valid_left, valid_right : ndarray (H, W) bool, optional
        Where each rectified image sees the scene; a branch end at its edge leaves the view.
    cx_px : float, optional
        The left rectified view's principal-point column (the right's: ``cx_px - offset_px``).
    baseline_mm : float, optional
        The rig's baseline (a size in mm at disparity d px: ``size_px * baseline_mm / (d - offset_px)``).
    left_block : ndarray (H / s, W / s) uint8, optional
        The block mask the left skeleton thinned (0/255, ``s`` = the skeleton graph's scale): where the
        tips of short isolated stubs are looked for (:func:`stubtips.stub_components`; without it the
        full left mask is labelled).
    """

    left_mask: np.ndarray
    right_mask: np.ndarray
    left_gray: np.ndarray
    right_gray: np.ndarray
    radius_map: RadiusMap
    d_range_px: tuple[float, float]
    f_px: float
    offset_px: float = 0.0
    valid_left: np.ndarray | None = None
    valid_right: np.ndarray | None = None
    cx_px: float | None = None
    left_block: np.ndarray | None = None
    baseline_mm: float | None = None
