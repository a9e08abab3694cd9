"""The calibration file: written atomically, readable by plain OpenCV and by the loader."""

import cv2
import numpy as np
import pytest

from appliance.calibrate import CalibrationError, StereoCalibration, load_calibration, save_calibration

K = np.array([[1000.0, 0, 640], [0, 1000.0, 480], [0, 0, 1]])
D = np.array([-0.1, 0.05, 0.001, -0.001, 0.0])


def rig(**extra):
    R = cv2.Rodrigues(np.array([0.01, -0.02, 0.005]))[0]
    return StereoCalibration.from_pose((1280, 960), K, D, K, D, R, [-120.0, 0.5, 1.0], **extra)


def test_from_pose_proper_rig_has_positive_baseline():
    c = rig()
    assert c.baseline_mm == pytest.approx(np.linalg.norm([-120.0, 0.5, 1.0]), rel=1e-6)
    assert c.f_px > 0
    assert c.P2[0, 3] == pytest.approx(-c.f_px * c.baseline_mm)


def test_round_trip_through_filestorage_and_loader(tmp_path):
    c = rig(rms_px=0.12, epipolar_rms_px=0.05, meta={"date": "2026-01-01", "pattern": "9x6"})
    path = tmp_path / "calib.yaml"
    save_calibration(c, path)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert int(fs.getNode("image_width").real()) == 1280
    assert np.allclose(fs.getNode("K1").mat(), K)
    assert np.allclose(fs.getNode("P2").mat(), c.P2)
    assert fs.getNode("baseline_mm").real() == pytest.approx(c.baseline_mm)
    assert fs.getNode("epipolar_rms_px").real() == pytest.approx(0.05)
    assert fs.getNode("pattern").string() == "9x6"
    fs.release()
    back = load_calibration(path)
    for name in ("K1", "D1", "K2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q"):
        assert np.allclose(getattr(back, name), getattr(c, name)), name
    assert back.rms_px == pytest.approx(0.12) and back.meta["date"] == "2026-01-01"


def test_file_with_only_first_eight_nodes_loads(tmp_path):
    c = rig()
    path = tmp_path / "other_tool.yaml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 1280)
    fs.write("image_height", 960)
    for name in ("K1", "D1", "K2", "D2", "R", "T"):
        fs.write(name, np.asarray(getattr(c, name)))
    fs.release()
    back = load_calibration(path)
    assert back.f_px == pytest.approx(c.f_px) and back.baseline_mm == pytest.approx(c.baseline_mm)
    assert np.allclose(back.Q, c.Q) and np.isnan(back.rms_px)


def test_failed_write_keeps_the_good_file(tmp_path):
    path = tmp_path / "calib.yaml"
    save_calibration(rig(), path)
    good = path.read_bytes()
    bad = StereoCalibration(**{**rig().__dict__, "K1": "not a matrix"})   # fails half-way through the write
    with pytest.raises(ValueError):
        save_calibration(bad, path)
    assert path.read_bytes() == good
    assert [p.name for p in tmp_path.iterdir()] == ["calib.yaml"]   # no temp file left behind


def test_missing_node_is_one_line_error(tmp_path):
    path = tmp_path / "broken.yaml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 1280)
    fs.write("image_height", 960)
    fs.write("K1", K)
    fs.release()
    with pytest.raises(CalibrationError, match=r"broken.yaml: node D1 missing"):
        load_calibration(path)


@pytest.mark.parametrize("text, why", [
    ("%YAML:1.0\nK1: [1, 2\n", r"line \d+: "),   # a hand edit that breaks the YAML
    ("just words", r"line 1: "),
])
def test_malformed_file_is_one_line_error(tmp_path, text, why):
    path = tmp_path / "hand_edited.yaml"
    path.write_text(text)
    with pytest.raises(CalibrationError, match=rf"hand_edited.yaml: not an OpenCV FileStorage file \({why}"):
        load_calibration(path)
