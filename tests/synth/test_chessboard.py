"""Rendered chessboards: OpenCV finds the inner corners where the true rig projects them."""

import cv2
import numpy as np

from appliance.synth.chessboard import board_poses, render_chessboard_set
from appliance.synth.rig import Rig, default_rig


def _half_rig() -> Rig:
    r = default_rig()
    scale = np.diag([0.5, 0.5, 1.0])
    return Rig(scale @ r.K1, r.D1, scale @ r.K2, r.D2, r.R, r.T, 640, 480)


def test_detected_corners_are_the_projected_truth(tmp_path):
    rig = _half_rig()
    n = render_chessboard_set(rig, tmp_path, n_pairs=3, seed=5, z_range_mm=(350.0, 600.0))
    assert n == 3
    poses = board_poses(rig, 3, seed=5, z_range_mm=(350.0, 600.0))
    gx, gy = np.meshgrid(np.arange(1, 10), np.arange(1, 7))
    board = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)]) * 25.0
    errors = []
    for i, (R_board, t_board) in enumerate(poses):
        for side in ("left", "right"):
            img = cv2.imread(str(tmp_path / f"{side}_{i:02d}.png"), cv2.IMREAD_GRAYSCALE)
            assert img.shape == (480, 640)
            found, corners = cv2.findChessboardCornersSB(img, (9, 6), flags=cv2.CALIB_CB_ACCURACY)
            assert found, (side, i)
            corners = corners.reshape(-1, 2)
            truth = rig.project(board @ R_board.T + t_board, side)
            if np.linalg.norm(corners[0] - truth[0]) > np.linalg.norm(corners[0] - truth[-1]):
                corners = corners[::-1]            # OpenCV may start from the opposite corner
            errors.append(np.linalg.norm(corners - truth, axis=1))
    errors = np.concatenate(errors)
    assert np.median(errors) < 0.1 and errors.max() < 0.35


def test_poses_cover_both_images_with_the_board_whole():
    rig = default_rig()
    poses = board_poses(rig, 16)
    assert len(poses) == 16
    tilts = [np.degrees(np.arccos(abs(R[2, 2]))) for R, _ in poses]
    assert max(tilts) > 20 and min(tilts) < 15
    gx, gy = np.meshgrid(np.arange(1, 10), np.arange(1, 7))
    board = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)]) * 25.0
    for side in ("left", "right"):
        px = np.concatenate([rig.project(board @ R.T + t, side) for R, t in poses])
        assert (px >= 0).all() and (px[:, 0] < rig.width_px).all() and (px[:, 1] < rig.height_px).all()
        cells, _, _ = np.histogram2d(px[:, 0], px[:, 1], bins=[8, 6], range=[[0, rig.width_px], [0, rig.height_px]])
        assert (cells > 0).mean() > 0.65, side
