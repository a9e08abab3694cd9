import cv2
import numpy as np
import pytest

from appliance.calibrate.board import Board
from appliance.calibrate.detect import find_corners, orient_like

from .conftest import chessboard_image


@pytest.mark.parametrize("detector", ["sb", "classic"])
def test_corners_found_where_drawn(detector):
    img, truth = chessboard_image()
    corners = find_corners(img, Board(9, 6, 25), detector)
    assert corners is not None and corners.shape == (54, 2)
    corners = orient_like(truth, corners)
    assert np.abs(corners - truth).max() < 0.3


def test_colour_image_accepted():
    img, truth = chessboard_image()
    corners = find_corners(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR), Board(9, 6, 25))
    assert corners is not None and np.abs(orient_like(truth, corners) - truth).max() < 0.3


@pytest.mark.parametrize("detector", ["sb", "classic"])
def test_no_board_is_none(detector):
    assert find_corners(np.full((480, 640), 128, np.uint8), Board(9, 6, 25), detector) is None


def test_larger_pattern_is_none():
    img, _ = chessboard_image()
    assert find_corners(img, Board(11, 8, 25)) is None   # a board larger than the one shown is never found


def test_orient_like_reverses_a_turned_board():
    _, truth = chessboard_image()
    assert np.array_equal(orient_like(truth, truth[::-1]), truth)
    assert np.array_equal(orient_like(truth, truth), truth)
