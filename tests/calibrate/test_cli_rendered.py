"""`appliance calibrate` (the real executable) on rendered chessboards, against the true rig.

The set is the repository's fixtures/chessboard with fixtures/rig.yaml; while those are not generated,
the tests render their own (tests/calibrate/render.py, fixed seed) so the checks always run.
"""

import shutil

import cv2
import numpy as np
import pytest

from appliance.calibrate import load_calibration
from appliance.calibrate.compare import compare

from .conftest import CHESSBOARD, RIG, appliance
from .render import render_chessboards

NODES = ("image_width", "image_height", "K1", "D1", "K2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2",
         "Q", "f_px", "baseline_mm", "rms_px", "epipolar_rms_px", "date", "pattern")


@pytest.fixture(scope="module")
def boards(tmp_path_factory):
    """(folder of rendered pairs, path of the true rig)."""
    if CHESSBOARD.is_dir() and RIG.is_file():
        return CHESSBOARD, RIG
    folder = tmp_path_factory.mktemp("render") / "chessboard"
    return folder, render_chessboards(folder)


@pytest.fixture(scope="module")
def truth(boards):
    return load_calibration(boards[1])


@pytest.fixture(scope="module")
def folder_run(tmp_path_factory, boards):
    """One calibration of the whole folder with the default (SB) detector."""
    out = tmp_path_factory.mktemp("rendered") / "calib.yaml"
    r = appliance("calibrate", "--images", boards[0], "--pattern", "9x6", "--square-mm", "25", "--out", out)
    return out, r


def test_focal_length_and_baseline_match_the_rig(folder_run, truth):
    out, r = folder_run
    assert r.returncode == 0, r.stderr
    c = load_calibration(out)
    assert c.image_size == truth.image_size
    e = compare(c, truth)
    assert abs(e["fx_pct"]) < 0.2 and abs(e["fy_pct"]) < 0.2          # benchmark goal 0.1 %
    assert abs(e["baseline_pct"]) < 0.2
    assert e["pp_px"] < 1.5
    assert c.f_px == pytest.approx(truth.f_px, rel=5e-3)
    assert e["depth_pct_at_1000"] < 0.5
    assert c.rms_px < 0.5 and c.epipolar_rms_px < 0.5


def test_file_round_trips_through_filestorage(folder_run):
    out, _ = folder_run
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    try:
        missing = [n for n in NODES if fs.getNode(n).empty()]
        assert missing == []
        c = load_calibration(out)
        assert fs.getNode("f_px").real() == pytest.approx(c.f_px)
        assert fs.getNode("baseline_mm").real() == pytest.approx(c.baseline_mm)
        assert np.allclose(fs.getNode("T").mat().ravel(), c.T)
        assert "9x6" in fs.getNode("pattern").string()
    finally:
        fs.release()


def test_report_next_to_the_output(folder_run):
    out, r = folder_run
    for name in ("errors", "coverage", "rectified"):
        path = out.with_name(f"calib_{name}.png")
        assert f"wrote {path}" in r.stdout
        assert cv2.imread(str(path)) is not None


def test_swapped_folder_refused(tmp_path, boards):
    swapped = tmp_path / "swapped"
    swapped.mkdir()
    for img in sorted(boards[0].glob("left_*.png")):
        shutil.copy(img, swapped / img.name.replace("left", "right"))
        shutil.copy(img.with_name(img.name.replace("left", "right")), swapped / img.name)
    r = appliance("calibrate", "--images", swapped, "--detector", "classic", "--out", tmp_path / "c.yaml")
    assert r.returncode == 1
    errors = [line for line in r.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "swapped" in errors[0] and str(swapped) in errors[0]
    assert not (tmp_path / "c.yaml").exists()


@pytest.mark.parametrize("stdin", ["", "\n"], ids=["eof", "a line piped in"])
def test_live_capture_from_fake_device(tmp_path, boards, truth, stdin):
    # Enter stops the capture only on a terminal: a line piped in (a script) does not end it at once
    cfg = tmp_path / "fast.yaml"
    cfg.write_text("camera:\n  fake_rate_hz: -1.0\ncalibration:\n  detector: classic\n")
    out = tmp_path / "live" / "calib.yaml"
    r = appliance("calibrate", "--device", f"fake:{boards[0]}", "--config", cfg, "--min-pairs", "6", "--out", out,
                  stdin=stdin)
    assert r.returncode == 0, r.stderr
    kept = sorted((tmp_path / "live" / "calib_pairs").glob("left_*.png"))
    n_fixture = len(list(boards[0].glob("left_*.png")))
    assert 6 <= len(kept) <= n_fixture
    assert "coverage x" in r.stderr and "kept pairs" in r.stderr
    c = load_calibration(out)
    assert 6 <= int(c.meta["pairs"]) <= len(kept)                   # outliers may have been dropped
    assert c.baseline_mm == pytest.approx(truth.baseline_mm, rel=1e-2)
    assert c.f_px == pytest.approx(truth.f_px, rel=1e-2)
