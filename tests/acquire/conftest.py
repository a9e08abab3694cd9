"""Small stereo pairs made in the test: each pair's images carry its number, so order is checkable."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from appliance.config import load_config

W, H = 96, 64  # one camera's image, px


def camera_cfg(**camera):
    """The default camera section with ``camera`` overlaid (validated like a user's file)."""
    return load_config(overrides={"camera": camera}).camera


def pair_images(i: int) -> tuple[np.ndarray, np.ndarray]:
    """Pair ``i``: left grey level 20 + 20 i, right 220 - 20 i; left has a white square top-left."""
    left = np.full((H, W, 3), 20 + 20 * i, np.uint8)
    right = np.full((H, W, 3), 220 - 20 * i, np.uint8)
    left[4:20, 4:20] = 255
    return left, right


def level(image: np.ndarray) -> float:
    """Mean of the bottom half, where only the pair's grey level is (robust to JPEG)."""
    return float(image[H // 2:].mean())


def pair_number(left: np.ndarray) -> int:
    return round((level(left) - 20) / 20)


@pytest.fixture
def pair_folder(tmp_path) -> Path:
    folder = tmp_path / "pairs"
    folder.mkdir()
    for i in range(6):
        left, right = pair_images(i)
        cv2.imwrite(str(folder / f"left_{i:02d}.png"), left)
        cv2.imwrite(str(folder / f"right_{i:02d}.png"), right)
    return folder


def write_side_by_side(path: Path, n: int, fps: float = 25.0) -> Path:
    """An MJPG .avi of ``n`` side-by-side pairs (left half left camera), ``2W x H``."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (2 * W, H))
    assert writer.isOpened()
    for i in range(n):
        writer.write(np.hstack(pair_images(i)))
    writer.release()
    return path


@pytest.fixture
def sbs_video(tmp_path) -> Path:
    return write_side_by_side(tmp_path / "sbs.avi", 6)
