"""`appliance calibrate` on OpenCV's real stereo chessboard pairs (Debian package opencv-doc).

9x6 corners, 30 mm squares, published baseline ~99.8 mm. Skipped when the package is absent.
"""

import cv2
import numpy as np
import pytest
import yaml

from appliance.calibrate import load_calibration

from .conftest import appliance, opencv_pairs


@pytest.fixture(scope="module")
def real_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("real")
    folder = opencv_pairs(tmp / "pairs")
    out = tmp / "out" / "calib.yaml"
    r = appliance("calibrate", "--images", folder, "--pattern", "9x6", "--square-mm", "30",
                  "--out", out, "--ros-out", tmp / "ros")
    return tmp, folder, out, r


def test_real_pairs_calibrate(real_run):
    tmp, _, out, r = real_run
    assert r.returncode == 0, r.stderr
    c = load_calibration(out)
    assert c.image_size == (640, 480)
    assert abs(c.baseline_mm - 99.8) < 1.0          # published ~99.8 mm; we find 99.4
    assert c.T[0] < 0                                # the right camera is on the right
    assert 0 < c.rms_px < 0.5 and 0 < c.epipolar_rms_px < 0.5
    assert "left05.jpg/right05.jpg" in r.stderr      # the pair whose left view misses the board is named
    assert "baseline b" in r.stdout and f"{c.baseline_mm:.2f} mm" in r.stdout


def test_report_pictures_written(real_run):
    tmp, _, out, _ = real_run
    for name in ("errors", "coverage", "rectified"):
        img = cv2.imread(str(out.with_name(f"calib_{name}.png")))
        assert img is not None and img.std() > 10, name
    assert cv2.imread(str(out.with_name("calib_rectified.png"))).shape == (480, 1280, 3)


def test_ros_camera_info(real_run):
    tmp, _, out, _ = real_run
    c = load_calibration(out)
    left = yaml.safe_load((tmp / "ros" / "left.yaml").read_text())
    right = yaml.safe_load((tmp / "ros" / "right.yaml").read_text())
    assert (right["image_width"], right["image_height"]) == (640, 480)
    assert right["distortion_model"] == "plumb_bob" and len(right["distortion_coefficients"]["data"]) == 5
    P = np.array(right["projection_matrix"]["data"]).reshape(3, 4)
    assert P[0, 3] == pytest.approx(-c.f_px * c.baseline_mm / 1000.0)      # ROS: -fx * B, B in metres
    assert np.allclose(np.array(left["camera_matrix"]["data"]).reshape(3, 3), c.K1)
    assert np.allclose(np.array(left["rectification_matrix"]["data"]).reshape(3, 3), c.R1)


def test_swapped_cameras_refused_and_good_file_kept(real_run, tmp_path):
    _, folder, out, _ = real_run
    swapped = tmp_path / "swapped"
    swapped.mkdir()
    for img in folder.iterdir():
        side = "right" if img.name.startswith("left") else "left"
        (swapped / img.name.replace("left" if side == "right" else "right", side)).write_bytes(img.read_bytes())
    good = out.read_bytes()
    r = appliance("calibrate", "--images", swapped, "--square-mm", "30", "--out", out)
    assert r.returncode == 1
    errors = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "swapped" in errors[0] and "T_x > 0" in errors[0]
    assert out.read_bytes() == good                  # a failed run never replaces a good calibration
