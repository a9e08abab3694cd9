"""Scores of a localization result (or a calibration) against a scene's exact truth.

Features are matched in the left image: each result feature to the nearest unmatched true feature of the
same kind within ``tol_px`` (greedy, nearest pairs first). Recall counts the true features visible in both
views; a result matched to a true feature hidden in one view (e.g. recovered behind a leaf) is not a false
positive. Depth errors are of the matched features (signed ``dz = Z - Z_true``), also in pixels of disparity
(``f b |1/Z - 1/Z_true|`` with the true rig's rectified f and b). Branch coverage is the fraction of the
visible true axis length (2 mm samples visible in both views) within ``cover_mm`` of a reported polyline;
branch precision the fraction of reported polyline length within ``cover_mm`` of a true axis.

    python -m appliance.synth.evaluate RESULT.json TRUTH.json [RESULT.json TRUTH.json ...] [--json OUT]
    python -m appliance.synth.evaluate --calib calib.yaml --rig fixtures/rig.yaml [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np

from appliance.calibrate.compare import compare
from appliance.calibrate.model import StereoCalibration, load_calibration
from appliance.errors import ApplianceError
from appliance.localize.result import Branch, Feature, LocalizationResult
from appliance.synth.caps import cap_readings
from appliance.synth.rig import Rig, rig_from_calibration
from appliance.synth.truth import SceneTruth, load_truth

SAFETY_K = 1.05          # safe depth = Z - k * radius (the paper's k)


@dataclass(frozen=True)
class FeatureRow:
    """One true feature (visible in both views) or one unmatched result feature.

    ``truth_index`` is -1 for a result feature matching no true feature; ``result_id`` is -1 for a true
    feature no result matched. Errors are NaN where not defined. ``cap_free`` tells, for a true tip seen
    in both views, whether its round end shows free in both (:mod:`appliance.synth.caps`); None otherwise.
    """

    truth_index: int
    result_id: int
    kind: str
    z_true_mm: float
    z_mm: float
    dz_mm: float
    disparity_err_px: float
    err_3d_mm: float
    left_err_px: float
    radius_err_mm: float
    cap_free: bool | None = None


def _stats(values) -> dict:
    v = np.abs(np.asarray(values, float))
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return {"median": float("nan"), "p95": float("nan"), "max": float("nan"), "n": 0}
    return {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(v.max()),
            "n": int(len(v))}


@dataclass(frozen=True)
class Score:
    """How a result compares with the truth of one scene (or several, pooled).

    Attributes
    ----------
    name : str
    n_true : int
        True features visible in both views.
    n_result : int
        Result features.
    n_found : int
        True features (visible in both) matched by a result feature.
    n_correct : int
        Result features matched to any true feature.
    recall, precision : float
    depth_err_mm, depth_err_px, err_3d_mm, left_err_px, radius_err_mm : dict
        ``median``, ``p95``, ``max`` of the absolute errors of matched features, and ``n``.
    visible_axis_mm, covered_axis_mm : float
        Visible true axis length and the part of it within ``cover_mm`` of a reported polyline.
    reported_mm, reported_on_axis_mm : float
        Reported polyline length and the part of it within ``cover_mm`` of a true axis.
    branch_radius_err_mm : dict
        Absolute error of each reported branch's radius against the true radius where it lies.
    rows : list of FeatureRow
    branch_radius_errors_mm : list of float
        Signed radius error of each reported branch lying on a true axis.
    n_false_on_axis : int
        Result features matched to no true feature that lie within ``cover_mm`` of a true axis (a fork placed
        more than the match radius from its place, a crossing taken for a fork): false, but on a branch; the
        others (``n_result - n_correct - n_false_on_axis``) are obstacles where there is none.
    """

    name: str
    n_true: int
    n_result: int
    n_found: int
    n_correct: int
    depth_err_mm: dict
    depth_err_px: dict
    err_3d_mm: dict
    left_err_px: dict
    radius_err_mm: dict
    visible_axis_mm: float
    covered_axis_mm: float
    reported_mm: float
    reported_on_axis_mm: float
    branch_radius_err_mm: dict
    rows: list = field(default_factory=list)
    branch_radius_errors_mm: list = field(default_factory=list)
    n_false_on_axis: int = 0

    @property
    def recall(self) -> float:
        return self.n_found / self.n_true if self.n_true else float("nan")

    @property
    def precision(self) -> float:
        return self.n_correct / self.n_result if self.n_result else float("nan")

    @property
    def branch_coverage(self) -> float:
        return self.covered_axis_mm / self.visible_axis_mm if self.visible_axis_mm else float("nan")

    @property
    def branch_precision(self) -> float:
        return self.reported_on_axis_mm / self.reported_mm if self.reported_mm else float("nan")

    def to_dict(self) -> dict:
        """JSON-ready: plain types, NaN as ``None``."""
        d = asdict(self)
        d.update(recall=self.recall, precision=self.precision, branch_coverage=self.branch_coverage,
                 branch_precision=self.branch_precision)
        return _plain(d)


def _plain(x):
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return None if not np.isfinite(x) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def _samples(polyline: np.ndarray, step_mm: float):
    """Points every ``step_mm`` along a polyline (M, 3) and the length each stands for."""
    seg = np.linalg.norm(np.diff(polyline, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    if cum[-1] <= 0:
        return polyline[:1], np.zeros(1)
    n = max(int(np.ceil(cum[-1] / step_mm)), 1)
    s = (np.arange(n) + 0.5) * cum[-1] / n
    pts = np.column_stack([np.interp(s, cum, polyline[:, k]) for k in range(3)])
    return pts, np.full(n, cum[-1] / n)


def _distance_to_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray):
    """Distance (N,) of each point to the nearest segment (a[j], b[j]) and that segment's index."""
    if len(a) == 0:
        return np.full(len(points), np.inf), np.zeros(len(points), int)
    ab = b - a
    l2 = np.maximum((ab * ab).sum(1), 1e-12)
    out_d = np.empty(len(points))
    out_j = np.empty(len(points), int)
    for start in range(0, len(points), 2048):
        p = points[start:start + 2048, None, :]
        t = np.clip(((p - a[None]) * ab[None]).sum(2) / l2[None], 0, 1)
        d = np.linalg.norm(p - (a[None] + t[..., None] * ab[None]), axis=2)
        j = d.argmin(1)
        out_d[start:start + 2048] = d[np.arange(len(j)), j]
        out_j[start:start + 2048] = j
    return out_d, out_j


def covered_axis(result: LocalizationResult, truth: SceneTruth, cover_mm: float = 10.0):
    """The true axes' samples seen in both views, and which of them a reported branch covers.

    Returns
    -------
    points_mm : ndarray (N, 3)
        Samples every ~2 mm of every true axis visible in both views, left camera frame, mm.
    length_mm : ndarray (N,)
        Axis length each sample stands for, mm.
    covered : ndarray (N,) bool
        Within ``cover_mm`` of a reported polyline.
    """
    pts, lens, _, vis = _true_axis_samples(truth)
    lines = [np.asarray(b.polyline_mm, float) for b in result.branches if len(b.polyline_mm) >= 2]
    a = np.concatenate([p[:-1] for p in lines]) if lines else np.zeros((0, 3))
    b = np.concatenate([p[1:] for p in lines]) if lines else np.zeros((0, 3))
    dist, _ = _distance_to_segments(pts[vis], a, b)
    return pts[vis], lens[vis], dist <= cover_mm


def _true_axis_samples(truth: SceneTruth, step_mm: float = 2.0):
    """Samples of every true axis: points (N, 3), length each (N,), radius (N,), visible in both views (N,)."""
    pts, lens, radii = [], [], []
    for b in truth.branches:
        p, ln = _samples(b.axis_mm, step_mm)
        seg = np.linalg.norm(np.diff(b.axis_mm, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        s = np.cumsum(ln) - ln / 2
        pts.append(p)
        lens.append(ln)
        radii.append(np.interp(s, cum, b.radius_mm))
    pts, lens, radii = np.concatenate(pts), np.concatenate(lens), np.concatenate(radii)
    h, w = truth.mask_left.shape
    vis = np.ones(len(pts), bool)
    for side, mask in (("left", truth.mask_left), ("right", truth.mask_right)):
        px = np.round(truth.rig.project(pts, side)).astype(int)
        inside = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
        u, v = np.clip(px[:, 0], 0, w - 1), np.clip(px[:, 1], 0, h - 1)
        vis &= inside & mask[v, u]
        if side == "left":               # the visible surface there is this tube's, not something in front
            z = truth.depth_left_mm[v, u]
            vis &= (z > pts[:, 2] - 2.5 * radii - 3) & (z < pts[:, 2] + 1)
    return pts, lens, radii, vis


def _free(reading: tuple[str, str] | None) -> bool | None:
    return None if reading is None else reading == ("free", "free")


def feature_rows(result: LocalizationResult, truth: SceneTruth, tol_px: float = 5.0,
                 match_kind: bool = True) -> tuple[list[FeatureRow], int]:
    """The feature part of :func:`score_result` (its rows and the number of matched pairs), without the branches'
    coverage (the larger part of a score's cost)."""
    calib = truth.rig.calibration()
    fb = calib.f_px * calib.baseline_mm
    tf = truth.features
    both = tf.visible_left & tf.visible_right
    res = list(result.features)
    # greedy one-to-one matching in the left image
    pairs = []
    if res and len(tf):
        rp = np.array([f.left_px for f in res], float)
        d = np.linalg.norm(rp[:, None, :] - tf.left_px[None], axis=2)
        if match_kind:
            same = np.array([[f.kind == k for k in tf.kind] for f in res])
            d = np.where(same, d, np.inf)
        for flat in np.argsort(d, axis=None):
            i, j = np.unravel_index(flat, d.shape)
            if d[i, j] > tol_px:
                break
            if all(i != a and j != b for a, b in pairs):
                pairs.append((int(i), int(j)))
    by_truth = {j: i for i, j in pairs}
    caps = cap_readings(truth)
    rows = []
    for j in range(len(tf)):
        if j not in by_truth and not both[j]:
            continue
        z_true = float(tf.xyz_mm[j, 2])
        if j in by_truth:
            f = res[by_truth[j]]
            z = float(f.xyz_mm[2])
            with np.errstate(divide="ignore"):
                disp = abs(fb / z - fb / z_true) if z > 0 else float("inf")
            rows.append(FeatureRow(j, int(f.id), str(tf.kind[j]), z_true, z, z - z_true, disp,
                                   float(np.linalg.norm(np.subtract(f.xyz_mm, tf.xyz_mm[j]))),
                                   float(np.linalg.norm(np.subtract(f.left_px, tf.left_px[j]))),
                                   float(f.radius_mm - tf.radius_mm[j]), _free(caps[j])))
        else:
            nan = float("nan")
            rows.append(FeatureRow(j, -1, str(tf.kind[j]), z_true, nan, nan, nan, nan, nan, nan, _free(caps[j])))
    matched_res = {i for i, _ in pairs}
    for i, f in enumerate(res):
        if i not in matched_res:
            nan = float("nan")
            rows.append(FeatureRow(-1, int(f.id), f.kind, nan, float(f.xyz_mm[2]), nan, nan, nan, nan, nan))
    return rows, len(pairs)


def score_result(result: LocalizationResult, truth: SceneTruth, tol_px: float = 5.0, cover_mm: float = 10.0,
                 name: str = "", match_kind: bool = True) -> Score:
    """Score ``result`` against ``truth``.

    Parameters
    ----------
    result : LocalizationResult
    truth : SceneTruth
    tol_px : float
        Largest left-image distance of a matched feature, px.
    cover_mm : float
        Distance within which a reported polyline covers a true axis, mm.
    name : str
        Label in tables.
    match_kind : bool
        Match only features of the same kind.
    """
    tf = truth.features
    both = tf.visible_left & tf.visible_right
    rows, n_pairs = feature_rows(result, truth, tol_px, match_kind)
    found = [r for r in rows if r.truth_index >= 0 and r.result_id >= 0]

    # branches: coverage of the visible true axes, and how much of what was reported lies on a true axis
    _, lens, on = covered_axis(result, truth, cover_mm)
    covered = float(lens[on].sum())
    true_a = np.concatenate([br.axis_mm[:-1] for br in truth.branches])
    true_b = np.concatenate([br.axis_mm[1:] for br in truth.branches])
    true_r = np.concatenate([(br.radius_mm[:-1] + br.radius_mm[1:]) / 2 for br in truth.branches])
    by_id = {f.id: f for f in result.features}
    false_xyz = np.array([by_id[r.result_id].xyz_mm for r in rows if r.truth_index < 0], float).reshape(-1, 3)
    n_false_on_axis = int((_distance_to_segments(false_xyz, true_a, true_b)[0] <= cover_mm).sum())
    reported = on_axis = 0.0
    branch_radius_err = []
    for br in result.branches:
        if len(br.polyline_mm) < 2:
            continue
        p, ln = _samples(np.asarray(br.polyline_mm, float), 2.0)
        d, j = _distance_to_segments(p, true_a, true_b)
        reported += float(ln.sum())
        near = d <= cover_mm
        on_axis += float(ln[near].sum())
        if near.any():
            branch_radius_err.append(float(br.radius_mm - np.mean(true_r[j[near]])))
    return Score(
        name=name, n_true=int(both.sum()), n_result=len(result.features),
        n_found=sum(1 for r in found if both[r.truth_index]), n_correct=n_pairs,
        depth_err_mm=_stats([r.dz_mm for r in found]),
        depth_err_px=_stats([r.disparity_err_px for r in found]),
        err_3d_mm=_stats([r.err_3d_mm for r in found]),
        left_err_px=_stats([r.left_err_px for r in found]),
        radius_err_mm=_stats([r.radius_err_mm for r in found]),
        visible_axis_mm=float(lens.sum()), covered_axis_mm=covered,
        reported_mm=reported, reported_on_axis_mm=on_axis,
        branch_radius_err_mm=_stats(branch_radius_err), rows=rows, branch_radius_errors_mm=branch_radius_err,
        n_false_on_axis=n_false_on_axis,
    )


def pool(scores, name: str = "all") -> Score:
    """One score over several scenes: counts and lengths summed, error statistics over all matched rows."""
    rows = [r for s in scores for r in s.rows]
    found = [r for r in rows if r.truth_index >= 0 and r.result_id >= 0]
    return Score(
        name=name, n_true=sum(s.n_true for s in scores), n_result=sum(s.n_result for s in scores),
        n_found=sum(s.n_found for s in scores), n_correct=sum(s.n_correct for s in scores),
        depth_err_mm=_stats([r.dz_mm for r in found]), depth_err_px=_stats([r.disparity_err_px for r in found]),
        err_3d_mm=_stats([r.err_3d_mm for r in found]), left_err_px=_stats([r.left_err_px for r in found]),
        radius_err_mm=_stats([r.radius_err_mm for r in found]),
        visible_axis_mm=sum(s.visible_axis_mm for s in scores), covered_axis_mm=sum(s.covered_axis_mm for s in scores),
        reported_mm=sum(s.reported_mm for s in scores), reported_on_axis_mm=sum(s.reported_on_axis_mm for s in scores),
        branch_radius_err_mm=_stats([e for s in scores for e in s.branch_radius_errors_mm]), rows=rows,
        branch_radius_errors_mm=[e for s in scores for e in s.branch_radius_errors_mm],
        n_false_on_axis=sum(s.n_false_on_axis for s in scores),
    )


def format_table(scores) -> str:
    """A plain-text table, one line per score (a pooled line is added for several)."""
    scores = list(scores)
    if len(scores) > 1:
        scores.append(pool(scores))
    head = (f"{'scene':<12}{'found':>8}{'recall':>7}{'prec':>6}{'|dZ| mm: med':>13}{'p95':>7}{'max':>7}"
            f"{'disp px p95':>12}{'3D mm p95':>10}{'r mm':>6}{'cover':>6}{'b.prec':>7}")
    lines = [head, "-" * len(head)]
    for s in scores:
        dz, dp = s.depth_err_mm, s.depth_err_px
        lines.append(f"{s.name:<12}{f'{s.n_found}/{s.n_true}':>8}{s.recall:>7.2f}{s.precision:>6.2f}"
                     f"{dz['median']:>13.2f}{dz['p95']:>7.2f}{dz['max']:>7.2f}{dp['p95']:>12.3f}"
                     f"{s.err_3d_mm['p95']:>10.2f}{s.radius_err_mm['median']:>6.2f}{s.branch_coverage:>6.2f}"
                     f"{s.branch_precision:>7.2f}")
    lines.append("found: true features seen in both views matched in the left image; r: median radius error;"
                 " cover: visible axis length covered; b.prec: reported length on a true axis")
    return "\n".join(lines)


def result_from_truth(truth: SceneTruth, visible_only: bool = True) -> LocalizationResult:
    """The truth as a perfect localizer would report it (features seen in both views; whole axes)."""
    tf = truth.features
    keep = (tf.visible_left & tf.visible_right) if visible_only else np.ones(len(tf), bool)
    features = tuple(
        Feature(int(j), str(tf.kind[j]), tuple(tf.left_px[j]), tuple(tf.right_px[j]), tuple(tf.xyz_mm[j]),
                float(tf.radius_mm[j]), float(tf.xyz_mm[j, 2] - SAFETY_K * tf.radius_mm[j]))
        for j in np.nonzero(keep)[0])
    ids = {int(f.id) for f in features}
    branches = []
    for i, b in enumerate(truth.branches):
        start = [j for j in ids if tf.kind[j] == "bifurcation" and tf.branch[j] == i]
        end = [j for j in ids if tf.kind[j] == "endpoint" and tf.branch[j] == i]
        branches.append(Branch(i, (start[0] if start else -1, end[0] if end else -1), b.axis_mm.copy(),
                               float(b.radius_mm.mean())))
    return LocalizationResult(features, tuple(branches))


def score_calibration(calib: StereoCalibration, rig: Rig) -> dict:
    """A calibration against the true rig: :func:`appliance.calibrate.compare.compare` plus the baseline
    error in mm and the rotation error in degrees."""
    true = rig.calibration()
    out = compare(calib, true)
    out["baseline_mm"] = float(calib.baseline_mm - true.baseline_mm)
    dR = np.asarray(calib.R) @ np.asarray(rig.R).T
    out["rotation_deg"] = float(np.degrees(np.linalg.norm(cv2.Rodrigues(dR)[0])))
    return out


CALIBRATION_ROWS = (
    ("fx_pct", "focal length fx (worst camera)", "%"), ("fy_pct", "focal length fy (worst camera)", "%"),
    ("pp_px", "principal point (worst camera)", "px"), ("baseline_pct", "baseline", "%"),
    ("baseline_mm", "baseline", "mm"), ("rotation_deg", "rotation between the cameras", "deg"),
    ("depth_pct_at_500", "depth RMS at 500 mm", "%"), ("depth_pct_at_1000", "depth RMS at 1000 mm", "%"),
    ("depth_pct_at_1500", "depth RMS at 1500 mm", "%"),
)


def format_calibration(errors: dict) -> str:
    """A plain-text table of :func:`score_calibration`'s errors."""
    lines = [f"{'calibration error':<34}{'value':>12}", "-" * 46]
    lines += [f"{label:<34}{errors[key]:>+9.3f} {unit:<3}" for key, label, unit in CALIBRATION_ROWS if key in errors]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m appliance.synth.evaluate", description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="*", type=Path, help="RESULT.json TRUTH.json, repeated")
    ap.add_argument("--json", type=Path, help="write the scores here")
    ap.add_argument("--tol-px", type=float, default=5.0)
    ap.add_argument("--calib", type=Path, help="score this calibration file against --rig instead")
    ap.add_argument("--rig", type=Path, help="the true rig (e.g. fixtures/rig.yaml)")
    a = ap.parse_args(argv)
    if a.calib or a.rig:
        if not (a.calib and a.rig) or a.pairs:
            ap.error("--calib and --rig go together, without RESULT/TRUTH pairs")
        try:
            errors = score_calibration(load_calibration(a.calib), rig_from_calibration(load_calibration(a.rig)))
        except ApplianceError as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
        print(format_calibration(errors))
        if a.json:
            a.json.write_text(json.dumps(errors, indent=1) + "\n")
        return 0
    if not a.pairs or len(a.pairs) % 2:
        ap.error("give RESULT.json TRUTH.json pairs")
    scores = []
    for res_path, truth_path in zip(a.pairs[::2], a.pairs[1::2]):
        try:
            result = LocalizationResult.from_dict(json.loads(res_path.read_text()))
            scores.append(score_result(result, load_truth(truth_path), a.tol_px, name=truth_path.stem))
        except (OSError, ValueError, KeyError, TypeError) as e:
            print(f"error: {res_path}: not a readable result ({e})", file=sys.stderr)
            return 1
        except ApplianceError as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
    print(format_table(scores))
    if a.json:
        a.json.write_text(json.dumps([s.to_dict() for s in scores], indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
