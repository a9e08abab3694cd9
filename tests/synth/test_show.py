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
