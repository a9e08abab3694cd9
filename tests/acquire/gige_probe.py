"""Run by test_gige.py inside a network namespace it makes (lo has 127.0.0.1 and 127.0.0.2), so
Aravis fake GigE cameras there never meet another test run's: prints what happened as JSON.

    python gige_probe.py grab FORMAT OUT.npz   one side-by-side camera on 127.0.0.1: 5 pairs saved to OUT.npz
    python gige_probe.py pair                  two cameras (127.0.0.1, 127.0.0.2) as one stereo pair: 16 pairs
    python gige_probe.py out-of-sync           the same with a zero skew allowed: OutOfSync
    python gige_probe.py lost                  one camera that stops mid-stream: DeviceLost
"""

import gc
import json
import sys

import numpy as np

from appliance.acquire import AcquireError, open_driver
from appliance.acquire.gige import load_aravis
from appliance.config import load_config

Aravis = load_aravis()
mode = sys.argv[1]
fakes = [Aravis.GvFakeCamera.new(address, serial) for address, serial in
         (("127.0.0.1", "LEFT01"), ("127.0.0.2", "RIGHT02"))]
if not all(f.is_running() for f in fakes):
    sys.exit("fake cameras did not start")
camera = {"width_px": 64, "height_px": 48, "pixel_format": "MONO8", "fps_hz": 25.0, "max_stereo_skew_ms": 5.0,
          "open_timeout_s": 1.0, "out_of_sync_frames": 6}
device, n = "gige:127.0.0.1,127.0.0.2", 8
if mode == "grab":
    camera.update(width_px=96, height_px=64, pixel_format=sys.argv[2], fps_hz=50.0)
    device, n = "gige:127.0.0.1", 5
elif mode == "lost":
    device = "gige:127.0.0.2"
elif mode == "out-of-sync":
    camera["max_stereo_skew_ms"] = 0.0
elif mode == "pair":
    # The two fakes run free on their own timers in this process; on a loaded machine their
    # frames jitter by several ms, so allow up to (but below) half the 40 ms frame period.
    camera["max_stereo_skew_ms"] = 15.0
    n = 16
cfg = load_config(overrides={"camera": camera}).camera
got, error = [], None
with open_driver(device, cfg) as driver:
    try:
        for frame in driver:
            got.append(frame)
            if mode == "lost" and len(got) == 2:
                del fakes[1]  # the camera goes away
                gc.collect()
            if len(got) == n:
                break
    except AcquireError as exc:
        error = f"{type(exc).__name__}: {exc}"
if mode == "grab":
    np.savez(sys.argv[3], left=np.stack([f.left for f in got]), right=np.stack([f.right for f in got]))
print(json.dumps({
    "info": [driver.info.driver, driver.info.width_px, driver.info.height_px, driver.info.pixel_format,
             list(driver.info.serials), driver.info.fps_hz],
    "error": error,
    "seq": [f.seq for f in got],
    "skew_ms": [(f.stamp_left_ns - f.stamp_right_ns) / 1e6 for f in got],
    "period_ms": [(b.stamp_ns - a.stamp_ns) / 1e6 for a, b in zip(got, got[1:])],
    "shapes": [list(f.left.shape) + list(f.right.shape) for f in got],
    "dropped": driver.dropped_pairs,
}))
