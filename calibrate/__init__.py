"""Chessboard stereo calibration and the calibration model."""

from appliance.calibrate.model import (
    CalibrationError,
    StereoCalibration,
    load_calibration,
    save_calibration,
)

__all__ = ["CalibrationError", "StereoCalibration", "load_calibration", "save_calibration"]
