"""How much of the pose space a set of board views covers (like ROS camera_calibration's bars).

A view is four numbers in 0..1: x and y (where the board is in the image), size (how much
of the image it fills) and skew (how far it is tilted). A new view is worth keeping only
when it is not close to a kept one; coverage of each number is its kept range over a target range.
"""

from __future__ import annotations

import numpy as np

PARAMS = ("x", "y", "size", "skew")
TARGET_RANGE = np.array([0.7, 0.7, 0.4, 0.5])   # ranges ROS camera_calibration asks for
MIN_DISTANCE = 0.2                               # L1 distance below which a view is "already seen"


def pose_params(corners_px: np.ndarray, cols: int, image_size: tuple[int, int]) -> np.ndarray:
    """x, y, size, skew of one board view, each in 0..1.

    Parameters
    ----------
    corners_px : ndarray, shape (cols*rows, 2)
        The board's corners in one image, row by row, px.
    cols : int
        Corners per board row.
    image_size : (int, int)
        (width, height), px.

    Returns
    -------
    ndarray, shape (4,)
    """
    w, h = image_size
    ul, ur, dr, dl = corners_px[0], corners_px[cols - 1], corners_px[-1], corners_px[-cols]
    a, b, c = ur - ul, dr - ur, dl - dr
    area = abs(_cross(a, b)) / 2 + abs(_cross(c, dl - ul)) / 2    # two triangles of the quadrilateral
    border = np.sqrt(area)
    mean = corners_px.mean(axis=0)
    x = np.clip((mean[0] - border / 2) / max(w - border, 1.0), 0, 1)
    y = np.clip((mean[1] - border / 2) / max(h - border, 1.0), 0, 1)
    size = np.sqrt(area / (w * h))
    cos = np.dot(-a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
    skew = min(1.0, 2 * abs(np.pi / 2 - np.arccos(np.clip(cos, -1, 1))))
    return np.array([x, y, size, skew])


def _cross(u: np.ndarray, v: np.ndarray) -> float:
    """z of the cross product of two 2D vectors."""
    return float(u[0] * v[1] - u[1] * v[0])


def adds_coverage(params: np.ndarray, kept: list[np.ndarray]) -> bool:
    """True when ``params`` is at least ``MIN_DISTANCE`` (L1) from every kept view's."""
    return all(np.abs(params - k).sum() >= MIN_DISTANCE for k in kept)


def coverage(kept: list[np.ndarray]) -> np.ndarray:
    """Progress of x, y, size, skew in 0..1: each one's kept range over its target range; shape (4,)."""
    if not kept:
        return np.zeros(4)
    p = np.asarray(kept)
    return np.minimum((p.max(axis=0) - p.min(axis=0)) / TARGET_RANGE, 1.0)
