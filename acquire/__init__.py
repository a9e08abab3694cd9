"""Stereo drivers behind one interface: V4L2, GigE Vision, and a fake that replays recordings."""

from appliance.acquire.frame import (
    AcquireError, DeviceLost, DeviceNotFound, DriverInfo, FormatNotSupported, OutOfSync,
    PermissionDenied, StereoDriver, StereoFrame,
)

__all__ = [
    "AcquireError", "DeviceLost", "DeviceNotFound", "DriverInfo", "FormatNotSupported",
    "OutOfSync", "PermissionDenied", "StereoDriver", "StereoFrame",
]
