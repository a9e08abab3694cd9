"""A picture of a scene with its truth: both images side by side, true axes and numbered features.

    python -m appliance.synth.show fixtures/scenes/truth_00.json out.png [--left L.png --right R.png]

Images default to ``left_NN.png``/``right_NN.png`` next to ``truth_NN.json``. Features: a cross (yellow for
tips, magenta for forks) where visible in that view, a grey circle where hidden; axes drawn thin in cyan.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from appliance.errors import ApplianceError
from appliance.localize.result import LocalizationResult
from appliance.synth.evaluate import Score, covered_axis
from appliance.synth.truth import SceneTruth, load_truth

COLOURS = {"endpoint": (0, 230, 255), "bifurcation": (255, 0, 255)}


def draw_truth(left: np.ndarray, right: np.ndarray, truth: SceneTruth, axes: bool = True) -> np.ndarray:
    """Left and right BGR images side by side (H, 2W, 3) with the truth drawn on them."""
    f = truth.features
    panels = []
    for side, img, px, vis in (("left", left, f.left_px, f.visible_left), ("right", right, f.right_px,
                                                                          f.visible_right)):
        out = img.copy() if img.ndim == 3 else cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
        if axes:
            for b in truth.branches:
                seg = np.linalg.norm(np.diff(b.axis_mm, axis=0), axis=1)
                cum = np.concatenate([[0.0], np.cumsum(seg)])
                s = np.linspace(0, cum[-1], max(int(cum[-1] / 3), 2))
                pts = np.column_stack([np.interp(s, cum, b.axis_mm[:, k]) for k in range(3)])
                line = np.round(truth.rig.project(pts, side) * 4).astype(np.int32)
                cv2.polylines(out, [line.reshape(-1, 1, 2)], False, (255, 255, 0), 1, cv2.LINE_AA, shift=2)
        for j, ((u, v), seen) in enumerate(zip(px, vis)):
            c = (int(round(u)), int(round(v)))
            if seen:
                cv2.drawMarker(out, c, COLOURS[str(f.kind[j])], cv2.MARKER_CROSS, 18, 2, cv2.LINE_AA)
            else:
                cv2.circle(out, c, 8, (160, 160, 160), 1, cv2.LINE_AA)
            cv2.putText(out, str(j), (c[0] + 7, c[1] - 7), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 3,
                        cv2.LINE_AA)
            cv2.putText(out, str(j), (c[0] + 7, c[1] - 7), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 1,
                        cv2.LINE_AA)
        cv2.putText(out, side, (12, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (255, 255, 255), 2, cv2.LINE_AA)
        panels.append(out)
    return np.hstack(panels)


def draw_score(left: np.ndarray, result: LocalizationResult, truth: SceneTruth, score: Score,
               cover_mm: float = 10.0) -> np.ndarray:
    """The left image (H, W, 3) with how a result scored against the truth: the true axes green where a
    reported branch covers them (within ``cover_mm``) and red where none does, the reported branches
    thin in blue beneath (seen where they are not on a true axis), true features seen in both views ringed green when found and red when missed, and
    reported features matching no true one crossed in orange."""
    out = (left if left.ndim == 3 else cv2.cvtColor(left, cv2.COLOR_GRAY2BGR)) // 2   # dimmed: marks stand out
    for b in result.branches:
        if len(b.polyline_mm) >= 2:
            line = np.round(truth.rig.project(np.asarray(b.polyline_mm, float), "left") * 4).astype(np.int32)
            cv2.polylines(out, [line.reshape(-1, 1, 2)], False, (255, 170, 0), 1, cv2.LINE_AA, shift=2)
    pts, _, covered = covered_axis(result, truth, cover_mm)
    px = np.round(truth.rig.project(pts, "left")).astype(int) if len(pts) else np.zeros((0, 2), int)
    for (u, v), on in zip(px.tolist(), covered.tolist()):
        cv2.circle(out, (u, v), 2, (0, 220, 0) if on else (0, 0, 255), -1)
    found = {r.truth_index for r in score.rows if r.truth_index >= 0 and r.result_id >= 0}
    for r in score.rows:
        if r.truth_index >= 0:
            u, v = np.round(truth.features.left_px[r.truth_index]).astype(int).tolist()
            cv2.circle(out, (u, v), 10, (0, 220, 0) if r.truth_index in found else (0, 0, 255), 2, cv2.LINE_AA)
    by_id = {f.id: f for f in result.features}
    for r in score.rows:
        if r.truth_index < 0 and r.result_id in by_id:
            u, v = np.round(by_id[r.result_id].left_px).astype(int).tolist()
            cv2.drawMarker(out, (u, v), (0, 140, 255), cv2.MARKER_TILTED_CROSS, 16, 2, cv2.LINE_AA)
    text = (f"{score.name}  found {score.n_found}/{score.n_true}  false {score.n_result - score.n_correct}  "
            f"cover {score.branch_coverage:.2f}")
    cv2.putText(out, text, (12, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (255, 255, 255), 2, cv2.LINE_AA)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m appliance.synth.show", description=__doc__.splitlines()[0])
    ap.add_argument("truth", type=Path, help="truth_NN.json")
    ap.add_argument("out", type=Path, help="PNG to write")
    ap.add_argument("--left", type=Path)
    ap.add_argument("--right", type=Path)
    a = ap.parse_args(argv)
    nn = a.truth.stem.rsplit("_", 1)[-1]
    left_path = a.left or a.truth.with_name(f"left_{nn}.png")
    right_path = a.right or a.truth.with_name(f"right_{nn}.png")
    try:
        truth = load_truth(a.truth)
        images = [cv2.imread(str(p)) for p in (left_path, right_path)]
        for p, img in zip((left_path, right_path), images):
            if img is None:
                raise ApplianceError(f"{p}: not a readable image")
        a.out.parent.mkdir(parents=True, exist_ok=True)
        if not cv2.imwrite(str(a.out), draw_truth(images[0], images[1], truth)):
            raise ApplianceError(f"{a.out}: cannot write the picture")
    except ApplianceError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
