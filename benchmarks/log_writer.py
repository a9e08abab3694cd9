"""Field-log throughput: how fast LogWriter logs 1280x960 pairs, and how fast logs read back.

    python benchmarks/log_writer.py [--pairs 300] [--scenes fixtures/scenes]

Writes the fixture scenes (rendered 1280x960 pairs) over and over with a result per pair, as
fast as possible, once as JPEG (default quality) and once as lossless PNG; prints pairs/s and
ms per pair (encoding alone, and everything), kB per pair, MB/s written, then the reading rates
(iter_stereo_frames, check_log). The run loop needs 30 pairs/s.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from appliance.acquire import StereoFrame
from appliance.acquire.pairs import find_pairs
from appliance.calibrate import load_calibration
from appliance.config import load_config
from appliance.localize.result import Branch, LocalizationResult
from appliance.logs import LogWriter, check_log, encode_frame, iter_stereo_frames

REPO = Path(__file__).resolve().parents[1]


def load_pairs(folder: Path) -> list[tuple[np.ndarray, np.ndarray]]:
    import cv2

    pairs, _ = find_pairs(folder)
    return [(cv2.imread(str(p.left)), cv2.imread(str(p.right))) for p in pairs]


def a_result(stamp_ns: int) -> LocalizationResult:
    """Ten branches of eight segments: about what a tree shows."""
    branches = tuple(Branch(b, (-1, -1), np.column_stack([np.arange(9) * 20.0, np.full(9, b * 30.0),
                                                          np.full(9, 900.0 + b)]), 4.0) for b in range(10))
    return LocalizationResult((), branches, stamp_ns)


def bench(pairs, cfg, calib, n: int) -> None:
    frames = [StereoFrame(left, right, i, 0, 0) for i, (left, right) in enumerate(pairs)]
    t = time.perf_counter()
    for i in range(min(n, 30)):
        encode_frame(frames[i % len(frames)], cfg.image_encoding, cfg.jpeg_quality)
    encode_ms = (time.perf_counter() - t) / min(n, 30) * 1e3
    with tempfile.TemporaryDirectory() as tmp:
        with LogWriter(Path(tmp) / "bench.mcap", cfg, calibration=calib) as writer:
            t = time.perf_counter()
            for i in range(n):
                stamp = time.time_ns()
                left, right = pairs[i % len(pairs)]
                writer.write_frame(StereoFrame(left, right, i, stamp, stamp))
                writer.write_result(a_result(stamp), i, np.eye(4))
        write_s = time.perf_counter() - t
        size = writer.path.stat().st_size
        t = time.perf_counter()
        read = sum(1 for _ in iter_stereo_frames(writer.path))
        read_s = time.perf_counter() - t
        t = time.perf_counter()
        summary = check_log(writer.path)
        check_s = time.perf_counter() - t
    assert read == n and summary.intact and writer.frames_dropped == 0
    label = f"{cfg.image_encoding}" + (f" q{cfg.jpeg_quality}" if cfg.image_encoding == "jpeg" else "")
    print(f"{label:8s} write {n / write_s:6.1f} pairs/s ({write_s / n * 1e3:5.1f} ms/pair, encoding "
          f"{encode_ms:5.1f} ms), {size / n / 1e3:6.0f} kB/pair, {size / write_s / 1e6:5.1f} MB/s; "
          f"read {n / read_s:6.1f} pairs/s; check {size / check_s / 1e6:6.0f} MB/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=300)
    parser.add_argument("--scenes", type=Path, default=REPO / "fixtures" / "scenes")
    args = parser.parse_args()
    pairs = load_pairs(args.scenes)
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    h, w = pairs[0][0].shape[:2]
    print(f"{len(pairs)} pairs of {w}x{h} from {args.scenes}, {args.pairs} logged per run")
    cfg = load_config().logging
    bench(pairs, cfg, calib, args.pairs)
    bench(pairs, dataclasses.replace(cfg, image_encoding="png"), calib, max(args.pairs // 5, 10))


if __name__ == "__main__":
    main()
