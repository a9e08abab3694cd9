"""Parse a device string into the driver it names.

``/dev/video0``               one UVC camera delivering side-by-side frames
``/dev/video0,/dev/video2``   two V4L2 cameras, paired by timestamp
``gige:ADDRESS[,ADDRESS]``    one side-by-side GigE Vision camera, or two paired by timestamp
``fake:PATH``                 replay a folder of pairs, a side-by-side video or an appliance MCAP log
"""

from __future__ import annotations

import ipaddress
import re
from dataclasses import dataclass
from typing import Literal

from appliance.acquire.frame import InvalidDevice

_V4L2 = re.compile(r"/dev/video\d+|/dev/v4l/by-(id|path)/\S+")
_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9.\-]*[A-Za-z0-9])?")

USAGE = "/dev/videoN | /dev/videoN,/dev/videoM | gige:ADDRESS[,ADDRESS] | fake:PATH"


@dataclass(frozen=True)
class DeviceSpec:
    """What a device string names.

    Attributes
    ----------
    kind : "v4l2" | "gige" | "fake"
    targets : tuple of str
        One entry: a side-by-side camera (or the replayed path). Two: left and right cameras.
    """

    kind: Literal["v4l2", "gige", "fake"]
    targets: tuple[str, ...]

    @property
    def paired(self) -> bool:
        """True when two cameras are paired by timestamp."""
        return len(self.targets) == 2


def parse_device(device: str) -> DeviceSpec:
    """Parse ``device``; raise :class:`InvalidDevice` (one line, naming it) when it is garbage."""
    text = device.strip() if isinstance(device, str) else ""
    if text.startswith("fake:"):
        path = text[len("fake:"):]
        if not path:
            raise InvalidDevice(f"device {device!r}: fake: needs a path "
                                "(fake:FOLDER, fake:VIDEO or fake:LOG.mcap)")
        return DeviceSpec("fake", (path,))
    if text.startswith("gige:"):
        addresses = _split(device, text[len("gige:"):])
        for address in addresses:
            if not _is_host(address):
                raise InvalidDevice(f"device {device!r}: {address!r} is not an IP address or host name")
        return DeviceSpec("gige", addresses)
    if text.startswith("/dev/"):
        paths = _split(device, text)
        for path in paths:
            if not _V4L2.fullmatch(path):
                raise InvalidDevice(f"device {device!r}: {path!r} is not a V4L2 device (/dev/videoN)")
        return DeviceSpec("v4l2", paths)
    raise InvalidDevice(f"device {device!r}: not a device string; expected {USAGE}")


def _split(device: str, text: str) -> tuple[str, ...]:
    parts = tuple(p.strip() for p in text.split(","))
    if not 1 <= len(parts) <= 2 or not all(parts):
        raise InvalidDevice(f"device {device!r}: give one camera or two separated by a comma")
    if len(parts) == 2 and parts[0] == parts[1]:
        raise InvalidDevice(f"device {device!r}: left and right name the same camera")
    return parts


def _is_host(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
        return True
    except ValueError:
        return bool(_HOST.fullmatch(text)) and not text.replace(".", "").isdigit()
