"""Rectification of a stereo pair with maps computed once per calibration.

Rectified images have their epipolar lines on pixel rows: a 3D point seen at row ``v``
in the rectified left image is at the same row in the rectified right image.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from appliance.calibrate.model import StereoCalibration
from appliance.localize.errors import LocalizeError


@dataclass(frozen=True, eq=False)
class Rectifier:
    """Remap tables of both cameras and the point mappings between frames.

    Attributes
    ----------
    calib : StereoCalibration
    maps : tuple of two (map1, map2) pairs
        ``cv2.initUndistortRectifyMap`` tables (fixed point, CV_16SC2) of the left and
        right camera.
    valid : tuple of two ndarray (H, W) bool
        Rectified pixels that see the camera's image (2 px in from its outline).
    """

    calib: StereoCalibration
    maps: tuple

    valid: tuple = ()

    @classmethod
    def from_calibration(cls, calib: StereoCalibration) -> Rectifier:
        """Build the remap tables and the valid areas (the only expensive step; done once)."""
        size = tuple(int(s) for s in calib.image_size)
        maps = tuple(
            cv2.initUndistortRectifyMap(K, D, Rr, P, size, cv2.CV_16SC2)
            for K, D, Rr, P in ((calib.K1, calib.D1, calib.R1, calib.P1), (calib.K2, calib.D2, calib.R2, calib.P2))
        )
        ones = np.full(size[::-1], 255, np.uint8)
        valid = tuple(cv2.erode(cv2.remap(ones, m1, m2, cv2.INTER_NEAREST, borderValue=0), np.ones((5, 5), np.uint8),
                                borderType=cv2.BORDER_CONSTANT, borderValue=0) > 0
                      for m1, m2 in maps)
        return cls(calib, maps, valid)

    def check_size(self, image: np.ndarray, what: str) -> None:
        """Raise LocalizeError unless ``image`` has the calibration's size."""
        w, h = self.calib.image_size
        if image is None or image.ndim < 2 or image.shape[:2] != (h, w):
            got = "nothing" if image is None else f"{image.shape[1]}x{image.shape[0]}"
            raise LocalizeError(f"{what}: image is {got}, the calibration is for {w}x{h}")

    def rectify(self, image: np.ndarray, side: int, nearest: bool = False) -> np.ndarray:
        """Rectified copy of one camera's image.

        Parameters
        ----------
        image : ndarray, shape (H, W) or (H, W, C)
        side : int
            0 left camera, 1 right camera.
        nearest : bool
            Nearest-neighbour interpolation (for masks); linear otherwise.
        """
        m1, m2 = self.maps[side]
        interp = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
        return cv2.remap(image, m1, m2, interp, borderMode=cv2.BORDER_CONSTANT, borderValue=0)

    def to_original(self, pts_px: np.ndarray, side: int) -> np.ndarray:
        """Rectified pixel positions -> pixel positions in the original (distorted) image.

        Parameters
        ----------
        pts_px : ndarray, shape (N, 2)
            (u, v) in the rectified image of ``side``.

        Returns
        -------
        ndarray, shape (N, 2), float64
        """
        pts = np.asarray(pts_px, np.float64).reshape(-1, 2)
        if len(pts) == 0:
            return np.zeros((0, 2))
        c = self.calib
        P, Rr, K, D = (c.P1, c.R1, c.K1, c.D1) if side == 0 else (c.P2, c.R2, c.K2, c.D2)
        rays = np.column_stack([(pts[:, 0] - P[0, 2]) / P[0, 0], (pts[:, 1] - P[1, 2]) / P[1, 1], np.ones(len(pts))])
        rays = rays @ Rr  # rows: R^T @ ray, back into the camera's unrectified frame
        img, _ = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
        return img.reshape(-1, 2)


class LazyRectified:
    """A rectified image computed tile by tile when indexed (``img[y0:y1, x0:x1]``).

    The matcher reads the grey images only in small patches and strips; rectifying just the
    tiles it touches saves most of a full remap.
    """

    def __init__(self, rectifier: Rectifier, image: np.ndarray, side: int, tile_px: tuple[int, int] = (32, 128)):
        self.rectifier, self.image, self.side = rectifier, image, side
        self.th, self.tw = tile_px
        w, h = rectifier.calib.image_size
        self.shape = (h, w)
        self.dtype = image.dtype
        self._tiles: dict[tuple[int, int], np.ndarray] = {}

    def _tile(self, i: int, j: int) -> np.ndarray:
        if (i, j) not in self._tiles:
            m1, m2 = self.rectifier.maps[self.side]
            y0, x0 = i * self.th, j * self.tw
            y1, x1 = min(y0 + self.th, self.shape[0]), min(x0 + self.tw, self.shape[1])
            self._tiles[i, j] = cv2.remap(self.image, m1[y0:y1, x0:x1], m2[y0:y1, x0:x1], cv2.INTER_LINEAR,
                                          borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        return self._tiles[i, j]

    def __getitem__(self, index):
        ys, xs = index
        y0, y1, _ = ys.indices(self.shape[0])
        x0, x1, _ = xs.indices(self.shape[1])
        if y1 <= y0 or x1 <= x0:
            return np.zeros((max(y1 - y0, 0), max(x1 - x0, 0)), self.dtype)
        i0, i1, j0, j1 = y0 // self.th, (y1 - 1) // self.th, x0 // self.tw, (x1 - 1) // self.tw
        block = np.vstack([np.hstack([self._tile(i, j) for j in range(j0, j1 + 1)]) for i in range(i0, i1 + 1)])
        return block[y0 - i0 * self.th:y1 - i0 * self.th, x0 - j0 * self.tw:x1 - j0 * self.tw]
