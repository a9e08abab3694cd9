"""solve_stereo on corners projected through a known rig: exact recovery, outliers, swapped rigs."""

import cv2
import numpy as np
import pytest

from appliance.calibrate import CalibrationError, StereoCalibration
from appliance.calibrate.board import Board
from appliance.calibrate.solve import epipolar_rms_px, solve_stereo
from appliance.calibrate.views import View, Views

BOARD = Board(9, 6, 25.0)
SIZE = (1280, 960)
K = np.array([[1100.0, 0, 650], [0, 1100.0, 470], [0, 0, 1]])
D = np.array([-0.12, 0.08, 0.0005, -0.0003, 0.0])
R_RIG = cv2.Rodrigues(np.array([0.004, -0.01, 0.002]))[0]
T_RIG = np.array([-120.0, 0.4, 0.8])


def project(rvec, tvec, K, D, R=np.eye(3), T=np.zeros(3)):
    R_cam = R @ cv2.Rodrigues(np.asarray(rvec, float))[0]
    t_cam = R @ np.asarray(tvec, float) + T
    px, _ = cv2.projectPoints(BOARD.object_points().astype(float), cv2.Rodrigues(R_cam)[0], t_cam, K, D)
    return px.reshape(-1, 2).astype(np.float32)


def views(n=14, seed=3, noise_px=0.05, swap=False):
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        rvec = rng.uniform(-0.45, 0.45, 3) * [1, 1, 0.3]
        tvec = np.array([rng.uniform(-250, 50), rng.uniform(-180, 30), rng.uniform(700, 1300)])
        left = project(rvec, tvec, K, D) + rng.normal(0, noise_px, (54, 2)).astype(np.float32)
        right = project(rvec, tvec, K, D, R_RIG, T_RIG) + rng.normal(0, noise_px, (54, 2)).astype(np.float32)
        out.append(View(f"{i:02d}", right, left) if swap else View(f"{i:02d}", left, right))
    return out


def test_recovers_the_rig():
    sol = solve_stereo(Views(SIZE, views()), BOARD, source="synthetic")
    c = sol.calib
    assert c.baseline_mm == pytest.approx(np.linalg.norm(T_RIG), rel=1e-3)
    assert c.K1[0, 0] == pytest.approx(1100, rel=1e-3) and c.K2[1, 1] == pytest.approx(1100, rel=1e-3)
    assert abs(c.K1[0, 2] - 650) < 1 and abs(c.K2[1, 2] - 470) < 1
    assert c.rms_px == pytest.approx(0.05, abs=0.03)
    assert c.epipolar_rms_px < 0.15 and sol.dropped == []
    assert c.meta["source"] == "synthetic" and c.meta["pairs"] == "14"


def test_outlier_view_dropped_and_named():
    vs = views()
    bad = vs[5]
    vs[5] = View(bad.key, bad.left_px + np.random.default_rng(0).normal(0, 2.0, (54, 2)).astype(np.float32),
                 bad.right_px)
    sol = solve_stereo(Views(SIZE, vs), BOARD)
    assert [k for k, _ in sol.dropped] == ["05"]
    assert len(sol.views) == 13 and sol.calib.rms_px < 0.1


def test_swapped_rig_refused():
    with pytest.raises(CalibrationError, match=r"swapped .*\(T_x > 0"):
        solve_stereo(Views(SIZE, views(swap=True)), BOARD, source="pairs")


def test_too_few_pairs_names_skipped():
    with pytest.raises(CalibrationError, match=r"pairs: only 3 usable image pairs, need at least 8 — skipped a: why"):
        solve_stereo(Views(SIZE, views(n=3), skipped=[("a", "why")]), BOARD, source="pairs")


def test_epipolar_rms_zero_for_exact_points():
    c = StereoCalibration.from_pose(SIZE, K, D, K, D, R_RIG, T_RIG)
    vs = views(n=2, noise_px=0.0)
    assert epipolar_rms_px(c, vs[0].left_px, vs[0].right_px) < 0.01
    assert epipolar_rms_px(c, vs[0].left_px, vs[0].right_px + [0, 2]) == pytest.approx(2, rel=0.1)
