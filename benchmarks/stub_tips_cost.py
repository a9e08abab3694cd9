"""Cost of the stub-tip rule (``dense.STUB_TIPS``, localize/stubtips.py) per pair, on the fixture scenes.

    python benchmarks/stub_tips_cost.py [--rounds 20] [--masks both] [--module PATH]

In one process, for each fixture scene (00-03) and mask source, the improved localizer runs with the rule
off and on, alternated (ABBA) for ``--rounds`` rounds, OpenCV on one thread. Printed per scene and mask
source: the median wall time per pair off and on, their difference (which also holds the found features'
later steps, and is noisier), and the median time inside ``stub_tips`` and ``taken_points`` (the rule's own
steps), wall and CPU (``time.thread_time``: less moved by other processes). ``--module PATH`` times the
``stub_tips`` of another file (an older version, for an A/B in one process). The load average is printed
before and after: the machine's speed drifts with it.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import time
from pathlib import Path

import cv2
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import Localizer, dense
from appliance.synth.truth import load_truth

REPO = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=20, help="on/off rounds (each: off, on, on, off)")
    ap.add_argument("--masks", choices=["true", "colour", "both"], default="both")
    ap.add_argument("--module", type=Path, help="time the stub_tips of this file instead")
    ap.add_argument("--scenes", default="00,01,02,03", help="fixture scenes, comma-separated")
    a = ap.parse_args()
    stub = dense.stub_tips
    if a.module:
        spec = importlib.util.spec_from_file_location("stubtips_other", a.module)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        stub = mod.stub_tips
    spent, cpu = [], []

    def timed(f):
        def call(*args, **kw):
            t, c = time.perf_counter(), time.thread_time()
            try:
                return f(*args, **kw)
            finally:
                spent.append(time.perf_counter() - t)
                cpu.append(time.thread_time() - c)
        return call

    dense.stub_tips = timed(stub)
    if hasattr(dense, "taken_points"):              # (the points it must not take: part of the rule's cost)
        dense.taken_points = timed(dense.taken_points)
    cv2.setNumThreads(1)
    loc = Localizer(load_calibration(REPO / "fixtures" / "rig.yaml"), load_config().localize, "improved")
    fx = REPO / "fixtures" / "scenes"
    modes = ["true", "colour"] if a.masks == "both" else [a.masks]
    pairs = []
    for nn in a.scenes.split(","):
        left, right = cv2.imread(str(fx / f"left_{nn}.png")), cv2.imread(str(fx / f"right_{nn}.png"))
        exact = load_truth(fx / f"truth_{nn}.json").exact_masks(soft=True)    # (as measured at stop 22)
        for mode in modes:
            kw = dict(mask_left=exact[0], mask_right=exact[1]) if mode == "true" else {}
            pairs.append((f"{nn} {mode}", left, right, kw))
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    times = {(name, on): [] for name, *_ in pairs for on in (False, True)}
    own = {name: [] for name, *_ in pairs}
    own_cpu = {name: [] for name, *_ in pairs}
    for name, left, right, kw in pairs:                     # warm-up (compiles, caches)
        for on in (False, True):
            dense.STUB_TIPS = on
            loc.localize(left, right, **kw)
    for _ in range(a.rounds):
        for name, left, right, kw in pairs:
            for on in (False, True, True, False):
                dense.STUB_TIPS = on
                spent.clear()
                cpu.clear()
                t = time.perf_counter()
                loc.localize(left, right, **kw)
                times[(name, on)].append(time.perf_counter() - t)
                if on:
                    own[name].append(sum(spent))
                    own_cpu[name].append(sum(cpu))
    print(f"load average after:  {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'pair':<12}{'off ms':>9}{'on ms':>9}{'on-off':>9}{'stub_tips ms':>14}{'(CPU ms)':>10}"
          f"   ({a.rounds} rounds x 2 each)")
    for name, *_ in pairs:
        off, on = statistics.median(times[(name, False)]) * 1e3, statistics.median(times[(name, True)]) * 1e3
        print(f"{name:<12}{off:>9.2f}{on:>9.2f}{on - off:>9.2f}{statistics.median(own[name]) * 1e3:>14.3f}"
              f"{statistics.median(own_cpu[name]) * 1e3:>10.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
