"""The depth-error plot (synth/errorplot.py): dots where the errors are, through the real module entry point."""

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

from appliance.synth.errorplot import COLOURS, Panel, draw_error_plot, draw_panel, panels_from_scores

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"


def _has(img: np.ndarray, x: int, y: int, colour, r: int = 2) -> bool:
    """Whether ``colour`` is drawn within ``r`` px of (x, y)."""
    return bool(np.all(img[y - r:y + r + 1, x - r:x + r + 1] == colour, axis=2).any())


def test_panel_puts_a_dot_at_its_depth_and_error_and_an_outlier_on_the_edge():
    # 560 x 300 px: 500-1500 mm over x 46..550 (0.504 px/mm); +-8 mm over y 26..276 (15.625 px/mm)
    panel = Panel("t", np.array([1000.0, 750.0, 1250.0]), np.array([2.0, -4.0, 30.0]),
                  np.array(["endpoint", "bifurcation", "endpoint"]))
    img = draw_panel(panel)
    assert img.shape == (300, 560, 3)
    assert _has(img, 298, 120, COLOURS["endpoint"])           # (1000 mm, +2 mm)
    assert _has(img, 172, 214, COLOURS["bifurcation"])        # (750 mm, -4 mm)
    assert not _has(img, 298, 182, COLOURS["endpoint"], r=4)  # nothing at (1000 mm, -2 mm)
    assert _has(img, 424, 30, COLOURS["endpoint"], r=3)       # +30 mm: a triangle on the top edge at 1250 mm
    assert not _has(img, 424, 270, COLOURS["endpoint"], r=3)  # ... not the bottom one


def test_grid_holds_every_panel_and_a_legend():
    panels = [Panel(f"m{i}", np.array([900.0]), np.array([0.5]), np.array(["endpoint"])) for i in range(3)]
    img = draw_error_plot(panels)
    assert img.shape == (2 * 300 + 24, 2 * 560, 3)
    for x, y in ((248, 143), (560 + 248, 143), (248, 300 + 143)):   # each panel's dot (900 mm, +0.5 mm), row-major
        assert _has(img, x, y, COLOURS["endpoint"])
    assert not _has(img, 560 + 248, 300 + 143, COLOURS["endpoint"], r=4)   # the fourth cell is blank


def test_module_plots_a_benchmark_json_of_a_scored_fixture(tmp_path):
    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer
    from appliance.synth.evaluate import pool, score_result
    from appliance.synth.truth import load_truth

    truth = load_truth(FIXTURES / "scenes" / "truth_00.json")
    left, right = (cv2.imread(str(FIXTURES / "scenes" / f"{s}_00.png")) for s in ("left", "right"))
    result = Localizer(load_calibration(FIXTURES / "rig.yaml"), load_config().localize).localize(left, right)
    score = pool([score_result(result, truth, name="fixture 00")], name="improved")
    scores = tmp_path / "scores.json"
    scores.write_text(json.dumps({"improved": score.to_dict()}))
    [panel] = panels_from_scores(json.loads(scores.read_text()))
    assert len(panel.dz_mm) == sum(r.truth_index >= 0 and r.result_id >= 0 for r in score.rows) > 0
    out = tmp_path / "plot.png"
    r = subprocess.run([sys.executable, "-m", "appliance.synth.errorplot", scores, out], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    img = cv2.imread(str(out))
    assert img.shape == (300 + 24, 2 * 560, 3)
    dots = np.all(img == COLOURS["endpoint"], axis=2) | np.all(img == COLOURS["bifurcation"], axis=2)
    assert dots[:, :560].sum() >= 5 * len(panel.dz_mm) and not dots[:, 560:].any()


def test_module_names_a_file_that_is_not_scores(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"improved": {"rows": 3}}')
    r = subprocess.run([sys.executable, "-m", "appliance.synth.errorplot", bad, tmp_path / "o.png"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 1 and "bad.json" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "o.png").exists()
