"""Run boundaries against the true outline: the mask's (soft crossing) vs the grey image's (subpixel.py).

    python benchmarks/edge_offsets.py [--seeds 100 101 102]

Scenes: out/localize_scenes (rendered by benchmarks/localize_accuracy.py --extra N). The true
outline: where the branch coverage of a 4x4-supersampled cast of the scene (rectified with linear
interpolation) crosses one half, nearest the mask's boundary, per row. For the exact masks and the
colour recogniser's, on the boundaries where the outline is steep (``subpixel.steep_boundaries``):

- position: percentiles of |boundary - true| (px), left and right views pooled;
- disparity: left boundary minus the right boundary of the same side in the same row (the one
  nearest the true disparity, within 1.5 px), less the same of the true outline (px): what an
  edge's error does to depth.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize.edges import find_runs
from appliance.localize.rectify import Rectifier
from appliance.localize.segment import segment_color
from appliance.localize.subpixel import refine_runs, steep_boundaries
from appliance.synth.rig import default_rig
from appliance.synth.scene import _cast, _segments, make_scene
from appliance.synth.truth import load_truth

REPO = Path(__file__).resolve().parents[1]
SS = 4
Q = [50, 75, 90, 95, 98]


def true_crossing(cov: np.ndarray, row: np.ndarray, x: np.ndarray, reach: int = 3) -> np.ndarray:
    """Where ``cov`` (H, W float, 0-1) crosses 0.5 along each row nearest ``x`` (NaN if not within ``reach`` px)."""
    xi = np.rint(x).astype(int)
    cols = np.clip(xi[:, None] + np.arange(-reach, reach + 1), 0, cov.shape[1] - 1)
    p = cov[row[:, None], cols] - 0.5
    a, b = p[:, :-1], p[:, 1:]
    cross = (np.sign(a) * np.sign(b) <= 0) & (a != b)
    pos = cols[:, :-1] + a / np.where(a != b, a - b, 1)
    dist = np.where(cross, np.abs(pos - x[:, None]), np.inf)
    k = np.argmin(dist, 1)
    i = np.arange(len(k))
    return np.where(np.isfinite(dist[i, k]), pos[i, k], np.nan)


def coverage(scene, seg, rig, rect: Rectifier, side: int) -> np.ndarray:
    """Rectified branch coverage (H, W) float32 of one camera from a 4x4-supersampled cast."""
    w, h = rig.size
    hits = _cast(scene, seg, rig, ("left", "right")[side], SS)
    on = ((hits.ids >= 0) & (hits.ids < len(seg.a))).reshape(h, SS, w, SS).mean(axis=(1, 3)).astype(np.float32)
    m1, m2 = rect.maps[side]
    return cv2.remap(on, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, nargs="+", default=[100, 101, 102])
    a = ap.parse_args()
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    rect = Rectifier.from_calibration(calib)
    fb = calib.f_px * calib.baseline_mm
    seg_cfg = load_config().localize.segment
    rig = default_rig()
    cache = REPO / "out" / "localize_scenes"
    pos = {(m, k): [] for m in ("exact", "colour") for k in ("mask", "grey")}
    disp = {(m, k): [] for m in ("exact", "colour") for k in ("mask", "grey")}
    for seed in a.seeds:
        scene = make_scene(seed)
        seg = _segments(scene.branches)
        truth = load_truth(cache / f"truth_{seed}.json")
        imgs = [cv2.imread(str(cache / f"{s}_{seed}.png")) for s in ("left", "right")]
        cov = [coverage(scene, seg, rig, rect, side) for side in (0, 1)]
        m1, m2 = rect.maps[0]
        depth = cv2.remap(np.nan_to_num(truth.depth_left_mm, nan=0).astype(np.float32), m1, m2, cv2.INTER_NEAREST)
        grey = [rect.rectify(cv2.cvtColor(imgs[side], cv2.COLOR_BGR2GRAY), side) for side in (0, 1)]
        for mode in ("exact", "colour"):
            masks = ([truth.mask_left.astype(np.uint8) * 255, truth.mask_right.astype(np.uint8) * 255] if mode == "exact"
                     else [segment_color(img, seg_cfg)[0] for img in imgs])
            soft = [rect.rectify(m, side) for side, m in enumerate(masks)]
            runs = [find_runs(s, soft=True) for s in soft]
            both = {"mask": runs, "grey": [refine_runs(r, g, s) for r, g, s in zip(runs, grey, soft)]}
            for side in (0, 1):
                row = np.r_[runs[side].row, runs[side].row]
                x = np.r_[runs[side].left_px, runs[side].right_px]
                t = true_crossing(cov[side], row, x)
                ok = np.isfinite(t) & steep_boundaries(soft[side], row, x)
                for k, r in both.items():
                    pos[mode, k].append(np.abs(np.r_[r[side].left_px, r[side].right_px] - t)[ok])
            rl, rr = runs
            for edge, inward in (("left_px", 1), ("right_px", -1)):
                xl, xr = getattr(rl, edge), getattr(rr, edge)
                tl = true_crossing(cov[0], rl.row, xl)
                # the right boundary of the same side and row nearest the disparity of the depth just inside
                zi = depth[rl.row, np.clip(np.rint(xl + inward).astype(int), 0, depth.shape[1] - 1)]
                q = rl.row * 1e4 + xl - fb / np.where(zi > 0, zi, np.inf)
                keys = rr.row * 1e4 + xr
                jr = np.clip(np.searchsorted(keys, q), 1, len(keys) - 1)
                jr = np.where(np.abs(keys[jr - 1] - q) < np.abs(keys[jr] - q), jr - 1, jr)
                tr = true_crossing(cov[1], rr.row[jr], xr[jr])
                ok = (zi > 0) & (np.abs(keys[jr] - q) < 1.5) & np.isfinite(tl + tr) & steep_boundaries(soft[0], rl.row, xl)
                for k, r in both.items():
                    d = getattr(r[0], edge) - getattr(r[1], edge)[jr]
                    disp[mode, k].append(np.abs(d - (tl - tr))[ok])
        print(f"seed {seed}: done", flush=True)
    for title, table in (("position |error| px", pos), ("edge disparity |error| px", disp)):
        print(f"\n== {title} (steep outline), percentiles {Q}")
        for (mode, k), v in table.items():
            e = np.concatenate(v)
            print(f"{mode:7s} {k:5s} n={len(e):6d}  " + "  ".join(f"{p:.3f}" for p in np.percentile(e, Q)))


if __name__ == "__main__":
    main()
