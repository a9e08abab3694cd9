"""Branch radius from the distance transform of the mask."""

from __future__ import annotations

import cv2
import numpy as np


def ridge_radius_map(mask: np.ndarray, window_px: int = 1) -> np.ndarray:
    """Radius of the branch around each pixel, px, shape (H, W) float32.

    The distance transform (L2, precise) less half a pixel (the mask boundary is half
    way between a branch pixel and a background pixel), max-filtered over
    ``window_px`` so points a little off the ridge (a coarse skeleton) read the ridge.
    """
    dt = cv2.distanceTransform((mask > 0).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    if window_px > 1:
        dt = cv2.dilate(dt, np.ones((window_px, window_px), np.uint8))
    return np.maximum(dt - 0.5, 0.0)


def radius_at(radius_map: np.ndarray, xy_px: np.ndarray) -> np.ndarray:
    """Radius map sampled at the nearest pixels of ``xy_px`` (N, 2) (x, y); shape (N,)."""
    xy = np.rint(np.asarray(xy_px, float).reshape(-1, 2)).astype(int)
    h, w = radius_map.shape
    x = np.clip(xy[:, 0], 0, w - 1)
    y = np.clip(xy[:, 1], 0, h - 1)
    return radius_map[y, x].astype(float)


def segment_radius(radius_map: np.ndarray, xy_px: np.ndarray) -> float:
    """The paper's segment radius: mean of the radius at its skeleton points, px (NaN if none)."""
    r = radius_at(radius_map, xy_px)
    return float(r.mean()) if len(r) else float("nan")
