"""Chessboard pairs rendered through a known rig, for calibration fixtures and tests.

Each camera's supersample rays are computed once (``cv2.undistortPoints`` of the 2x2 supersampled grid);
a view is then one ray-plane intersection per sample, box-filtered, blurred slightly and noised. Poses are
drawn from a seed so that the boards, seen whole by both cameras, cover the image at varied tilts and
distances.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from appliance.synth.rig import Rig

SS = 2


def _board_image(grid: np.ndarray, R_board: np.ndarray, t_board: np.ndarray, cols: int, rows: int,
                 square_mm: float, size: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Grey uint8 view of the board at pose (R_board, t_board) in this camera's frame (mm).

    Board coordinates: inner corner (i, j) at ``(i + 1, j + 1) * square_mm`` along the board's x/y axes.
    """
    normal = R_board[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (normal @ t_board) / (grid[..., 0] * normal[0] + grid[..., 1] * normal[1] + normal[2])
    P = np.stack([grid[..., 0] * s, grid[..., 1] * s, s], axis=-1) - t_board
    u = (P @ R_board[:, 0]) / square_mm
    v = (P @ R_board[:, 1]) / square_mm
    inside = (u >= 0) & (u < cols + 1) & (v >= 0) & (v < rows + 1)
    margin = (u >= -1) & (u < cols + 2) & (v >= -1) & (v < rows + 2)
    dark = (np.floor(u) + np.floor(v)) % 2 == 0
    img = np.where(inside, np.where(dark, 35.0, 215.0), np.where(margin, 225.0, 110.0)).astype(np.float32)
    img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    noise = cv2.GaussianBlur(rng.normal(0, 1.0, img.shape).astype(np.float32), (0, 0), 0.7)   # demosaiced: ~0.4
    img = cv2.GaussianBlur(img, (0, 0), 0.7) + noise
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def board_outline_mm(cols: int, rows: int, square_mm: float) -> np.ndarray:
    """The four outer corners of the board's white margin in board coordinates (4, 3), mm."""
    lo, hx, hy = -square_mm, (cols + 2) * square_mm, (rows + 2) * square_mm
    return np.array([[lo, lo, 0], [hx, lo, 0], [hx, hy, 0], [lo, hy, 0]])


def board_poses(rig: Rig, n: int, cols: int = 9, rows: int = 6, square_mm: float = 25.0, seed: int = 11,
                z_range_mm=(420.0, 1000.0), margin_px: float = 15.0, candidates: int = 150):
    """``n`` poses (R_board, t_board) in the left frame with the board whole in both images.

    Random poses (tilts up to ~35 degrees) are drawn until ``candidates`` are valid; then poses are picked
    greedily to cover the most new cells of an 8x6 grid over both images (the inner corners' cells).
    """
    rng = np.random.default_rng(seed)
    w, h = rig.size
    half = np.array([(cols + 1) * square_mm / 2, (rows + 1) * square_mm / 2, 0.0])
    outline = board_outline_mm(cols, rows, square_mm)
    gx, gy = np.meshgrid(np.arange(1, cols + 1), np.arange(1, rows + 1))
    inner = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)]) * square_mm
    valid, cells = [], []
    for _ in range(50 * candidates):
        if len(valid) == candidates:
            break
        R_board = cv2.Rodrigues(rng.uniform(-0.6, 0.6, 3) * [1, 1, 0.4])[0]
        z = rng.uniform(*z_range_mm)
        target = rng.uniform([0, 0], [w, h])
        ray = cv2.undistortPoints(target.reshape(1, 1, 2), rig.K1, rig.D1).ravel()
        t_board = np.array([ray[0] * z, ray[1] * z, z]) - R_board @ half
        corners = outline @ R_board.T + t_board
        seen = set()
        for k, side in enumerate(("left", "right")):
            _, _, Rc, tc = rig.camera(side)
            if ((corners @ Rc.T + tc)[:, 2] < 100).any():
                break
            px = rig.project(corners, side)
            if (px < margin_px).any() or (px[:, 0] > w - 1 - margin_px).any() or \
                    (px[:, 1] > h - 1 - margin_px).any():
                break
            q = rig.project(inner @ R_board.T + t_board, side)
            seen |= {(k, int(u * 8 // w), int(v * 6 // h)) for u, v in q}
        else:
            valid.append((R_board, t_board))
            cells.append(seen)
    poses, covered = [], set()
    for _ in range(min(n, len(valid))):
        best = max(range(len(valid)), key=lambda i: len(cells[i] - covered) if valid[i] is not None else -1)
        poses.append(valid[best])
        covered |= cells[best]
        valid[best] = None
    return poses


def render_chessboard_set(rig: Rig, folder: str | Path, n_pairs: int = 16, cols: int = 9, rows: int = 6,
                          square_mm: float = 25.0, seed: int = 11, z_range_mm=(420.0, 1000.0)) -> int:
    """Write ``left_NN.png``/``right_NN.png`` into ``folder``; returns the number of pairs written."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    grids = {side: rig.normalised_grid(side, SS) for side in ("left", "right")}
    rng = np.random.default_rng(seed + 1)
    poses = board_poses(rig, n_pairs, cols, rows, square_mm, seed, z_range_mm)
    for i, (R_board, t_board) in enumerate(poses):
        for side in ("left", "right"):
            _, _, Rc, tc = rig.camera(side)
            img = _board_image(grids[side], Rc @ R_board, Rc @ t_board + tc, cols, rows, square_mm, rig.size, rng)
            cv2.imwrite(str(folder / f"{side}_{i:02d}.png"), img, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return len(poses)
