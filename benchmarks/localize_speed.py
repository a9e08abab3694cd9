"""Localization speed per pair on one core, per stage, on every fixture scene, against OpenCV SGBM_3WAY.

    python benchmarks/localize_speed.py [--runs 30] [--paper] [--threads 1] [--parts]

The same measurement as ``appliance bench localize`` (median of --runs after two warm-up runs,
cv2 limited to --threads threads, one by default), for the embedded colour recogniser and for the
exact masks. ``front`` is the sum of the stages before matching (segment ... recover).
``--parts`` then splits the match stage: wall time per pair inside its main functions and
primitives (outermost calls only, so nested parts are not counted twice; timed with
``perf_counter`` around each call, which adds ~1 us per call), colour masks, all scenes.
Target (issue 5): <= 20 ms median at 1280x960 and >= 15x faster than SGBM.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import time
from collections import Counter
from pathlib import Path

import cv2
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.synth.truth import load_truth

from appliance.commands.bench import measure

REPO = Path(__file__).resolve().parents[1]

# (module, attribute path) of the match stage's parts timed by --parts: its steps, then the primitives
# they share (timed in a second pass); callers look these up at call time (module globals, class
# attributes), so patching them times every call
STEPS = [("dense", "fit_steep_many"), ("dense", "_resolve_shared"), ("dense", "_flat_curves"), ("dense", "find_runs"),
         ("dense", "refine_runs"), ("dense", "cap_curves"), ("dense", "flat_cap_curves"), ("dense", "edge_consensus"),
         ("dense", "_piece_uvd"), ("ends", "EndPlacer.fork"), ("ends", "EndPlacer.prewalk"),
         ("ends", "EndPlacer.tips"), ("ends", "EndPlacer.tip"), ("ends", "EndPlacer.hidden_fork"),
         ("ends", "EndPlacer.joint"), ("ends", "EndPlacer.bridge_holds")]
PRIMITIVES = [("dense", "robust_fit"), ("dense", "robust_fit_groups"), ("dense", "_consensus_lines"),
              ("ends", "robust_fit"), ("dense", "surface_disparity"), ("ends", "nearer_in_front"),
              ("dense", "find_runs"), ("ends", "find_runs"), ("curves", "Poly.fit"), ("curves", "Poly.__call__"),
              ("curves", "BranchCurve._eval"), ("edges", "Runs.find"), ("edges", "Runs.between"),
              ("dense", "end_slopes")]


@contextlib.contextmanager
def timed_parts(parts):
    """Time the calls of ``parts`` (wall seconds in the outermost timed call, per part), restoring them after."""
    spent, depth, undo = Counter(), [0], []

    def timed(f, label):
        def call(*a, **k):
            if depth[0]:
                return f(*a, **k)
            depth[0] += 1
            t = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                spent[label] += time.perf_counter() - t
                depth[0] -= 1
        return call

    for mod, path in parts:
        owner = importlib.import_module(f"appliance.localize.{mod}")
        *outer, name = path.split(".")
        for o in outer:
            owner = getattr(owner, o, None)
        if owner is None or name not in vars(owner):
            continue
        f = vars(owner)[name]
        label = path if outer else f"{path} ({mod})"
        setattr(owner, name, classmethod(timed(f.__func__, label)) if isinstance(f, classmethod) else timed(f, label))
        undo.append((owner, name, f))
    try:
        yield spent
    finally:
        for owner, name, f in reversed(undo):
            setattr(owner, name, f)


def match_parts(calib, cfg, pairs, runs: int, parts) -> tuple[float, Counter]:
    """Mean match-stage ms per pair and ms per pair in each of ``parts`` (one OpenCV thread)."""
    loc = Localizer(calib, cfg, "improved")
    cv2.setNumThreads(1)
    for left, right in pairs:
        loc.localize(left, right)
    match = 0.0
    with timed_parts(parts) as spent:
        for _ in range(runs):
            for left, right in pairs:
                match += loc.localize(left, right).timings_ms["match"]
    n = runs * len(pairs)
    return match / n, Counter({k: v * 1e3 / n for k, v in spent.items()})


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--paper", action="store_true", help="also time the paper's variant (slow)")
    ap.add_argument("--threads", type=int, default=1, help="OpenCV threads (cv2.setNumThreads)")
    ap.add_argument("--parts", action="store_true", help="also split the match stage into its parts")
    a = ap.parse_args()
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    cfg = load_config().localize
    variants = ["improved", "paper"] if a.paper else ["improved"]
    rows, pairs = [], []
    for t in sorted((REPO / "fixtures" / "scenes").glob("truth_*.json")):
        nn = t.stem.split("_")[1]
        left = cv2.imread(str(REPO / "fixtures" / "scenes" / f"left_{nn}.png"))
        right = cv2.imread(str(REPO / "fixtures" / "scenes" / f"right_{nn}.png"))
        truth = load_truth(t)
        pairs.append((left, right))
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
    if a.parts:
        for title, parts in (("steps", STEPS), ("primitives (inside the steps)", PRIMITIVES)):
            match_ms, spent = match_parts(calib, cfg, pairs, max(a.runs // 3, 3), parts)
            print(f"\nmatch stage, {title}: ms per pair, colour masks, mean of all scenes "
                  f"(match {match_ms:.2f} ms with these timed)")
            for k, v in spent.most_common():
                print(f"  {k:<36}{v:7.2f}")
            print(f"  {'(the rest)':<36}{match_ms - sum(spent.values()):7.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
