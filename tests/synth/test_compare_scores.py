"""benchmarks/compare_scores.py, run as a user runs it on two saved score files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from appliance.synth.evaluate import FeatureRow, Score, pool

REPO = Path(__file__).resolve().parents[2]
NAN = float("nan")


def _score(rows: list[FeatureRow]) -> dict:
    stats = {"median": 0.0, "p95": 0.0, "max": 0.0, "n": 0}
    found = sum(r.truth_index >= 0 and r.result_id >= 0 for r in rows)
    s = Score("s", n_true=sum(r.truth_index >= 0 for r in rows), n_result=sum(r.result_id >= 0 for r in rows),
              n_found=found, n_correct=found, depth_err_mm=stats, depth_err_px=stats, err_3d_mm=stats,
              left_err_px=stats, radius_err_mm=stats, visible_axis_mm=1.0, covered_axis_mm=1.0, reported_mm=1.0,
              reported_on_axis_mm=1.0, branch_radius_err_mm=stats, rows=rows)
    return {"improved, true masks": pool([s]).to_dict(), "improved, colour masks": pool([s]).to_dict()}


def _row(index, result, kind, z, dz):
    return FeatureRow(index, result, kind, z, z + dz, dz, NAN, NAN, NAN, NAN)


def test_two_runs_side_by_side_name_what_moved(tmp_path):
    before = [_row(0, 0, "bifurcation", 1000.0, 6.0), _row(1, 1, "endpoint", 800.0, 1.0),
              _row(2, -1, "endpoint", 1200.0, NAN), _row(-1, 2, "endpoint", NAN, NAN)]
    after = [_row(0, 0, "bifurcation", 1000.0, 0.5), _row(1, 1, "endpoint", 800.0, 1.1),
             _row(2, 3, "endpoint", 1200.0, -2.0)]
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(_score(before)))
    b.write_text(json.dumps(_score(after)))
    out = subprocess.run([sys.executable, str(REPO / "benchmarks" / "compare_scores.py"), str(a), str(b)],
                         capture_output=True, text=True, check=True).stdout
    true_part = out.split("== improved, colour masks")[0]
    assert "max   6.00" in true_part and "max   2.00" in true_part
    assert "tips 1/2 (1)" in true_part and "tips 2/2 (0)" in true_part
    assert "T0 bifurcation at Z 1000 mm: +6.00 mm -> +0.50 mm" in true_part
    assert "T2 endpoint at Z 1200 mm: missed -> -2.00 mm" in true_part
    assert "T1 endpoint" not in true_part                    # (moved by 0.1 mm: under the 0.3 mm default)


def test_a_file_that_is_no_score_is_named(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    r = subprocess.run([sys.executable, str(REPO / "benchmarks" / "compare_scores.py"), str(bad), str(bad)],
                       capture_output=True, text=True)
    assert r.returncode != 0 and str(bad) in r.stderr and "not a localize_accuracy.py --json file" in r.stderr
