"""What every stereo driver delivers and how it fails."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Protocol

import numpy as np

from appliance.errors import ApplianceError


@dataclass(frozen=True, eq=False)
class StereoFrame:
    """One synchronised pair.

    Attributes
    ----------
    left, right : ndarray, shape (H, W, 3) uint8 BGR or (H, W) uint8 grey
        The two (unrectified) images.
    seq : int
        Pair number from the driver, counting from 0; gaps mean dropped pairs.
    stamp_left_ns, stamp_right_ns : int
        Capture times, ns (CLOCK_REALTIME or the recording's clock).
    """

    left: np.ndarray
    right: np.ndarray
    seq: int
    stamp_left_ns: int
    stamp_right_ns: int

    @property
    def stamp_ns(self) -> int:
        """The pair's stamp: the mean of the two capture times, ns."""
        return (self.stamp_left_ns + self.stamp_right_ns) // 2


@dataclass(frozen=True)
class DriverInfo:
    """What a driver is: for logs and `appliance devices`."""

    driver: str            # "v4l2", "v4l2-pair", "gige", "fake"
    device: str            # the device string it was opened with
    width_px: int          # one camera's image
    height_px: int
    pixel_format: str
    fps_hz: float
    serials: tuple[str, ...] = ()


class StereoDriver(Protocol):
    """A source of :class:`StereoFrame`. Use as a context manager, iterate for frames."""

    info: DriverInfo
    dropped_pairs: int  # pairs dropped for stamp skew, counted

    def __enter__(self) -> StereoDriver: ...
    def __exit__(self, *exc) -> None: ...
    def __iter__(self) -> Iterator[StereoFrame]: ...
    def close(self) -> None: ...


class AcquireError(ApplianceError):
    """Base of the typed driver failures."""


class InvalidDevice(AcquireError):
    """A device string that names no driver (``/dev/videoN``, ``gige:``, ``fake:``)."""


class DeviceNotFound(AcquireError):
    """The device does not exist, or delivers no frame within ``camera.open_timeout_s``."""


class PermissionDenied(AcquireError):
    """The device exists but this user may not read it."""


class FormatNotSupported(AcquireError):
    """The device refuses the requested pixel format, resolution or frame rate."""


class DeviceLost(AcquireError):
    """The device stopped delivering mid-stream (the run loop reconnects)."""


class OutOfSync(AcquireError):
    """Left and right can no longer be paired within the allowed skew."""
