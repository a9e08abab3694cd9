"""``open_driver``: the one entry point from a device string to a running stereo driver."""

from __future__ import annotations

from pathlib import Path

from appliance.acquire.device import parse_device
from appliance.acquire.driver import PairedDriver, SideBySideDriver
from appliance.acquire.frame import DeviceNotFound, StereoDriver


def check_device(device: str) -> None:
    """Raise the error :func:`open_driver` would give for a device that is not there, without opening it.

    Cheap (no camera is touched, no network is used), so that a caller with slow set-up to do (the run
    loop's localizer loads its kernels) can report a typo'd device first. It checks the string, that each
    ``/dev/videoN`` exists and can be read, and that a ``fake:`` path exists; a GigE camera is only
    found by opening it.

    Raises
    ------
    InvalidDevice, DeviceNotFound, PermissionDenied
        One line naming the device.
    """
    spec = parse_device(device)
    if spec.kind == "v4l2":
        from appliance.acquire.v4l2 import check_readable

        for target in spec.targets:
            check_readable(target)
    elif spec.kind == "fake" and not Path(spec.targets[0]).exists():
        raise DeviceNotFound(f"fake:{spec.targets[0]}: no such folder or file")


def open_driver(device: str, cfg, *, api: int | None = None) -> StereoDriver:
    """Open the stereo driver that ``device`` names.

    Parameters
    ----------
    device : str
        ``/dev/videoN`` | ``/dev/videoN,/dev/videoM`` | ``gige:ADDRESS[,ADDRESS]`` | ``fake:PATH``.
    cfg : CameraConfig
        ``width_px``/``height_px`` are ONE camera's image; a side-by-side camera is asked
        for twice the width.
    api : int, optional
        OpenCV capture API for V4L2 sources (default ``cv2.CAP_V4L2``).

    Returns
    -------
    StereoDriver
        A context manager; iterate it for :class:`StereoFrame`.

    Raises
    ------
    InvalidDevice, DeviceNotFound, PermissionDenied, FormatNotSupported, AcquireError
        One line naming the device.
    """
    spec = parse_device(device)
    if spec.kind == "fake":
        from appliance.acquire.fake import FakeDriver

        return FakeDriver(spec.targets[0], cfg)
    if spec.kind == "v4l2":
        import cv2

        from appliance.acquire.v4l2 import OpenCVCamera

        def camera(target, width_px):
            return OpenCVCamera(target, width_px, cfg.height_px, cfg.fps_hz, cfg.pixel_format,
                                cfg.open_timeout_s, api=cv2.CAP_V4L2 if api is None else api)
    else:
        from appliance.acquire.gige import AravisCamera

        def camera(target, width_px):
            return AravisCamera(target, width_px, cfg.height_px, cfg.fps_hz, cfg.pixel_format,
                                cfg.open_timeout_s)

    driver = f"{spec.kind}-pair" if spec.paired else spec.kind
    if not spec.paired:
        return SideBySideDriver(camera(spec.targets[0], 2 * cfg.width_px), device, driver,
                                cfg.side_by_side_left_half)
    left = camera(spec.targets[0], cfg.width_px)
    try:
        right = camera(spec.targets[1], cfg.width_px)
    except BaseException:
        left.close()
        raise
    return PairedDriver(left, right, device, driver, cfg.max_stereo_skew_ms, cfg.out_of_sync_frames,
                        cfg.open_timeout_s)
