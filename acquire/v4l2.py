"""V4L2 cameras through OpenCV's VideoCapture.

The capture API is a parameter: ``cv2.CAP_V4L2`` for a camera, while tests run the very
same class on a side-by-side video file through ``cv2.CAP_FFMPEG`` (no camera in CI).

Stamps are ``time.time_ns()`` (CLOCK_REALTIME) taken when ``grab()`` returns, before the
image is decoded: OpenCV's ``CAP_PROP_POS_MSEC`` is not a reliable capture time on V4L2
(it is the driver's buffer time on some kernels, 0 or the frame count on others).
"""

from __future__ import annotations

import math
import os
import threading
import time

import cv2
import numpy as np

from appliance.acquire.driver import CameraInfo
from appliance.acquire.frame import DeviceLost, DeviceNotFound, FormatNotSupported, PermissionDenied

V4L2_FORMATS = ("MJPG", "YUYV")


def check_readable(path: str) -> None:
    """Raise :class:`DeviceNotFound` or :class:`PermissionDenied` (naming ``path``) before opening."""
    denied = PermissionDenied(f"{path}: permission denied (add the user to the 'video' group)")
    try:
        os.stat(path)
    except FileNotFoundError:
        raise DeviceNotFound(f"{path}: no such device (is the camera plugged in? `appliance devices` "
                             "lists them)") from None
    except PermissionError:
        raise denied from None
    if not os.access(path, os.R_OK | (os.W_OK if path.startswith("/dev/") else 0)):
        raise denied


def fourcc_text(value: float) -> str:
    """The four characters of an OpenCV FOURCC property value."""
    code = int(value)
    return "".join(chr((code >> (8 * i)) & 0xFF) for i in range(4)).strip("\x00 ") or "?"


class OpenCVCamera:
    """One camera (or a video file standing in for one) read through ``cv2.VideoCapture``.

    Parameters
    ----------
    source : str
        ``/dev/videoN`` (or a video file with ``api=cv2.CAP_FFMPEG``).
    width_px, height_px : int
        The full frame asked for (twice one camera's width for a side-by-side camera).
    fps_hz : float
        Frame rate asked for.
    pixel_format : "MJPG" | "YUYV"
        What the camera should send (decoded to BGR by OpenCV).
    open_timeout_s : float
        The first frame must arrive within this time, or :class:`DeviceNotFound`.
    api : int
        OpenCV capture API, ``cv2.CAP_V4L2`` for cameras.

    Raises
    ------
    DeviceNotFound, PermissionDenied, FormatNotSupported
        One line each, naming ``source``.
    """

    def __init__(self, source: str, width_px: int, height_px: int, fps_hz: float, pixel_format: str,
                 open_timeout_s: float, api: int = cv2.CAP_V4L2):
        if pixel_format not in V4L2_FORMATS:
            raise FormatNotSupported(f"{source}: camera.pixel_format {pixel_format} is not a V4L2 format "
                                     f"(use {' or '.join(V4L2_FORMATS)})")
        check_readable(source)
        # A stalled V4L2 read waits in select() for OPENCV_VIDEOIO_V4L_SELECT_TIMEOUT seconds
        # (default 10, read once per process): bound it by camera.open_timeout_s instead.
        os.environ.setdefault("OPENCV_VIDEOIO_V4L_SELECT_TIMEOUT", str(max(1, math.ceil(open_timeout_s))))
        self.name = source
        self._cap = None
        self.frames = 0
        cap = cv2.VideoCapture(source, api)
        if not cap.isOpened():  # OpenCV only warns on stderr
            raise DeviceNotFound(f"{source}: cannot be opened as a video capture device")
        cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*pixel_format))
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, width_px)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, height_px)
        cap.set(cv2.CAP_PROP_FPS, fps_hz)
        self._cap = cap
        got_format = fourcc_text(cap.get(cv2.CAP_PROP_FOURCC))
        first = self._first_frame(open_timeout_s)
        height, width = first[1].shape[:2]
        if (width, height) != (width_px, height_px) or got_format != pixel_format:
            self.close()
            raise FormatNotSupported(f"{source}: delivers {width}x{height} {got_format}, "
                                     f"not the {width_px}x{height_px} {pixel_format} asked for")
        self._pending: tuple[int, np.ndarray] | None = first
        fps = cap.get(cv2.CAP_PROP_FPS)
        self.info = CameraInfo(width, height, got_format, fps if fps > 0 else fps_hz)

    def _first_frame(self, timeout_s: float) -> tuple[int, np.ndarray]:
        # VideoCapture.read blocks (V4L2: up to its select timeout, whole seconds), so the
        # first frame is awaited in a thread to honour camera.open_timeout_s exactly.
        box: list = []
        worker = threading.Thread(target=lambda: box.append(self._grab()), daemon=True)
        worker.start()
        worker.join(timeout_s)
        if worker.is_alive() or not box or box[0] is None:
            if not worker.is_alive():
                self.close()
            raise DeviceNotFound(f"{self.name}: opened but delivered no frame within {timeout_s:g} s "
                                 "(camera.open_timeout_s)")
        return box[0]

    def _grab(self) -> tuple[int, np.ndarray] | None:
        if not self._cap.grab():
            return None
        stamp_ns = time.time_ns()
        ok, image = self._cap.retrieve()
        return (stamp_ns, image) if ok and image is not None else None

    def read(self) -> tuple[int, np.ndarray]:
        """The next ``(stamp_ns, BGR image)``; raises :class:`DeviceLost` when reading fails."""
        item, self._pending = self._pending, None
        if item is None:
            item = self._grab() if self._cap is not None else None
        if item is None:
            raise DeviceLost(f"{self.name}: stopped delivering frames after {self.frames} "
                             "(unplugged or failing?)")
        self.frames += 1
        return item

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None
