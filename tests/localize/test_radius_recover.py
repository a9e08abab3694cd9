import cv2
import numpy as np
import pytest
from appliance.config import load_config
from appliance.localize.graph import JOINT, build_graph
from appliance.localize.prune import prune
from appliance.localize.radius import radius_at, ridge_radius_map, segment_radius
from appliance.localize.recover import _line_pixels, end_geometry, recover
from appliance.localize.skeleton import skeletonize


@pytest.mark.parametrize("radius_px", [3.0, 6.0, 11.5])
def test_cylinder_radius_from_distance_transform_within_half_a_pixel(radius_px):
    ss = 8  # supersampled disc-swept line, half-covered pixels are branch
    big = np.zeros((200 * ss, 300 * ss), np.uint8)
    cv2.line(big, (30 * ss, 40 * ss), (270 * ss, 160 * ss), 255, int(2 * radius_px * ss))
    mask = (cv2.resize(big, (300, 200), interpolation=cv2.INTER_AREA) >= 128).astype(np.uint8)
    g = build_graph(skeletonize(mask))
    rmap = ridge_radius_map(mask)
    longest = int(np.argmax(g.seg_length_px))
    pts = g.to_full(g.seg_yx[longest])
    assert abs(segment_radius(rmap, pts) - radius_px) <= 0.5
    assert np.all(np.abs(radius_at(rmap, pts[len(pts) // 4: -len(pts) // 4]) - radius_px) <= 0.75)


def _cut_line():
    mask = np.zeros((200, 400), np.uint8)
    cv2.line(mask, (20, 120), (380, 80), 255, 9)
    cv2.circle(mask, (200, 100), 30, 0, -1)        # an apple in front of it
    return mask


@pytest.mark.parametrize("method", ["collinear", "hough"])
def test_a_line_cut_by_a_disc_is_bridged_and_flagged(method):
    cfg = load_config(overrides={"localize": {"recover": {"method": method}}}).localize.recover
    mask = _cut_line()
    rmap = ridge_radius_map(mask)
    _, g = prune(skeletonize(mask), 5.0)
    assert len(g.seg_nodes) == 2 and not g.seg_recovered.any()
    g2 = recover(g, cfg, rmap)
    assert g2.seg_recovered.sum() == 1
    bridge = int(np.flatnonzero(g2.seg_recovered)[0])
    a, b = g2.seg_nodes[bridge]
    assert g2.node_kind[a] == JOINT and g2.node_kind[b] == JOINT
    assert 50 <= g2.seg_length_px[bridge] <= 75        # the gap: the disc's diameter less the line's half width


def test_ends_that_do_not_point_at_each_other_are_not_bridged():
    mask = np.zeros((200, 400), np.uint8)
    cv2.line(mask, (20, 100), (170, 100), 255, 9)
    cv2.line(mask, (230, 40), (380, 190), 255, 9)  # 45 degrees off
    cfg = load_config().localize.recover
    _, g = prune(skeletonize(mask), 5.0)
    assert not recover(g, cfg, ridge_radius_map(mask)).seg_recovered.any()


def test_no_recovery_when_disabled():
    cfg = load_config(overrides={"localize": {"recover": {"method": "none"}}}).localize.recover
    mask = _cut_line()
    _, g = prune(skeletonize(mask), 5.0)
    assert not recover(g, cfg, ridge_radius_map(mask)).seg_recovered.any()


def test_end_directions_point_out_of_their_segments():
    mask = np.zeros((200, 300), np.uint8)
    cv2.line(mask, (40, 150), (260, 40), 255, 7)         # a straight stick: two ends
    g = build_graph(skeletonize(mask))
    ends = end_geometry(g, ridge_radius_map(mask))
    assert len(ends.node) == 2
    axis = np.array([220.0, -110.0]) / np.hypot(220, 110)
    for xy, d in zip(ends.xy_px, ends.dir):
        outward = np.sign(np.dot(xy - [150, 95], axis))
        assert np.dot(d, axis) * outward >= np.cos(np.radians(3))     # along the stick, away from its middle
    assert np.allclose(ends.radius_px, 3.0, atol=1.0)


def test_line_pixels_are_the_distinct_pixels_of_the_line_sorted():
    rng = np.random.default_rng(4)
    graph = build_graph(skeletonize(np.pad(np.full((20, 40), 255, np.uint8), 10), "fast", 4))
    for _ in range(50):
        a, b = rng.uniform(0, 60, 2), rng.uniform(0, 60, 2)
        px = _line_pixels(graph, a, b)
        pa, pb = (a + 0.5) / graph.scale - 0.5, (b + 0.5) / graph.scale - 0.5
        n = int(np.ceil(np.abs(pb - pa).max())) + 1
        want = np.unique(np.rint(pa + np.linspace(0, 1, n)[:, None] * (pb - pa)).astype(int)[:, ::-1], axis=0)
        assert np.array_equal(px, want) and px.dtype == want.dtype


def _covered_many_loop(occluded, segments):
    """recover._covered_many before it sampled all gaps at once (one np.linspace per gap)."""
    if occluded is None or not segments:
        return [1.0] * len(segments)
    pts, counts = [], []
    for a, b in segments:
        n = int(np.hypot(*(b - a))) + 2
        pts.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
        counts.append(n)
    hit = occluded(np.concatenate(pts))
    ends = np.cumsum(counts).tolist()
    return [float(np.mean(hit[e - n:e])) for e, n in zip(ends, counts)]


def test_covered_many_samples_every_gap_as_one_linspace_each():
    """The gaps' sample points (asked of the occluder) and their covered shares are those of one
    np.linspace per gap, bit for bit."""
    from appliance.localize.recover import _covered_many

    rng = np.random.default_rng(4)
    asked = []

    def occluded(xy):
        asked.append(xy.copy())
        return (np.sin(xy[:, 0] * 0.37) + np.cos(xy[:, 1] * 0.21)) > 0.3

    shares = []
    for _ in range(400):
        segs = [(rng.uniform(0, 1280, 2), rng.uniform(0, 1280, 2) if rng.random() < 0.7 else rng.uniform(0, 3, 2))
                for _ in range(int(rng.integers(1, 6)))]
        asked.clear()
        got, want = _covered_many(occluded, segs), _covered_many_loop(occluded, segs)
        assert got == want and all(type(x) is float for x in got)
        assert np.array_equal(asked[0], asked[1])
        shares += got
    assert len(set(shares)) > 200 and min(shares) < 0.1 and max(shares) > 0.6      # shares of all kinds
    assert _covered_many(None, segs) == [1.0] * len(segs) and _covered_many(occluded, []) == []
