"""How far a calibration is from a reference (true) rig: focal lengths, principal points, baseline, depth.

The rectified focal length ``f_px`` is a choice of the rectification (``stereoRectify`` with alpha = 0
scales so that every rectified pixel is valid, which depends on the lens distortion extrapolated to the
image corners), so it is not compared directly; what it is for — depth — is: true 3D points are imaged
through the reference rig and triangulated back through the calibration under test.
"""

from __future__ import annotations

import cv2
import numpy as np

from appliance.calibrate.model import StereoCalibration


def triangulate_mm(calib: StereoCalibration, left_px: np.ndarray, right_px: np.ndarray) -> np.ndarray:
    """3D points in the left camera's unrectified frame from matched unrectified pixels.

    Parameters
    ----------
    calib : StereoCalibration
    left_px, right_px : ndarray, shape (N, 2)
        The same points in the left and right (distorted) images, px.

    Returns
    -------
    ndarray, shape (N, 3), mm — rectified disparity, ``Q``, then the rectifying rotation undone.
    """
    rl = cv2.undistortPoints(left_px.reshape(-1, 1, 2).astype(np.float64), calib.K1, calib.D1,
                             R=calib.R1, P=calib.P1).reshape(-1, 2)
    rr = cv2.undistortPoints(right_px.reshape(-1, 1, 2).astype(np.float64), calib.K2, calib.D2,
                             R=calib.R2, P=calib.P2).reshape(-1, 2)
    h = np.column_stack([rl, rl[:, 0] - rr[:, 0], np.ones(len(rl))]) @ calib.Q.T
    rect = h[:, :3] / h[:, 3:]
    return rect @ calib.R1        # R1 maps unrectified -> rectified; its transpose maps back


def compare(calib: StereoCalibration, truth: StereoCalibration, z_mm=(500.0, 1000.0, 1500.0)) -> dict:
    """Errors of ``calib`` against ``truth``.

    Returns
    -------
    dict
        ``fx_pct``/``fy_pct`` (worst of the two cameras, signed, %), ``pp_px`` (worst principal point
        distance, px), ``baseline_pct`` (signed, %), ``f_rect_pct`` (rectified f, signed, %, for
        information), and ``depth_pct_at_<Z>`` (RMS relative depth error of a grid of points spanning
        the image at depth Z, %) for each ``z_mm``.
    """
    def worst(values):
        return float(max(values, key=abs))

    pct = lambda a, b: 100.0 * (a - b) / b  # noqa: E731
    out = {
        "fx_pct": worst([pct(calib.K1[0, 0], truth.K1[0, 0]), pct(calib.K2[0, 0], truth.K2[0, 0])]),
        "fy_pct": worst([pct(calib.K1[1, 1], truth.K1[1, 1]), pct(calib.K2[1, 1], truth.K2[1, 1])]),
        "pp_px": max(float(np.hypot(*(calib.K1[:2, 2] - truth.K1[:2, 2]))),
                     float(np.hypot(*(calib.K2[:2, 2] - truth.K2[:2, 2])))),
        "baseline_pct": pct(calib.baseline_mm, truth.baseline_mm),
        "f_rect_pct": pct(calib.f_px, truth.f_px),
    }
    w, h = truth.image_size
    u, v = np.meshgrid(np.linspace(0.1 * w, 0.9 * w, 9), np.linspace(0.1 * h, 0.9 * h, 7))
    rays = cv2.undistortPoints(np.column_stack([u.ravel(), v.ravel()]).reshape(-1, 1, 2), truth.K1,
                               truth.D1).reshape(-1, 2)
    for z in z_mm:
        X = np.column_stack([rays * z, np.full(len(rays), z)])
        left, _ = cv2.projectPoints(X, np.zeros(3), np.zeros(3), truth.K1, truth.D1)
        right, _ = cv2.projectPoints(X, cv2.Rodrigues(truth.R)[0], truth.T, truth.K2, truth.D2)
        got = triangulate_mm(calib, left.reshape(-1, 2), right.reshape(-1, 2))
        out[f"depth_pct_at_{z:g}"] = float(np.sqrt(np.mean(((got[:, 2] - z) / z) ** 2)) * 100)
    return out
