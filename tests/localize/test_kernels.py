"""kernels.warm_up (localize/kernels.py): after it, localizing compiles no new signature of any kernel."""

from __future__ import annotations

import cv2

from appliance.localize import kernels_dense, kernels_fit, kernels_ncc, kernels_refine, kernels_runs, kernels_walks


def test_warm_up_compiles_every_signature_the_localizer_uses():
    """After a Localizer is built (it warms the kernels up), localizing compiles nothing more: no frame
    waits for numba (a live stream's first result, a worker's first pair)."""
    from importlib import import_module
    from pathlib import Path

    import cv2
    import numba
    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer

    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    loc = Localizer(load_calibration(fixtures / "rig.yaml"), load_config().localize)
    shared = {                  # (the kernels that lived in kernels.py itself; the other modules have their own test)
        "kernels_fit": "fit_groups robust_fit_groups eval_clamped end_slopes_groups",
        "kernels_runs": "runs_find runs_between mask_runs",
        "kernels_walks": "walk_edges child_outline_pairs near_points last_on",
        "kernels_graph": "zhang_suen_flat remove_corners_flat graph_core",
        "kernels_segment": "unmix_blocks blocks_hold_disc blocks_disc_colour",
        "kernels_ncc": "ncc_peaks ncc_search ncc_scores masked_sqdiff",
        "kernels_refine": "refine_steps",
        "kernels_dense": "consensus_lines line_vote centre_line nearest_per_query near_junctions",
    }
    jitted = {f"{m}.{n}": getattr(import_module(f"appliance.localize.{m}"), n)
              for m, names in shared.items() for n in names.split()}
    assert all(isinstance(f, numba.core.registry.CPUDispatcher) for f in jitted.values())
    before = {n: len(f.signatures) for n, f in jitted.items()}
    loc.localize(cv2.imread(str(fixtures / "scenes" / "left_00.png")), cv2.imread(str(fixtures / "scenes" / "right_00.png")))
    assert {n: len(f.signatures) for n, f in jitted.items()} == before
    assert all(before.values())


def test_warm_up_compiles_the_patch_and_line_kernels_signatures():
    """After a Localizer is built, localizing (colour and exact masks, scenes with caps and flat pieces)
    compiles none of these kernels again (warm_up passes the same array layouts as the callers)."""
    from pathlib import Path

    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer
    from appliance.synth.truth import load_truth

    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    loc = Localizer(load_calibration(fixtures / "rig.yaml"), load_config().localize)
    mine = [kernels_ncc.ncc_search, kernels_ncc.ncc_peaks, kernels_ncc.ncc_scores, kernels_ncc.masked_sqdiff, kernels_refine.refine_steps,
            kernels_dense.line_vote, kernels_dense.centre_line]
    before = [len(f.signatures) for f in mine]
    for n in ("01", "03"):
        left, right = (cv2.imread(str(fixtures / "scenes" / f"{s}_{n}.png")) for s in ("left", "right"))
        truth = load_truth(fixtures / "scenes" / f"truth_{n}.json")
        loc.localize(left, right)
        loc.localize(left, right, mask_left=truth.mask_left, mask_right=truth.mask_right)
    assert [len(f.signatures) for f in mine] == before and all(before)


def test_warm_up_compiles_the_runs_slopes_and_picks_signatures():
    """After a Localizer is built, localizing (colour and exact masks) compiles none of these kernels again."""
    from pathlib import Path

    from appliance.calibrate.model import load_calibration
    from appliance.config import load_config
    from appliance.localize import Localizer
    from appliance.synth.truth import load_truth

    fixtures = Path(__file__).resolve().parents[2] / "fixtures"
    loc = Localizer(load_calibration(fixtures / "rig.yaml"), load_config().localize)
    mine = [kernels_fit.end_slopes_groups, kernels_runs.mask_runs, kernels_walks.last_on,
            kernels_dense.nearest_per_query, kernels_dense.near_junctions]
    before = [len(f.signatures) for f in mine]
    left, right = (cv2.imread(str(fixtures / "scenes" / f"{s}_03.png")) for s in ("left", "right"))
    truth = load_truth(fixtures / "scenes" / "truth_03.json")
    loc.localize(left, right)
    loc.localize(left, right, mask_left=truth.mask_left, mask_right=truth.mask_right)
    assert [len(f.signatures) for f in mine] == before and all(before)
