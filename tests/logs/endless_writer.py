"""Run by the tests as a process: log pairs (with results) until killed, or ``frames`` of them.

    python endless_writer.py OUT [frames=N] [rate_hz=R] [key=value ...]

Other ``key=value`` are logging config overrides (YAML values). ``rate_hz`` (default 30) <= 0
writes as fast as possible. Prints "seq stamp_left_ns stop_reason" after each pair is handed
to the writer and, when ``frames`` are done, "done <stats as JSON>".
"""

import dataclasses
import json
import sys
import time

import yaml

from appliance.acquire import StereoFrame
from appliance.config import load_config
from appliance.logs import LogWriter

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from conftest import CAMERA_TO_BASE, frame_images, make_calibration, make_result  # noqa: E402

options = {k: yaml.safe_load(v) for k, v in (kv.split("=", 1) for kv in sys.argv[2:])}
frames, rate_hz = options.pop("frames", None), options.pop("rate_hz", 30)
cfg = load_config(overrides={"logging": options})
with LogWriter(sys.argv[1], cfg.logging, calibration=make_calibration(), device="fake:endless",
               version="test") as writer:
    start = time.monotonic()
    seq = 0
    while frames is None or seq < frames:
        left, right = frame_images(seq % 50)
        stamp = time.time_ns()
        writer.write_frame(StereoFrame(left, right, seq, stamp, stamp))
        writer.write_result(dataclasses.replace(make_result(seq), stamp_ns=stamp), seq, CAMERA_TO_BASE)
        print(seq, stamp, writer.stop_reason or "", flush=True)
        seq += 1
        if rate_hz > 0:
            time.sleep(max(0.0, start + seq / rate_hz - time.monotonic()))
print("done", json.dumps({**writer.stats(), "paths": [str(p) for p in writer.paths]}), flush=True)
