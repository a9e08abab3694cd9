"""The committed scenes' truth against their rendered images: axes, features and depth line up."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from appliance.synth.rig import default_rig
from appliance.synth.scene import make_scene, render
from appliance.synth.truth import TruthError, load_truth, save_truth

SCENES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
TRUTHS = sorted(SCENES.glob("truth_*.json"))


@pytest.fixture(scope="module", params=TRUTHS, ids=lambda p: p.stem)
def truth(request):
    return load_truth(request.param)


def _centre_offsets(truth, side):
    """Signed offsets (px) between each projected axis sample and the middle of the mask run across it.

    Samples are 4 mm apart, away from the branch ends, kept where the run across the branch has the
    branch's own projected width (not merged with another branch, not cut by a leaf).
    """
    rig = truth.rig
    mask = truth.mask_left if side == "left" else truth.mask_right
    K = rig.K1 if side == "left" else rig.K2
    h, w = mask.shape
    offsets = []
    for b in truth.branches:
        seg = np.linalg.norm(np.diff(b.axis_mm, axis=0), axis=1)
        cum = np.concatenate([[0], np.cumsum(seg)])
        s = np.arange(3 * b.radius_mm[0] + 30, cum[-1] - 3 * b.radius_mm[0] - 30, 4.0)
        if len(s) == 0:
            continue
        pts = np.column_stack([np.interp(s, cum, b.axis_mm[:, k]) for k in range(3)])
        ahead = np.column_stack([np.interp(s + 1, cum, b.axis_mm[:, k]) for k in range(3)])
        r = np.interp(s, cum, b.radius_mm)
        p, q = rig.project(pts, side), rig.project(ahead, side)
        tangent = (q - p) / np.linalg.norm(q - p, axis=1, keepdims=True)
        normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
        z_cam = (pts @ (np.eye(3) if side == "left" else rig.R).T + (0 if side == "left" else rig.T))[:, 2]
        width_px = 2 * r * K[0, 0] / z_cam
        steps = np.arange(-40, 40.01, 0.05)
        for i in range(len(s)):
            line = p[i] + steps[:, None] * normal[i]
            ui, vi = np.round(line[:, 0]).astype(int), np.round(line[:, 1]).astype(int)
            if ui.min() < 0 or vi.min() < 0 or ui.max() >= w or vi.max() >= h:
                continue
            on = mask[vi, ui]
            c = len(steps) // 2
            if not on[c]:
                continue
            lo, hi = c, c
            while lo > 0 and on[lo - 1]:
                lo -= 1
            while hi < len(on) - 1 and on[hi + 1]:
                hi += 1
            if lo == 0 or hi == len(on) - 1 or abs((hi - lo) * 0.05 - width_px[i]) > 1.2:
                continue
            offsets.append((steps[lo] + steps[hi]) / 2)
    return np.array(offsets)


@pytest.mark.parametrize("side", ["left", "right"])
def test_projected_axis_is_the_centre_line_of_the_rendered_branch(truth, side):
    off = _centre_offsets(truth, side)
    assert len(off) > 100
    near = np.abs(off) < 2.0                     # the rest: a crossing branch of the same width
    assert near.mean() > 0.97
    assert abs(off[near].mean()) < 0.12          # no bias: truth and image agree to a small fraction of a px
    assert np.median(np.abs(off)) < 0.25         # per sample: mask quantisation (+-0.5 px per edge) only
    assert np.percentile(np.abs(off), 90) < 0.5


def test_visible_features_sit_on_their_branch(truth):
    f = truth.features
    rig = truth.rig
    for side, mask, px, vis in (("left", truth.mask_left, f.left_px, f.visible_left),
                                ("right", truth.mask_right, f.right_px, f.visible_right)):
        assert vis.any()
        assert np.allclose(px, rig.project(f.xyz_mm, side), atol=1e-3)
        for (u, v) in px[vis]:
            assert mask[int(round(v)), int(round(u))], (side, u, v)
    # depth of a visible feature's pixel: its own tube's front surface (a fork: the parent's), r / sin(ray, axis)
    for j in np.nonzero(f.visible_left)[0]:
        (u, v), xyz, r = f.left_px[j], f.xyz_mm[j], f.radius_mm[j]
        if f.parent[j] >= 0:
            r = truth.branches[f.parent[j]].radius_mm[truth.branches[f.branch[j]].parent_vertex]
        z = truth.depth_left_mm[int(round(v)), int(round(u))]
        assert xyz[2] - 3.7 * r - 2 < z < xyz[2] + 1.0, (z, xyz, r)


def test_scene_geometry_follows_the_brief(truth):
    kinds = set(truth.features.kind)
    assert kinds == {"endpoint", "bifurcation"}
    for b in truth.branches:
        assert 3.9 <= b.radius_mm.min() and b.radius_mm.max() <= 25.0
        assert (500 <= b.axis_mm[:, 2]).all() and (b.axis_mm[:, 2] <= 1500).all()
        if b.parent >= 0:                          # a fork: the child's axis starts on the parent's axis
            assert np.allclose(b.axis_mm[0], truth.branches[b.parent].axis_mm[b.parent_vertex])
    depth = truth.depth_left_mm[truth.mask_left]
    assert np.isfinite(depth).all() and np.isnan(truth.depth_left_mm[~truth.mask_left]).all()
    assert 480 < depth.min() and depth.max() < 1500
    directions = np.concatenate([np.diff(b.axis_mm[:, :2], axis=0) for b in truth.branches])
    horizontal = np.abs(directions[:, 1]) < 0.15 * np.abs(directions[:, 0])
    assert horizontal.mean() > 0.1                 # some near-horizontal branch in every scene


def test_fixture_is_what_the_generator_makes():
    """Regenerating scene 00 reproduces the committed images and truth (fixed seeds)."""
    left, right, truth = render(make_scene(0), default_rig(), seed=0)
    committed = load_truth(SCENES / "truth_00.json")
    assert np.allclose(truth.features.xyz_mm, committed.features.xyz_mm, atol=1e-3)
    assert (truth.features.visible_left == committed.features.visible_left).all()
    assert (truth.mask_left == committed.mask_left).mean() > 0.9999
    for img, name in ((left, "left_00.png"), (right, "right_00.png")):
        diff = np.abs(img.astype(int) - cv2.imread(str(SCENES / name)).astype(int))
        assert diff.mean() < 0.05 and diff.max() <= 3


def test_soft_coverage_is_the_masks_with_their_outline_in_quarters(truth):
    # 2x2 supersamples: a pixel's coverage is 0, 1/4, 1/2, 3/4 or 1, and its half level is the mask
    for cover, mask in ((truth.cover_left, truth.mask_left), (truth.cover_right, truth.mask_right)):
        assert cover.dtype == np.float32 and cover.shape == mask.shape
        assert np.array_equal(cover >= 0.5, mask)
        assert np.allclose(np.rint(cover * 4) / 4, cover, atol=0.01)
        partial = (cover > 0) & (cover < 1)
        # partly covered pixels are the outline: about one per outline pixel of the mask
        outline = mask & ~cv2.erode(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        assert 0.3 < partial.sum() / outline.sum() < 3
    assert truth.exact_masks(soft=True)[0] is truth.cover_left and truth.exact_masks()[0] is truth.mask_left


def test_truth_files_round_trip(tmp_path, truth):
    json_path, npz_path = save_truth(truth, tmp_path / "t")
    back = load_truth(json_path)
    assert np.allclose(back.features.left_px, truth.features.left_px, atol=1e-4)
    assert (back.features.kind == truth.features.kind).all()
    assert np.array_equal(back.mask_right, truth.mask_right)
    assert np.array_equal(back.cover_left, truth.cover_left)
    assert np.allclose(back.rig.T, truth.rig.T)
    npz_path.unlink()
    with pytest.raises(TruthError, match="t.npz"):
        load_truth(json_path)


def test_render_is_deterministic_and_jpeg_optional():
    r = default_rig()
    scale = np.diag([0.25, 0.25, 1.0])
    small = type(r)(scale @ r.K1, r.D1, scale @ r.K2, r.D2, r.R, r.T, 320, 240)
    scene = make_scene(2)
    a_left, a_right, a_truth = render(scene, small, seed=4)
    b_left, _, _ = render(scene, small, seed=4)
    j_left, _, j_truth = render(scene, small, seed=4, jpeg_quality=60)
    assert a_left.shape == (240, 320, 3) and a_left.dtype == np.uint8
    assert np.array_equal(a_left, b_left)
    assert not np.array_equal(a_left, j_left) and np.abs(a_left.astype(int) - j_left).mean() < 6
    assert np.array_equal(a_truth.mask_left, j_truth.mask_left)
    gain = a_right.mean() / a_left.mean()
    assert 0.85 < gain < 1.15 and a_truth.mask_left.any()
