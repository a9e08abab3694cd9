"""Run by the tests as a process: log 30 pairs/s (with results) until killed.

    python endless_writer.py OUT.mcap [key=value ...]   (logging config overrides, YAML values)

Prints "seq stamp_left_ns" after each pair is handed to the writer.
"""

import sys
import time

import yaml

from appliance.acquire import StereoFrame
from appliance.config import load_config
from appliance.logs import LogWriter

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from conftest import CAMERA_TO_BASE, frame_images, make_calibration, make_result  # noqa: E402

overrides = dict(kv.split("=", 1) for kv in sys.argv[2:])
cfg = load_config(overrides={"logging": {k: yaml.safe_load(v) for k, v in overrides.items()}})
with LogWriter(sys.argv[1], cfg.logging, calibration=make_calibration(), device="fake:endless",
               version="test") as writer:
    start = time.monotonic()
    seq = 0
    while True:
        left, right = frame_images(seq % 50)
        stamp = time.time_ns()
        writer.write_frame(StereoFrame(left, right, seq, stamp, stamp))
        writer.write_result(make_result(seq), seq, CAMERA_TO_BASE)
        print(seq, stamp, writer.stop_reason or "", flush=True)
        seq += 1
        time.sleep(max(0.0, start + seq / 30 - time.monotonic()))
