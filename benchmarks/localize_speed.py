"""Localization speed per pair on one core, per stage, on every fixture scene, against OpenCV SGBM_3WAY.

    python benchmarks/localize_speed.py [--runs 30] [--paper] [--threads 1]

The same measurement as ``appliance bench localize`` (median of --runs after two warm-up runs,
cv2 limited to --threads threads, one by default), for the embedded colour recogniser and for the
exact masks. ``front`` is the sum of the stages before matching (segment ... recover).
Target (issue 5): <= 20 ms median at 1280x960 and >= 15x faster than SGBM.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.synth.truth import load_truth

from appliance.commands.bench import measure

REPO = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--paper", action="store_true", help="also time the paper's variant (slow)")
    ap.add_argument("--threads", type=int, default=1, help="OpenCV threads (cv2.setNumThreads)")
    a = ap.parse_args()
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    cfg = load_config().localize
    variants = ["improved", "paper"] if a.paper else ["improved"]
    rows = []
    for t in sorted((REPO / "fixtures" / "scenes").glob("truth_*.json")):
        nn = t.stem.split("_")[1]
        left = cv2.imread(str(REPO / "fixtures" / "scenes" / f"left_{nn}.png"))
        right = cv2.imread(str(REPO / "fixtures" / "scenes" / f"right_{nn}.png"))
        truth = load_truth(t)
        for variant in variants:
            loc = Localizer(calib, cfg, variant)
            runs = a.runs if variant == "improved" else max(3, a.runs // 10)
            for masks, ml, mr in (("colour", None, None), ("true", truth.mask_left, truth.mask_right)):
                fig = measure(loc, left, right, ml, mr, runs=runs, sgbm_runs=2, threads=a.threads)
                rows.append((nn, variant, masks, fig))
                print(f"scene {nn} {variant:<9} {masks:<7} {fig['median_ms']:7.1f} ms", flush=True)
    stages = list(rows[0][3]["stages"])
    front = stages[:stages.index("match")] if "match" in stages else stages
    head = f"{'scene':<6}{'variant':<10}{'masks':<8}" + "".join(f"{k[:9]:>10}" for k in stages) + \
        f"{'front':>9}{'total':>9}{'SGBM':>8}{'x':>6}"
    print("\n" + head + "\n" + "-" * len(head))
    for nn, variant, masks, fig in rows:
        st = fig["stages"]
        print(f"{nn:<6}{variant:<10}{masks:<8}" + "".join(f"{st.get(k, 0):10.2f}" for k in stages)
              + f"{sum(st.get(k, 0) for k in front):9.1f}"
              + f"{fig['median_ms']:9.1f}{fig['sgbm_median_ms']:8.0f}{fig['sgbm_median_ms'] / fig['median_ms']:6.1f}")
    print(f"ms per pair, medians, {a.threads} OpenCV thread(s); front = {' + '.join(front)}; "
          "x = SGBM time / localize time")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
