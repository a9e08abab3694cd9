"""Localization accuracy on rendered scenes with exact truth: improved vs the paper vs OpenCV SGBM.

    python benchmarks/localize_accuracy.py [--extra N] [--masks true|colour|both] [--soft-truth] [--json OUT]
        [--plot PNG] [--pictures DIR] [--ss N]

Scenes: fixtures/scenes (4) plus ``--extra`` more rendered with seeds 100.. (cached in
out/localize_scenes). Rig f ~1450 px, b ~120 mm, 1280x960, branches 500-1500 mm away.
``--ss N`` renders with N x N supersamples per pixel instead of the fixtures' 2 x 2 (finer anti-aliasing,
the same scenes, sensor noise and gains), cached in out/localize_scenes_ssN; the 4 fixture scenes are
then rendered again too (scene seeds 0-3, as ``fixtures/make_fixtures.py`` made them).
Methods, each scored with :func:`appliance.synth.evaluate.score_result` (features matched in the
left image within 5 px, same kind; ``--tol-px`` sets that radius):

- ``improved``: the default configuration (dense centre-line matching).
- ``paper``: the paper's steps (thinning, 5 px pruning, Hough recovery, feature matching).
- ``sgbm``: OpenCV StereoSGBM (SGBM_3WAY) on the rectified pair, its disparity sampled at the
  TRUE features' rectified positions (so its recall is the share of those it has a disparity for,
  and its errors are only depth errors: an upper bound on how well a dense matcher does there).

Masks: ``true`` gives every method the exact branch masks (segmentation not to blame): whole pixels,
those at least half covered (``--soft-truth``: the renderer's coverage of each pixel, 0-1 in quarters,
as a good segmenter's probability would be); ``colour`` the embedded colour recogniser. Prints the
evaluator's table per method, p95 |dZ| per 250 mm band and the pooled figures; targets (issue 5): p95 |dZ| <= 1.5 mm at 1000 mm and <= 6.2 mm over
500-1500 mm, >= 3x lower p95 than SGBM, recall >= 0.9, branch coverage >= 0.9, radius error
median <= 1 mm.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import cv2
import numpy as np
from appliance.calibrate.model import StereoCalibration, load_calibration
from appliance.config import load_config
from appliance.localize import Feature, LocalizationResult, Localizer
from appliance.localize.sgbm import sgbm_disparity
from appliance.localize.triangulate import triangulate
from appliance.synth.evaluate import format_table, pool, score_result
from appliance.synth.errorplot import draw_error_plot, panels_from_scores
from appliance.synth.show import draw_score
from appliance.synth.truth import SceneTruth, load_truth

REPO = Path(__file__).resolve().parents[1]
BANDS_MM = [(500, 750), (750, 1000), (1000, 1250), (1250, 1500)]


def scene_cache(ss: int) -> Path:
    """The directory of the scenes rendered with ``ss`` x ``ss`` supersamples per pixel: out/localize_scenes
    for the default 2 (the cache every earlier figure used), out/localize_scenes_ss<ss> otherwise."""
    return REPO / "out" / ("localize_scenes" if ss == 2 else f"localize_scenes_ss{ss}")


def cached_scene(seed: int, cache: Path, ss: int = 2, tag: str | None = None) -> tuple[Path, Path, Path]:
    """(left, right, truth json) of scene ``seed`` rendered with ``ss`` supersamples in ``cache``, rendered
    (and timed) if missing; ``tag`` names the files (default: the seed)."""
    from appliance.synth.rig import default_rig
    from appliance.synth.scene import make_scene, render
    from appliance.synth.truth import save_truth

    tag = str(seed) if tag is None else tag
    stem = cache / f"truth_{tag}"
    left, right = cache / f"left_{tag}.png", cache / f"right_{tag}.png"
    if not (stem.with_suffix(".json").exists() and left.exists() and right.exists()
            and "cover_left" in np.load(stem.with_suffix(".npz")).files):   # (older caches: no soft masks)
        cache.mkdir(parents=True, exist_ok=True)
        print(f"rendering scene {seed} (ss {ss}) ...", flush=True)
        t0 = time.perf_counter()
        l_img, r_img, truth = render(make_scene(seed), default_rig(), seed=seed, ss=ss)
        cv2.imwrite(str(left), l_img)
        cv2.imwrite(str(right), r_img)
        save_truth(truth, stem)
        print(f"rendered scene {seed} (ss {ss}) in {time.perf_counter() - t0:.1f} s", flush=True)
    return left, right, stem.with_suffix(".json")


def scenes(extra: int, seeds: range | None = None, ss: int = 2) -> list[tuple[str, Path, Path, Path]]:
    """(name, left, right, truth json) of the fixture scenes and ``extra`` rendered ones (seeds 100..);
    with ``seeds``, of those rendered seeds alone (a hold-out scored on its own). With ``ss`` other than
    the fixtures' 2, the fixture scenes (seeds 0-3) are rendered with ``ss`` supersamples as well."""
    out = []
    cache = scene_cache(ss)
    fx = REPO / "fixtures" / "scenes"
    if seeds is None:
        for t in sorted(fx.glob("truth_*.json")):
            nn = t.stem.split("_")[1]
            if ss == 2:
                out.append((f"fixture {nn}", fx / f"left_{nn}.png", fx / f"right_{nn}.png", t))
            else:
                out.append((f"fixture {nn}", *cached_scene(int(nn), cache, ss, tag=f"fixture_{nn}")))
        seeds = range(100, 100 + extra)
    for seed in seeds:
        out.append((f"seed {seed}", *cached_scene(seed, cache, ss)))
    return out


def rectified_points(calib: StereoCalibration, px: np.ndarray, side: int) -> np.ndarray:
    """Original (distorted) pixels -> rectified pixels of one camera, (N, 2)."""
    K, D, R, P = (calib.K1, calib.D1, calib.R1, calib.P1) if side == 0 else (calib.K2, calib.D2, calib.R2, calib.P2)
    return cv2.undistortPoints(np.asarray(px, float).reshape(-1, 1, 2), K, D, R=R, P=P).reshape(-1, 2)


def sgbm_result(loc: Localizer, left: np.ndarray, right: np.ndarray, truth: SceneTruth) -> LocalizationResult:
    """SGBM's disparity sampled (bilinear) at the true features seen in both views, as a result."""
    calib = loc.calib
    gl = loc.rectifier.rectify(cv2.cvtColor(left, cv2.COLOR_BGR2GRAY), 0)
    gr = loc.rectifier.rectify(cv2.cvtColor(right, cv2.COLOR_BGR2GRAY), 1)
    disp = sgbm_disparity(gl, gr, loc.d_range_px)
    tf = truth.features
    feats = []
    for j in np.flatnonzero(tf.visible_left & tf.visible_right):
        u, v = rectified_points(calib, tf.left_px[j], 0)[0]
        x0, y0 = int(np.floor(u)), int(np.floor(v))
        if not (0 <= x0 < disp.shape[1] - 1 and 0 <= y0 < disp.shape[0] - 1):
            continue
        patch = disp[y0:y0 + 2, x0:x0 + 2]
        if not np.isfinite(patch).all():
            continue
        fx, fy = u - x0, v - y0
        d = (patch[0, 0] * (1 - fx) * (1 - fy) + patch[0, 1] * fx * (1 - fy) + patch[1, 0] * (1 - fx) * fy
             + patch[1, 1] * fx * fy)
        xyz = triangulate([u], [v], [d], calib)[0]
        feats.append(Feature(int(j), str(tf.kind[j]), tuple(tf.left_px[j]), tuple(tf.right_px[j]), tuple(xyz),
                             float(tf.radius_mm[j]), float(xyz[2])))
    return LocalizationResult(tuple(feats))


def axis_errors(result: LocalizationResult, truth: SceneTruth, step_mm: float = 2.0, near_mm: float = 10.0):
    """Distance (mm) of reported branch axes to the nearest true axis, sampled every ``step_mm``; only
    samples within ``near_mm`` (the covered ones, so wrong pieces do not swamp the figure), with their true Z."""
    a = np.concatenate([b.axis_mm[:-1] for b in truth.branches])
    b = np.concatenate([b.axis_mm[1:] for b in truth.branches])
    ab = b - a
    out = []
    for br in result.branches:
        poly = np.asarray(br.polyline_mm, float)
        seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
        cum = np.r_[0.0, np.cumsum(seg)]
        if cum[-1] <= 0:
            continue
        s = np.arange(0.0, cum[-1], step_mm)
        pts = np.column_stack([np.interp(s, cum, poly[:, k]) for k in range(3)])
        t = np.clip(((pts[:, None] - a[None]) * ab[None]).sum(2) / (ab * ab).sum(1)[None], 0, 1)
        q = a[None] + t[..., None] * ab[None]
        d = np.linalg.norm(pts[:, None] - q, axis=2)
        j = d.argmin(1)
        dist = d[np.arange(len(j)), j]
        keep = dist <= near_mm
        out += list(zip(dist[keep], q[np.arange(len(j)), j][keep, 2]))
    return out


def band_table(pooled: dict) -> str:
    """p95 |dZ| (mm) of matched features per true-depth band, one row per method."""
    head = f"{'method':<22}" + "".join(f"{f'{a}-{b} mm':>14}" for a, b in BANDS_MM) + f"{'all':>10}"
    lines = [head, "-" * len(head)]
    for name, score in pooled.items():
        rows = [r for r in score.rows if r.truth_index >= 0 and r.result_id >= 0]
        z = np.array([r.z_true_mm for r in rows])
        dz = np.abs(np.array([r.dz_mm for r in rows]))
        cells = []
        for a, b in BANDS_MM:
            sel = (z >= a) & (z < b)
            cells.append(f"{np.percentile(dz[sel], 95):7.2f} (n={sel.sum():2d})" if sel.any() else f"{'-':>14}")
        all_p95 = f"{np.percentile(dz, 95):10.2f}" if len(dz) else f"{'-':>10}"
        lines.append(f"{name:<22}" + "".join(f"{c:>14}" for c in cells) + all_p95)
    lines.append("cells: p95 of |Z - Z_true| of matched features whose true depth lies in the band (n = count)")
    return "\n".join(lines)


def _seed_range(text: str) -> range:
    """``A-B`` (or one seed ``A``) -> range(A, B + 1)."""
    try:
        lo, _, hi = text.partition("-")
        r = range(int(lo), int(hi or lo) + 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not A-B (two whole numbers)") from None
    if not len(r):
        raise argparse.ArgumentTypeError(f"{text!r} is empty (A must not exceed B)")
    return r


def _supersamples(text: str) -> int:
    """``--ss``: a whole number >= 1."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: at least 1 supersample per pixel")
    return n


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", type=int, default=0, help="render this many more scenes (seeds 100..)")
    ap.add_argument("--seeds", metavar="A-B", type=_seed_range,
                    help="score only the rendered scenes of seeds A..B (rendered if not cached; no fixtures, no --extra)")
    ap.add_argument("--masks", choices=["true", "colour", "both"], default="both")
    ap.add_argument("--soft-truth", action="store_true",
                    help="exact masks as the renderer's soft coverage of each pixel, not whole pixels (half covered)")
    ap.add_argument("--tol-px", type=float, default=5.0, metavar="PX",
                    help="match radius of a reported feature to a true one in the left image, px (default 5)")
    ap.add_argument("--json", type=Path, help="write pooled scores here")
    ap.add_argument("--plot", type=Path, metavar="PNG",
                    help="draw dZ against true Z of every matched feature, one panel per method (synth.errorplot)")
    ap.add_argument("--pictures", type=Path, metavar="DIR",
                    help="write how the improved variant scored on each scene here (synth.show.draw_score)")
    ap.add_argument("--ss", type=_supersamples, default=2, metavar="N",
                    help="render with N x N supersamples per pixel (default 2, the fixtures'); "
                         "other N: cached in out/localize_scenes_ssN, fixture scenes rendered again")
    a = ap.parse_args()
    if a.pictures:
        a.pictures.mkdir(parents=True, exist_ok=True)
    cfg = load_config().localize
    calib = load_calibration(REPO / "fixtures" / "rig.yaml")
    locs = {v: Localizer(calib, cfg, v) for v in ("improved", "paper")}
    mask_modes = ["true", "colour"] if a.masks == "both" else [a.masks]
    per_method: dict[str, list] = {}
    times: dict[str, list] = {}
    axes: dict[str, list] = {}
    for name, lp, rp, tp in scenes(a.extra, a.seeds, a.ss):
        left, right, truth = cv2.imread(str(lp)), cv2.imread(str(rp)), load_truth(tp)
        for mode in mask_modes:
            exact = truth.exact_masks(soft=a.soft_truth)
            kw = dict(mask_left=exact[0], mask_right=exact[1]) if mode == "true" else {}
            for variant, loc in locs.items():
                t0 = time.perf_counter()
                res = loc.localize(left, right, **kw)
                times.setdefault(f"{variant}, {mode} masks", []).append(time.perf_counter() - t0)
                score = score_result(res, truth, tol_px=a.tol_px, name=name)
                per_method.setdefault(f"{variant}, {mode} masks", []).append(score)
                if a.pictures and variant == "improved":
                    pic = draw_score(left, res, truth, score)
                    cv2.imwrite(str(a.pictures / f"{name.replace(' ', '_')}_{mode}.png"), pic)
                axes.setdefault(f"{variant}, {mode} masks", []).extend(axis_errors(res, truth))
        per_method.setdefault("sgbm at true features", []).append(
            score_result(sgbm_result(locs["improved"], left, right, truth), truth, tol_px=a.tol_px, name=name))
        print(f"{name}: done", flush=True)
    pooled = {}
    for method, scores in per_method.items():
        print(f"\n== {method}")
        print(format_table(scores))
        pooled[method] = pool(scores, name=method)
    print("\n== p95 |dZ| per depth band")
    print(band_table(pooled))
    print("\n== pooled")
    head = (f"{'method':<22}{'recall':>7}{'prec':>6}{'p95 mm':>8}{'p95 px':>8}{'cover':>7}{'b.prec':>7}{'r err mm':>9}"
            f"{'false off axes':>15}")
    print(head)
    print("-" * len(head))
    for method, s in pooled.items():
        print(f"{method:<22}{s.recall:>7.2f}{s.precision:>6.2f}{s.depth_err_mm['p95']:>8.2f}"
              f"{s.depth_err_px['p95']:>8.3f}{s.branch_coverage:>7.2f}{s.branch_precision:>7.2f}"
              f"{s.radius_err_mm['median']:>9.2f}{s.n_result - s.n_correct - s.n_false_on_axis:>15d}")
    print("false off axes: reported features matched to no true one and over 10 mm from every true axis (an obstacle "
          "where there is none; the other false ones lie on a branch)")
    print("\n== per kind: true features found / seen in both views, and false ones")
    head = f"{'method':<22}{'tips':>14}{'false tips':>12}{'forks':>14}{'false forks':>13}{'free-cap tips':>15}"
    print(head)
    print("-" * len(head))
    for method, s in pooled.items():
        cells = []
        for kind in ("endpoint", "bifurcation"):
            true = [r for r in s.rows if r.truth_index >= 0 and r.kind == kind]
            found = sum(r.result_id >= 0 for r in true)
            false = sum(r.truth_index < 0 and r.kind == kind for r in s.rows)
            cells.append(f"{f'{found}/{len(true)}':>14}{false:>{12 if kind == 'endpoint' else 13}}")
        free = [r for r in s.rows if r.cap_free]
        cells.append(f"{f'{sum(r.result_id >= 0 for r in free)}/{len(free)}':>15}")
        print(f"{method:<22}" + "".join(cells))
    print("free-cap tips: tips seen in both views whose round end shows in both, neither cut by an occluder nor "
          "continued or touched by another branch (synth.caps)")
    print("\n== branch axes: distance of reported axis points to the true axis (covered points), mm")
    head = f"{'method':<22}" + "".join(f"{f'{lo}-{hi} p95':>14}" for lo, hi in BANDS_MM) + f"{'median':>8}{'p95':>8}"
    print(head)
    print("-" * len(head))
    for method, rows in axes.items():
        e = np.array(rows).reshape(-1, 2)
        cells = []
        for lo, hi in BANDS_MM:
            sel = (e[:, 1] >= lo) & (e[:, 1] < hi)
            cells.append(f"{np.percentile(e[sel, 0], 95):14.2f}" if sel.any() else f"{'-':>14}")
        print(f"{method:<22}" + "".join(cells) + f"{np.median(e[:, 0]):8.2f}{np.percentile(e[:, 0], 95):8.2f}")
    print("\n== time per pair (this machine, all cores, includes the first call)")
    for method, t in times.items():
        print(f"{method:<22}{1e3 * np.median(t):8.0f} ms")
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps({m: s.to_dict() for m, s in pooled.items()}, indent=1) + "\n")
    if a.plot:
        a.plot.parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(a.plot), draw_error_plot(panels_from_scores({m: s.to_dict() for m, s in pooled.items()})))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
