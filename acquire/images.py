"""Pure conversions from what cameras deliver to the BGR arrays the localizer wants."""

from __future__ import annotations

import cv2
import numpy as np

# GenICam pixel format name -> OpenCV conversion to BGR (None: no conversion needed).
# GenICam names the 2x2 Bayer tile from the top-left pixel (BayerRG8 = R G / G B), as do
# OpenCV's explicit COLOR_Bayer{RGGB,...}2BGR codes (its short names are shifted by one).
_TO_BGR = {
    "Mono8": cv2.COLOR_GRAY2BGR,
    "Mono16": cv2.COLOR_GRAY2BGR,
    "BayerRG8": cv2.COLOR_BayerRGGB2BGR,
    "BayerGR8": cv2.COLOR_BayerGRBG2BGR,
    "BayerGB8": cv2.COLOR_BayerGBRG2BGR,
    "BayerBG8": cv2.COLOR_BayerBGGR2BGR,
    "RGB8": cv2.COLOR_RGB2BGR,
    "BGR8": None,
}
PIXEL_FORMATS = tuple(_TO_BGR)

# camera.pixel_format (config) -> GenICam PixelFormat asked of a GigE camera.
GENICAM_FORMAT = {"MONO8": "Mono8", "BAYER_RG8": "BayerRG8", "RGB8": "RGB8"}


def to_bgr(raw: np.ndarray, pixel_format: str) -> np.ndarray:
    """Convert one camera image to BGR.

    Parameters
    ----------
    raw : ndarray
        (H, W) uint8 for Mono8 and Bayer*8, (H, W) uint16 for Mono16 (scaled to 8 bits by
        its top byte), (H, W, 3) uint8 for RGB8/BGR8.
    pixel_format : str
        GenICam name, one of :data:`PIXEL_FORMATS`.

    Returns
    -------
    ndarray, shape (H, W, 3) uint8, BGR
    """
    code = _TO_BGR[pixel_format]
    if raw.dtype == np.uint16:
        raw = (raw >> 8).astype(np.uint8)
    return np.ascontiguousarray(raw) if code is None else cv2.cvtColor(raw, code)


def buffer_to_array(data: bytes | memoryview, width_px: int, height_px: int, pixel_format: str) -> np.ndarray:
    """View a packed image buffer as an array of the shape :func:`to_bgr` takes."""
    if pixel_format == "Mono16":
        return np.frombuffer(data, np.uint16, width_px * height_px).reshape(height_px, width_px)
    channels = 3 if pixel_format in ("RGB8", "BGR8") else 1
    shape = (height_px, width_px, 3) if channels == 3 else (height_px, width_px)
    return np.frombuffer(data, np.uint8, width_px * height_px * channels).reshape(shape)


def split_side_by_side(frame: np.ndarray, left_half: str = "left") -> tuple[np.ndarray, np.ndarray]:
    """Split a side-by-side stereo frame into its two images.

    Parameters
    ----------
    frame : ndarray, shape (H, 2W, ...)
    left_half : "left" | "right"
        Which half holds the left camera (``camera.side_by_side_left_half``).

    Returns
    -------
    left, right : ndarray, shape (H, W, ...), contiguous copies
    """
    half = frame.shape[1] // 2
    a, b = np.ascontiguousarray(frame[:, :half]), np.ascontiguousarray(frame[:, half: 2 * half])
    return (a, b) if left_half == "left" else (b, a)
