"""Logs made in the tests: textured pairs that differ per seq, a plausible rig, results with branches."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from appliance.acquire import StereoFrame
from appliance.calibrate.model import StereoCalibration
from appliance.config import load_config
from appliance.localize.result import Branch, Feature, LocalizationResult

W, H = 320, 240
T0_NS = 1_790_000_000_000_000_000   # a fixed start stamp (2026)
PERIOD_NS = 33_333_333              # 30 Hz
SKEW_NS = 250_000                   # right camera 0.25 ms after the left
CAMERA_TO_BASE = np.array([[0.0, 0.0, 1.0, 100.0], [-1.0, 0.0, 0.0, 20.0], [0.0, -1.0, 0.0, 500.0],
                           [0.0, 0.0, 0.0, 1.0]])
PYTHON = sys.executable


def logging_cfg(**logging):
    """The default logging section with ``logging`` overlaid (validated like a user's file)."""
    return load_config(overrides={"logging": logging}).logging


def make_calibration(width=W, height=H) -> StereoCalibration:
    f = 1.13 * width
    K = np.array([[f, 0, width / 2 - 3.5], [0, f, height / 2 + 2.25], [0, 0, 1.0]])
    R = cv2.Rodrigues(np.array([0.002, -0.01, 0.001]))[0]
    return StereoCalibration.from_pose((width, height), K, [-0.1, 0.05, 0.001, -0.0005, 0.0], K * 1.001,
                                       [-0.09, 0.04, 0, 0, 0], R, [-120.0, 0.4, 0.8], rms_px=0.21,
                                       meta={"source": "tests/logs"})


def frame_images(seq: int, width=W, height=H) -> tuple[np.ndarray, np.ndarray]:
    """Textured BGR images, different for every seq and between left and right."""
    rng = np.random.default_rng(seq)
    small = rng.integers(0, 256, (height // 8, width // 8, 3), np.uint8)
    left = cv2.resize(small, (width, height), interpolation=cv2.INTER_LINEAR)
    right = np.roll(left, 7, axis=1)
    right[:, :7] = 255 - right[:, :7]
    return left, right


def make_frame(seq: int, width=W, height=H) -> StereoFrame:
    left, right = frame_images(seq, width, height)
    stamp = T0_NS + seq * PERIOD_NS
    return StereoFrame(left, right, seq, stamp, stamp + SKEW_NS)


def make_result(seq: int, n_branches: int = 2) -> LocalizationResult:
    """Features and branches whose numbers depend on seq (branch b has b + 2 polyline points)."""
    z = 800.0 + seq
    features = tuple(Feature(i, "endpoint" if i % 2 else "bifurcation", (10.0 + i, 20.5), (3.25 + i, 20.5),
                             (i * 10.0, -5.0, z), 4.0 + i, z - 1.05 * (4.0 + i)) for i in range(3))
    branches = tuple(
        Branch(b, (b, -1), np.array([[b * 30.0 + 5 * k, 10.0 * k, z + k] for k in range(b + 2)]),
               3.5 + b, recovered=bool(b % 2))
        for b in range(n_branches))
    return LocalizationResult(features, branches, T0_NS + seq * PERIOD_NS + SKEW_NS // 2,
                              {"segment": 1.25, "match": 0.5})


@pytest.fixture
def calib() -> StereoCalibration:
    return make_calibration()


@pytest.fixture
def repo_root() -> Path:
    return Path(__file__).resolve().parents[2]
