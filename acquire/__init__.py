"""Stereo drivers behind one interface: V4L2, GigE Vision, and a fake that replays recordings.

    with open_driver("fake:fixtures/scenes", cfg.camera) as drv:
        for frame in drv: ...
"""

from appliance.acquire.device import DeviceSpec, parse_device
from appliance.acquire.frame import (
    AcquireError, DeviceLost, DeviceNotFound, DriverInfo, FormatNotSupported, InvalidDevice, OutOfSync,
    PermissionDenied, StereoDriver, StereoFrame,
)
from appliance.acquire.open import check_device, open_driver

__all__ = [
    "AcquireError", "DeviceLost", "DeviceNotFound", "DeviceSpec", "DriverInfo", "FormatNotSupported",
    "InvalidDevice", "OutOfSync", "PermissionDenied", "StereoDriver", "StereoFrame", "check_device", "open_driver",
    "parse_device",
]
