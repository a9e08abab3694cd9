import subprocess
import sys

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import LocalizeError, Localizer
from appliance.localize.triangulate import triangulate

from .shapes import branch_pair, ideal_rig

CFG = load_config().localize


@pytest.mark.parametrize("depth_mm", [600.0, 1000.0, 1400.0])
def test_dense_matching_gives_the_depth_of_a_drawn_branch(depth_mm):
    calib = ideal_rig()
    left, right, ml, mr, d = branch_pair(calib, depth_mm)
    res = Localizer(calib, CFG, "improved").localize(left, right, mask_left=ml, mask_right=mr)
    assert len(res.branches) == 1
    z = res.branches[0].polyline_mm[:, 2]
    dz_per_px = depth_mm / d
    assert np.abs(z[1:-1] - depth_mm).max() < 0.1 * dz_per_px     # a tenth of a pixel of disparity
    # the ends are the tips: the drawing is flat, but its caps' rows are read as a round 3D cap's
    # (ends.cap_row_scale), which moves them by ~0.06-0.13 px here
    assert res.branches[0].radius_mm == pytest.approx(6.0 * depth_mm / calib.f_px, rel=0.1)
    tips = [f for f in res.features if f.kind == "endpoint"]
    assert len(tips) == 2
    for f in tips:
        assert abs(f.xyz_mm[2] - depth_mm) < 0.2 * dz_per_px
        assert f.safe_depth_mm == pytest.approx(f.xyz_mm[2] - CFG.safety_factor_k * f.radius_mm)
        assert min(np.hypot(f.left_px[0] - x, f.left_px[1] - y) for x, y in [(300, 60), (260, 420)]) < 8
        assert f.right_px[0] == pytest.approx(f.left_px[0] - d, abs=1.0)


def test_paper_variant_matches_the_drawn_tips():
    calib = ideal_rig()
    depth_mm = 900.0
    left, right, ml, mr, d = branch_pair(calib, depth_mm)
    res = Localizer(calib, CFG, "paper").localize(left, right, mask_left=ml, mask_right=mr)
    assert {f.kind for f in res.features} == {"endpoint"} and len(res.features) == 2
    for f in res.features:
        assert abs(f.xyz_mm[2] - depth_mm) < 2 * depth_mm / d      # whole-pixel features
    assert len(res.branches) == 1
    assert sorted(res.branches[0].feature_ids) == [0, 1]


def test_colour_recogniser_finds_a_bark_coloured_branch():
    calib = ideal_rig()
    left, right, ml, mr, d = branch_pair(calib, 1000.0, radius_px=8.0)
    green = np.array([40, 140, 60], np.uint8)
    bark = np.array([45, 70, 95], np.uint8)
    imgs = []
    for m in (ml, mr):
        img = np.where(m[..., None] > 0, bark, green).astype(np.uint8)
        imgs.append(cv2.GaussianBlur(img, (3, 3), 0))
    res = Localizer(calib, CFG, "improved").localize(*imgs)
    assert len(res.branches) == 1
    assert np.abs(res.branches[0].polyline_mm[:, 2] - 1000.0).max() < 1000.0 / d


def test_triangulation_returns_the_unrectified_left_frame():
    from appliance.synth.rig import default_rig

    rig = default_rig()
    calib = rig.calibration()
    X = np.array([[100.0, -50.0, 900.0], [-200.0, 80.0, 1300.0]])
    Xr = X @ calib.R1.T
    u = calib.P1[0, 0] * Xr[:, 0] / Xr[:, 2] + calib.P1[0, 2]
    v = calib.P1[1, 1] * Xr[:, 1] / Xr[:, 2] + calib.P1[1, 2]
    d = calib.f_px * calib.baseline_mm / Xr[:, 2] + calib.P1[0, 2] - calib.P2[0, 2]
    assert np.allclose(triangulate(u, v, d, calib), X, atol=1e-6)


def test_nothing_in_view_is_an_empty_result():
    calib = ideal_rig()
    grey = np.full((480, 640, 3), 128, np.uint8)
    res = Localizer(calib, CFG).localize(grey, grey, stamp_ns=42)
    assert res.features == () and res.branches == () and res.stamp_ns == 42
    assert "segment" in res.timings_ms


def test_bad_input_is_a_clear_error():
    calib = ideal_rig()
    loc = Localizer(calib, CFG)
    small = np.zeros((240, 320, 3), np.uint8)
    with pytest.raises(LocalizeError, match="320x240.*640x480"):
        loc.localize(small, small)
    img = np.zeros((480, 640, 3), np.uint8)
    with pytest.raises(LocalizeError, match="empty"):
        loc.localize(img, img, mask_left=np.zeros((480, 640)), mask_right=np.ones((480, 640)))


def test_same_input_same_result():
    calib = ideal_rig()
    left, right, ml, mr, _ = branch_pair(calib, 800.0)
    loc = Localizer(calib, CFG)
    a = loc.localize(left, right, mask_left=ml, mask_right=mr).to_dict()
    b = loc.localize(left, right, mask_left=ml, mask_right=mr).to_dict()
    a.pop("timings_ms"), b.pop("timings_ms")
    assert a == b


def test_an_obliquely_cut_end_is_not_a_tip_when_asked():
    calib = ideal_rig()
    left, right, ml, mr, d = branch_pair(calib, 1000.0, radius_px=8.0)
    for img, m, shift in ((left, ml, 0.0), (right, mr, d)):
        cut = np.array([[150, 300], [400, 200], [400, 480], [150, 480]], np.float64)   # a slanted edge
        cut[:, 0] -= shift
        cv2.fillPoly(img, [np.rint(cut).astype(np.int32)], (40, 40, 40))
        cv2.fillPoly(m, [np.rint(cut).astype(np.int32)], 0)
    plain = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    cfg = load_config(overrides={"localize": {"match": {"oblique_end_ratio": 0.35}}}).localize
    strict = Localizer(calib, cfg).localize(left, right, mask_left=ml, mask_right=mr)
    for result in (plain, strict):
        # the oblique ratio, and without it the check beyond the end (branch at the same depth
        # there: the slab cuts it), both withhold the cut end; the round cap at the top stays
        tips = [f for f in result.features if f.kind == "endpoint"]
        assert len(tips) == 1 and tips[0].left_px[1] < 100


def test_an_end_cut_by_something_nearer_is_not_a_tip():
    calib = ideal_rig()
    left, right, ml, mr, _ = branch_pair(calib, 1000.0, radius_px=8.0)
    full = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert len([f for f in full.features if f.kind == "endpoint"]) == 2      # both round caps
    # a plain slab 100 mm nearer across the lower part, its edge slanted to the rows: it cuts the
    # branch at another place in the right view than the branch's own disparity puts a tip
    # (an edge along the rows would cut both views on the same row: no telling it from a tip)
    d_slab = calib.f_px * calib.baseline_mm / 900.0
    for img, m, shift in ((left, ml, 0.0), (right, mr, d_slab)):
        slab = np.array([[100, 250], [480, 400], [480, 479], [100, 479]], np.float64)
        slab[:, 0] -= shift
        cv2.fillPoly(img, [np.rint(slab).astype(np.int32)], (40, 40, 40))
        cv2.fillPoly(m, [np.rint(slab).astype(np.int32)], 0)
    cut = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in cut.features if f.kind == "endpoint"]
    assert len(tips) == 1 and tips[0].left_px[1] < 100          # only the cap at the top
    assert len(cut.branches) == 1


def test_a_piece_is_cut_where_its_disparity_jumps_and_its_longest_plausible_part_kept():
    from appliance.localize.localizer import plausible_part

    v = np.arange(0.0, 60.0, 2.0)                       # 30 samples down the rows, 2 px apart
    uvd = np.column_stack([np.full_like(v, 400.0), v, 150.0 + 0.1 * v])   # a tilted branch: kept whole
    assert plausible_part(uvd, 0.5) is uvd
    bad = uvd.copy()
    bad[:5, 2] -= 30.0                                  # a wild start (a bad fit, a join at another depth)
    bad[25:, 2] += np.arange(5) * 4.0                   # and a runaway end: 2 px of disparity per px
    part = plausible_part(bad, 0.5)
    np.testing.assert_array_equal(part, bad[5:26])
    assert plausible_part(bad, 0.0) is bad              # 0 = off


def test_a_piece_keeps_only_its_longest_run_inside_the_working_range():
    from appliance.localize.localizer import longest_run

    calib = ideal_rig()
    loc = Localizer(calib, CFG)
    dmin, dmax = loc.d_range_px
    d = np.r_[np.full(3, 0.5 * dmin), np.full(6, 0.5 * (dmin + dmax)), 2.0 * dmax, np.full(4, dmax)]
    uvd = np.column_stack([np.full(len(d), 100.0), np.arange(len(d), dtype=float), d])
    ok = (d >= 0.95 * dmin) & (d <= 1.05 * dmax)
    np.testing.assert_array_equal(longest_run(uvd, ok), uvd[3:9])
    assert longest_run(uvd, np.ones(len(d), bool)) is uvd
    assert len(longest_run(uvd, np.zeros(len(d), bool))) == 0


def test_a_probability_mask_is_kept_soft():
    # an external segmenter's probabilities (floats 0-1) keep their outline's coverage; other masks
    # are binary (non-zero = branch)
    from appliance.localize.segment import as_mask

    p = np.zeros((4, 6))
    p[1:3, 2:5] = [[0.2, 1.0, 0.6], [0.49, 0.51, 1.0]]
    m = as_mask(p, (4, 6), "left mask")
    assert m.dtype == np.uint8 and m[1, 2] == 51 and m[1, 3] == 255 and m[2, 2] == 125 and m[2, 3] == 130
    assert set(np.unique(as_mask((p * 7).astype(np.uint8), (4, 6), "left mask"))) == {0, 255}
    with pytest.raises(LocalizeError, match=r"left mask: mask is empty \(no pixel of probability 0.5"):
        as_mask(p * 0.45, (4, 6), "left mask")
    # the drawn branch with its segmenter's probabilities: the same depths as with binary masks
    calib = ideal_rig()
    left, right, _, _, d = branch_pair(calib, 1000.0)
    soft = [np.clip((cv2.cvtColor(g, cv2.COLOR_BGR2GRAY) - 40.0) / 160.0, 0, 1) for g in (left, right)]
    res = Localizer(calib, CFG, "improved").localize(left, right, mask_left=soft[0], mask_right=soft[1])
    z = res.branches[0].polyline_mm[1:-1, 2]
    assert np.abs(z - 1000.0).max() < 0.1 * 1000.0 / d
    assert len([f for f in res.features if f.kind == "endpoint"]) == 2


def test_whole_pieces_is_the_per_piece_test_of_the_range_and_the_steps():
    """_assemble's batched test (all pieces' samples at once) keeps a piece whole exactly when the
    per-piece path (no disparity <= 0, longest_run in range, plausible_part) gives the piece itself."""
    from types import SimpleNamespace

    from appliance.localize.localizer import _whole_pieces, longest_run, plausible_part
    rng = np.random.default_rng(11)
    lo, hi, grad = 80.0, 300.0, 0.5
    pieces, whole = [], 0
    for _ in range(600):
        n = int(rng.integers(2, 30))
        u = np.cumsum(rng.uniform(-2, 2, n)) + 500
        v = np.cumsum(rng.uniform(0, 2, n)) + 100
        d = 150 + np.cumsum(rng.choice([0.0, 0.1, 0.3, 1.5, 3.0], n, p=[0.4, 0.3, 0.2, 0.07, 0.03]))
        if rng.random() < 0.1:
            d[rng.integers(n)] = rng.choice([-1.0, 0.0, 50.0, 400.0, np.nan])
        pieces.append(SimpleNamespace(uvd=np.column_stack([u, v, d])))
    for g in (grad, 0.0):
        got = _whole_pieces(pieces, lo, hi, g)
        for p, ok in zip(pieces, got):
            d = p.uvd[:, 2]
            want = not (d <= 0).any() and plausible_part(longest_run(p.uvd, (d >= lo) & (d <= hi)), g) is p.uvd
            assert ok == want
            whole += ok
    assert 200 < whole < 1100                            # both outcomes well represented
    assert _whole_pieces([], lo, hi, grad) == []


def test_reading_results_does_not_load_the_compiled_kernels():
    # `appliance logs`, the arm link and the command line's start import the result types only: numba and the
    # kernels (~0.5 s of every such process's start) come with the first use of Localizer.
    code = ("import sys, appliance.cli, appliance.localize as loc; assert 'numba' not in sys.modules; "
            "loc.Localizer; assert 'numba' in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)
