"""List the V4L2 devices present, from sysfs, with the formats they offer.

Names and drivers come from ``/sys/class/video4linux/videoN`` (no device is opened for
them); formats and frame sizes from the V4L2 ioctls VIDIOC_ENUM_FMT / VIDIOC_ENUM_FRAMESIZES
on ``/dev/videoN`` (read-only, the camera is not started).
"""

from __future__ import annotations

import fcntl
import os
import re
import struct
from dataclasses import dataclass
from pathlib import Path

SYSFS_ROOT = Path("/sys/class/video4linux")
DEV_ROOT = Path("/dev")

_V4L2_BUF_TYPE_VIDEO_CAPTURE = 1
_V4L2_FRMSIZE_TYPE_DISCRETE = 1
_FMTDESC = struct.Struct("=III32sII12x")  # struct v4l2_fmtdesc: 64 bytes
_FRMSIZE = struct.Struct("=III24s8x")     # struct v4l2_frmsizeenum: 44 bytes


def _iowr(nr: int, size: int) -> int:
    return (3 << 30) | (size << 16) | (ord("V") << 8) | nr


VIDIOC_ENUM_FMT = _iowr(2, _FMTDESC.size)
VIDIOC_ENUM_FRAMESIZES = _iowr(74, _FRMSIZE.size)


@dataclass(frozen=True)
class V4L2Device:
    """One ``/dev/videoN`` node.

    Attributes
    ----------
    node : str
        ``/dev/videoN``.
    name : str
        The card name the driver reports (``/sys/.../name``).
    driver : str
        Kernel driver (``uvcvideo`` for USB cameras), "" when sysfs does not say.
    index : int
        Node index within its device (a UVC camera's capture node is 0, its metadata node 1).
    formats : tuple of str
        ``"MJPG 2560x960 1280x480"`` per capture format (FOURCC, discrete sizes).
    problem : str
        Why formats are missing ("" when they were read).
    """

    node: str
    name: str
    driver: str
    index: int
    formats: tuple[str, ...]
    problem: str = ""


def list_v4l2_devices(sysfs_root: str | Path = SYSFS_ROOT,
                      dev_root: str | Path = DEV_ROOT) -> list[V4L2Device]:
    """The V4L2 devices under ``sysfs_root`` (empty when there are none), by number."""
    root = Path(sysfs_root)
    if not root.is_dir():
        return []
    entries = [p for p in root.iterdir() if re.fullmatch(r"video\d+", p.name)]
    devices = []
    for entry in sorted(entries, key=lambda p: int(p.name[5:])):
        node = Path(dev_root) / entry.name
        driver_link = entry / "device" / "driver"
        driver = os.path.basename(os.path.realpath(driver_link)) if driver_link.exists() else ""
        try:
            formats, problem = enum_formats(node), ""
        except OSError as exc:
            formats, problem = (), f"formats unknown: {node}: {exc.strerror or exc}"
        devices.append(V4L2Device(str(node), _read(entry / "name"), driver,
                                  int(_read(entry / "index") or 0), formats, problem))
    return devices


def enum_formats(node: str | Path) -> tuple[str, ...]:
    """Capture formats of a V4L2 node: ``"FOURCC WxH WxH ..."`` each (raises OSError)."""
    fd = os.open(node, os.O_RDONLY | os.O_NONBLOCK)
    try:
        formats = []
        for index in range(64):
            buf = bytearray(_FMTDESC.pack(index, _V4L2_BUF_TYPE_VIDEO_CAPTURE, 0, b"", 0, 0))
            if not _ioctl(fd, VIDIOC_ENUM_FMT, buf):
                break
            fourcc = _FMTDESC.unpack(buf)[4]
            text = fourcc.to_bytes(4, "little").decode("ascii", "replace").strip()
            formats.append(" ".join([text, *_frame_sizes(fd, fourcc)]))
        return tuple(formats)
    finally:
        os.close(fd)


def _frame_sizes(fd: int, fourcc: int) -> list[str]:
    sizes = []
    for index in range(64):
        buf = bytearray(_FRMSIZE.pack(index, fourcc, 0, b""))
        if not _ioctl(fd, VIDIOC_ENUM_FRAMESIZES, buf):
            break
        _, _, kind, data = _FRMSIZE.unpack(buf)
        if kind != _V4L2_FRMSIZE_TYPE_DISCRETE:
            break  # stepwise/continuous: any size within bounds; not listed
        width, height = struct.unpack_from("=II", data)
        sizes.append(f"{width}x{height}")
    return sizes


def _ioctl(fd: int, request: int, buf: bytearray) -> bool:
    """True when the ioctl filled ``buf``; False at the end of an enumeration (EINVAL)."""
    try:
        fcntl.ioctl(fd, request, buf)
        return True
    except OSError as exc:
        if exc.errno == 22:  # EINVAL: index past the last entry
            return False
        raise


def _read(path: Path) -> str:
    try:
        return path.read_text().strip()
    except OSError:
        return ""
