"""Run inside a network namespace (see test_gige.py): two Aravis fake GigE cameras on 127.0.0.1
and 127.0.0.2, opened as one stereo pair by address; prints what the driver delivered as JSON."""

import json
import sys

from appliance.acquire import open_driver
from appliance.acquire.gige import load_aravis
from appliance.config import load_config

Aravis = load_aravis()
fakes = [Aravis.GvFakeCamera.new(address, serial) for address, serial in
         (("127.0.0.1", "LEFT01"), ("127.0.0.2", "RIGHT02"))]
if not all(f.is_running() for f in fakes):
    sys.exit("fake cameras did not start")
cfg = load_config(overrides={"camera": {"width_px": 64, "height_px": 48, "pixel_format": "MONO8",
                                        "fps_hz": 25.0, "max_stereo_skew_ms": 5.0}}).camera
with open_driver("gige:127.0.0.1,127.0.0.2", cfg) as driver:
    frames = iter(driver)
    got = [next(frames) for _ in range(8)]
print(json.dumps({
    "info": [driver.info.driver, driver.info.width_px, driver.info.height_px, driver.info.pixel_format,
             list(driver.info.serials)],
    "seq": [f.seq for f in got],
    "skew_ms": [(f.stamp_left_ns - f.stamp_right_ns) / 1e6 for f in got],
    "period_ms": [(b.stamp_ns - a.stamp_ns) / 1e6 for a, b in zip(got, got[1:])],
    "shapes": [list(f.left.shape) + list(f.right.shape) for f in got],
    "dropped": driver.dropped_pairs,
}))
