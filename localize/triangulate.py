"""Rectified (u, v, disparity) -> 3D points in the left camera's unrectified optical frame."""

from __future__ import annotations

import numpy as np
from appliance.calibrate.model import StereoCalibration


def triangulate(u_px, v_px, d_px, calib: StereoCalibration) -> np.ndarray:
    """3D points of rectified left pixels with their disparities.

    Uses ``Q`` (rectified left frame), then rotates back by ``R1^T`` so the result is in
    the left camera's unrectified optical frame.

    Parameters
    ----------
    u_px, v_px, d_px : array_like, shape (N,)
        Rectified left column, row and disparity ``u_left - u_right`` (> 0), px.

    Returns
    -------
    ndarray, shape (N, 3)
        X, Y, Z in mm.
    """
    u, v, d = (np.asarray(a, np.float64).ravel() for a in (u_px, v_px, d_px))
    h = np.column_stack([u, v, d, np.ones_like(u)]) @ np.asarray(calib.Q, np.float64).T
    xyz_rect = h[:, :3] / h[:, 3:4]
    return xyz_rect @ np.asarray(calib.R1, np.float64)  # rows: R1^T @ p


def disparity_range_px(calib: StereoCalibration, working_range_mm: tuple[float, float]) -> tuple[float, float]:
    """Disparities (min, max) of depths (far, near) of the working range, px.

    Includes the rectified principal-point offset ``cx_left - cx_right`` (0 with
    CALIB_ZERO_DISPARITY).
    """
    near, far = working_range_mm
    fb = calib.f_px * calib.baseline_mm
    offset = float(calib.P1[0, 2] - calib.P2[0, 2])
    return fb / far + offset, fb / near + offset
