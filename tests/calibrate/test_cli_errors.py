"""Bad inputs to `appliance calibrate`: one clear line on stderr, exit 1, no calibration written."""

import cv2
import numpy as np

from .conftest import appliance, chessboard_image


def check_error(result, *fragments):
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    error = [line for line in lines if line.startswith("error: ")]
    assert len(error) == 1, result.stderr
    for fragment in fragments:
        assert fragment in error[0], error[0]
    return error[0]


def test_empty_folder(tmp_path):
    (tmp_path / "pairs").mkdir()
    r = appliance("calibrate", "--images", tmp_path / "pairs", "--out", tmp_path / "c.yaml")
    check_error(r, "pairs", "no left/right image pairs")
    assert not (tmp_path / "c.yaml").exists()


def test_missing_folder(tmp_path):
    r = appliance("calibrate", "--images", tmp_path / "nowhere", "--out", tmp_path / "c.yaml")
    check_error(r, "nowhere", "no such folder")


def test_no_board_found(tmp_path):
    folder = tmp_path / "pairs"
    folder.mkdir()
    blank = np.full((240, 320, 3), 128, np.uint8)
    for i in range(3):
        cv2.imwrite(str(folder / f"left{i:02d}.png"), blank)
        cv2.imwrite(str(folder / f"right{i:02d}.png"), blank)
    r = appliance("calibrate", "--images", folder, "--out", tmp_path / "c.yaml", "--min-pairs", "3")
    check_error(r, "only 0 usable image pairs, need at least 3", "left00.png/right00.png", "board not found")
    assert not (tmp_path / "c.yaml").exists()


def test_mismatched_sizes_reported_and_skipped(tmp_path):
    folder = tmp_path / "pairs"
    folder.mkdir()
    img, _ = chessboard_image()
    for i in range(3):
        cv2.imwrite(str(folder / f"left_{i}.png"), img)
        cv2.imwrite(str(folder / f"right_{i}.png"), cv2.resize(img, (320, 240)))
    (folder / "left_9.png").write_bytes(b"not a png")
    cv2.imwrite(str(folder / "right_9.png"), img)
    r = appliance("calibrate", "--images", folder, "--out", tmp_path / "c.yaml", "--min-pairs", "3")
    line = check_error(r, "only 0 usable image pairs",
                       "left_0.png/right_0.png: sizes differ: left 640x480, right 320x240")
    assert "(+1 more)" in line


def test_unreadable_config_and_pattern(tmp_path):
    r = appliance("calibrate", "--images", tmp_path, "--pattern", "9by6")
    check_error(r, "--pattern '9by6'")
    r = appliance("calibrate", "--images", tmp_path, "--detector", "magic")
    check_error(r, "calibration.detector")


def test_images_or_device_required(tmp_path):
    r = appliance("calibrate", "--out", tmp_path / "c.yaml")
    assert r.returncode == 2 and "--images DIR or --device DEV" in r.stderr


def test_unknown_device_is_one_line_error(tmp_path):
    r = appliance("calibrate", "--device", f"fake:{tmp_path / 'none'}", "--out", tmp_path / "c.yaml")
    check_error(r, "fake:")
    assert not (tmp_path / "c.yaml").exists()
