"""The true stereo rig of the synthetic scenes: intrinsics, distortion, the right camera's pose.

Conventions are OpenCV's ``stereoCalibrate``: ``X_right = R @ X_left + T`` (mm); pixels are of the
distorted images; pixel centres are at integer coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from appliance.calibrate.model import StereoCalibration

_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-12)


@dataclass(frozen=True, eq=False)
class Rig:
    """A stereo pair with known intrinsics and pose.

    Attributes
    ----------
    K1, K2 : ndarray, shape (3, 3)
        Camera matrices, px.
    D1, D2 : ndarray, shape (5,)
        Distortion (k1, k2, p1, p2, k3).
    R : ndarray, shape (3, 3)
        Rotation of the right camera, ``X_right = R @ X_left + T``.
    T : ndarray, shape (3,)
        Translation, mm.
    width_px, height_px : int
        Image size of each camera.
    """

    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray
    width_px: int
    height_px: int

    @property
    def size(self) -> tuple[int, int]:
        """(width, height), px."""
        return (self.width_px, self.height_px)

    def calibration(self) -> StereoCalibration:
        """The rig as a :class:`StereoCalibration` (with its rectification)."""
        return StereoCalibration.from_pose(self.size, self.K1, self.D1, self.K2, self.D2, self.R, self.T,
                                           meta={"source": "appliance.synth true rig"})

    def camera(self, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(K, D, R_cam, t_cam)`` of ``side`` ("left"/"right"); ``X_cam = R_cam @ X_left + t_cam``."""
        if side == "left":
            return self.K1, self.D1, np.eye(3), np.zeros(3)
        if side == "right":
            return self.K2, self.D2, self.R, self.T
        raise ValueError(f"side must be 'left' or 'right', not {side!r}")

    def project(self, xyz_mm: np.ndarray, side: str) -> np.ndarray:
        """Pixels (N, 2) of points ``xyz_mm`` (N, 3) in the left camera frame, through the distorted ``side``."""
        K, D, Rc, tc = self.camera(side)
        pts = np.asarray(xyz_mm, np.float64).reshape(-1, 3)
        if len(pts) == 0:
            return np.zeros((0, 2))
        px, _ = cv2.projectPoints(pts, cv2.Rodrigues(Rc)[0], tc, K, D)
        return px.reshape(-1, 2)

    def normalised_grid(self, side: str, ss: int = 1) -> np.ndarray:
        """Undistorted normalised coordinates (x, y) of every sample of a ``ss`` x ``ss`` supersampled image.

        Sample (j, i) is at pixel ``((i + 0.5) / ss - 0.5, (j + 0.5) / ss - 0.5)``.

        Returns
        -------
        ndarray, shape (height_px * ss, width_px * ss, 2), float64 — ray of the sample in the camera's own
        frame is ``(x, y, 1)``.
        """
        K, D, _, _ = self.camera(side)
        w, h = self.width_px * ss, self.height_px * ss
        ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
        pts = np.stack([(xs + 0.5) / ss - 0.5, (ys + 0.5) / ss - 0.5], axis=-1).reshape(-1, 1, 2)
        return cv2.undistortPoints(pts, K, D, criteria=_CRITERIA).reshape(h, w, 2)


def default_rig() -> Rig:
    """The rig of the fixtures: 1280x960, f ~1450 px, 120 mm baseline, slightly rotated, mild barrel distortion."""
    K1 = np.array([[1452.0, 0.0, 643.5], [0.0, 1450.0, 478.0], [0.0, 0.0, 1.0]])
    K2 = np.array([[1447.0, 0.0, 636.0], [0.0, 1446.0, 484.5], [0.0, 0.0, 1.0]])
    D1 = np.array([-0.085, 0.11, 0.0004, -0.0003, -0.02])
    D2 = np.array([-0.080, 0.10, -0.0002, 0.0003, -0.02])
    R = cv2.Rodrigues(np.array([0.004, -0.009, 0.003]))[0]
    T = np.array([-120.0, 0.5, 0.9])
    return Rig(K1, D1, K2, D2, R, T, 1280, 960)


def rig_from_calibration(calib: StereoCalibration) -> Rig:
    """The :class:`Rig` of a calibration (intrinsics and pose; rectification is re-derived on demand)."""
    w, h = calib.image_size
    return Rig(calib.K1, calib.D1, calib.K2, calib.D2, calib.R, np.asarray(calib.T).reshape(3), int(w), int(h))
