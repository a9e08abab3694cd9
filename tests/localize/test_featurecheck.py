"""Each feature's disparity checked against its branches' bark texture (localize/featurecheck.py).

Constructed pair: a textured scene whose right view is the left one shifted by D_PX (a surface at one
depth), a horizontal branch band of radius R_PX in the left mask from u = 60 to a tip at u = 200, and
a fork at u = 130 where a second, diagonal piece leaves the band. A feature at the right disparity is
kept; at a disparity 3 px off, or 12-15 px off (outside the
search window: the wide search), it is withheld; a feature on bark without texture is kept (no verdict).
"""

import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from appliance.calibrate.model import load_calibration
from appliance.config import load_config
from appliance.localize import Localizer
from appliance.localize import featurecheck as FC
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


def test_fork_whose_pieces_agree_withheld_tip_kept():
    """Issue 5 (seeds 356-387): a fork 1.2 px off (under max_diff_px 1.6) whose pieces' texture all
    reads ~1.2 px away on the same side is withheld by the pieces' agreement; a tip with the same error
    (one piece: no agreement) is kept; 0.5 px off, both are kept."""
    left, right, mask = _pair()
    off = check_features(_features(D_PX - 1.2, D_PX - 1.2), _pieces(), left, right, mask, D_RANGE, F_PX, 0.0,
                         max_diff_px=1.6)
    tip, fork = off
    assert not tip.withheld and np.isnan(tip.agree_px) and abs(tip.diff_px) < 1.6
    assert fork.withheld and abs(fork.diff_px) < 1.6 and 0.9 < fork.agree_px < 1.6
    near = check_features(_features(D_PX - 0.5, D_PX - 0.5), _pieces(), left, right, mask, D_RANGE, F_PX, 0.0,
                          max_diff_px=1.6)
    assert not any(c.withheld for c in near) and abs(near[1].agree_px) < 0.9
    never = check_features(_features(D_PX - 1.2, D_PX - 1.2), _pieces(), left, right, mask, D_RANGE, F_PX, 0.0,
                           max_diff_px=1.6, agree_px=float("inf"))
    assert not any(c.withheld for c in never) and never[1].agree_px == fork.agree_px


def _piece_rows(feature: int, piece: int, s: np.ndarray, d: np.ndarray, slope: float = 0.0) -> dict:
    n = len(s)
    return {"feature": np.full(n, feature), "piece": np.full(n, piece), "s": np.asarray(s, float),
            "d_axis": np.broadcast_to(np.asarray(d, float), (n,)).copy(), "slope": np.full(n, slope), "score": np.full(n, 0.95)}


def _table_of(*parts: dict) -> dict:
    return {c: np.concatenate([p[c] for p in parts]) for c in parts[0]}


def _agree_numpy(t: dict, d_px: np.ndarray) -> np.ndarray:
    """The pieces' agreement by its definition (FC.estimate's docstring), piece by piece in numpy."""
    out = np.full(len(d_px), np.nan)
    for f in range(len(d_px)):
        est = []
        for j in np.unique(t["piece"][t["feature"] == f]):
            k = (t["feature"] == f) & (t["piece"] == j) & np.isfinite(t["d_axis"]) & (t["score"] >= FC.MIN_SCORE)
            s, d, g = t["s"][k], t["d_axis"][k], t["slope"][k]
            if len(s) < FC.MIN_PATCHES:
                continue
            if len(s) >= FC.FIT_MIN_PATCHES and np.ptp(s) >= FC.FIT_MIN_SPAN_PX:
                b, a = np.polyfit(s, d, 1)
                if np.abs(d - a - b * s).max() <= FC.FIT_MAX_RES_PX and abs(b) <= FC.MAX_PIECE_SLOPE:
                    est.append(a - d_px[f])
                    continue
            carried = d - g * s
            if np.ptp(carried) <= 2 * FC.MAX_SPREAD_PX:
                est.append(carried.mean() - d_px[f])
        if len(est) >= 2:
            e = np.sort(est)
            up = e[-2] if e[0] >= -FC.OPPOSE_PX and e[-2] > 0 else 0.0
            down = e[1] if e[-1] <= FC.OPPOSE_PX and e[1] < 0 else 0.0
            out[f] = up if up >= -down else down
    return out


def test_agreement_needs_two_pieces_on_one_side():
    """The pieces' agreement (FC.estimate) on patch tables: two pieces reading +1.2 and +1.0 px: +1.0
    (the second largest); a third reading -0.5 (over OPPOSE_PX on the other side): 0; a single piece: NaN;
    pieces read by their own lines (texture slope 0.02 px/px over 30-70 px) and by the pieces' slopes."""
    s = np.arange(30.0, 71.0, 8.0)
    d0 = 100.0
    two = _table_of(_piece_rows(0, 0, s, d0 + 1.2 + 0.02 * s), _piece_rows(0, 1, s, d0 + 1.0 - 0.01 * s))
    assert FC.estimate(two, np.array([d0]))[3][0] == pytest.approx(1.0)
    three = _table_of(_piece_rows(0, 0, s, d0 + 1.2 + 0.02 * s), _piece_rows(0, 1, s, d0 + 1.0 - 0.01 * s),
                      _piece_rows(0, 2, s, d0 - 0.5))
    assert FC.estimate(three, np.array([d0]))[3][0] == 0.0
    one = _piece_rows(0, 0, s, d0 + 1.2 + 0.02 * s)
    assert np.isnan(FC.estimate(one, np.array([d0]))[3][0])
    # two patches each (no line of their own): carried along the pieces' slopes
    carried = _table_of(_piece_rows(0, 0, s[:2], d0 - 1.3 + 0.05 * s[:2], 0.05),
                        _piece_rows(0, 1, s[:2], d0 - 1.1, 0.0))
    assert FC.estimate(carried, np.array([d0]))[3][0] == pytest.approx(-1.1)


def test_agreement_is_its_definition_on_random_tables():
    """FC.estimate's agreement (kernels_check.estimate_pieces) against :func:`_agree_numpy` on 300 random
    tables of 1-4 features with 1-3 pieces each: equal (NaN alike); agreements of both signs, zero and NaN occur."""
    rng = np.random.default_rng(21)
    seen = set()
    for _ in range(300):
        parts, d_px = [], []
        piece = 0
        for f in range(int(rng.integers(1, 5))):
            d_px.append(100.0 + rng.normal(0, 1))
            for _ in range(int(rng.integers(1, 4))):
                n = int(rng.integers(1, 7))
                s = np.sort(rng.uniform(5, 70, n))
                g = rng.normal(0, 0.03)
                d = 100.0 + rng.normal(0, 1.0) + rng.normal(0, 0.03) * s + rng.normal(0, rng.choice([0.05, 0.4]), n)
                d[rng.random(n) < 0.1] = np.nan
                p = _piece_rows(f, piece, s, d, g)
                p["score"] = rng.choice([0.5, 0.9, 0.99], n)
                parts.append(p)
                piece += 1
        t, d_px = _table_of(*parts), np.array(d_px)
        got, want = FC.estimate(t, d_px)[3], _agree_numpy(t, d_px)
        np.testing.assert_allclose(got, want, atol=1e-9)
        seen |= {("nan" if np.isnan(a) else "zero" if a == 0 else "pos" if a > 0 else "neg") for a in got}
    assert seen == {"nan", "zero", "pos", "neg"}


@pytest.fixture
def scene_375(rendered_scene):
    """Rendered scene 375 (the benchmark's seed) and the rig's calibration."""
    return rendered_scene(375)


@pytest.mark.parametrize("agreement", [False, True])
def test_seed375_fork_whose_pieces_agree_is_withheld(scene_375, monkeypatch, agreement):
    # seed 375's fork 1 (Z 1094 mm, exact masks) is placed 1.37 px off (-9.3 mm). Its texture check reads
    # -0.46 px (the least alarming reading, under max_diff_px), but its two thick pieces' own lines both
    # read -1.35 px at the fork: the pieces' agreement withholds it. fork356's fixes of its placing (a side's
    # width allowing for perspective, the child's curve vouching at most 60 px past its span) bring it to
    # -2.9 mm: they are off here, so that the net is tested on the error it was made for.
    import appliance.localize.forkdisp as forkdisp
    import appliance.localize.forkends as forkends
    from appliance.synth.evaluate import score_result
    monkeypatch.setattr(forkdisp, "SIDE_WIDTH_PERSPECTIVE", False)
    monkeypatch.setattr(forkends, "KNOWN_VOUCH_CAPPED", False)
    if not agreement:
        monkeypatch.setattr(FC, "AGREE_PX", float("inf"))
    left, right, truth, calib = scene_375
    res = Localizer(calib, load_config().localize).localize(left, right, mask_left=truth.mask_left,
                                                            mask_right=truth.mask_right)
    row = next(r for r in score_result(res, truth).rows if r.truth_index == 1)
    assert row.kind == "bifurcation"
    if agreement:
        assert row.result_id < 0 or abs(row.dz_mm) <= 3.0
    else:
        assert row.result_id >= 0 and row.dz_mm <= -5.0


def test_the_check_benchmark_runs_on_the_fixtures_and_withholds_no_correct_feature():
    # benchmarks/feature_check.py as a user runs it (a real process): it subclasses the localizer, so a
    # change of the localizer's internals breaks it (stop 18's withheld list did, unnoticed until now)
    repo = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, str(repo / "benchmarks" / "feature_check.py"), "--extra", "0",
                          "--masks", "true"], capture_output=True, text=True, timeout=300, cwd=repo)
    assert out.returncode == 0, out.stderr
    n, correct, gross = map(int, re.search(r"features (\d+): correct (\d+), gross (\d+)", out.stdout).groups())
    assert n >= 20 and correct == n and gross == 0, out.stdout
    assert re.search(r"withheld at 1\.6 px: correct 0,", out.stdout), out.stdout


def test_far_piece_reads_the_piece_furthest_off_when_its_patches_agree():
    # a fork (feature 0) with two pieces: piece 0's patches at the fork's disparity, piece 1's three patches
    # 13 px under it (flat, agreeing): far -13. Feature 1 (a tip): its piece's patches scattered over 4 px
    # (no reading) or only two (too few): 0.
    t = {"feature": np.array([0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1]),
         "piece": np.array([0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3]),
         "s": np.array([20.0, 25, 30, 20, 25, 30, 10, 15, 20, 10, 15]),
         "d_axis": np.array([176.5, 176.6, 176.7, 163.0, 163.2, 163.4, 60.0, 62.0, 64.0, 70.0, 70.0]),
         "slope": np.array([0.0, 0, 0, 0.02, 0.02, 0.02, 0, 0, 0, 0, 0]),
         "score": np.full(11, 0.95)}
    far = FC.far_piece(t, np.array([176.3, 62.0]))
    assert far[0] == pytest.approx(163.2 - 0.02 * 25 - 176.3) and far[1] == 0.0
    t["score"][3] = 0.5                                                  # (two confident patches: too few)
    assert FC.far_piece(t, np.array([176.3, 62.0]))[0] == 0.0       # (piece 0, 0.3 px off, is not read)
    assert FC.far_piece(t, np.array([179.6, 62.0]))[0] == pytest.approx(176.6 - 179.6)   # ... unless beyond 3 px


def test_a_fork_whose_pieces_read_far_off_is_withheld_at_the_far_pieces_reading():
    # the constructed fork at D_PX: at its disparity no piece reads far and it is kept; 4 px off, every
    # piece does, and the check's reading is the furthest piece's (at D_PX).
    left, right, mask = _pair()
    ok = check_features(_features(D_PX, D_PX), _pieces(), left, right, mask, D_RANGE, F_PX)
    assert not ok[1].withheld
    off = check_features(_features(D_PX, D_PX + 4.0), _pieces(), left, right, mask, D_RANGE, F_PX)
    assert off[1].withheld and abs(off[1].d_check_px - D_PX) < 0.5


def _turning_pair(k: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    """The constructed pair with the disparity changing along the rows: D_PX at column 200 (the tip), D_PX + k
    (x - 200) elsewhere (a branch turning in depth, k px per px); the left mask and the tip's two pieces with
    that disparity along them."""
    rng = np.random.default_rng(5)
    t = cv2.GaussianBlur(rng.uniform(0, 255, (H, W + 60)).astype(np.float32), (0, 0), 1.2)
    t = (60 + 140 * (t - t.min()) / (t.max() - t.min())).astype(np.uint8)
    left = np.ascontiguousarray(t[:, :W])
    xr = np.tile(np.arange(W, dtype=np.float32), (H, 1))
    map_x = (xr + D_PX - k * 200.0) / (1.0 - k)                      # (x_left - D(x_left) = x_right)
    right = cv2.remap(t, map_x, np.tile(np.arange(H, dtype=np.float32)[:, None], (1, W)), cv2.INTER_CUBIC)
    mask = np.zeros((H, W), np.uint8)
    cv2.line(mask, (60, 100), (200, 100), 255, int(2 * R_PX) + 1)
    x = np.linspace(60, 130, 36), np.linspace(130, 200, 36)
    pieces = [PieceUVD(i, np.column_stack([xi, np.full(36, 100.0), D_PX + k * (xi - 200.0)]), R_PX, False, (i, i + 1))
              for i, xi in enumerate(x)]
    return left, right, mask, pieces


def test_turn_overshoot_signs_a_tips_distance_past_its_texture_along_the_turn():
    # features 0, 1: tips on pieces turning at -0.08 / +0.06 px per px away from them; 2: a tip on a piece
    # turning slower than TURN_SLOPE; 3: a fork; 4: a tip without a verdict. Feature 0's fourth patch is not
    # confident (its distance not in the carry).
    t = {"feature": np.array([0, 0, 0, 0, 1, 1, 1, 2, 3, 3, 4]),
         "slope": np.array([-0.08] * 4 + [0.06] * 3 + [0.03, -0.1, -0.1, 0.1]),
         "s": np.array([10.0, 10.0, 10.0, 30.0, 10.0, 15.0, 20.0, 10.0, 10.0, 20.0, 10.0]), "d_axis": np.full(11, 100.0),
         "score": np.array([0.95, 0.95, 0.95, 0.5, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9])}
    d = np.array([167.5, 100.0, 50.0, 80.0, 60.0])
    check = np.array([166.6, 101.0, 49.0, 79.0, np.nan])
    tip = np.array([True, True, True, False, True])
    over, carry = FC.turn_overshoot(t, d, check, tip)
    assert over[0] == pytest.approx(0.9) and over[1] == pytest.approx(1.0)
    assert carry[0] == pytest.approx(0.08 * 10.0) and carry[1] == pytest.approx(0.06 * 15.0)
    assert np.isnan(over[2:]).all() and np.isnan(carry[2:]).all()
    t["slope"] = -t["slope"]                                         # (the tips short of their texture instead)
    assert (FC.turn_overshoot(t, d, check, tip)[0][:2] < 0).all()
    t["score"][1] = 0.5                                              # (two confident patches: no line, no value)
    assert np.isnan(FC.turn_overshoot(t, d, check, tip)[0][0])


@pytest.mark.parametrize("k", [0.06, -0.06])
def test_a_tip_past_its_texture_along_a_turn_in_depth_is_withheld(k, monkeypatch):
    # the texture reads the tip at D_PX (its patches 8-32 px back, carried ~1.2 px); a tip 1.2 px past it along
    # the turn (the far side from the piece's body: + for a disparity falling away from the tip) is withheld,
    # 1.2 px short of it is kept (under max_diff_px), and on a piece not turning in depth either is kept
    left, right, mask, pieces = _turning_pair(k)
    past = 1.2 * np.sign(k)
    checks = [check_features([FeatureUVD(2, "endpoint", 200.0, 100.0, D_PX + dd, R_PX)], pieces, left, right,
                             mask, D_RANGE, F_PX)[0] for dd in (past, -past)]
    assert abs(checks[0].d_check_px - D_PX) < 0.4 and checks[0].n_patches >= 2, checks[0]
    assert checks[0].overshoot_px > FC.TURN_PX and checks[0].turned and checks[0].withheld
    assert checks[1].overshoot_px < 0 and not checks[1].withheld
    monkeypatch.setattr(FC, "TURN_CARRY_SHARE", 1.0 / (abs(k) * 8.0))    # (the patches ~8+ px back: a carry of
    c = check_features([FeatureUVD(2, "endpoint", 200.0, 100.0, D_PX + past, R_PX)], pieces, left, right, mask,
                       D_RANGE, F_PX)[0]                                # 1+ px allows the overshoot)
    assert not c.turned and not c.withheld
    left, right, mask, pieces = _turning_pair(0.0)
    for dd in (1.2, -1.2):
        c = check_features([FeatureUVD(2, "endpoint", 200.0, 100.0, D_PX + dd, R_PX)], pieces, left, right, mask,
                           D_RANGE, F_PX)[0]
        assert np.isnan(c.overshoot_px) and not c.withheld and abs(c.diff_px + dd) < 0.4
