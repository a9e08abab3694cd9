"""The two ways a stereo pair is made from cameras: one side-by-side camera, or two paired by stamp.

A *camera* here is anything with ``name`` (for messages), ``info`` (``width_px``, ``height_px``,
``pixel_format``, ``fps_hz``, ``serial``), ``read() -> (stamp_ns, image)`` (raises
:class:`DeviceLost`) and ``close()``: :class:`appliance.acquire.v4l2.OpenCVCamera` and
:class:`appliance.acquire.gige.AravisCamera`.
"""

from __future__ import annotations

import queue
import threading
import time
from dataclasses import dataclass
from typing import Iterator, Protocol

import numpy as np

from appliance.acquire.frame import AcquireError, DeviceLost, DriverInfo, OutOfSync, StereoFrame
from appliance.acquire.images import split_side_by_side
from appliance.acquire.pairing import StampPairer


@dataclass(frozen=True)
class CameraInfo:
    """What one camera delivers."""

    width_px: int
    height_px: int
    pixel_format: str
    fps_hz: float
    serial: str = ""


class Camera(Protocol):
    name: str
    info: CameraInfo

    def read(self) -> tuple[int, np.ndarray]: ...
    def close(self) -> None: ...


class DriverBase:
    """Context manager and the counters every driver has."""

    info: DriverInfo
    dropped_pairs: int = 0

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError


class SideBySideDriver(DriverBase):
    """One camera whose frames hold both images side by side (split in halves).

    Both images share the camera's capture stamp, so no pair is ever dropped for skew.
    """

    def __init__(self, camera: Camera, device: str, driver: str, left_half: str = "left"):
        self.camera = camera
        self.left_half = left_half
        c = camera.info
        self.info = DriverInfo(driver, device, c.width_px // 2, c.height_px, c.pixel_format, c.fps_hz,
                               (c.serial,) if c.serial else ())
        self.dropped_pairs = 0

    def __iter__(self) -> Iterator[StereoFrame]:
        seq = 0
        while True:
            stamp_ns, image = self.camera.read()
            left, right = split_side_by_side(image, self.left_half)
            yield StereoFrame(left, right, seq, stamp_ns, stamp_ns)
            seq += 1

    def close(self) -> None:
        self.camera.close()


class PairedDriver(DriverBase):
    """Two cameras, each read by its own thread, paired by nearest capture stamp.

    Parameters
    ----------
    left, right : Camera
    device, driver : str
        For :class:`DriverInfo`.
    max_skew_ms : float
        Pairs further apart are dropped and counted in ``dropped_pairs`` (one per image dropped).
    out_of_sync_frames : int
        This many images dropped in a row, with no pair between, raise :class:`OutOfSync`.
    timeout_s : float
        No image from either camera for this long: the camera's own error, or DeviceLost.
    """

    def __init__(self, left: Camera, right: Camera, device: str, driver: str, max_skew_ms: float,
                 out_of_sync_frames: int, timeout_s: float):
        self.cameras = (left, right)
        self.pairer = StampPairer(int(max_skew_ms * 1e6))
        self.out_of_sync_frames = out_of_sync_frames
        self.timeout_s = timeout_s
        l, r = left.info, right.info
        self.info = DriverInfo(driver, device, l.width_px, l.height_px, l.pixel_format,
                               min(l.fps_hz, r.fps_hz), tuple(c.serial for c in (l, r) if c.serial))
        self._queue: queue.Queue = queue.Queue(maxsize=16)
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._reader, args=(side,), daemon=True, name=f"acquire-{cam.name}")
                         for side, cam in enumerate(self.cameras)]
        for t in self._threads:
            t.start()

    @property
    def dropped_pairs(self) -> int:
        """Images dropped for skew (the start-up backlog of the camera opened first is not counted)."""
        return self.pairer.dropped

    def _reader(self, side: int) -> None:
        camera = self.cameras[side]
        while not self._stop.is_set():
            try:
                item = (side, *camera.read(), None)
            except AcquireError as exc:
                item = (side, 0, None, exc)
            while not self._stop.is_set():
                try:
                    self._queue.put(item, timeout=0.1)
                    break
                except queue.Full:
                    continue
            if item[3] is not None:
                return

    def __iter__(self) -> Iterator[StereoFrame]:
        seq = 0
        names = " and ".join(c.name for c in self.cameras)
        failed: tuple[int, AcquireError] | None = None   # (side, error) of a camera that failed
        deadline = 0.0
        while True:
            try:
                wait_s = self.timeout_s if failed is None else max(0.0, deadline - time.monotonic())
                side, stamp_ns, image, error = self._queue.get(timeout=wait_s)
            except queue.Empty:
                if failed is not None:
                    raise failed[1] from None
                raise DeviceLost(f"{names}: no image for {self.timeout_s:g} s from either camera") from None
            if failed is not None and side == failed[0]:
                continue
            if error is not None:
                if failed is not None:
                    raise failed[1]
                # The camera's own typed error (DeviceLost ...): first pair what the other camera
                # still delivers within the skew (its reader may lag behind), then raise it.
                if not self.pairer.pending(side):
                    raise error
                failed, deadline = (side, error), time.monotonic() + self.pairer.max_skew_ns / 1e9
                continue
            self.pairer.push(side, stamp_ns, image)
            for (stamp_l, left), (stamp_r, right) in self.pairer.pop():
                yield StereoFrame(left, right, seq, stamp_l, stamp_r)
                seq += 1
            if failed is not None and not self.pairer.pending(failed[0]):
                raise failed[1]                             # nothing left to pair
            if self.pairer.dropped_in_row >= self.out_of_sync_frames:
                raise OutOfSync(f"{names}: {self.pairer.dropped_in_row} images in a row found no partner "
                                f"within {self.pairer.max_skew_ns / 1e6:g} ms (camera.max_stereo_skew_ms)")

    def close(self) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(timeout=5.0)
        for camera in self.cameras:
            camera.close()
