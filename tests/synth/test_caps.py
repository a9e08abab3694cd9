"""Reading a tip's cap in a mask: free, cut by an occluder, run on or touched by another branch."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from appliance.synth.caps import cap_reading, cap_readings, free_caps
from appliance.synth.truth import load_truth

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
R = 8.0
TIP = np.array([100.0, 60.0])
OUT = np.array([1.0, 0.0])


def _twig() -> np.ndarray:
    """A horizontal bar of radius R ending at TIP in a round cap, pointing right (+x)."""
    m = np.zeros((120, 200), np.uint8)
    cv2.rectangle(m, (20, 52), (100, 68), 255, -1)
    cv2.circle(m, (100, 60), 8, 255, -1)
    return m > 0


def test_a_round_end_is_free():
    assert cap_reading(_twig(), TIP, OUT, R) == "free"


def test_a_tilted_round_end_is_free():
    m = np.zeros((200, 200), np.uint8)
    cv2.line(m, (40, 160), (120, 80), 255, 16)       # round line caps: radius 8 about the ends
    d = np.array([1.0, -1.0]) / np.sqrt(2)
    assert cap_reading(m > 0, np.array([120.0, 80.0]), d, R) == "free"


def test_a_cap_behind_a_leaf_is_cut():
    m = _twig()
    m[:, 104:] = False                               # an occluder's edge 4 px in front of the outline
    assert cap_reading(m, TIP, OUT, R) == "cut"


def test_a_cap_continued_by_another_branch_runs():
    m = _twig()
    m[50:70, 100:160] = True                         # a branch crossing over the end
    assert cap_reading(m, TIP, OUT, R) == "runs"


def test_a_cap_against_another_branch_is_touched():
    m = _twig()
    m[30:90, 110:118] = True                         # a branch passing 2-10 px beyond the outline
    assert cap_reading(m, TIP, OUT, R) == "touched"


def test_a_cap_at_the_image_border_is_cut():
    m = _twig()
    assert cap_reading(m[:, :104], TIP, OUT, R) == "cut"


@pytest.mark.parametrize("stem", ["truth_00", "truth_01"])
def test_rendered_tips_are_read(stem):
    truth = load_truth(SCENES / f"{stem}.json")
    tf = truth.features
    readings = cap_readings(truth)
    tips_seen = (tf.kind == "endpoint") & tf.visible_left & tf.visible_right
    assert [r is not None for r in readings] == list(tips_seen)
    free = free_caps(truth)
    assert free.sum() >= 0.5 * tips_seen.sum() and not free[~tips_seen].any()
    assert all(a in ("free", "cut", "runs", "touched") for r in readings if r for a in r)
