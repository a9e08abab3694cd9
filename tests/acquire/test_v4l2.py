"""The V4L2 driver's code path (OpenCVCamera + SideBySideDriver), run through VideoCapture on a
side-by-side video file: CI has no camera, but the open checks, the read and the split are the same."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
import cv2
import pytest

from appliance.acquire import DeviceLost, DeviceNotFound, FormatNotSupported, PermissionDenied, open_driver
from appliance.acquire.driver import PairedDriver, SideBySideDriver
from appliance.acquire.v4l2 import OpenCVCamera

from .conftest import H, W, camera_cfg, level, pair_number


def open_file(path, width_px=2 * W, height_px=H, pixel_format="MJPG", timeout_s=2.0):
    return OpenCVCamera(str(path), width_px, height_px, 30.0, pixel_format, timeout_s, api=cv2.CAP_FFMPEG)


def test_side_by_side_frames_are_split_in_order_then_device_lost(sbs_video):
    driver = SideBySideDriver(open_file(sbs_video), str(sbs_video), "v4l2")
    assert (driver.info.width_px, driver.info.height_px, driver.info.pixel_format) == (W, H, "MJPG")
    frames = []
    with driver, pytest.raises(DeviceLost, match="sbs.avi: stopped delivering frames after 6"):
        for frame in driver:
            frames.append(frame)
    assert [f.seq for f in frames] == list(range(6))
    assert [pair_number(f.left) for f in frames] == list(range(6))
    for i, f in enumerate(frames):
        assert f.left.shape == f.right.shape == (H, W, 3)
        assert abs(level(f.right) - (220 - 20 * i)) < 6    # right half went to the right image
        assert f.left[10, 10].min() > 240 and f.right[10, 10].max() < 230
        assert f.stamp_left_ns == f.stamp_right_ns
    stamps = [f.stamp_ns for f in frames]
    assert stamps == sorted(stamps) and abs(stamps[0] / 1e9 - __import__("time").time()) < 60


def test_left_half_can_be_the_right_camera(sbs_video):
    with SideBySideDriver(open_file(sbs_video), str(sbs_video), "v4l2", left_half="right") as driver:
        frame = next(iter(driver))
    assert abs(level(frame.left) - 220) < 6 and frame.right[10, 10].min() > 240


def test_wrong_resolution_is_format_not_supported(sbs_video):
    with pytest.raises(FormatNotSupported, match=r"sbs.avi: delivers 192x64 MJPG, not the 2560x960 MJPG asked for"):
        open_file(sbs_video, width_px=2560, height_px=960)


def test_wrong_pixel_format_is_format_not_supported(sbs_video):
    with pytest.raises(FormatNotSupported, match="delivers 192x64 MJPG, not the 192x64 YUYV"):
        open_file(sbs_video, pixel_format="YUYV")
    with pytest.raises(FormatNotSupported, match="MONO8 is not a V4L2 format"):
        open_file(sbs_video, pixel_format="MONO8")


def test_something_that_delivers_no_frame_is_not_found(tmp_path):
    junk = tmp_path / "junk.avi"
    junk.write_bytes(b"\0" * 1000)
    with pytest.raises(DeviceNotFound, match="junk.avi: "):
        open_file(junk)


def test_missing_device_is_named():
    with pytest.raises(DeviceNotFound) as err:
        open_driver("/dev/video9", camera_cfg())
    assert str(err.value).startswith("/dev/video9: no such device")
    assert "\n" not in str(err.value)
    with pytest.raises(DeviceNotFound, match="^/dev/video8: no such device"):
        open_driver("/dev/video8,/dev/video9", camera_cfg())


def test_unreadable_device_is_permission_denied(sbs_video, tmp_path_factory):
    folder = tmp_path_factory.mktemp("open")
    folder.chmod(0o755)
    for parent in folder.parents:  # pytest's base folder is private to its user
        if parent == Path(tempfile.gettempdir()):
            break
        parent.chmod(parent.stat().st_mode | 0o111)
    sbs_video = shutil.copy(sbs_video, folder / "sbs.avi")
    sbs_video.chmod(0o600)
    if os.geteuid() != 0:
        sbs_video.chmod(0)
        with pytest.raises(PermissionDenied, match="sbs.avi: permission denied"):
            open_file(sbs_video)
        return
    # root reads anything: try it in a forked child that drops to the unprivileged 'nobody'
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # child
        try:
            os.setgid(65534)
            os.setuid(65534)
            open_file(sbs_video)
            message = "opened"
        except Exception as exc:  # noqa: BLE001 - reported to the parent
            message = f"{type(exc).__name__} {exc}"
        os.write(write_end, message.encode())
        os._exit(0)
    os.close(write_end)
    os.waitpid(pid, 0)
    message = os.read(read_end, 4096).decode()
    os.close(read_end)
    assert message == f"PermissionDenied {sbs_video}: permission denied (add the user to the 'video' group)"


def test_two_cameras_pair_by_stamp(sbs_video, tmp_path):
    # Two captures read by their own threads, paired by nearest stamp (a generous skew: files
    # are read as fast as possible, so this checks the plumbing, tests/acquire/test_pairing.py the rule).
    left = OpenCVCamera(str(sbs_video), 2 * W, H, 30.0, "MJPG", 2.0, api=cv2.CAP_FFMPEG)
    right = OpenCVCamera(str(sbs_video), 2 * W, H, 30.0, "MJPG", 2.0, api=cv2.CAP_FFMPEG)
    with PairedDriver(left, right, "a,b", "v4l2-pair", max_skew_ms=1000.0, out_of_sync_frames=30,
                      timeout_s=2.0) as driver:
        frames = []
        with pytest.raises(DeviceLost, match="stopped delivering frames after 6"):
            for frame in driver:
                frames.append(frame)
    assert 1 <= len(frames) <= 6 and len(frames) * 2 + driver.dropped_pairs <= 12
    assert [f.seq for f in frames] == list(range(len(frames)))
    assert all(abs(f.stamp_left_ns - f.stamp_right_ns) <= 1e9 for f in frames)
    assert driver.info.driver == "v4l2-pair" and driver.info.width_px == 2 * W
