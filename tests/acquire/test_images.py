import numpy as np
import pytest

from appliance.acquire.images import buffer_to_array, split_side_by_side, to_bgr

BGR = (10, 100, 200)  # blue, green, red


def mosaic(pattern: str, h=8, w=8) -> np.ndarray:
    """A flat BGR colour as a Bayer mosaic whose 2x2 tile reads ``pattern`` from the top-left."""
    value = {"B": BGR[0], "G": BGR[1], "R": BGR[2]}
    raw = np.empty((h, w), np.uint8)
    for k, (dy, dx) in enumerate([(0, 0), (0, 1), (1, 0), (1, 1)]):
        raw[dy::2, dx::2] = value[pattern[k]]
    return raw


@pytest.mark.parametrize("fmt,pattern", [("BayerRG8", "RGGB"), ("BayerGR8", "GRBG"),
                                         ("BayerGB8", "GBRG"), ("BayerBG8", "BGGR")])
def test_bayer_to_bgr(fmt, pattern):
    bgr = to_bgr(mosaic(pattern), fmt)
    assert bgr.shape == (8, 8, 3)
    assert tuple(bgr[4, 4]) == BGR


def test_rgb_mono_and_16_bit():
    rgb = np.zeros((2, 3, 3), np.uint8)
    rgb[..., 0] = 200  # red first
    assert tuple(to_bgr(rgb, "RGB8")[0, 0]) == (0, 0, 200)
    assert to_bgr(np.full((2, 3), 7, np.uint8), "Mono8").shape == (2, 3, 3)
    assert tuple(to_bgr(np.full((2, 3), 0x1234, np.uint16), "Mono16")[1, 2]) == (0x12,) * 3


def test_buffer_shapes():
    assert buffer_to_array(bytes(24), 4, 2, "RGB8").shape == (2, 4, 3)
    assert buffer_to_array(bytes(16), 4, 2, "Mono16").dtype == np.uint16
    assert buffer_to_array(bytes(8), 4, 2, "BayerRG8").shape == (2, 4)


def test_split_side_by_side():
    frame = np.hstack([np.zeros((2, 3), np.uint8), np.ones((2, 3), np.uint8)])
    left, right = split_side_by_side(frame)
    assert left.max() == 0 and right.min() == 1 and left.flags.c_contiguous
    left, right = split_side_by_side(frame, "right")
    assert left.min() == 1 and right.max() == 0
