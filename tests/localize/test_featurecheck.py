"""Each feature's disparity checked against its branches' bark texture (localize/featurecheck.py).

Constructed pair: a textured scene whose right view is the left one shifted by D_PX (a surface at one
depth), a horizontal branch band of radius R_PX in the left mask from u = 60 to a tip at u = 200, and
a fork at u = 130 where a second, diagonal piece leaves the band. A feature at the right disparity is
kept; at a disparity 3 px off, or 12-15 px off (outside the
search window: the wide search), it is withheld; a feature on bark without texture is kept (no verdict).
"""

from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.localize.featurecheck import check_features, patch_table
from appliance.localize.localizer import paper_config
from appliance.localize.matching import FeatureUVD, PieceUVD

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"

H, W = 200, 300
D_PX, R_PX, F_PX = 40.0, 8.0, 1450.0
D_RANGE = (20.0, 80.0)


def _pair(textured: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Left and right grey images (right[y, x] = left[y, x + D_PX]) and the left branch mask."""
    rng = np.random.default_rng(5)
    wide = W + int(D_PX)
    if textured:
        t = cv2.GaussianBlur(rng.uniform(0, 255, (H, wide)).astype(np.float32), (0, 0), 1.2)
        t = (60 + 140 * (t - t.min()) / (t.max() - t.min())).astype(np.uint8)
    else:
        t = np.full((H, wide), 120, np.uint8)
    left, right = np.ascontiguousarray(t[:, :W]), np.ascontiguousarray(t[:, int(D_PX):int(D_PX) + W])
    mask = np.zeros((H, W), np.uint8)
    cv2.line(mask, (60, 100), (200, 100), 255, int(2 * R_PX) + 1)
    cv2.line(mask, (130, 100), (180, 30), 255, int(2 * R_PX) + 1)
    return left, right, mask


def _pieces() -> list:
    main_a = np.column_stack([np.linspace(60, 130, 36), np.full(36, 100.0), np.full(36, D_PX)])
    main_b = np.column_stack([np.linspace(130, 200, 36), np.full(36, 100.0), np.full(36, D_PX)])
    side = np.column_stack([np.linspace(130, 180, 30), np.linspace(100, 30, 30), np.full(30, D_PX)])
    return [PieceUVD(0, main_a, R_PX, False, (0, 1)), PieceUVD(1, main_b, R_PX, False, (1, 2)),
            PieceUVD(2, side, R_PX, False, (1, 3))]


def _features(d_tip: float, d_fork: float) -> list:
    return [FeatureUVD(2, "endpoint", 200.0, 100.0, d_tip, R_PX),
            FeatureUVD(1, "bifurcation", 130.0, 100.0, d_fork, R_PX)]


def _check(features, textured=True):
    left, right, mask = _pair(textured)
    return check_features(features, _pieces(), left, right, mask, D_RANGE, F_PX, 0.0, max_diff_px=1.0)


def test_right_disparity_kept_and_measured():
    checks = _check(_features(D_PX, D_PX))
    assert [c.withheld for c in checks] == [False, False]
    for c in checks:
        assert c.n_patches >= 2
        # the texture's axis disparity: the surface's, moved one (~0.9) radius back (0.2 px at 40 px)
        assert abs(c.diff_px) < 0.4, c


def test_wrong_disparity_withheld():
    checks = _check(_features(D_PX + 3.0, D_PX - 2.5))
    assert [c.withheld for c in checks] == [True, True]
    assert abs(checks[0].diff_px + 3.0) < 0.4 and abs(checks[1].diff_px - 2.5) < 0.4


def test_far_off_disparity_withheld():
    """Features 12-15 px off: the texture's peak lies outside the +-8 px window; the whole working range
    searched again finds it."""
    checks = _check(_features(D_PX + 15.0, D_PX - 12.0))
    assert [c.withheld for c in checks] == [True, True]
    assert abs(checks[0].diff_px + 15.0) < 0.4 and abs(checks[1].diff_px - 12.0) < 0.4


def test_far_off_without_texture_no_verdict():
    checks = _check(_features(D_PX + 15.0, D_PX - 12.0), textured=False)
    assert not any(c.withheld for c in checks) and all(np.isnan(c.d_check_px) for c in checks)


def test_far_off_on_periodic_bark_no_verdict():
    """Bark repeating every 25 px along the rows: the wide search finds two equal peaks (40, 65 px), no
    unique one: no verdict for a feature 12 px off (whose window holds neither)."""
    _, _, mask = _pair()
    rng = np.random.default_rng(7)
    period = cv2.GaussianBlur(rng.uniform(0, 255, (H, 25)).astype(np.float32), (0, 0), 1.0)
    t = np.tile(period, (1, (W + int(D_PX)) // 25 + 1))
    t = (60 + 140 * (t - t.min()) / (t.max() - t.min())).astype(np.uint8)
    left, right = np.ascontiguousarray(t[:, :W]), np.ascontiguousarray(t[:, int(D_PX):int(D_PX) + W])
    feats = [FeatureUVD(2, "endpoint", 200.0, 100.0, D_PX + 12.5, R_PX)]
    checks = check_features(feats, _pieces(), left, right, mask, D_RANGE, F_PX, 0.0, max_diff_px=1.0)
    assert not checks[0].withheld and np.isnan(checks[0].d_check_px)
    near = check_features([FeatureUVD(2, "endpoint", 200.0, 100.0, D_PX, R_PX)], _pieces(), left, right, mask,
                          D_RANGE, F_PX, 0.0, max_diff_px=1.0)
    assert abs(near[0].diff_px) < 0.4                               # (the bark does have texture)


def test_small_difference_kept():
    checks = _check(_features(D_PX + 0.6, D_PX - 0.6))
    assert not any(c.withheld for c in checks)


def test_no_texture_no_verdict():
    checks = _check(_features(D_PX + 3.0, D_PX + 3.0), textured=False)
    assert not any(c.withheld for c in checks)
    assert all(np.isnan(c.d_check_px) for c in checks)


def test_no_pieces_no_verdict():
    left, right, mask = _pair()
    checks = check_features(_features(D_PX + 3.0, D_PX), [], left, right, mask, D_RANGE, F_PX)
    assert [c.withheld for c in checks] == [False, False] and all(c.n_patches == 0 for c in checks)
    assert check_features([], _pieces(), left, right, mask, D_RANGE, F_PX) == []


def test_patches_inside_branch_and_clear_of_fork():
    left, right, mask = _pair()
    t = patch_table(_features(D_PX, D_PX), _pieces(), left, right, mask, D_RANGE, F_PX, 0.0)
    for k in range(len(t["u"])):
        u, v, hh, hw = t["u"][k], t["v"][k], t["hh"][k], t["hw"][k]
        assert mask[v - hh:v + hh + 1, u - hw:u + hw + 1].min() == 255
    fork = t["feature"] == 1
    assert fork.any() and (t["s"][fork] >= 1.2 * R_PX).all()     # (clear of the other pieces' silhouettes)
    assert set(t["piece"][fork].tolist()) == {0, 1, 2}


def test_config_improved_on_paper_off():
    cfg = load_config().localize
    assert cfg.feature_check.enabled and cfg.feature_check.max_diff_px > 0
    assert not paper_config(cfg).feature_check.enabled


def test_localizer_runs_the_check_and_only_withholds():
    """On a rendered fixture the check runs as its own stage; the features it reports are those reported
    without it, less the withheld ones (none here: every feature of fixture 00 agrees with its bark)."""
    cfg = load_config().localize
    calib = load_calibration(FIXTURES / "rig.yaml")
    left = cv2.imread(str(FIXTURES / "scenes" / "left_00.png"))
    right = cv2.imread(str(FIXTURES / "scenes" / "right_00.png"))
    on = Localizer(calib, cfg).localize(left, right)
    off_cfg = replace(cfg, feature_check=replace(cfg.feature_check, enabled=False))
    off = Localizer(calib, off_cfg).localize(left, right)
    assert "check" in on.timings_ms and "check" not in off.timings_ms
    assert [f.xyz_mm for f in on.features] == [f.xyz_mm for f in off.features]
    strict = replace(cfg, feature_check=replace(cfg.feature_check, max_diff_px=1e-6))
    few = Localizer(calib, strict).localize(left, right)
    assert len(few.features) < len(off.features)                      # (the check does read the texture)
    assert {f.xyz_mm for f in few.features} <= {f.xyz_mm for f in off.features}
