"""OpenCV StereoSGBM on the rectified pair: the dense baseline the benchmarks compare with."""

from __future__ import annotations

import cv2
import numpy as np


def sgbm_matcher(d_range_px: tuple[float, float], block_px: int = 5) -> cv2.StereoSGBM:
    """SGBM_3WAY covering the disparity range (min rounded down, count up to a multiple of 16)."""
    dmin = int(np.floor(d_range_px[0]))
    num = int(np.ceil((d_range_px[1] - dmin + 1) / 16.0)) * 16
    return cv2.StereoSGBM_create(
        minDisparity=dmin, numDisparities=num, blockSize=block_px,
        P1=8 * 3 * block_px ** 2, P2=32 * 3 * block_px ** 2, disp12MaxDiff=1, uniquenessRatio=10,
        speckleWindowSize=100, speckleRange=2, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)


def sgbm_disparity(left_rect: np.ndarray, right_rect: np.ndarray, d_range_px: tuple[float, float]) -> np.ndarray:
    """Disparity map (H, W) float32 px of a rectified pair; NaN where SGBM found none."""
    disp = sgbm_matcher(d_range_px).compute(left_rect, right_rect).astype(np.float32) / 16.0
    dmin = np.floor(d_range_px[0])
    disp[disp < dmin] = np.nan
    return disp
