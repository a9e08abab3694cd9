"""Benchmark of the whole run loop on the bundled fixtures: pairs/s, latency, MB/s written, memory.

    .venv/bin/python benchmarks/run_loop.py [--frames 10000] [--rate-hz 30] [--encoding jpeg] [--no-log]

The fake driver loops over fixtures/scenes (1280x960) at ``--rate-hz`` (``-1``: as fast as
possible). A replay source is never dropped by the loop, so at a fixed rate the figure to read is
whether the loop keeps up (pairs/s achieved vs asked, latency capture -> result); ``-1`` gives
the sustained throughput. Memory is the process' resident set size, sampled every status period:
flat means no leak over a long replay.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.run import RunOptions, run_loop

REPO = Path(__file__).resolve().parents[1]


def rss_mb() -> float:
    """Resident set size of this process, MB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10000)
    ap.add_argument("--rate-hz", type=float, default=30.0, help="fake camera rate; -1 = as fast as possible")
    ap.add_argument("--encoding", choices=["jpeg", "png"], default="jpeg")
    ap.add_argument("--no-log", action="store_true")
    ap.add_argument("--paper", action="store_true")
    ap.add_argument("--workers", type=int, default=1, help="localizer processes")
    args = ap.parse_args()

    cfg = load_config(None, {"camera": {"fake_loop": True, "fake_rate_hz": args.rate_hz},
                             "logging": {"image_encoding": args.encoding}})
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    samples: list[tuple[float, int, float]] = []   # (t_s, localized, rss_mb)
    t0 = time.monotonic()

    def on_status(s):
        samples.append((time.monotonic() - t0, s.localized, rss_mb()))
        print(f"\r{s.localized}/{args.frames} pairs  {s.rate_hz:5.1f} pairs/s  dropped {s.dropped_localize}  "
              f"p50 {s.latency_p50_ms:6.1f} ms  rss {samples[-1][2]:6.0f} MB", end="", flush=True)

    with tempfile.TemporaryDirectory() as tmp:
        opts = RunOptions(device=f"fake:{REPO / 'fixtures' / 'scenes'}",
                          log_dir=None if args.no_log else Path(tmp), frames=args.frames,
                          variant="paper" if args.paper else "improved", status_period_s=1.0,
                          workers=args.workers)
        status = run_loop(cfg, calib, opts, on_status=on_status)
        elapsed_s = time.monotonic() - t0
        written_mb = sum(p.stat().st_size for p in Path(tmp).glob("*.mcap")) / 1e6
    print()
    rss = np.array([s[2] for s in samples])
    third = max(1, len(rss) // 3)
    print(f"pairs {status.localized} in {elapsed_s:.1f} s: {status.localized / elapsed_s:.1f} pairs/s "
          f"(camera {args.rate_hz:g} Hz, {args.workers} localizer process(es)), dropped localize {status.dropped_localize} log {status.dropped_log}")
    print(f"latency capture -> result: p50 {status.latency_p50_ms:.1f} ms, p99 {status.latency_p99_ms:.1f} ms "
          "(last 300 pairs)")
    if not args.no_log:
        print(f"written {written_mb:.1f} MB, {written_mb / elapsed_s:.1f} MB/s ({args.encoding})")
    print(f"memory (RSS): first third median {np.median(rss[:third]):.0f} MB, last third median "
          f"{np.median(rss[-third:]):.0f} MB, max {rss.max():.0f} MB")


if __name__ == "__main__":
    main()
