"""The evaluator: perfect for the truth itself, the right degradations for perturbed copies."""

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from appliance.calibrate.model import StereoCalibration, save_calibration
from appliance.localize.result import Feature, LocalizationResult
from appliance.synth.evaluate import format_table, pool, result_from_truth, score_calibration, score_result
from appliance.synth.rig import default_rig
from appliance.synth.truth import load_truth

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"


@pytest.fixture(scope="module")
def truth():
    return load_truth(SCENES / "truth_01.json")


def test_truth_itself_scores_perfectly(truth):
    s = score_result(result_from_truth(truth), truth)
    both = truth.features.visible_left & truth.features.visible_right
    assert s.n_true == both.sum() > 3
    assert s.recall == 1.0 and s.precision == 1.0
    assert s.depth_err_mm["max"] == 0.0 and s.depth_err_px["max"] == 0.0 and s.err_3d_mm["max"] == 0.0
    assert s.branch_coverage == 1.0 and s.branch_precision == 1.0
    assert s.visible_axis_mm > 300


def test_perturbed_copy_scores_as_expected(truth):
    perfect = result_from_truth(truth)
    shifted = tuple(dataclasses.replace(f, xyz_mm=(f.xyz_mm[0], f.xyz_mm[1], f.xyz_mm[2] + 2.0))
                    for f in perfect.features)
    dropped = shifted[1:]
    s = score_result(dataclasses.replace(perfect, features=dropped), truth)
    n = len(perfect.features)
    assert s.n_found == n - 1 and s.recall == pytest.approx((n - 1) / n)
    assert s.precision == 1.0
    assert s.depth_err_mm["median"] == pytest.approx(2.0) and s.depth_err_mm["max"] == pytest.approx(2.0)
    assert s.err_3d_mm["p95"] == pytest.approx(2.0)
    calib = truth.rig.calibration()
    z = np.array([f.xyz_mm[2] for f in perfect.features[1:]])
    expected_px = calib.f_px * calib.baseline_mm * (1 / z - 1 / (z + 2))
    assert s.depth_err_px["max"] == pytest.approx(expected_px.max(), rel=1e-6)
    missed = [r for r in s.rows if r.result_id == -1]
    assert [r.truth_index for r in missed] == [perfect.features[0].id]


def test_false_features_and_misplaced_branches_count_against(truth):
    perfect = result_from_truth(truth)
    ghost = Feature(999, "endpoint", (5.0, 5.0), (0.0, 5.0), (0.0, 0.0, 800.0), 5.0, 795.0)
    moved = [dataclasses.replace(b, polyline_mm=b.polyline_mm + [0.0, 30.0, 0.0]) if k == 0 else b
             for k, b in enumerate(perfect.branches)]
    s = score_result(LocalizationResult(perfect.features + (ghost,), tuple(moved)), truth)
    assert s.recall == 1.0 and s.precision == pytest.approx(len(perfect.features) / (len(perfect.features) + 1))
    assert 0.0 < s.branch_coverage < 1.0 and s.branch_precision < 1.0
    # a false feature on a true axis (a fork placed off its place) is counted apart from one where nothing is
    assert s.n_false_on_axis == 0
    axis_point = tuple(truth.branches[0].axis_mm[len(truth.branches[0].axis_mm) // 2])
    misplaced = Feature(998, "bifurcation", (5.0, 900.0), (0.0, 900.0), axis_point, 5.0, axis_point[2] - 5.0)
    s = score_result(LocalizationResult(perfect.features + (ghost, misplaced), perfect.branches), truth)
    assert s.n_result - s.n_correct == 2 and s.n_false_on_axis == 1
    assert pool([s, s]).n_false_on_axis == 2
    # a wrong kind is not a match
    swapped = tuple(dataclasses.replace(f, kind="endpoint" if f.kind == "bifurcation" else "bifurcation")
                    for f in perfect.features)
    assert score_result(LocalizationResult(swapped, perfect.branches), truth).n_found == 0


def test_table_json_and_command_line(truth, tmp_path):
    s = score_result(result_from_truth(truth), truth, name="scene 01")
    table = format_table([s, s])
    assert "scene 01" in table and "all" in table and "1.00" in table
    pooled = pool([s, s])
    assert pooled.n_true == 2 * s.n_true and pooled.recall == 1.0
    assert pooled.branch_radius_err_mm["n"] == 2 * s.branch_radius_err_mm["n"] > 0
    d = json.loads(json.dumps(s.to_dict()))
    assert d["recall"] == 1.0 and len(d["rows"]) == s.n_true
    res = tmp_path / "result.json"
    res.write_text(json.dumps(result_from_truth(truth).to_dict()))
    out = tmp_path / "scores.json"
    r = subprocess.run([sys.executable, "-m", "appliance.synth.evaluate", res, SCENES / "truth_01.json",
                        "--json", out], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "truth_01" in r.stdout
    assert json.loads(out.read_text())[0]["precision"] == 1.0
    r = subprocess.run([sys.executable, "-m", "appliance.synth.evaluate", tmp_path / "missing.json",
                        SCENES / "truth_01.json"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and "missing.json" in r.stderr


def test_calibration_score_against_the_true_rig():
    rig = default_rig()
    assert score_calibration(rig.calibration(), rig)["rotation_deg"] == pytest.approx(0.0, abs=1e-9)
    K1 = rig.K1.copy()
    K1[0, 0] *= 1.01
    off = StereoCalibration.from_pose(rig.size, K1, rig.D1, rig.K2, rig.D2, rig.R, rig.T * 1.02)
    e = score_calibration(off, rig)
    assert e["fx_pct"] == pytest.approx(1.0, rel=1e-6)
    assert e["baseline_mm"] == pytest.approx(0.02 * np.linalg.norm(rig.T), rel=1e-3)
    assert e["baseline_pct"] == pytest.approx(2.0, rel=1e-3)


def test_calibration_command_line(tmp_path):
    rig = default_rig()
    K1 = rig.K1.copy()
    K1[0, 0] *= 1.01
    calib = StereoCalibration.from_pose(rig.size, K1, rig.D1, rig.K2, rig.D2, rig.R, rig.T)
    save_calibration(calib, tmp_path / "c.yaml")
    repo = SCENES.parents[1]
    r = subprocess.run([sys.executable, "-m", "appliance.synth.evaluate", "--calib", tmp_path / "c.yaml", "--rig",
                        repo / "fixtures" / "rig.yaml", "--json", tmp_path / "e.json"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "+1.000 %" in r.stdout
    assert json.loads((tmp_path / "e.json").read_text())["fx_pct"] == pytest.approx(1.0, rel=1e-6)
