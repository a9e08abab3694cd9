"""The GigE driver against Aravis' own fake GigE Vision camera, speaking GVCP/GVSP over loopback.

Cameras are opened by address only; nothing here runs device discovery (a broadcast).
Skipped, with the reason, where Aravis or PyGObject is not installed (docs/acquire.md says how).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from appliance.acquire import AcquireError, DeviceNotFound, FormatNotSupported, open_driver

from .conftest import camera_cfg

try:
    from appliance.acquire.gige import load_aravis

    Aravis = load_aravis()
except AcquireError as exc:
    pytest.skip(f"GigE tests need Aravis: {exc}", allow_module_level=True)

W, H = 96, 64


@pytest.fixture(scope="module")
def fake_camera():
    """One fake GigE camera on 127.0.0.1 (GVCP port 3956), in this process."""
    fake = Aravis.GvFakeCamera.new("127.0.0.1", "APPL01")
    if not fake.is_running():
        pytest.fail("Aravis fake GigE camera could not listen on 127.0.0.1:3956 (port taken?)")
    yield fake
    del fake


def grab(pixel_format, n=4, fps_hz=50.0):
    cfg = camera_cfg(width_px=W, height_px=H, pixel_format=pixel_format, fps_hz=fps_hz)
    with open_driver("gige:127.0.0.1", cfg) as driver:
        frames = iter(driver)
        return driver.info, [next(frames) for _ in range(n)]


def test_mono8_side_by_side_split_and_stamps(fake_camera):
    info, frames = grab("MONO8", n=5)
    assert (info.driver, info.width_px, info.height_px, info.pixel_format) == ("gige", W, H, "Mono8")
    assert info.serials == ("APPL01",) and info.fps_hz == pytest.approx(50.0)
    assert [f.seq for f in frames] == [0, 1, 2, 3, 4]
    for f in frames:
        assert f.left.shape == f.right.shape == (H, W, 3) and f.left.dtype == np.uint8
        # the fake draws (x + y + frame) % 255: grey, +1 per column, and the right half goes on
        assert np.array_equal(f.left[..., 0], f.left[..., 2])
        assert int(f.right[0, 0, 0]) == (int(f.left[0, 0, 0]) + W) % 255
        row = f.left[3, :, 0].astype(int)
        assert np.all((np.diff(row) == 1) | (np.diff(row) == -254))
    periods_ms = np.diff([f.stamp_ns for f in frames[1:]]) / 1e6  # the first may have waited in a buffer
    assert np.all(np.abs(periods_ms - 20.0) < 8.0), periods_ms


def test_rgb8_becomes_bgr(fake_camera):
    _, frames = grab("RGB8", n=2)
    f = frames[-1]
    # The fake paints RGB8 with a jet colour map of (x + y + frame) % 255: along a row the hue
    # runs blue -> cyan -> green -> yellow -> red (OpenCV hue 120 -> 0), then wraps to blue.
    # Red and blue swapped would run it the other way.
    row = np.concatenate([f.left[:1], f.right[:1]], axis=1)  # (1, 2W, 3) BGR
    hue = cv2.cvtColor(row, cv2.COLOR_BGR2HSV)[0, :, 0].astype(int)
    steps = np.diff(hue)
    steps = steps[steps < 30]  # leave out the wrap from red back to blue
    assert np.all(steps <= 0) and -steps.sum() > 30


def test_bayer_is_demosaiced(fake_camera):
    _, frames = grab("BAYER_RG8", n=2)
    f = frames[-1]
    assert f.left.shape == (H, W, 3)
    assert np.abs(f.left[..., 0].astype(int) - f.left[..., 2]).mean() > 20  # colour, not grey


def test_errors_name_the_camera(fake_camera):
    with pytest.raises(FormatNotSupported, match=r"^gige:127.0.0.1: camera.pixel_format MJPG is not a GigE format"):
        open_driver("gige:127.0.0.1", camera_cfg(width_px=W, height_px=H, pixel_format="MJPG"))
    with pytest.raises(DeviceNotFound, match=r"^gige:127.0.0.9: no GigE Vision camera answers at 127.0.0.9"):
        open_driver("gige:127.0.0.9", camera_cfg(width_px=W, height_px=H, pixel_format="MONO8"))


def in_namespace(mode: str) -> dict:
    """Run gige_pair_probe.py MODE in a network namespace made here, where lo also has 127.0.0.2
    (the fake camera only listens on an address an interface has; two fakes need two)."""
    if not (shutil.which("unshare") and shutil.which("ip")):
        pytest.skip("needs unshare (util-linux) and ip (iproute2) to make a network namespace")
    probe = subprocess.run(["unshare", "--net", "true"], capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot make a network namespace here: {probe.stderr.strip()}")
    script = Path(__file__).with_name("gige_pair_probe.py")
    out = subprocess.run(
        ["unshare", "--net", "sh", "-c",
         'ip link set lo up && ip addr add 127.0.0.2/8 dev lo && exec "$0" "$@"', sys.executable, str(script), mode],
        capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_stereo_pair_of_two_cameras():
    got = in_namespace("pair")
    assert got["error"] is None
    assert got["info"] == ["gige-pair", 64, 48, "Mono8", ["LEFT01", "RIGHT02"]]
    assert got["seq"] == list(range(8))
    assert got["dropped"] <= 2, got  # a loaded machine may make a fake camera miss a frame now and then
    assert all(abs(s) <= 5.0 for s in got["skew_ms"])
    assert all(abs(p - 40.0) < 10.0 for p in got["period_ms"])
    assert got["shapes"] == [[48, 64, 3, 48, 64, 3]] * 8


def test_pair_never_within_skew_is_out_of_sync():
    got = in_namespace("out-of-sync")
    assert got["seq"] == [] and got["dropped"] >= 6
    assert got["error"] == ("OutOfSync: gige:127.0.0.1 and gige:127.0.0.2: 6 images in a row found no partner "
                            "within 0 ms (camera.max_stereo_skew_ms)")


def test_camera_gone_mid_stream_is_device_lost():
    got = in_namespace("lost")
    assert got["seq"][:2] == [0, 1]
    assert got["error"].startswith("DeviceLost: gige:127.0.0.2: no frame for 1 s after ")
