"""The truth picture of a committed scene, through the real module entry point."""

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"


def test_show_draws_features_on_both_images(tmp_path):
    out = tmp_path / "truth_00.png"
    r = subprocess.run([sys.executable, "-m", "appliance.synth.show", SCENES / "truth_00.json", out],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    pic = cv2.imread(str(out))
    left = cv2.imread(str(SCENES / "left_00.png"))
    assert pic.shape == (left.shape[0], 2 * left.shape[1], 3)
    changed = np.any(pic[:, :left.shape[1]] != left, axis=2)
    assert 0.001 < changed.mean() < 0.2          # markers and axes drawn, the image still shows through


def test_show_names_a_missing_image(tmp_path):
    r = subprocess.run([sys.executable, "-m", "appliance.synth.show", SCENES / "truth_00.json", tmp_path / "o.png",
                        "--left", tmp_path / "nope.png"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and "nope.png" in r.stderr


def test_score_picture_marks_covered_axes_and_missed_and_false_features():
    from appliance.localize.result import Branch, Feature, LocalizationResult
    from appliance.synth.evaluate import covered_axis, score_result
    from appliance.synth.show import draw_score
    from appliance.synth.truth import load_truth

    truth = load_truth(SCENES / "truth_00.json")
    left = cv2.imread(str(SCENES / "left_00.png"))
    # one true branch reported exactly, and one feature where nothing is
    b0 = truth.branches[0].axis_mm
    false = Feature(0, "endpoint", (40.0, 40.0), (10.0, 40.0), (0.0, 0.0, 1000.0), 5.0, 995.0)
    result = LocalizationResult((false,), (Branch(0, (-1, -1), b0, 5.0),))
    score = score_result(result, truth, name="fixture 00")
    pic = draw_score(left, result, truth, score)
    assert pic.shape == left.shape
    pts, _, covered = covered_axis(result, truth)
    assert covered.any() and not covered.all()
    green, red = np.array([0, 220, 0]), np.array([0, 0, 255])
    px = np.round(truth.rig.project(pts, "left")).astype(int)
    on = (px[:, 0] >= 0) & (px[:, 0] < left.shape[1]) & (px[:, 1] >= 0) & (px[:, 1] < left.shape[0])
    colours = pic[px[on, 1], px[on, 0]]
    # most covered samples are green, most uncovered red (markers drawn later may lie on a few)
    assert (colours[covered[on]] == green).all(1).mean() > 0.8
    assert (colours[~covered[on]] == red).all(1).mean() > 0.8
    assert (pic[40, 40] == [0, 140, 255]).all()                      # the false feature's cross
    assert score.n_found == 0                                        # every true feature ringed as missed
