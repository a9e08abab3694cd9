"""The whole method against the exact truth of the committed rendered scenes (fixtures/scenes).

Bounds are what the methods reach with a margin (see docs/localize.md for the figures), so a
change that makes localization worse fails here.
"""

from pathlib import Path

import cv2
import pytest
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.synth.evaluate import pool, score_result
from appliance.synth.truth import load_truth

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
SCENES = sorted((FIXTURES / "scenes").glob("truth_*.json"))


def _scores(variant: str, true_masks: bool = True):
    calib = load_calibration(FIXTURES / "rig.yaml")
    loc = Localizer(calib, load_config().localize, variant)
    scores = []
    for t in SCENES:
        nn = t.stem.split("_")[1]
        left = cv2.imread(str(FIXTURES / "scenes" / f"left_{nn}.png"))
        right = cv2.imread(str(FIXTURES / "scenes" / f"right_{nn}.png"))
        truth = load_truth(t)
        kw = dict(mask_left=truth.mask_left, mask_right=truth.mask_right) if true_masks else {}
        scores.append(score_result(loc.localize(left, right, **kw), truth, name=nn))
    return pool(scores)


@pytest.fixture(scope="module")
def improved():
    return _scores("improved")


@pytest.fixture(scope="module")
def paper():
    return _scores("paper")


def test_fixtures_are_there():
    assert len(SCENES) >= 4


def test_improved_method_against_truth(improved):
    # reached on the 4 fixtures (true masks): recall 0.72, precision 1.0, |dZ| median 0.72 mm,
    # p95 3.5 mm, disparity median ~0.12 px, coverage 0.85, branch precision 0.92, radius 0.47 mm
    assert improved.n_true >= 30
    assert improved.recall >= 0.68               # 0.67 before tips' round caps and flat stubs (tips.py)
    assert improved.precision >= 0.95
    assert improved.depth_err_mm["median"] <= 1.0
    assert improved.depth_err_mm["p95"] <= 4.0   # 4.4 mm before forks took the pieces that reach them
    assert improved.depth_err_px["median"] <= 0.25
    assert improved.branch_coverage >= 0.82        # 0.85 with pieces matched edge by edge (single_edge.py)
    assert improved.branch_precision >= 0.88
    assert improved.radius_err_mm["median"] <= 1.0


def test_paper_variant_against_truth(paper):
    assert paper.recall >= 0.3
    assert paper.depth_err_mm["median"] <= 6.0
    assert paper.branch_coverage >= 0.3


def test_improved_beats_the_paper(improved, paper):
    assert improved.recall >= paper.recall
    assert improved.precision > paper.precision
    assert improved.branch_coverage > paper.branch_coverage + 0.2
    assert improved.depth_err_mm["median"] < paper.depth_err_mm["median"]


def test_improved_with_the_colour_recogniser():
    s = _scores("improved", true_masks=False)     # reached: recall 0.64, precision 1.0, p95 2.6 mm
    assert s.recall >= 0.6
    assert s.precision >= 0.95
    assert s.depth_err_mm["median"] <= 2.0          # 2.7 mm before the soft outlines (segment.unmix_edges)
    assert s.depth_err_mm["p95"] <= 3.2            # 2.9 mm with the grey image's outlines near ends (subpixel.py)
    assert s.branch_coverage >= 0.77                # reached 0.82 (0.77 before the outline unmixing)
    assert s.branch_precision >= 0.8                # reached 0.86
