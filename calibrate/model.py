"""The stereo calibration: intrinsics, the pair's pose, rectification, and its file format.

File format: an OpenCV FileStorage YAML (readable by any OpenCV) with nodes
``image_width``, ``image_height``, ``K1``, ``D1``, ``K2``, ``D2``, ``R``, ``T`` (mm) and,
derived from those, ``E``, ``F``, ``R1``, ``R2``, ``P1``, ``P2``, ``Q``, ``f_px``,
``baseline_mm``, plus quality figures ``rms_px``, ``epipolar_rms_px`` and metadata.
A file with only the first eight nodes loads: the rest is derived.

Conventions are OpenCV's ``stereoCalibrate``: ``X_right = R @ X_left + T`` (mm).
"""

from __future__ import annotations

import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from appliance.errors import ApplianceError


class CalibrationError(ApplianceError):
    """A calibration file is missing, unreadable or inconsistent, or a calibration failed."""


@dataclass(frozen=True, eq=False)
class StereoCalibration:
    """A calibrated stereo pair and its rectification.

    Attributes
    ----------
    image_size : (int, int)
        (width, height) of one camera's image, px.
    K1, K2 : ndarray, shape (3, 3)
        Camera matrices, px.
    D1, D2 : ndarray, shape (N,)
        Distortion coefficients (k1, k2, p1, p2, k3[, ...]).
    R : ndarray, shape (3, 3)
        Rotation of the right camera: ``X_right = R @ X_left + T``.
    T : ndarray, shape (3,)
        Translation, mm.
    E, F : ndarray, shape (3, 3)
        Essential and fundamental matrices.
    R1, R2 : ndarray, shape (3, 3)
        Rectifying rotations (unrectified camera frame -> rectified frame).
    P1, P2 : ndarray, shape (3, 4)
        Rectified projection matrices; ``P2[0, 3] = -f_px * baseline_mm``.
    Q : ndarray, shape (4, 4)
        Disparity-to-depth matrix (rectified left frame, mm).
    rms_px, epipolar_rms_px : float
        Stereo reprojection RMS and rectified row error RMS (NaN when unknown).
    meta : dict
        Free-form strings: date, pattern, source.
    """

    image_size: tuple[int, int]
    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray
    E: np.ndarray
    F: np.ndarray
    R1: np.ndarray
    R2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    Q: np.ndarray
    rms_px: float = float("nan")
    epipolar_rms_px: float = float("nan")
    meta: dict = field(default_factory=dict)

    @property
    def f_px(self) -> float:
        """Rectified focal length, px."""
        return float(self.P1[0, 0])

    @property
    def baseline_mm(self) -> float:
        """Distance between the optical centres, mm (positive for a proper left/right rig)."""
        return float(-self.P2[0, 3] / self.P2[0, 0])

    @classmethod
    def from_pose(cls, image_size, K1, D1, K2, D2, R, T, alpha: float = 0.0, **extra):
        """Derive E, F and the rectification from intrinsics and the pair's pose.

        Parameters
        ----------
        image_size : (int, int)
            (width, height), px.
        K1, D1, K2, D2, R, T : array_like
            As in the class attributes; ``T`` in mm.
        alpha : float
            ``cv2.stereoRectify`` free scaling (0 = only valid pixels).
        **extra
            ``rms_px``, ``epipolar_rms_px``, ``meta``.
        """
        K1, K2, R = (np.asarray(a, np.float64).reshape(3, 3) for a in (K1, K2, R))
        D1, D2 = (np.asarray(a, np.float64).ravel() for a in (D1, D2))
        T = np.asarray(T, np.float64).reshape(3)
        size = (int(image_size[0]), int(image_size[1]))
        tx = np.array([[0, -T[2], T[1]], [T[2], 0, -T[0]], [-T[1], T[0], 0]])
        E = tx @ R
        F = np.linalg.inv(K2).T @ E @ np.linalg.inv(K1)
        F = F / F[2, 2] if abs(F[2, 2]) > 1e-12 else F
        R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(
            K1, D1, K2, D2, size, R, T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha
        )
        return cls(size, K1, D1, K2, D2, R, T, E, F, R1, R2, P1, P2, Q, **extra)


NODES = ("K1", "D1", "K2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q")


def save_calibration(calib: StereoCalibration, path: str | Path) -> None:
    """Write ``calib`` atomically: a failed write never replaces an existing file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".yaml", dir=path.parent)
    os.close(fd)
    try:
        fs = cv2.FileStorage(tmp, cv2.FILE_STORAGE_WRITE)
        fs.write("image_width", calib.image_size[0])
        fs.write("image_height", calib.image_size[1])
        for name in NODES:
            fs.write(name, np.asarray(getattr(calib, name), np.float64))
        fs.write("f_px", calib.f_px)
        fs.write("baseline_mm", calib.baseline_mm)
        fs.write("rms_px", float(calib.rms_px))
        fs.write("epipolar_rms_px", float(calib.epipolar_rms_px))
        for key, value in calib.meta.items():
            fs.write(key, str(value))
        fs.release()
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_calibration(path: str | Path, alpha: float = 0.0) -> StereoCalibration:
    """Read a calibration; derive E, F, rectification when the file has only the pose.

    Raises
    ------
    CalibrationError
        Missing file, not a FileStorage file, missing or malformed node.
    """
    path = Path(path)
    if not path.is_file():
        raise CalibrationError(f"{path}: calibration file not found")
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as e:
        # (OpenCV 5's binding raises SystemError, its cause the parser's cv2.error, whose `func` holds
        # "FILE(LINE): what is wrong")
        where = str(getattr(e.__cause__, "func", "") or "")
        m = re.fullmatch(r".*\((\d+)\): (.+)", where.strip())
        why = f" (line {m[1]}: {m[2]})" if m else ""
        raise CalibrationError(f"{path}: not an OpenCV FileStorage file{why}") from None
    if not fs.isOpened():
        raise CalibrationError(f"{path}: not an OpenCV FileStorage file")
    try:
        def mat(name, shape=None):
            node = fs.getNode(name)
            if node.empty():
                raise CalibrationError(f"{path}: node {name} missing")
            m = node.mat()
            if m is None:
                raise CalibrationError(f"{path}: node {name} is not a matrix")
            m = np.asarray(m, np.float64)
            if shape is not None and m.size != int(np.prod(shape)):
                raise CalibrationError(f"{path}: node {name} must have {int(np.prod(shape))} values, has {m.size}")
            return m.reshape(shape) if shape is not None else m.ravel()

        w, h = (fs.getNode(n) for n in ("image_width", "image_height"))
        if w.empty() or h.empty():
            raise CalibrationError(f"{path}: nodes image_width/image_height missing")
        size = (int(w.real()), int(h.real()))
        pose = dict(
            K1=mat("K1", (3, 3)), D1=mat("D1"), K2=mat("K2", (3, 3)), D2=mat("D2"),
            R=mat("R", (3, 3)), T=mat("T", (3,)),
        )

        def real(name):
            node = fs.getNode(name)
            return float(node.real()) if not node.empty() else float("nan")

        meta = {}
        for key in ("date", "pattern", "source", "pairs"):
            node = fs.getNode(key)
            if not node.empty():
                meta[key] = node.string()
        extra = dict(rms_px=real("rms_px"), epipolar_rms_px=real("epipolar_rms_px"), meta=meta)
        if all(not fs.getNode(n).empty() for n in NODES):
            shapes = dict(E=(3, 3), F=(3, 3), R1=(3, 3), R2=(3, 3), P1=(3, 4), P2=(3, 4), Q=(4, 4))
            derived = {n: mat(n, s) for n, s in shapes.items()}
            return StereoCalibration(size, **pose, **derived, **extra)
        return StereoCalibration.from_pose(size, **pose, alpha=alpha, **extra)
    finally:
        fs.release()
