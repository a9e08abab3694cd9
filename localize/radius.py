"""Branch radius from the distance transform of the mask."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from appliance.localize import kernels_points, kernels_front
from appliance.localize.skeleton import binary

# masks with at most this share of non-zero pixels get :func:`kernels_front.distance_near` (~0.06
# against ~0.4 ms for a 320x240 branch mask); fuller ones, whose pixels lie far from a zero, OpenCV's
NEAR_MAX_SHARE = 0.5


@dataclass(frozen=True, eq=False)
class RadiusMap:
    """Radius of the branch around each pixel of a (possibly downscaled) mask.

    Attributes
    ----------
    image : ndarray (H/scale, W/scale) float32
        Radius, full-resolution px.
    scale : int
        Full-resolution pixels per map pixel.
    """

    image: np.ndarray
    scale: int = 1


def ridge_radius_map(mask: np.ndarray, window_px: int = 1, scale: int = 1) -> RadiusMap:
    """Radius of the branch around each pixel (full-resolution px).

    The distance transform (L2, precise) less half a pixel (the mask boundary is half
    way between a branch pixel and a background pixel), max-filtered over
    ``window_px`` so points a little off the ridge (a coarse skeleton) read the ridge.
    ``mask`` may be a ``scale`` times smaller mask (then the radius is only good to
    about ``scale / 2`` px). The distances are those of OpenCV's precise transform
    (``DIST_MASK_PRECISE``: exact, up to the root's last bit), computed near the branches only
    (:func:`kernels_front.distance_near`) on mostly empty masks.
    """
    m = binary(mask)
    if cv2.countNonZero(m) <= NEAR_MAX_SHARE * m.size:
        dt = kernels_front.distance_near(m, np.empty(m.shape, np.float32))
    else:
        dt = cv2.distanceTransform(m, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    if window_px > 1:
        dt = cv2.dilate(dt, np.ones((window_px, window_px), np.uint8))
    r = cv2.max(cv2.subtract(dt, 0.5), 0.0)          # in OpenCV: one pass each at full size
    if scale != 1:
        r *= np.float32(scale)
    return RadiusMap(r, scale)


def radius_at(radius_map: RadiusMap | np.ndarray, xy_px: np.ndarray) -> np.ndarray:
    """Radius at full-resolution points ``xy_px`` (N, 2) (x, y), nearest map pixel; shape (N,)."""
    if not isinstance(radius_map, RadiusMap):
        radius_map = RadiusMap(np.asarray(radius_map))
    img, s = radius_map.image, radius_map.scale
    xy_f = np.asarray(xy_px, float).reshape(-1, 2)
    if img.dtype == np.float32 and img.ndim == 2 and img.flags.c_contiguous:      # (compiled: the same values)
        r = kernels_points.radius_lookup(img, float(s), np.ascontiguousarray(xy_f))
        if r is not None:
            return r
    xy = np.rint((xy_f + 0.5) / s - 0.5).astype(int)
    h, w = img.shape
    x = np.minimum(np.maximum(xy[:, 0], 0), w - 1)        # (np.clip of ints: the same, fewer checks)
    y = np.minimum(np.maximum(xy[:, 1], 0), h - 1)
    return img[y, x].astype(float)


def segment_radius(radius_map: RadiusMap | np.ndarray, xy_px: np.ndarray) -> float:
    """The paper's segment radius: mean of the radius at its skeleton points, px (NaN if none)."""
    r = radius_at(radius_map, xy_px)
    return float(r.mean()) if len(r) else float("nan")
