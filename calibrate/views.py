"""Chessboard views of a stereo pair: read image pairs, detect the board in both, keep the usable ones."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Iterator

import cv2
import numpy as np

from appliance.acquire.pairs import ImagePair, find_pairs
from appliance.calibrate.board import Board
from appliance.calibrate.detect import find_corners, orient_like
from appliance.calibrate.model import CalibrationError

# track(iterable, total, description) -> the same items; the command passes a rich progress bar.
Track = Callable[[Iterable, int, str], Iterable]


def no_track(items: Iterable, total: int, description: str) -> Iterable:
    """A ``Track`` that shows nothing."""
    return items


@dataclass(frozen=True, eq=False)
class View:
    """The board's corners seen in both images of one pair.

    Attributes
    ----------
    key : str
        The pair's name (``"03"`` for ``left_03.png``/``right_03.png``).
    left_px, right_px : ndarray, shape (cols*rows, 2), float32
        Corners in the same order in both images, px.
    """

    key: str
    left_px: np.ndarray
    right_px: np.ndarray


@dataclass(frozen=True, eq=False)
class Views:
    """What corner detection made of a set of pairs.

    Attributes
    ----------
    image_size : (int, int)
        (width, height) of every kept image, px.
    views : list of View
        Pairs with the whole board seen in both images.
    skipped : list of (str, str)
        ``(pair name, reason)`` of each pair that was not used.
    sample : (ndarray, ndarray)
        One kept pair's images (left, right), for the rectification check picture.
    unpaired : int
        Images of the folder without a left/right partner (ignored).
    """

    image_size: tuple[int, int]
    views: list[View]
    skipped: list[tuple[str, str]] = field(default_factory=list)
    sample: tuple[np.ndarray, np.ndarray] | None = None
    unpaired: int = 0


def read_pairs(pairs: list[ImagePair]) -> Iterator[tuple[str, np.ndarray | None, np.ndarray | None, str]]:
    """Read each pair; yields ``(name, left, right, problem)`` with ``problem == ""`` when both read."""
    for pair in pairs:
        name = f"{pair.left.name}/{pair.right.name}"
        left = cv2.imread(str(pair.left), cv2.IMREAD_UNCHANGED)
        right = cv2.imread(str(pair.right), cv2.IMREAD_UNCHANGED)
        bad = [p.name for p, im in ((pair.left, left), (pair.right, right)) if im is None]
        yield name, _to_8bit(left), _to_8bit(right), f"cannot read {', '.join(bad)}" if bad else ""


def _to_8bit(image: np.ndarray | None) -> np.ndarray | None:
    """Grey or BGR uint8 (drops alpha, scales 16-bit)."""
    if image is None:
        return None
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    if image.ndim == 3 and image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return image


def detect_views(items: Iterable[tuple[str, np.ndarray | None, np.ndarray | None, str]], board: Board,
                 detector: str = "sb") -> Views:
    """Detect the board in each pair; pairs with a problem are skipped with their reason.

    Parameters
    ----------
    items : iterable of (name, left, right, problem)
        As :func:`read_pairs` yields them (``problem`` non-empty: skip with that reason).
    board : Board
    detector : {"sb", "classic"}
    """
    size = None
    views, skipped, sample = [], [], None
    for name, left, right, problem in items:
        if not problem and left.shape[:2] != right.shape[:2]:
            problem = (f"sizes differ: left {left.shape[1]}x{left.shape[0]}, "
                       f"right {right.shape[1]}x{right.shape[0]}")
        if not problem and size is not None and (left.shape[1], left.shape[0]) != size:
            problem = f"size {left.shape[1]}x{left.shape[0]} differs from the first pair's {size[0]}x{size[1]}"
        if problem:
            skipped.append((name, problem))
            continue
        left_px = find_corners(left, board, detector)
        right_px = find_corners(right, board, detector) if left_px is not None else None
        if left_px is None or right_px is None:
            side = "left" if left_px is None else "right"
            skipped.append((name, f"{board.cols}x{board.rows} board not found (whole) in the {side} image"))
            continue
        size = (left.shape[1], left.shape[0])
        views.append(View(name, left_px, orient_like(left_px, right_px)))
        sample = sample or (left, right)
    return Views(size or (0, 0), views, skipped, sample)


def views_from_folder(folder: str | Path, board: Board, detector: str = "sb", track: Track = no_track) -> Views:
    """Find the left/right pairs of ``folder`` by name and detect the board in them.

    Raises
    ------
    CalibrationError
        The folder does not exist or holds no left/right pairs.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise CalibrationError(f"{folder}: no such folder of image pairs")
    pairs, unpaired = find_pairs(folder)
    if not pairs:
        raise CalibrationError(f"{folder}: no left/right image pairs (names like left01.png/right01.png)")
    views = detect_views(track(read_pairs(pairs), len(pairs), "detecting corners"), board, detector)
    return Views(views.image_size, views.views, views.skipped, views.sample, len(unpaired))
