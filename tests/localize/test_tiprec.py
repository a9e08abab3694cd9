"""Tips found more often (issue 5, recall): an ambiguous cap told apart by the grey images, a stub's
cap radius from its width, a flat stub growing from a limb, a short flat stub whose skeleton end
lies nearer its far end (localize/caps.py, localize/tips.py; constructed masks)."""

import cv2
import numpy as np
from appliance.localize.caps import cap_curves, cap_disparity
from appliance.localize.curves import BranchCurve, Poly
from appliance.localize.edges import find_runs
from appliance.localize.ends import EndPlacer
from appliance.localize.graph import ENDPOINT, build_graph
from appliance.localize.matching import StereoMasks
from appliance.localize.radius import radius_at, ridge_radius_map
from appliance.localize.skeleton import skeletonize
from appliance.localize.tips import flat_cap_curves

from .shapes import end_placer

H, W, R = 200, 480, 6.0
SHIFT = 4                                   # sub-pixel drawing: coordinates in 1/16 px
UP = np.array([0.0, -1.0])


def _capsule(mask: np.ndarray, top: tuple, bottom: tuple, r: float) -> None:
    s = 1 << SHIFT
    a = tuple(int(round(v * s)) for v in top)
    b = tuple(int(round(v * s)) for v in bottom)
    cv2.line(mask, a, b, 255, int(round(2 * r)), cv2.LINE_AA, SHIFT)
    cv2.circle(mask, a, int(round(r * s)), 255, -1, cv2.LINE_AA, SHIFT)


def _twin_caps(d_true: float, d_twin: float, textured: bool) -> StereoMasks:
    """A steep stub's cap at ``d_true`` in the right view and the same cap's outline again along
    the rows at ``d_twin`` (another twig's): the masks alone cannot tell them apart. The grey
    images: a random texture, the right one the left moved by ``d_true`` (the twin's patch shows
    other texture), or nothing."""
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    top, bottom = (300.4, 60.0), (306.4, 140.0)
    for m, dx in ((left, 0.0), (right, d_true), (right, d_twin)):
        _capsule(m, (top[0] - dx, top[1]), (bottom[0] - dx, bottom[1]), R)
    if textured:
        rng = np.random.default_rng(5)
        g = cv2.GaussianBlur(rng.uniform(0, 255, (H, W + 400)).astype(np.float32), (0, 0), 1.5)
        gl = np.clip(g[:, :W], 0, 255).astype(np.uint8)
        shift = int(round(d_true))
        gr = np.clip(g[:, shift:shift + W], 0, 255).astype(np.uint8)       # right(x) = left(x + d)
    else:
        gl = gr = np.zeros((H, W), np.uint8)
    bl = cv2.threshold(left, 127, 255, cv2.THRESH_BINARY)[1]
    return StereoMasks(left, right, gl, gr, ridge_radius_map(bl), (100.0, 300.0), 1450.0)


def test_ambiguous_cap_is_told_apart_by_the_grey_images():
    for d_true, d_twin in ((150.0, 230.0), (230.0, 150.0)):       # the true fit second or first along the strip
        d = cap_disparity(_twin_caps(d_true, d_twin, True), np.array([300.4, 64.0]), 9, UP)
        assert d is not None and abs(d - d_true) < 0.3
        # without texture the masks alone stay ambiguous
        assert cap_disparity(_twin_caps(d_true, d_twin, False), np.array([300.4, 64.0]), 9, UP) is None


def test_cap_curve_takes_the_stubs_radius_from_its_width():
    """The radius map at the coarse skeleton's end lies inside the cap (short of the stub's
    radius); the cap curve's radius is the stub's width across behind the cap."""
    sm = _twin_caps(171.3, 400.0, False)           # (the twin out of the working range: one cap)
    bl = cv2.threshold(sm.left_mask, 127, 255, cv2.THRESH_BINARY)[1]
    graph = build_graph(skeletonize(bl, "fast", 4))
    curves = cap_curves(graph, sm, find_runs(sm.left_mask, soft=True), find_runs(sm.right_mask, soft=True), {}, 20.0)
    assert len(curves) == 1
    (c,) = curves.values()
    runs = find_runs(sm.left_mask, soft=True)
    body = 0.5 * runs.span_px[runs.find(np.array([100]), np.array([303.0]))[0]] / np.hypot(1.0, 6.0 / 80.0)
    end = graph.to_full(graph.node_yx[graph.node_kind == ENDPOINT])
    r_end = radius_at(sm.radius_map, end[np.argmin(end[:, 1])][None])[0]
    assert abs(c.radius_px - body) < 0.3                 # the drawn stub's half-width (its antialiased rim)
    assert r_end < c.radius_px - 0.8                     # the radius map at the skeleton's end: short
    assert abs(c.d_at(64.0)[0] - 171.3) < 0.3


def _flat_stub(mask: np.ndarray, tip: tuple, length: float, r: float = R) -> None:
    """A flat stub from its tip (the cap's centre, x y) ``length`` px to the right, 3 px lower there."""
    _capsule(mask, tip, (tip[0] + length, tip[1] + 3.0 * length / 60.0), r)


def _tip_of(b: EndPlacer, curves: dict, tip: tuple) -> np.ndarray | None:
    b.curves.update(curves)
    ends = [n for n in range(len(b.g.node_kind)) if b.g.node_kind[n] == ENDPOINT
            and np.hypot(*(b.node_xy[n] - tip)) < 3 * R]
    for n in ends:
        b.tip(n)
        if n in b.uvd and n not in b.hidden:
            return b.uvd[n]
    return None


def test_flat_stub_growing_from_a_limb_gets_its_caps_disparity():
    """The stub's last radii behind the cap reach the limb it grows from (in the left view): those
    columns cross the limb, not the stub, and must not move its centre line."""
    tip, d_true = (300.4, 80.0), 150.0
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _flat_stub(left, tip, 60.0)
    _flat_stub(right, (tip[0] - d_true, tip[1]), 60.0)
    limb = np.array([[312, 0], [336, 0], [336, H], [312, H]], np.float32)     # in front: further left in the right view
    cv2.fillPoly(left, [np.rint(limb * 16).astype(np.int32)], 255, cv2.LINE_AA, SHIFT)
    cv2.fillPoly(right, [np.rint((limb - [260, 0]) * 16).astype(np.int32)], 255, cv2.LINE_AA, SHIFT)
    b, segs, runs_lt = end_placer(left, right)
    curves = flat_cap_curves(b, segs, runs_lt)
    uvd = _tip_of(b, curves, tip)
    assert uvd is not None
    assert np.hypot(uvd[0] - tip[0], uvd[1] - tip[1]) < 1.5 and abs(uvd[2] - d_true) < 0.3


def test_short_flat_stub_walks_out_of_its_own_cap():
    """A stub a few radii long past an occluder: its skeleton end lies nearer the cut end than the
    cap's edge is ahead of it; the curve's walks must still leave through the cap."""
    tip, d_true = (300.4, 80.0), 170.0
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _flat_stub(left, tip, 26.0, 7.0)
    _flat_stub(right, (tip[0] - d_true, tip[1]), 40.0, 7.0)            # longer in the right view
    b, segs, runs_lt = end_placer(left, right)
    curves = flat_cap_curves(b, segs, runs_lt)
    uvd = _tip_of(b, curves, tip)
    assert uvd is not None
    assert np.hypot(uvd[0] - tip[0], uvd[1] - tip[1]) < 1.5 and abs(uvd[2] - d_true) < 0.3


def test_flat_tips_run_end_read_further_inside_where_the_line_leaves_the_cap_off_its_row():
    """A flat piece's fitted line inclined to the rows leaves the cap near its top: 1 px back along
    that row is off the mask (no run end, the tip would be hidden); half a radius back the row's
    run is the cap's and its end gives the disparity."""
    tip, d_true = (300.4, 80.0), 150.0
    left, right = np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8)
    _flat_stub(left, tip, 60.0)
    _flat_stub(right, (tip[0] - d_true, tip[1]), 60.0)
    b, _, _ = end_placer(left, right)
    b.runs_l, b.runs_r = find_runs(left, soft=True), find_runs(right, soft=True)
    out = np.array([-0.8, -0.6])
    uv_edge = np.array(tip) + (R + 2.0) * out          # (the drawn rim lies ~0.7 px out; the walk's edge past it)
    assert b._end_disparity(uv_edge, out, d_true + 0.5, R) is None
    d = b._end_disparity(uv_edge, out, d_true + 0.5, R, 0.5 * R)
    assert d is not None and abs(d - d_true) < 0.3


def _steep_end(cut: bool, offset_r: float):
    """A steep stub (tip up) and a fitted line ``offset_r`` radii off its middle; ``cut``: its end
    cut by an occluder's edge 60 deg from the rows instead of a round cap. The placer, the line's curve, its end."""
    tip = (300.4, 60.0)
    left = np.zeros((H, W), np.uint8)
    _capsule(left, tip, (300.4, 140.0), R)
    if cut:
        edge = np.array([[250, -20], [350, -20], [350, -11.6], [250, 161.6]], np.float32)   # above the edge: gone
        cv2.fillPoly(left, [np.rint(edge * 16).astype(np.int32)], 0, cv2.LINE_AA, SHIFT)
    b, _, _ = end_placer(left, left)
    end = [n for n in range(len(b.g.node_kind)) if b.g.node_kind[n] == ENDPOINT]
    node = min(end, key=lambda n: b.node_xy[n][1])
    c = BranchCurve(0, True, (75.0, 130.0), Poly.constant(300.4 + offset_r * R), Poly.constant(150.0), R, 50,
                    (0.0, 0.0))
    return b, c, node


def _split(b, c, node, sides=None):
    t_edge, sign = b._walk_out(c, node)
    speed = float(np.hypot(*(c.uv_at(t_edge + sign)[0] - c.uv_at(t_edge)[0])))
    t_a, t_b = sides if sides is not None else b._walk_sides(c, node, 0.4 * R)
    return abs(t_a - t_b) * speed / R, t_edge, sign


def test_oblique_test_reads_a_round_cap_about_its_middle_not_an_off_line():
    b, c, node = _steep_end(False, 0.55)
    split, t_edge, sign = _split(b, c, node)
    assert split > b.cfg.oblique_end_ratio                      # about the off line: looks oblique
    uv_edge = c.uv_at(t_edge)[0]
    out = np.array([0.0, -1.0])
    sides = b._sides_about_middle(c, node, uv_edge, out, R, sign, split, b._walk_sides(c, node, 0.4 * R))
    assert _split(b, c, node, sides)[0] <= b.cfg.oblique_end_ratio   # about the middle: round
    # an occluder's oblique edge ends the sides further apart than any offset line explains
    b, c, node = _steep_end(True, 0.55)
    split, t_edge, sign = _split(b, c, node)
    first = b._walk_sides(c, node, 0.4 * R)
    assert split > 1.1
    assert b._sides_about_middle(c, node, c.uv_at(t_edge)[0], out, R, sign, split, first) == first


def test_stub_width_is_not_read_where_the_stub_runs_into_its_limb():
    """Rows behind a stub's cap that cross the limb it grows from (twice as wide and more) are
    not the stub's width: the radius map's value stands; the stub alone gives its own width."""
    from appliance.localize.caps import _width_radius
    mask = np.zeros((H, W), np.uint8)
    _capsule(mask, (300.0, 60.0), (300.0, 140.0), 8.0)                 # the stub, radius 8 px
    line = Poly(np.array([300.0]))                                      # its centre line u(v)
    runs = find_runs(mask, soft=True)
    body = 0.5 * runs.span_px[runs.find(np.array([100]), np.array([300.0]))[0]]   # (its antialiased rim)
    assert abs(_width_radius(runs, line, np.array([300.0, 66.0]), UP, 6.0) - body) < 0.05
    mask[80:140, 270:330] = 255                                         # a limb 60 px wide from row 80
    assert _width_radius(find_runs(mask, soft=True), line, np.array([300.0, 66.0]), UP, 6.0) == 6.0
