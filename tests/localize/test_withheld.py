"""Features the feature check withholds are in the result (``LocalizationResult.withheld``), its JSON, the log's
result message and the overlay: a replay can tell a withheld fork from one never found."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import LocalizationResult, Localizer
from appliance.localize.overlay import draw_overlay
from appliance.logs.messages import result_from_json, result_json

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"


@pytest.fixture(scope="module")
def strict_and_off():
    """Fixture 00 with the check off, and with a check so strict that it withholds every feature it can judge."""
    cfg = load_config().localize
    calib = load_calibration(FIXTURES / "rig.yaml")
    left = cv2.imread(str(FIXTURES / "scenes" / "left_00.png"))
    right = cv2.imread(str(FIXTURES / "scenes" / "right_00.png"))
    strict = replace(cfg, feature_check=replace(cfg.feature_check, max_diff_px=1e-6))
    off = replace(cfg, feature_check=replace(cfg.feature_check, enabled=False))
    return (Localizer(calib, strict).localize(left, right), Localizer(calib, off).localize(left, right),
            left, right, calib)


def test_withheld_features_are_the_ones_not_reported(strict_and_off):
    few, off, *_ = strict_and_off
    assert few.withheld and not off.withheld
    assert len(few.features) + len(few.withheld) == len(off.features)
    reported = np.array([f.left_px for f in off.features])
    for w in few.withheld:
        assert np.abs(reported - w.left_px).max(axis=1).min() < 1e-6       # at a feature found without the check
        assert w.kind in {f.kind for f in off.features} and w.reason in ("texture", "pieces_agree")
        assert abs(w.check_disparity_px - w.disparity_px) > 1e-6 and 10 < w.disparity_px < 500


def test_withheld_survive_json_and_the_log_message(strict_and_off):
    few = strict_and_off[0]
    back = LocalizationResult.from_dict(result_from_json(result_json(few, seq=7)))
    assert back.withheld == few.withheld
    assert LocalizationResult.from_dict({"features": [], "branches": []}).withheld == ()   # older logs


def test_overlay_marks_withheld_features(strict_and_off):
    few, _, left, right, calib = strict_and_off
    with_marks = draw_overlay(left, right, few, calib, legend=False)
    without = draw_overlay(left, right, replace(few, withheld=()), calib, legend=False)
    for w in few.withheld:
        u, v = (int(round(c)) for c in w.left_px)
        patch = (with_marks[v - 4:v + 5, u - 4:u + 5].astype(int) - without[v - 4:v + 5, u - 4:u + 5]).any(axis=2)
        assert patch.any()
    assert np.array_equal(with_marks[:, left.shape[1]:], without[:, left.shape[1]:])   # left image only
