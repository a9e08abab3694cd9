"""Forks and tips placed on the fitted curves (appliance.localize.ends), on drawn stereo pairs."""

import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize import Localizer

from .shapes import branch_pair, ideal_rig, y_pair

CFG = load_config().localize


@pytest.mark.parametrize("angle_deg", [25.0, 60.0])
def test_a_fork_is_where_the_child_axis_meets_the_parent_axis(angle_deg):
    # at a shallow angle the skeleton junction lies far ahead of the fork (where the outlines
    # part); the fork must still land on the axes' meeting point, with the parent's disparity
    calib = ideal_rig()
    left, right, ml, mr, fork, d = y_pair(calib, 1000.0, angle_deg)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    forks = [f for f in res.features if f.kind == "bifurcation"]
    assert len(forks) == 1
    f = forks[0]
    assert np.hypot(*np.subtract(f.left_px, fork)) <= 2.0
    assert abs((f.left_px[0] - f.right_px[0]) - d) <= 0.3


def test_a_child_at_another_depth_is_no_fork():
    # drawn 150 mm nearer, the "child" only crosses the parent in the image: no fork, though the
    # parent and the child are still reported as branches at their own depths
    calib = ideal_rig()
    left, right, ml, mr, _, _ = y_pair(calib, 1000.0, 45.0, child_depth_mm=850.0)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert not [f for f in res.features if f.kind == "bifurcation"]
    z = sorted(np.median(b.polyline_mm[:, 2]) for b in res.branches if len(b.polyline_mm) > 2)
    assert z and abs(z[0] - 850.0) <= 10.0 and abs(z[-1] - 1000.0) <= 10.0


@pytest.mark.parametrize("angle_deg, d_child, agrees", [(45.0, 84.0, True), (45.0, 88.0, False),
                                                       (86.0, 84.0, False), (86.0, 88.0, False)])
def test_the_right_outline_confirms_a_fork_only_where_depth_would_move_it(angle_deg, d_child, agrees):
    # a vertical parent (radius 10 px, disparity 84 px) and a child (6 px) leaving it at
    # ``angle_deg`` from it, drawn at disparity ``d_child`` in the right view: a child at 45 deg
    # 4 px nearer crosses the parent 4 px further along it there; one within 4 deg of the rows
    # crosses it at the same place at any depth, so its outline tells nothing
    from types import SimpleNamespace

    from appliance.localize.ends import EndPlacer

    w, h, ss, d = 640, 480, 4, 84.0
    fork, a = np.array([320.0, 300.0]), np.radians(angle_deg)
    e2 = np.array([np.sin(a), -np.cos(a)])
    masks = []
    for shift, shift_child in ((0.0, 0.0), (d, d_child)):
        big = np.zeros((h * ss, w * ss), np.uint8)

        def px(p, dx):
            return round((p[0] - dx + 0.5) * ss - 0.5), round((p[1] + 0.5) * ss - 0.5)
        cv2.line(big, px((320.0, 40.0), shift), px((320.0, 460.0), shift), 255, 20 * ss)
        cv2.line(big, px(fork, shift_child), px(fork + 150.0 * e2, shift_child), 255, 12 * ss)
        masks.append(cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA))
    parent = SimpleNamespace(t_of=lambda uv: np.atleast_2d(uv)[:, 1], d_at=lambda t: np.full(np.shape(t), d))
    placer = SimpleNamespace(sm=SimpleNamespace(left_mask=masks[0], right_mask=masks[1]), curves={0: parent})
    placer._fork_from_child_outline = lambda *a, **k: EndPlacer._fork_from_child_outline(placer, *a, **k)
    along = np.array([0.0, -1.0])
    xy = EndPlacer._fork_from_child_outline(placer, fork + 50.0 * along, along, fork + 40.0 * e2, e2, fork, 10.0, 6.0)
    assert xy is not None and np.hypot(*(xy - fork)) <= 1.0
    assert bool(EndPlacer._outline_agrees(placer, xy, along, fork + 40.0 * e2, e2, [0], 10.0, 6.0)) is agrees


@pytest.mark.parametrize("base_y", [488.0, 474.0])
def test_a_fork_on_the_edge_of_the_view_is_no_fork(base_y):
    # two branches spreading upwards from (330, base_y), at 1000 mm: whose meeting lies below the
    # bottom edge (row 479) leave the view as a V whose junction is on the edge: no fork there;
    # meeting 5 px inside the view, they have one fork, at the meeting point
    calib = ideal_rig()
    w, h = calib.image_size
    ss, d = 4, calib.f_px * calib.baseline_mm / 1000.0
    base = (330.0, base_y)
    imgs, masks = [], []
    for shift in (0.0, d):
        def px(p, shift=shift):
            return round((p[0] - shift + 0.5) * ss - 0.5), round((p[1] + 0.5) * ss - 0.5)
        big = np.full((h * ss, w * ss), 40, np.uint8)
        for top, r in (((250.0, 150.0), 11), ((430.0, 160.0), 9)):
            cv2.line(big, px(base), px(top), 200, 2 * r * ss)
            cv2.circle(big, px(top), r * ss, 200, -1)
        grey = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
        imgs.append(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))
        masks.append(((grey.astype(int) - 40) > 80).astype(np.uint8) * 255)
    res = Localizer(calib, CFG).localize(imgs[0], imgs[1], mask_left=masks[0], mask_right=masks[1])
    forks = [f for f in res.features if f.kind == "bifurcation"]
    assert len([f for f in res.features if f.kind == "endpoint"]) == 2
    if base_y > h - 1:
        assert not forks
    else:
        assert len(forks) == 1 and np.hypot(*np.subtract(forks[0].left_px, base)) <= 2.0


def test_pieces_are_not_joined_across_depths():
    # the crossing "child" ends at the junction placed with the parent's disparity: its piece must
    # not be drawn on to that point (a straight 3D link from 850 mm to 1000 mm)
    calib = ideal_rig()
    left, right, ml, mr, _, _ = y_pair(calib, 1000.0, 45.0, child_depth_mm=850.0)
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    spans = [np.ptp(b.polyline_mm[:, 2]) for b in res.branches if len(b.polyline_mm) > 2]
    assert spans and max(spans) <= 30.0


def test_a_tip_whose_cap_is_cut_by_the_edge_of_the_view_is_a_tip():
    # the round cap (radius 11 px) runs past the top edge, the tip's centre (8 px below it) is in
    # view: the chord of the cap at the edge tells it from a branch that leaves the view
    calib = ideal_rig()
    left, right, ml, mr, d = branch_pair(calib, 900.0, radius_px=11.0, top=(300.0, 8.0))
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 100]
    assert len(tips) == 1
    assert np.hypot(*np.subtract(tips[0].left_px, (300.0, 8.0))) <= 1.0
    assert abs((tips[0].left_px[0] - tips[0].right_px[0]) - d) <= 0.5
    # a branch that runs on out of the view has no tip there
    left, right, ml, mr, d = branch_pair(calib, 900.0, radius_px=11.0, top=(300.0, -30.0))
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert not [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 100]


def test_a_bent_branch_running_on_behind_an_occluder_is_no_hidden_fork():
    # a branch bending by 12 deg just below a dark band (an occluder at its own depth: in the
    # right view it hides other rows): the upper piece's end is hidden, and its centre line
    # carried on meets the lower piece's bend at 12 deg: the same branch, not a child's fork
    calib = ideal_rig()
    d = calib.f_px * calib.baseline_mm / 1000.0
    w, h = calib.image_size
    ss = 4
    views = []
    for shift, band in ((0.0, (150, 200)), (d, (140, 195))):
        big = np.full((h * ss, w * ss), 40, np.uint8)

        def px(p, shift=shift):
            return round((p[0] - shift + 0.5) * ss - 0.5), round((p[1] + 0.5) * ss - 0.5)
        bend = (300.0, 250.0)
        cv2.line(big, px((300.0, 460.0)), px(bend), 200, 16 * ss)
        cv2.line(big, px(bend), px((300.0 + 200 * np.tan(np.radians(12)), 50.0)), 200, 8 * ss)
        cv2.rectangle(big, (0, band[0] * ss), (w * ss, band[1] * ss), 40, -1)
        g = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
        views += [cv2.cvtColor(g, cv2.COLOR_GRAY2BGR), ((g.astype(int) - 40) > 80).astype(np.uint8) * 255]
    left, ml, right, mr = views
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    assert not [f for f in res.features if f.kind == "bifurcation"]
    assert len([f for f in res.features if f.kind == "endpoint"]) == 2      # the two real tips


def test_a_child_crossing_up_to_0_8_radius_wider_than_the_child_still_places_the_fork():
    # where a child leaves its parent its outline flares a little (the crotch): the crossing of a
    # line parallel to the parent may be wider than the child's own width by most of a radius
    from appliance.localize.ends import EndPlacer

    r = 20.0
    mask = np.zeros((60, 300), np.uint8)
    mask[8:13, 100:157] = 255                          # 57 px: 2 r + 0.85 r
    mask[38:43, 100:160] = 255                         # 60 px: 2 r + r
    along = np.array([1.0, 0.0])
    mid = EndPlacer._child_crossings([(np.array([0.0, 10.0]), 128.0)], along, r, 1.0, mask)[0]
    assert mid is not None and abs(mid - 128.0) <= 0.5
    assert EndPlacer._child_crossings([(np.array([0.0, 40.0]), 128.0)], along, r, 1.0, mask)[0] is None


def test_a_child_crossing_middle_is_sub_pixel_from_the_mask_coverage():
    # a soft mask (coverage 0-255) covering 100.2 .. 156.2 along a row: the middle is 128.2,
    # where whole pixels on or off would put it half a pixel off
    from appliance.localize.ends import EndPlacer

    x = np.arange(300.0)
    cover = np.clip(np.minimum(x + 0.5, 156.2) - np.maximum(x - 0.5, 100.2), 0.0, 1.0)
    mask = np.tile(np.rint(255 * cover).astype(np.uint8), (20, 1))
    mid = EndPlacer._child_crossings([(np.array([0.0, 10.0]), 128.0)], np.array([1.0, 0.0]), 28.0, 1.0, mask)[0]
    assert mid is not None and abs(mid - 128.2) <= 0.15


def test_a_flat_end_touched_by_another_branch_in_the_right_view_has_another_outline():
    # a flat branch (radius 8 px) ending in a round cap at u = 400 (left) and 400 - d (right):
    # the run ends agree row by row at d; with a slanting branch across the cap in the right view
    # only, the right run ends (on it) do not agree row by row at the disparity of any one row
    from types import SimpleNamespace

    from appliance.localize.edges import find_runs
    from appliance.localize.ends import EndPlacer

    d, r = 150.0, 8.0
    left = np.zeros((200, 600), np.uint8)
    cv2.line(left, (200, 100), (392, 100), 255, int(2 * r))
    cv2.circle(left, (392, 100), int(r), 255, -1)
    right = np.roll(left, -int(d), axis=1)
    touched = right.copy()
    cv2.line(touched, (214, 60), (294, 140), 255, 8)     # slanting across the cap's end
    uv_edge, out = np.array([400.0, 100.0]), np.array([1.0, 0.0])
    for mask_r, ok in ((right, True), (touched, False)):
        runs_r = find_runs(mask_r)
        e_r = runs_r.right_px[runs_r.find(np.array([100]), np.array([240.0]))[0]]
        sm = SimpleNamespace(left_mask=left)
        placer = SimpleNamespace(sm=sm, runs_l=find_runs(left), runs_r=runs_r)
        assert EndPlacer._end_outline_agrees(placer, uv_edge, out, float(400.5 - e_r), r) is ok


def test_a_tip_touched_on_one_side_takes_its_disparity_from_the_other_edge():
    # a vertical branch (radius 9 px) whose round cap is touched on its right side by something
    # 3 px nearer in disparity: the rows across the cap are merged with it on that side, the
    # middles of the merged runs are 1.5 px off, the left edges are the branch's own
    calib = ideal_rig()
    d = calib.f_px * calib.baseline_mm / 900.0
    w, h = calib.image_size
    ss, r = 4, 9.0
    views = []
    for shift, bar_shift in ((0.0, 0.0), (d, d + 3.0)):
        big = np.full((h * ss, w * ss), 40, np.uint8)

        def px(p, dx):
            return round((p[0] - dx + 0.5) * ss - 0.5), round((p[1] + 0.5) * ss - 0.5)
        cv2.line(big, px((300.0, 440.0), shift), px((300.0, 100.0), shift), 200, int(2 * r * ss))
        cv2.rectangle(big, px((300.0 + r - 1.0, 93.0), bar_shift), px((300.0 + r + 9.0, 130.0), bar_shift), 200, -1)
        g = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
        views += [cv2.cvtColor(g, cv2.COLOR_GRAY2BGR), ((g.astype(int) - 40) > 80).astype(np.uint8) * 255]
    left, ml, right, mr = views
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint" and f.left_px[1] < 200]
    assert len(tips) == 1
    assert np.hypot(*np.subtract(tips[0].left_px, (300.0, 100.0))) <= 1.5
    assert abs((tips[0].left_px[0] - tips[0].right_px[0]) - d) <= 0.5


def test_a_fork_on_a_flat_parent_takes_its_disparity_from_the_child_outline_in_the_right_view():
    # a horizontal parent (radius 10 px) with a child (6 px) leaving it at 60 deg, disparity
    # 120 px: from a parent's disparity 2 or 2.5 px off (a flat piece's texture), the child's
    # outline in the right view gives the fork's own
    from types import SimpleNamespace

    from appliance.localize.ends import EndPlacer

    w, h, ss, d = 640, 480, 4, 120.0
    fork, a = np.array([400.0, 300.0]), np.radians(60.0)
    e2 = np.array([np.cos(a), -np.sin(a)])
    masks = []
    for shift in (0.0, d):
        big = np.zeros((h * ss, w * ss), np.uint8)

        def px(p, shift=shift):
            return round((p[0] - shift + 0.5) * ss - 0.5), round((p[1] + 0.5) * ss - 0.5)
        cv2.line(big, px((150.0, 300.0)), px((600.0, 300.0)), 255, 20 * ss)
        cv2.line(big, px(fork), px(fork + 150.0 * e2), 255, 12 * ss)
        masks.append(cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA))
    placer = SimpleNamespace(sm=SimpleNamespace(left_mask=masks[0], right_mask=masks[1]),
                             _child_crossings=EndPlacer._child_crossings)
    placer._fork_from_child_outline = lambda *a, **k: EndPlacer._fork_from_child_outline(placer, *a, **k)
    along, c2 = np.array([1.0, 0.0]), fork + 40.0 * e2
    xy = EndPlacer._fork_from_child_outline(placer, np.array([300.0, 300.0]), along, c2, e2, fork, 10.0, 6.0)
    assert xy is not None and np.hypot(*(xy - fork)) <= 0.5
    for prior in (d + 2.0, d - 2.5):
        d_fork = EndPlacer._flat_fork_disparity(placer, xy, along, c2, e2, prior, 10.0, 6.0)
        assert d_fork is not None and abs(d_fork - d) <= 0.3


def test_deferred_provisional_forks_give_the_same_result(monkeypatch):
    # junctions none of whose pieces gain a curve between the fork rounds are placed provisionally
    # only when the final round finds no place: the result must be that of placing every one first
    # (fixture scene 02, exact masks: two junctions keep their provisional place)
    from pathlib import Path

    from appliance.calibrate.model import load_calibration
    from appliance.localize import dense, ends
    from appliance.synth.truth import load_truth

    scenes = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
    left, right = cv2.imread(str(scenes / "left_02.png")), cv2.imread(str(scenes / "right_02.png"))
    truth = load_truth(scenes / "truth_02.json")
    masks = {"mask_left": truth.mask_left.astype(np.uint8) * 255, "mask_right": truth.mask_right.astype(np.uint8) * 255}
    loc = Localizer(load_calibration(scenes.parent / "rig.yaml"), CFG)
    kept, placers = [], []

    class Deferring(ends.EndPlacer):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            placers.append(self)
            self.depth = 0

        def fork(self, node, final=False, needed=True):
            kept.append(self.depth > 0)         # placed provisionally from inside the final round
            self.depth += 1
            super().fork(node, final, needed)
            self.depth -= 1

    class PlacingEvery(Deferring):             # every junction placed provisionally first
        def fork(self, node, final=False, needed=True):
            super().fork(node, final, True)

    results = []
    for placer in (Deferring, PlacingEvery):
        monkeypatch.setattr(dense, "EndPlacer", placer)
        res = loc.localize(left, right, **masks).to_dict()
        res.pop("timings_ms")
        results.append(res)
    assert sum(kept) >= 1
    assert results[0] == results[1]
    a, b = placers
    assert a.hidden == b.hidden and a.radius == b.radius and a.uvd.keys() == b.uvd.keys()
    assert all(np.array_equal(a.uvd[n], b.uvd[n]) for n in a.uvd)


def _interval_middle_by_scanning(s, val, s_c, r_child, sin_t):
    """The interval's middle found by scanning sample by sample (the rule _interval_middle follows)."""
    on = [v >= 128 for v in val.tolist()]
    ds = s[1] - s[0]
    ic = int(np.rint((s_c - s[0]) / ds))
    w = int(2 * r_child / sin_t / ds)
    lo_i, hi_i = max(ic - w, 0), min(ic + w + 1, len(s))
    if lo_i >= hi_i or not any(on[lo_i:hi_i]):
        return None
    c = lo_i + min(max(ic - lo_i, 0), hi_i - lo_i - 1)
    right = next((j - c for j in range(c, hi_i) if on[j]), None)
    left = next((c - j for j in range(c, lo_i - 1, -1) if on[j]), None)
    k = c - left if right is None or (left is not None and left <= right) else c + right
    a = next((j for j in range(k, -1, -1) if not on[j]), None)
    b = next((j for j in range(k, len(on)) if not on[j]), None)
    if a is None or b is None:
        return None
    va, vb = float(val[a]), float(val[b])
    lo = s[a] + ds * (128.0 - va) / max(float(val[a + 1]) - va, 1e-9)
    hi = s[b] - ds * (128.0 - vb) / max(float(val[b - 1]) - vb, 1e-9)
    if abs((hi - lo) * sin_t - 2 * r_child) > 0.8 * r_child + 2:
        return None
    return 0.5 * (lo + hi)


def test_the_interval_middle_is_the_scanned_one_bit_for_bit():
    # random soft masks along a line (several intervals, some touching the ends): the vectorised
    # search gives the very value of the sample-by-sample scan, or None alike
    from appliance.localize.ends import EndPlacer

    rng = np.random.default_rng(5)
    found = 0
    for _ in range(400):
        n = int(rng.integers(20, 120))
        s = np.arange(n, dtype=float) * 1.0 - 0.3
        on = np.repeat(rng.random(n // 4 + 1) < 0.5, 4)[:n]
        val = np.where(on, 255, 0).astype(np.uint8)
        edge = rng.integers(0, n, n // 5)
        val[edge] = rng.integers(0, 256, len(edge))
        s_c, r_child, sin_t = float(rng.uniform(0, n)), float(rng.uniform(2, 12)), float(rng.uniform(0.3, 1.0))
        got = EndPlacer._interval_middle(s, val, s_c, r_child, sin_t)
        want = _interval_middle_by_scanning(s, val, s_c, r_child, sin_t)
        assert got == want
        found += got is not None
    assert found >= 40


def test_cap_row_scale_takes_a_cap_rows_circle_back_to_the_caps_centre():
    # a sphere's centre C seen by a rectified pair (baseline along x); the epipolar plane of each row
    # through the sphere cuts it in a circle around the foot of C on that plane: its disparity, scaled,
    # is C's
    from appliance.localize.tipends import cap_row_scale

    f, b, cy = 1460.0, 120.0, 479.5
    for c in (np.array([80.0, -330.0, 1000.0]), np.array([-200.0, 280.0, 700.0]), np.array([0.0, 40.0, 1400.0])):
        row_c = cy + f * c[1] / c[2]
        rows = row_c + np.array([-7.0, -3.0, 0.0, 2.0, 6.0])
        v = (rows - cy) / f
        n = np.stack([np.zeros_like(v), -np.ones_like(v), v], 1) / np.sqrt(1 + v * v)[:, None]   # planes' normals
        foot = c[None] - (n @ c)[:, None] * n
        d_foot = f * b / foot[:, 2]
        d_c = f * b / c[2]
        assert np.abs(d_foot - d_c).max() > 0.02 or abs(c[1]) < 50       # the effect is there off the middle
        assert np.abs(d_foot * cap_row_scale(rows, row_c, cy, f) - d_c).max() < 1e-9


def test_forks_made_when_read_and_walks_made_at_once_give_the_same_result(monkeypatch):
    # the provisional forks of junctions with a flat piece are made only when read, and the tips'
    # walks out all at once: the results must be those of making every fork first and walking
    # each end alone (fixture scenes 01 and 03, colour and exact masks)
    from pathlib import Path

    from appliance.calibrate.model import load_calibration
    from appliance.localize import dense, ends
    from appliance.synth.truth import load_truth

    scenes = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
    loc = Localizer(load_calibration(scenes.parent / "rig.yaml"), CFG)
    placers = []

    class Lazy(ends.EndPlacer):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            placers.append(self)

    class Eager(Lazy):
        def defer_forks(self, nodes):
            for node in nodes:
                self.fork(node)

        def prewalk(self, nodes):
            pass

    n_pending = 0
    for nn in ("01", "03"):
        left, right = cv2.imread(str(scenes / f"left_{nn}.png")), cv2.imread(str(scenes / f"right_{nn}.png"))
        truth = load_truth(scenes / f"truth_{nn}.json")
        for masks in ({}, {"mask_left": truth.mask_left.astype(np.uint8) * 255,
                           "mask_right": truth.mask_right.astype(np.uint8) * 255}):
            results = []
            placers.clear()
            for placer in (Lazy, Eager):
                monkeypatch.setattr(dense, "EndPlacer", placer)
                res = loc.localize(left, right, **masks).to_dict()
                res.pop("timings_ms")
                results.append(res)
            assert results[0] == results[1]
            a, b = placers
            assert a.hidden == b.hidden and a.radius == b.radius and a.uvd.keys() == b.uvd.keys()
            assert all(np.array_equal(a.uvd[n], b.uvd[n]) for n in a.uvd)
            n_pending += len(a._pending)
    assert n_pending >= 1                       # some provisional forks were never made


@pytest.mark.parametrize("n_samples, d_end, kept", [(0, 101.0, True), (0, 110.0, True), (0, 140.0, False),
                                                     (12, 140.0, True)])
def test_a_flat_tip_without_texture_keeps_only_a_run_end_near_its_carried_disparity(n_samples, d_end, kept):
    # a flat piece 80 px long from a fork (d 100 px) to its tip: without bark texture its disparity
    # is the fork's, carried; the tip's run end may differ by 2 px + 0.1 px per px carried (10 px),
    # not by 40 (another branch's run end, the fork two branches merely crossing); a piece whose
    # texture gave its disparity is not judged by this
    from types import SimpleNamespace

    from appliance.localize.curves import BranchCurve, Poly
    from appliance.localize.ends import EndPlacer

    c = BranchCurve(0, False, (300.0, 380.0), Poly.constant(200.0), Poly.constant(100.0), 5.0, n_samples)
    placer = SimpleNamespace(g=SimpleNamespace(seg_nodes=[(1, 2)]), cap_segments=set(),
                             uvd={1: np.array([380.0, 200.0, 100.0]), 2: np.array([300.0, 200.0, 100.0])})
    assert EndPlacer._carried_agrees(placer, c, 2, d_end) is kept


def test_a_curve_carried_to_a_fork_counts_the_rows_past_its_span():
    # a steep child fitted on rows 695-718 reaches a fork on row 662 only along its end slope:
    # carried 33 rows (more than CHILD_CARRY_PX: its disparity there is not the median's pick
    # when the right outline confirms a parent side); a fork inside the span carries nothing
    from types import SimpleNamespace

    from appliance.localize.curves import BranchCurve, Poly
    from appliance.localize.ends import EndPlacer
    from appliance.localize.forkends import CHILD_CARRY_PX

    c = BranchCurve(0, True, (695.0, 718.0), Poly.constant(300.0), Poly.constant(250.0), 9.0, 24)
    placer = SimpleNamespace(curves={0: c})
    assert EndPlacer._carried_px(placer, 0, np.array([345.0, 662.0])) == 33.0 > CHILD_CARRY_PX
    assert EndPlacer._carried_px(placer, 0, np.array([300.0, 700.0])) == 0.0
    assert EndPlacer._carried_px(placer, 0, np.array([300.0, 720.0])) == 2.0


@pytest.mark.parametrize("d_child, d_fork", [(161.7, 143.0), (146.0, 144.4)])
def test_a_stub_curve_far_in_depth_discredits_its_forks_right_outline(d_child, d_fork):
    # a fork on a flat parent (own disparity 143.0 px) took 144.4 from its child's right outline;
    # the child, a stub whose curve (rows 213-225, the fork on row 241) came later, lies at 161.7:
    # it points steeply in depth, its right outline left the parent where it is already nearer,
    # so the parent's own disparity stands; a stub at 146 px leaves the outline's
    from types import SimpleNamespace

    from appliance.localize.curves import BranchCurve, Poly
    from appliance.localize.ends import EndPlacer

    c = BranchCurve(4, True, (213.5, 225.5), Poly.constant(200.0), Poly.constant(d_child), 7.0, 7)
    placer = SimpleNamespace(curves={4: c}, _from_outline={0: (4, 143.0)}, node_xy=np.array([[157.0, 241.5]]),
                             uvd={0: np.array([157.0, 241.5, 144.4])})
    EndPlacer.recheck_outline_forks(placer)
    assert placer.uvd[0][2] == pytest.approx(d_fork)


@pytest.mark.parametrize("widen_px, kept", [(0, True), (5, False)])
def test_a_tip_whose_left_outline_is_wider_all_across_its_cap_is_withheld(widen_px, kept):
    # a steep rod (radius 10 px, 84 px of disparity) ends in a round cap at the top; the left mask
    # taking in 5 px of background on the right side of the cap's rows (a colour mask's error)
    # makes the cap's two edges disagree by ~5 px on every row: the tip is not reported (the
    # bottom tip stands)
    calib = ideal_rig()
    left, right, ml, mr, d = branch_pair(calib, 1000.0, radius_px=10.0, top=(300.0, 60.0), bottom=(290.0, 420.0))
    ml = ml.copy()
    for v in range(40, 100):
        on = np.flatnonzero(ml[v])
        if len(on):
            ml[v, on[-1] + 1: on[-1] + 1 + widen_px] = 255
    res = Localizer(calib, CFG).localize(left, right, mask_left=ml, mask_right=mr)
    tips = [f for f in res.features if f.kind == "endpoint"]
    assert any(f.left_px[1] > 400 and abs(f.left_px[0] - f.right_px[0] - d) <= 0.3 for f in tips)
    assert any(f.left_px[1] < 80 for f in tips) is kept
