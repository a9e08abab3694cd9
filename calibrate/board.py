"""The chessboard: its inner-corner grid and the corners' 3D positions on the board."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from appliance.calibrate.model import CalibrationError


@dataclass(frozen=True)
class Board:
    """A chessboard target.

    Attributes
    ----------
    cols, rows : int
        Inner corners along a row and along a column (OpenCV's ``patternSize = (cols, rows)``).
    square_mm : float
        Side of one square, mm.
    """

    cols: int
    rows: int
    square_mm: float

    @property
    def size(self) -> tuple[int, int]:
        """``(cols, rows)``, as OpenCV's ``patternSize``."""
        return (self.cols, self.rows)

    @property
    def name(self) -> str:
        """``"9x6 corners, 25 mm squares"``."""
        return f"{self.cols}x{self.rows} corners, {self.square_mm:g} mm squares"

    def object_points(self) -> np.ndarray:
        """Corner positions on the board plane (Z = 0), row by row; shape (cols*rows, 3), float32, mm."""
        grid = np.mgrid[0:self.cols, 0:self.rows].T.reshape(-1, 2)
        pts = np.zeros((len(grid), 3), np.float32)
        pts[:, :2] = grid * self.square_mm
        return pts


def parse_pattern(text: str) -> tuple[int, int]:
    """``"9x6"`` -> ``(9, 6)``: inner corners along a row and along a column.

    Raises
    ------
    CalibrationError
        Not ``COLSxROWS`` with both at least 2.
    """
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or min(int(m[1]), int(m[2])) < 2:
        raise CalibrationError(f"--pattern {text!r}: expected inner corners as COLSxROWS, e.g. 9x6")
    return int(m[1]), int(m[2])
