"""Chessboard corner detection in one image and in a stereo pair."""

from __future__ import annotations

import cv2
import numpy as np

from appliance.calibrate.board import Board

_SB_FLAGS = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
_CLASSIC_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
_SUBPIX = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)


def to_grey(image: np.ndarray) -> np.ndarray:
    """A uint8 grey view of a BGR or grey image; shape (H, W)."""
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image


def find_corners(image: np.ndarray, board: Board, detector: str = "sb") -> np.ndarray | None:
    """The board's inner corners in ``image``, or None when the whole board is not seen.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, 3), uint8
    board : Board
    detector : {"sb", "classic"}
        ``sb``: ``findChessboardCornersSB`` (sector-based, finds boards the classic detector misses);
        ``classic``: ``findChessboardCorners`` (much faster). Both are refined by ``cornerSubPix``:
        on rendered boards with exact truth, SB's own sub-pixel corners bias the focal length by
        +0.3..0.4 %, the refined ones by under 0.05 % (benchmarks/calibration.py).

    Returns
    -------
    ndarray, shape (cols*rows, 2), float32, px — or None.
    """
    grey = to_grey(image)
    if detector == "sb":
        ok, corners = cv2.findChessboardCornersSB(grey, board.size, flags=_SB_FLAGS)
    else:
        ok, corners = cv2.findChessboardCorners(grey, board.size, flags=_CLASSIC_FLAGS)
    if not ok or corners is None:
        return None
    corners = corners.reshape(-1, 1, 2).astype(np.float32)
    # half the smallest corner spacing, 2..11 px: never pulls a corner onto its neighbour
    grid = corners.reshape(board.rows, board.cols, 2)
    spacing = min(np.linalg.norm(np.diff(grid, axis=a), axis=2).min() for a in (0, 1))
    win = int(max(2, min(11, spacing / 3)))
    return cv2.cornerSubPix(grey, corners, (win, win), (-1, -1), _SUBPIX).reshape(-1, 2)


def orient_like(reference: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """``corners`` reordered so that they run in the same direction as ``reference``.

    A chessboard's corner order is ambiguous up to a 180-degree turn; the two views of a pair
    see the board from nearly the same direction, so the first-to-last corner vectors must agree.

    Parameters
    ----------
    reference, corners : ndarray, shape (N, 2), px
    """
    if np.dot(reference[-1] - reference[0], corners[-1] - corners[0]) < 0:
        return corners[::-1].copy()
    return corners
