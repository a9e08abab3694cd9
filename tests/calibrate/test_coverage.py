import numpy as np
import pytest

from appliance.calibrate.coverage import adds_coverage, coverage, pose_params

from .conftest import chessboard_image


def test_fronto_parallel_board_has_no_skew_and_its_size():
    _, corners = chessboard_image(square_px=40, margin_px=60, size=(640, 480))
    x, y, size, skew = pose_params(corners, 9, (640, 480))
    assert skew == pytest.approx(0, abs=1e-6)
    assert size == pytest.approx(np.sqrt(320 * 200 / (640 * 480)), rel=1e-3)   # 8x5 spacings of 40 px
    assert 0 < x < 0.5 and 0 < y < 0.5                                          # upper left of the image


def test_sheared_board_has_skew():
    _, corners = chessboard_image()
    sheared = corners + np.stack([0.3 * corners[:, 1], np.zeros(len(corners))], axis=1)
    assert pose_params(sheared.astype(np.float32), 9, (640, 480))[3] > 0.3


def test_only_new_poses_add_coverage():
    kept = [np.array([0.2, 0.2, 0.3, 0.0])]
    assert not adds_coverage(np.array([0.25, 0.25, 0.3, 0.05]), kept)
    assert adds_coverage(np.array([0.6, 0.2, 0.3, 0.0]), kept)
    assert adds_coverage(np.zeros(4), [])


def test_coverage_is_kept_range_over_target():
    assert np.array_equal(coverage([]), np.zeros(4))
    cov = coverage([np.array([0.1, 0.5, 0.2, 0.0]), np.array([0.45, 0.5, 0.6, 0.5])])
    assert np.allclose(cov, [0.5, 0.0, 1.0, 1.0])


def test_live_pairs_folder_never_reuses_a_full_one(tmp_path):
    from appliance.calibrate.live import pairs_folder

    out = tmp_path / "calib.yaml"
    assert pairs_folder(out) == tmp_path / "calib_pairs"
    (tmp_path / "calib_pairs").mkdir()
    assert pairs_folder(out) == tmp_path / "calib_pairs"          # empty: reused
    (tmp_path / "calib_pairs" / "left_00.png").write_bytes(b"x")
    assert pairs_folder(out) == tmp_path / "calib_pairs_2"
