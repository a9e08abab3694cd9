"""Chessboard pairs rendered through a known rig, for tests when fixtures/chessboard is absent.

Each camera's pixel -> ray map is computed once (``undistortPoints`` on a 2x supersampled grid);
a view is then one ray-plane intersection per sample, box-filtered down, blurred and noised.
Fixed seed: the same pairs every run.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from appliance.calibrate import StereoCalibration, save_calibration

SIZE = (960, 720)
SS = 2                     # supersampling factor per axis


def true_rig() -> StereoCalibration:
    """A rig like ours: 8 mm-ish lenses, barrel distortion, 120 mm baseline, slightly converging."""
    K1 = np.array([[860.0, 0, 482], [0, 860.0, 358], [0, 0, 1]])
    K2 = np.array([[856.0, 0, 476], [0, 857.0, 363], [0, 0, 1]])
    D1 = np.array([-0.14, 0.09, 0.0004, -0.0002, 0.0])
    D2 = np.array([-0.13, 0.08, -0.0003, 0.0001, 0.0])
    R = cv2.Rodrigues(np.array([0.003, -0.012, 0.002]))[0]
    return StereoCalibration.from_pose(SIZE, K1, D1, K2, D2, R, [-120.0, 0.3, 0.6])


def _rays(K, D) -> np.ndarray:
    """Normalised ray (x, y) of every supersample, shape (H*SS, W*SS, 2)."""
    w, h = SIZE
    ys, xs = np.mgrid[0:h * SS, 0:w * SS].astype(np.float32)
    pts = np.stack([(xs + 0.5) / SS - 0.5, (ys + 0.5) / SS - 0.5], axis=-1).reshape(-1, 1, 2)
    return cv2.undistortPoints(pts, K, D).reshape(h * SS, w * SS, 2)


def _render(rays, R_board, t_board, cols, rows, square_mm, rng) -> np.ndarray:
    """Grey image of the board at pose (R_board, t_board) in this camera's frame (mm)."""
    normal = R_board[:, 2]
    denom = rays[..., 0] * normal[0] + rays[..., 1] * normal[1] + normal[2]
    s = (normal @ t_board) / denom
    P = np.stack([rays[..., 0] * s, rays[..., 1] * s, s], axis=-1) - t_board
    u = (P @ R_board[:, 0]) / square_mm + 1.0      # board squares; inner corner (i, j) at u = i + 1, v = j + 1
    v = (P @ R_board[:, 1]) / square_mm + 1.0
    inside = (u >= 0) & (u < cols + 1) & (v >= 0) & (v < rows + 1)
    white_margin = (u >= -1) & (u < cols + 2) & (v >= -1) & (v < rows + 2)
    dark = (np.floor(u) + np.floor(v)) % 2 == 0
    img = np.where(inside, np.where(dark, 35.0, 220.0), np.where(white_margin, 230.0, 120.0)).astype(np.float32)
    img = cv2.resize(img, SIZE, interpolation=cv2.INTER_AREA)
    img = cv2.GaussianBlur(img, (0, 0), 0.7) + rng.normal(0, 1.0, img.shape[:2])
    return np.clip(img, 0, 255).astype(np.uint8)


def render_chessboards(folder: Path, n_pairs: int = 14, cols: int = 9, rows: int = 6,
                       square_mm: float = 25.0, seed: int = 7) -> Path:
    """Write ``left_NN.png``/``right_NN.png`` and the true ``rig.yaml`` into ``folder``; returns the rig path."""
    folder.mkdir(parents=True, exist_ok=True)
    rig = true_rig()
    rays_l, rays_r = _rays(rig.K1, rig.D1), _rays(rig.K2, rig.D2)
    rng = np.random.default_rng(seed)
    half = np.array([(cols + 1) * square_mm / 2 - square_mm, (rows + 1) * square_mm / 2 - square_mm, 0.0])
    w, h = SIZE
    for i in range(n_pairs):
        R_board = cv2.Rodrigues(rng.uniform(-0.5, 0.5, 3) * [1, 1, 0.5])[0]
        z = rng.uniform(450, 900)
        cx, cy = rng.uniform([0.25 * w, 0.25 * h], [0.75 * w, 0.75 * h])
        centre = np.array([(cx - rig.K1[0, 2]) / rig.K1[0, 0] * z, (cy - rig.K1[1, 2]) / rig.K1[1, 1] * z, z])
        t_board = centre - R_board @ half
        left = _render(rays_l, R_board, t_board, cols, rows, square_mm, rng)
        right = _render(rays_r, rig.R @ R_board, rig.R @ t_board + rig.T, cols, rows, square_mm, rng)
        cv2.imwrite(str(folder / f"left_{i:02d}.png"), left)
        cv2.imwrite(str(folder / f"right_{i:02d}.png"), right)
    rig_path = folder.parent / f"{folder.name}_rig.yaml"
    save_calibration(rig, rig_path)
    return rig_path
