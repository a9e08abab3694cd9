"""The GigE driver against Aravis' own fake GigE Vision camera, speaking GVCP/GVSP over loopback.

Cameras are opened by address only; nothing here runs device discovery (a broadcast). The fake
cameras run in a network namespace each test makes (gige_probe.py): two fakes need two addresses
(the fake only listens on an address an interface has), and a fake on the machine's own 127.0.0.1
would answer another test run's driver (both bind port 3956). Skipped, with the reason, where Aravis
or PyGObject is not installed (docs/acquire.md says how) or no namespace can be made.
"""

from __future__ import annotations

import json
import os
import re
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

    load_aravis()
except AcquireError as exc:
    pytest.skip(f"GigE tests need Aravis: {exc}", allow_module_level=True)

W, H = 96, 64
PROBE = Path(__file__).with_name("gige_probe.py")


def in_namespace(*args: str) -> dict:
    """Run gige_probe.py ARGS in a new network namespace whose lo has 127.0.0.1 and 127.0.0.2."""
    unshare = ["unshare", "--net"] if os.geteuid() == 0 else ["unshare", "--user", "--map-root-user", "--net"]
    if not (shutil.which("unshare") and shutil.which("ip")):
        pytest.skip("needs unshare (util-linux) and ip (iproute2) to make a network namespace")
    probe = subprocess.run([*unshare, "true"], capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot make a network namespace here: {probe.stderr.strip()}")
    out = subprocess.run(
        [*unshare, "sh", "-c", 'ip link set lo up && ip addr add 127.0.0.2/8 dev lo && exec "$0" "$@"',
         sys.executable, str(PROBE), *args],
        capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def grab(pixel_format: str, tmp_path: Path):
    got = in_namespace("grab", pixel_format, str(tmp_path / "frames.npz"))
    assert got["error"] is None
    frames = np.load(tmp_path / "frames.npz")
    return got, frames["left"], frames["right"]


def test_mono8_side_by_side_split_and_stamps(tmp_path):
    got, left, right = grab("MONO8", tmp_path)
    assert got["info"] == ["gige", W, H, "Mono8", ["LEFT01"], pytest.approx(50.0)]
    assert got["seq"] == [0, 1, 2, 3, 4] and got["skew_ms"] == [0.0] * 5
    assert left.shape == right.shape == (5, H, W, 3) and left.dtype == np.uint8
    # the fake draws (x + y + frame) % 255: grey, +1 per column, and the right half goes on
    assert np.array_equal(left[..., 0], left[..., 2])
    assert np.array_equal(right[:, 0, 0, 0].astype(int), (left[:, 0, 0, 0].astype(int) + W) % 255)
    steps = np.diff(left[:, 3, :, 0].astype(int), axis=1)
    assert np.all((steps == 1) | (steps == -254))
    # Stamps are the host's arrival times in ns: they increase, at 50 frames/s on average (not 25:
    # every other frame lost; not 100). Single periods jitter by 5-10 ms on a loaded machine (the fake
    # camera's timer thread wakes late, a frame waits in a buffer), so only the mean is bounded.
    periods_ms = np.array(got["period_ms"])
    assert np.all(periods_ms > 0) and abs(periods_ms.mean() - 20.0) < 6.0, periods_ms


def test_rgb8_becomes_bgr(tmp_path):
    _, left, right = grab("RGB8", tmp_path)
    # The fake paints RGB8 with a jet colour map of (x + y + frame) % 255: along a row the hue
    # runs blue -> cyan -> green -> yellow -> red (OpenCV hue 120 -> 0), then wraps to blue.
    # Red and blue swapped would run it the other way.
    row = np.concatenate([left[-1, :1], right[-1, :1]], axis=1)  # (1, 2W, 3) BGR
    hue = cv2.cvtColor(row, cv2.COLOR_BGR2HSV)[0, :, 0].astype(int)
    steps = np.diff(hue)
    steps = steps[steps < 30]  # leave out the wrap from red back to blue
    assert np.all(steps <= 0) and -steps.sum() > 30


def test_bayer_is_demosaiced(tmp_path):
    got, left, _ = grab("BAYER_RG8", tmp_path)
    assert got["info"][3] == "BayerRG8" and left.shape == (5, H, W, 3)
    assert np.abs(left[..., 0].astype(int) - left[..., 2]).mean() > 20  # colour, not grey


def test_errors_name_the_camera():
    with pytest.raises(FormatNotSupported, match=r"^gige:127.0.0.1: camera.pixel_format MJPG is not a GigE format"):
        open_driver("gige:127.0.0.1", camera_cfg(width_px=W, height_px=H, pixel_format="MJPG"))
    with pytest.raises(DeviceNotFound, match=r"^gige:127.0.0.9: no GigE Vision camera answers at 127.0.0.9"):
        open_driver("gige:127.0.0.9", camera_cfg(width_px=W, height_px=H, pixel_format="MONO8"))


def test_stereo_pair_of_two_cameras():
    got = in_namespace("pair")
    assert got["error"] is None
    assert got["info"] == ["gige-pair", 64, 48, "Mono8", ["LEFT01", "RIGHT02"], pytest.approx(25.0)]
    assert got["seq"] == list(range(16))
    # On a loaded machine a fake camera misses a frame now and then: its partner is dropped
    # (counted) and that pair comes a whole frame period (40 ms) late; most images still pair.
    assert got["dropped"] < len(got["seq"]), got
    assert all(abs(s) <= 15.0 for s in got["skew_ms"]), got
    # Each pair is a new frame (never one frame twice: > half a period apart), and pairs come on the
    # 40 ms grid (the median off-grid time; single periods jitter by 10 ms and more under load).
    periods = np.array(got["period_ms"])
    frames_apart = np.maximum(np.round(periods / 40.0), 1)
    assert np.all(periods > 20.0) and np.median(np.abs(periods - 40.0 * frames_apart)) < 5.0, periods
    assert got["shapes"] == [[48, 64, 3, 48, 64, 3]] * 16


def test_pair_never_within_skew_is_out_of_sync():
    got = in_namespace("out-of-sync")
    assert got["seq"] == [] and got["dropped"] >= 6
    # at least 6: images that arrive together (a loaded machine) are all dropped before the check
    m = re.fullmatch(r"OutOfSync: gige:127\.0\.0\.1 and gige:127\.0\.0\.2: (\d+) images in a row found no "
                     r"partner within 0 ms \(camera\.max_stereo_skew_ms\)", got["error"])
    assert m and int(m[1]) >= 6, got["error"]


def test_camera_gone_mid_stream_is_device_lost():
    got = in_namespace("lost")
    assert got["seq"][:2] == [0, 1]
    assert got["error"].startswith("DeviceLost: gige:127.0.0.2: no frame for 1 s after ")
