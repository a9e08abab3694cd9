"""Chessboard pairs rendered through a known rig, for tests when fixtures/chessboard is absent.

The rendering is the synthetic rig's (``appliance.synth.chessboard``: exact ray-plane intersection per
2x2 supersample through the distorted cameras), here through a smaller rig of its own. Fixed seed: the
same pairs every run.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from appliance.calibrate import StereoCalibration, save_calibration
from appliance.synth.chessboard import render_chessboard_set
from appliance.synth.rig import rig_from_calibration

SIZE = (960, 720)


def true_rig() -> StereoCalibration:
    """A rig like ours: 8 mm-ish lenses, barrel distortion, 120 mm baseline, slightly converging."""
    K1 = np.array([[860.0, 0, 482], [0, 860.0, 358], [0, 0, 1]])
    K2 = np.array([[856.0, 0, 476], [0, 857.0, 363], [0, 0, 1]])
    D1 = np.array([-0.14, 0.09, 0.0004, -0.0002, 0.0])
    D2 = np.array([-0.13, 0.08, -0.0003, 0.0001, 0.0])
    R = cv2.Rodrigues(np.array([0.003, -0.012, 0.002]))[0]
    return StereoCalibration.from_pose(SIZE, K1, D1, K2, D2, R, [-120.0, 0.3, 0.6])


def render_chessboards(folder: Path, n_pairs: int = 14, cols: int = 9, rows: int = 6,
                       square_mm: float = 25.0, seed: int = 7) -> Path:
    """Write ``left_NN.png``/``right_NN.png`` and the true ``rig.yaml`` into ``folder``; returns the rig path."""
    rig = true_rig()
    render_chessboard_set(rig_from_calibration(rig), folder, n_pairs, cols, rows, square_mm, seed,
                          z_range_mm=(400.0, 800.0))
    rig_path = folder.parent / f"{folder.name}_rig.yaml"
    save_calibration(rig, rig_path)
    return rig_path
