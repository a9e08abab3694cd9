"""`appliance localize` and `appliance bench localize` as real processes."""

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from appliance.localize import LocalizationResult
from appliance.synth.truth import load_truth

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
RIG = FIXTURES / "rig.yaml"
LEFT, RIGHT = FIXTURES / "scenes" / "left_00.png", FIXTURES / "scenes" / "right_00.png"


APPLIANCE = str(Path(sys.executable).with_name("appliance"))


def run(*args):
    return subprocess.run([APPLIANCE, *map(str, args)], capture_output=True, text=True, timeout=120)


def test_localize_writes_result_and_overlay(tmp_path):
    out, png = tmp_path / "r.json", tmp_path / "o.png"
    p = run("localize", "--calib", RIG, LEFT, RIGHT, "--json", out, "--overlay", png)
    assert p.returncode == 0, p.stderr
    data = json.loads(out.read_text())
    assert data["variant"] == "improved"
    res = LocalizationResult.from_dict(data)
    assert len(res.features) >= 3 and len(res.branches) >= 3
    for f in res.features:
        assert 500 * 0.9 < f.xyz_mm[2] < 1500 * 1.1
        assert f.safe_depth_mm < f.xyz_mm[2]
    assert "total" in data["timings_ms"]
    img = cv2.imread(str(png))
    assert img.shape == (960, 2560, 3)


def test_paper_variant_with_external_masks(tmp_path):
    truth = load_truth(FIXTURES / "scenes" / "truth_00.json")
    ml, mr = tmp_path / "ml.png", tmp_path / "mr.png"
    cv2.imwrite(str(ml), truth.mask_left.astype(np.uint8) * 255)
    cv2.imwrite(str(mr), truth.mask_right.astype(np.uint8) * 255)
    out = tmp_path / "r.json"
    p = run("localize", "--calib", RIG, LEFT, RIGHT, "--json", out, "--paper", "--mask-left", ml, "--mask-right", mr)
    assert p.returncode == 0, p.stderr
    data = json.loads(out.read_text())
    assert data["variant"] == "paper" and len(data["features"]) >= 3


def test_a_grey_level_mask_file_is_a_probability_not_non_zero(tmp_path):
    # a segmenter's probability map saved as 8 bits: soft outlines, and a faint background (0.12)
    # that "non-zero = branch" would have taken for branch everywhere
    truth = load_truth(FIXTURES / "scenes" / "truth_00.json")
    paths = {}
    for side, m in (("left", truth.mask_left), ("right", truth.mask_right)):
        binary = m.astype(np.uint8) * 255
        soft = np.clip(cv2.GaussianBlur(binary.astype(np.float32), (0, 0), 1.0) + 30, 0, 255).astype(np.uint8)
        for kind, img in (("binary", binary), ("soft", soft)):
            paths[kind, side] = tmp_path / f"{kind}_{side}.png"
            cv2.imwrite(str(paths[kind, side]), img)
    results = {}
    for kind in ("binary", "soft"):
        out = tmp_path / f"{kind}.json"
        p = run("localize", "--calib", RIG, LEFT, RIGHT, "--json", out,
                "--mask-left", paths[kind, "left"], "--mask-right", paths[kind, "right"])
        assert p.returncode == 0, p.stderr
        results[kind] = LocalizationResult.from_dict(json.loads(out.read_text()))
    hard, soft = results["binary"].features, results["soft"].features
    assert len(hard) >= 5 and abs(len(soft) - len(hard)) <= 2
    # the same features, at depths within a few mm (sub-pixel outlines move them a little)
    same = [min(np.hypot(*np.subtract(f.left_px, g.left_px)) for g in hard) for f in soft]
    assert np.mean(np.array(same) <= 3.0) >= 0.8


@pytest.mark.parametrize("case", ["size", "unreadable", "missing", "empty-mask", "unwritable"])
def test_bad_input_is_one_clear_line(tmp_path, case):
    args = ["localize", "--calib", RIG, LEFT, RIGHT, "--json", tmp_path / "r.json"]
    if case == "size":
        small = tmp_path / "small.png"
        cv2.imwrite(str(small), cv2.resize(cv2.imread(str(LEFT)), (640, 480)))
        args[3], expect = small, ["small.png", "640x480", "1280x960"]
    elif case == "unreadable":
        bad = tmp_path / "bad.png"
        bad.write_text("not an image")
        args[4], expect = bad, ["bad.png", "not a readable image"]
    elif case == "missing":
        args[4], expect = tmp_path / "nope.png", ["nope.png", "not found"]
    elif case == "empty-mask":
        empty, full = tmp_path / "empty.png", tmp_path / "full.png"
        cv2.imwrite(str(empty), np.zeros((960, 1280), np.uint8))
        cv2.imwrite(str(full), np.full((960, 1280), 255, np.uint8))
        args += ["--mask-left", empty, "--mask-right", full]
        expect = ["empty.png", "empty"]
    elif case == "unwritable":
        (tmp_path / "a_file").write_text("")   # a file where the output's folder should be
        args[6], expect = tmp_path / "a_file" / "r.json", ["r.json", "cannot make its folder", "File exists"]
    p = run(*args)
    assert p.returncode == 1
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    for word in expect:
        assert word in lines[0]
    assert not (tmp_path / "r.json").exists()


def test_no_branch_is_an_empty_result(tmp_path):
    grey = tmp_path / "grey.png"
    cv2.imwrite(str(grey), np.full((960, 1280, 3), (200, 180, 150), np.uint8))
    out = tmp_path / "r.json"
    p = run("localize", "--calib", RIG, grey, grey, "--json", out)
    assert p.returncode == 0, p.stderr
    data = json.loads(out.read_text())
    assert data["features"] == [] and data["branches"] == []


def test_bench_localize_json():
    p = run("bench", "localize", "--calib", RIG, LEFT, RIGHT, "--runs", "3", "--sgbm-runs", "1", "--json")
    assert p.returncode == 0, p.stderr
    data = json.loads(p.stdout)
    assert data["median_ms"] > 0 and data["sgbm_median_ms"] > 0
    assert {"segment", "rectify", "skeleton", "match"} <= set(data["stages"])
