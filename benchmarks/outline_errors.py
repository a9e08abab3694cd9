"""Per-edge outline error: run boundaries (mask crossing and refined) against the truth's crossing.

    python benchmarks/outline_errors.py [--seeds ...] [--holdout] [--variant NAME]

Scenes: out/localize_scenes (rendered by benchmarks/localize_accuracy.py --extra 24): the 4 fixtures
and seeds 100-115 by default (the tuning scenes), ``--holdout`` seeds 116-123. For the exact masks
(binary, as the benchmark passes them) and the embedded colour recogniser's (``segment_mask``), both
views, every run boundary of the rectified soft mask is compared with where the truth's soft coverage
(``SceneTruth.cover_left/right``, rectified with linear interpolation) crosses one half along the same
row, nearest the boundary (within 3 px). Split by:

- slant: angle of the true outline from the vertical (from the coverage's gradient), 0-15, 15-30,
  30-45, 45-60, > 60 deg;
- place: within 25 px of a true tip or fork of that view ("end") or not ("body");
- how refined (``subpixel.refine_runs`` over all runs): moved to the grey step ("grey"), steep but
  no clear step ("steep, no step"), not tried ("shallow": beyond the module's STEEP_TAN, 45 deg before it); and, for colour masks, whether the mask's
  pixels at the crossing carry the recogniser's bark share (soft) or are whole (0/255).

Prints |error| p50/p90/p95 and the signed median (inward positive: into the branch), px, of the mask's
crossing and of the refined boundary.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from pathlib import Path

import cv2
import numpy as np
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize.edges import find_runs
from appliance.localize.rectify import LazyRectified, Rectifier
from appliance.localize.segment import segment_mask
from appliance.synth.truth import load_truth

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
AREA = True            # the truth's outline from the coverage's area (else its linear 0.5 crossing)
SLANT = [0, 15, 30, 45, 60, 91]

from edge_offsets import true_crossing  # noqa: E402  (benchmarks/ on the path above)


def true_edge_area(cov: np.ndarray, row: np.ndarray, x: np.ndarray, inward: np.ndarray, out_px: int = 3,
                   in_px: int = 2) -> np.ndarray:
    """The outline's mean position over each row's height from the coverage's area: with the pixels
    ``out_px`` outside and ``in_px`` inside the boundary's pixel fully background (< 0.03) and fully
    branch (> 0.97), a left edge (``inward`` +1) lies at the window's inner end less the window's summed
    coverage (exact for a straight outline across the row, whatever its slant); NaN where the window
    is not clean (a thin branch, another outline near)."""
    xi = np.rint(x).astype(int)
    k = np.arange(-out_px, in_px + 1)
    cols = np.clip(xi[:, None] + inward[:, None].astype(int) * k, 0, cov.shape[1] - 1)
    c = cov[row[:, None], cols]
    clean = (c[:, 0] < 0.03) & (c[:, -1] > 0.97)
    inner = xi + inward * (in_px + 0.5)
    return np.where(clean, inner - inward * c.sum(1), np.nan)


def slant_deg(cov: np.ndarray, row: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Angle (deg) of the outline from the vertical at (row, x), from the coverage's gradient over 3x3."""
    h, w = cov.shape
    gx = cv2.Sobel(cov, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(cov, cv2.CV_32F, 0, 1, ksize=3)
    r = np.clip(row, 0, h - 1)
    c = np.clip(np.rint(x).astype(int), 0, w - 1)
    return np.degrees(np.arctan2(np.abs(gy[r, c]), np.abs(gx[r, c])))


def explain(sub, runs, grey: np.ndarray, soft: np.ndarray):
    """``sub.refine_runs`` over all runs, and per boundary (left ends, then right ends) how:
    0 moved to the grey step, 1 steep but no clear step, 2 shallow (not tried)."""
    n = len(runs.row)
    row, x = np.r_[runs.row, runs.row], np.r_[runs.left_px, runs.right_px]
    steep = sub.steep_boundaries(soft, row, x, getattr(sub, "STEEP_TAN", 1.0))
    how = np.full(2 * n, 2)
    xr = sub.refine_boundaries(grey, row[steep], x[steep])
    how[np.flatnonzero(steep)] = np.where(xr != x[steep], 0, 1)
    return sub.refine_runs(runs, grey, soft), how


def load_module(path: str):
    spec = importlib.util.spec_from_file_location("outline_variant", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def collect(names, sub, seg_cfg, calib, rect: Rectifier) -> list[dict]:
    """Per scene, mask source and view: arrays of boundary attributes and errors."""
    from localize_accuracy import rectified_points, scenes

    out = []
    for name, lp, rp, tp in scenes(24):
        if name.split()[-1] not in names:
            continue
        imgs = [cv2.imread(str(lp)), cv2.imread(str(rp))]
        truth = load_truth(tp)
        if truth.cover_left is None:
            print(f"{name}: no coverage in the truth, skipped")
            continue
        cov = [rect.rectify(c.astype(np.float32), side) for side, c in enumerate((truth.cover_left, truth.cover_right))]
        grey = [LazyRectified(rect, im, side) for side, im in enumerate(imgs)]      # (as the localizer reads it)
        tf = truth.features
        feats = [rectified_points(calib, tf.left_px[tf.visible_left], 0),
                 rectified_points(calib, tf.right_px[tf.visible_right], 1)]
        for mode in ("exact", "colour"):
            masks = ([truth.mask_left.astype(np.uint8) * 255, truth.mask_right.astype(np.uint8) * 255]
                     if mode == "exact" else [segment_mask(im, seg_cfg) for im in imgs])
            for side in (0, 1):
                m = masks[side]
                soft = rect.rectify(m, side, fast=True)
                part = rect.rectify(((m > 0) & (m < 255)).astype(np.uint8) * 255, side)
                runs = find_runs(soft, soft=True)
                ref, how = explain(sub, runs, grey[side], soft)
                n = len(runs.row)
                row = np.r_[runs.row, runs.row]
                x = np.r_[runs.left_px, runs.right_px]
                xr = np.r_[ref.left_px, ref.right_px]
                inward = np.r_[np.ones(n), -np.ones(n)]
                t = true_edge_area(cov[side], row, x, inward) if AREA else true_crossing(cov[side], row, x)
                ok = np.isfinite(t)
                f = feats[side]
                dmin = np.full(len(x), np.inf)
                if len(f):
                    dmin = np.sqrt(((np.column_stack([x, row])[:, None, :] - f[None, :, :]) ** 2).sum(-1)).min(1)
                xi = np.clip(np.rint(x).astype(int), 1, soft.shape[1] - 2)
                shared = np.maximum(part[row, xi - 1], np.maximum(part[row, xi], part[row, xi + 1])) > 0
                out.append(dict(name=name, mode=mode, side=side, err_mask=((x - t) * inward)[ok],
                                err_ref=((xr - t) * inward)[ok], slant=slant_deg(cov[side], row, np.nan_to_num(t))[ok],
                                end=(dmin < 25)[ok], how=how[ok], shared=shared[ok]))
        print(f"{name}: done", flush=True)
    return out


def stats(e: np.ndarray) -> str:
    if len(e) == 0:
        return f"{0:>7d}" + " " * 36
    a = np.abs(e)
    return f"{len(e):>7d} {np.percentile(a, 50):6.3f} {np.percentile(a, 90):6.3f} {np.percentile(a, 95):6.3f} {np.median(e):+7.3f}"


def report(rows: list[dict]) -> None:
    head = f"{'masks':7s} {'split':28s}{'n':>7s} {'mask: p50':>9s} {'p90':>6s} {'p95':>6s} {'signed':>7s} |" \
           f"{'refined: p50':>13s} {'p90':>6s} {'p95':>6s} {'signed':>7s}"
    print(head)
    print("-" * len(head))
    for mode in ("exact", "colour"):
        r = [d for d in rows if d["mode"] == mode]
        cat = {k: np.concatenate([d[k] for d in r]) for k in ("err_mask", "err_ref", "slant", "end", "how", "shared")}
        # refined boundaries' error where the truth and the boundary are within 3 px (all in practice)
        splits = [("all", np.ones(len(cat["slant"]), bool))]
        for lo, hi in zip(SLANT[:-1], SLANT[1:]):
            splits.append((f"slant {lo}-{min(hi, 90)} deg", (cat["slant"] >= lo) & (cat["slant"] < hi)))
        steep = cat["slant"] < 45
        splits += [("body (steep)", ~cat["end"] & steep), ("near ends/forks (steep)", cat["end"] & steep)]
        for k, label in enumerate(("grey", "steep, no step", "shallow")):
            splits.append((f"{label}", cat["how"] == k))
        if mode == "colour":
            splits += [("share at crossing (steep)", cat["shared"] & steep), ("whole px at crossing (steep)", ~cat["shared"] & steep)]
        for label, sel in splits:
            line = stats(cat["err_mask"][sel])
            print(f"{mode:7s} {label:28s}{line} |{stats(cat['err_ref'][sel])[7:]}")
        print()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, nargs="*")
    ap.add_argument("--holdout", action="store_true", help="seeds 116-123 (only score them)")
    ap.add_argument("--variant", type=Path, help="a file to use instead of localize/subpixel.py (A/B)")
    a = ap.parse_args()
    if a.seeds:
        names = [str(s) for s in a.seeds]
    elif a.holdout:
        names = [str(s) for s in range(116, 124)]
    else:
        names = [f"{k:02d}" for k in range(4)] + [str(s) for s in range(100, 116)]
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    rect = Rectifier.from_calibration(calib)
    sub = load_module(str(a.variant)) if a.variant else importlib.import_module("appliance.localize.subpixel")
    rows = collect(names, sub, load_config().localize.segment, calib, rect)
    report(rows)


if __name__ == "__main__":
    main()
