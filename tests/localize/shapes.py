"""Small constructed masks and a synthetic rectified rig for the localize tests."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.calibrate.model import StereoCalibration


def y_shape(size: int = 200) -> np.ndarray:
    """A thick stem with two arms: one fork, three tips (uint8 0/255)."""
    m = np.zeros((size, size), np.uint8)
    cv2.line(m, (100, 190), (100, 100), 255, 9)
    cv2.line(m, (100, 100), (40, 20), 255, 7)
    cv2.line(m, (100, 100), (160, 20), 255, 7)
    return m


def ideal_rig(width: int = 640, height: int = 480, f_px: float = 700.0, baseline_mm: float = 120.0):
    """A distortion-free, already rectified rig: rectification is the identity."""
    K = np.array([[f_px, 0, (width - 1) / 2], [0, f_px, (height - 1) / 2], [0, 0, 1]])
    return StereoCalibration.from_pose((width, height), K, np.zeros(5), K, np.zeros(5), np.eye(3),
                                       [-baseline_mm, 0.0, 0.0])


def branch_pair(calib: StereoCalibration, depth_mm: float, radius_px: float = 6.0,
                top=(300.0, 60.0), bottom=(260.0, 420.0), background: int = 40):
    """A rendered straight 'branch' at constant depth in both views, supersampled (anti-aliased edges).

    Returns (left BGR, right BGR, left mask, right mask, disparity px).
    """
    d = calib.f_px * calib.baseline_mm / depth_mm
    w, h = calib.image_size
    ss = 4
    out = []
    for shift in (0.0, d):
        big = np.full((h * ss, w * ss), background, np.uint8)
        p = tuple(int(round((c - (shift if k == 0 else 0) + 0.5) * ss - 0.5)) for k, c in enumerate(top))
        q = tuple(int(round((c - (shift if k == 0 else 0) + 0.5) * ss - 0.5)) for k, c in enumerate(bottom))
        cv2.line(big, p, q, 200, int(round(2 * radius_px * ss)))
        grey = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
        out.append(grey)
    imgs = [cv2.cvtColor(g, cv2.COLOR_GRAY2BGR) for g in out]
    masks = [((g.astype(int) - background) > (200 - background) / 2).astype(np.uint8) * 255 for g in out]
    return imgs[0], imgs[1], masks[0], masks[1], d
