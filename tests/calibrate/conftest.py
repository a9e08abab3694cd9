"""Helpers of the calibration tests: the CLI, the rendered chessboards, OpenCV's sample pairs."""

from __future__ import annotations

import gzip
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
CHESSBOARD = REPO / "fixtures" / "chessboard"
RIG = REPO / "fixtures" / "rig.yaml"
OPENCV_DATA = Path("/usr/share/doc/opencv-doc/examples/data")
OPENCV_KEYS = ("01", "02", "03", "04", "05", "06", "07", "08", "09", "11", "12", "13", "14")


def appliance(*args: str, cwd: Path | None = None, timeout: float = 120, stdin: str = "") -> subprocess.CompletedProcess:
    """Run the installed ``appliance`` executable; ``stdin`` is what a pipe gives it, then EOF (as in CI)."""
    exe = str(Path(sys.executable).with_name("appliance"))
    return subprocess.run([exe, *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          input=stdin, timeout=timeout)


def chessboard_image(cols: int = 9, rows: int = 6, square_px: int = 40, margin_px: int = 60,
                     size=(640, 480)) -> tuple[np.ndarray, np.ndarray]:
    """A fronto-parallel chessboard, grey uint8, and its inner corners (cols*rows, 2), px."""
    w, h = size
    y, x = np.mgrid[0:h, 0:w]
    sx, sy = (x - margin_px) // square_px, (y - margin_px) // square_px
    inside = (sx >= 0) & (sx <= cols) & (sy >= 0) & (sy <= rows)
    img = np.where(inside & ((sx + sy) % 2 == 0), 0, 255).astype(np.uint8)
    img = cv2.GaussianBlur(img, (5, 5), 1.0)
    gx, gy = np.meshgrid(np.arange(1, cols + 1), np.arange(1, rows + 1))
    corners = np.stack([gx.ravel(), gy.ravel()], axis=1) * square_px + margin_px - 0.5
    return img, corners.astype(np.float32)


def opencv_pairs(dest: Path, keys=OPENCV_KEYS) -> Path:
    """Copy OpenCV's sample pairs (left01.jpg ...) into ``dest``, unpacking Debian's ``.jpg.gz``.

    Skips the test when the ``opencv-doc`` package is not installed.
    """
    if not OPENCV_DATA.is_dir():
        pytest.skip("OpenCV's sample stereo pairs are absent: apt-get install opencv-doc")
    dest.mkdir(parents=True, exist_ok=True)
    for key in keys:
        for side in ("left", "right"):
            src = OPENCV_DATA / f"{side}{key}.jpg"
            if src.is_file():
                shutil.copy(src, dest / src.name)
            elif src.with_suffix(".jpg.gz").is_file():
                (dest / src.name).write_bytes(gzip.decompress(src.with_suffix(".jpg.gz").read_bytes()))
    return dest
