import numpy as np
import pytest

from appliance.calibrate import CalibrationError
from appliance.calibrate.board import Board, parse_pattern


def test_parse_pattern():
    assert parse_pattern("9x6") == (9, 6)
    assert parse_pattern(" 7X5 ") == (7, 5)


@pytest.mark.parametrize("text", ["9", "9x1", "nine by six", "9x6x2", ""])
def test_parse_pattern_rejects(text):
    with pytest.raises(CalibrationError, match="COLSxROWS"):
        parse_pattern(text)


def test_object_points_row_by_row_in_mm():
    pts = Board(9, 6, 25.0).object_points()
    assert pts.shape == (54, 3)
    assert np.allclose(pts[1] - pts[0], [25, 0, 0])      # along a row first
    assert np.allclose(pts[9] - pts[0], [0, 25, 0])      # then the next row
    assert np.allclose(pts[-1], [200, 125, 0])
