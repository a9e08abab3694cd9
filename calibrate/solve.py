"""From chessboard views to a stereo calibration: per camera, the pair, outliers, rectification."""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass

import cv2
import numpy as np

from appliance.calibrate.board import Board
from appliance.calibrate.model import CalibrationError, StereoCalibration
from appliance.calibrate.views import View, Views

_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-9)


@dataclass(frozen=True, eq=False)
class StereoSolution:
    """A calibration and how well the views fit it.

    Attributes
    ----------
    calib : StereoCalibration
    views : list of View
        The views used.
    view_rms_px : ndarray, shape (n_views, 2)
        RMS reprojection error of each used view in the left and right image, px.
    dropped : list of (str, float)
        Views dropped as outliers, with their RMS error, px.
    """

    calib: StereoCalibration
    views: list[View]
    view_rms_px: np.ndarray
    dropped: list[tuple[str, float]]


def epipolar_rms_px(calib: StereoCalibration, left_px: np.ndarray, right_px: np.ndarray) -> float:
    """RMS row difference of matched points after rectification, px.

    Parameters
    ----------
    calib : StereoCalibration
    left_px, right_px : ndarray, shape (N, 2)
        The same points in the unrectified left and right images, px.
    """
    rect_l = cv2.undistortPoints(left_px.reshape(-1, 1, 2).astype(np.float64), calib.K1, calib.D1,
                                 R=calib.R1, P=calib.P1)
    rect_r = cv2.undistortPoints(right_px.reshape(-1, 1, 2).astype(np.float64), calib.K2, calib.D2,
                                 R=calib.R2, P=calib.P2)
    return float(np.sqrt(np.mean((rect_l[:, 0, 1] - rect_r[:, 0, 1]) ** 2)))


def _stereo(views: list[View], board: Board, size, refine: bool):
    """Calibrate each camera, then the pair; returns (rms, K1, D1, K2, D2, R, T, per-view RMS (n, 2))."""
    obj = [board.object_points()] * len(views)
    left = [v.left_px.reshape(-1, 1, 2) for v in views]
    right = [v.right_px.reshape(-1, 1, 2) for v in views]
    _, K1, D1, _, _ = cv2.calibrateCamera(obj, left, size, None, None, criteria=_CRITERIA)
    _, K2, D2, _, _ = cv2.calibrateCamera(obj, right, size, None, None, criteria=_CRITERIA)
    flags = cv2.CALIB_USE_INTRINSIC_GUESS if refine else cv2.CALIB_FIX_INTRINSIC
    out = cv2.stereoCalibrateExtended(obj, left, right, K1, D1, K2, D2, size, None, None,
                                      flags=flags, criteria=_CRITERIA)
    rms, K1, D1, K2, D2, R, T = out[:7]
    return rms, K1, D1, K2, D2, R, T, np.asarray(out[-1], np.float64).reshape(-1, 2)


def solve_stereo(views: Views, board: Board, *, min_pairs: int = 8, outlier_factor: float = 2.5,
                 outlier_min_px: float = 0.3, refine: bool = True, alpha: float = 0.0,
                 source: str = "") -> StereoSolution:
    """Calibrate a stereo pair from chessboard views.

    Each camera is calibrated alone (``calibrateCamera``), then the pair (``stereoCalibrate``,
    intrinsics refined jointly when ``refine``), then rectified (``stereoRectify``). Views whose
    RMS reprojection error exceeds ``outlier_factor`` x the median (and ``outlier_min_px``) are dropped and the whole
    calibration is redone, until none is left or ``min_pairs`` would be undercut.

    Parameters
    ----------
    views : Views
    board : Board
    min_pairs : int
        Fewer usable views than this is an error.
    outlier_factor : float
        A view is an outlier above this multiple of the median view RMS ...
    outlier_min_px : float
        ... and above this RMS, px.
    refine : bool
        Refine the intrinsics in the stereo step (else keep the single-camera ones).
    alpha : float
        ``stereoRectify`` free scaling, 0..1.
    source : str
        Where the views came from (written to the calibration's metadata).

    Raises
    ------
    CalibrationError
        Too few usable views; left and right swapped (``T_x > 0``).
    """
    kept, size = list(views.views), views.image_size
    if len(kept) < min_pairs:
        why = "; ".join(f"{n}: {r}" for n, r in views.skipped[:3])
        more = f" (+{len(views.skipped) - 3} more)" if len(views.skipped) > 3 else ""
        raise CalibrationError(f"{source or 'calibration'}: only {len(kept)} usable image pairs, "
                               f"need at least {min_pairs}" + (f" — skipped {why}{more}" if why else ""))
    dropped: list[tuple[str, float]] = []
    while True:
        rms, K1, D1, K2, D2, R, T, per_view = _stereo(kept, board, size, refine)
        view_rms = np.sqrt(np.mean(per_view ** 2, axis=1))
        worst = np.argsort(view_rms)[::-1]
        limit = max(outlier_factor * np.median(view_rms), outlier_min_px)
        out = [int(i) for i in worst if view_rms[i] > limit]
        if not out or len(kept) - len(out) < min_pairs:
            break
        dropped += [(kept[i].key, float(view_rms[i])) for i in out]
        kept = [v for i, v in enumerate(kept) if i not in out]
    T = T.ravel()
    if T[0] > 0:
        raise CalibrationError(
            f"{source or 'calibration'}: left and right cameras are swapped — the camera named left is "
            f"{T[0]:.1f} mm to the RIGHT of the other (T_x > 0; depths would come out negative); "
            "exchange the left/right names (or cables) and calibrate again")
    meta = dict(date=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                pattern=board.name, source=source, pairs=str(len(kept)))
    calib = StereoCalibration.from_pose(size, K1, D1, K2, D2, R, T, alpha=alpha, rms_px=float(rms), meta=meta)
    epi = epipolar_rms_px(calib, np.concatenate([v.left_px for v in kept]),
                          np.concatenate([v.right_px for v in kept]))
    calib = StereoCalibration.from_pose(size, K1, D1, K2, D2, R, T, alpha=alpha, rms_px=float(rms),
                                        epipolar_rms_px=epi, meta=meta)
    return StereoSolution(calib, kept, per_view, dropped)
