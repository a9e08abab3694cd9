import cv2
import numpy as np
import pytest
from appliance.localize.graph import ENDPOINT, JUNCTION, build_graph
from appliance.localize.skeleton import neighbour_code, neighbour_tables, skeletonize

from .shapes import y_shape


@pytest.mark.parametrize("method", ["thinning", "fast"])
def test_y_shape_has_one_fork_and_three_tips(method):
    g = build_graph(skeletonize(y_shape(), method, downscale=2))
    assert (g.node_kind == JUNCTION).sum() == 1
    assert (g.node_kind == ENDPOINT).sum() == 3
    assert len(g.seg_nodes) == 3
    fork = g.to_full(g.node_yx[g.node_kind == JUNCTION])[0]
    assert np.hypot(*(fork - (100, 100))) < 8
    tips = g.to_full(g.node_yx[g.node_kind == ENDPOINT])
    for expected in [(100, 190), (40, 20), (160, 20)]:
        assert np.hypot(*(tips - expected).T).min() < 10
    assert g.node_degree[g.node_kind == JUNCTION][0] == 3


def test_segment_lengths_follow_the_pixel_path():
    m = np.zeros((100, 300), np.uint8)
    cv2.line(m, (20, 50), (280, 50), 255, 1)
    g = build_graph(skeletonize(m))
    assert len(g.seg_nodes) == 1
    assert g.seg_length_px[0] == pytest.approx(260, abs=2)
    d = np.zeros((300, 300), np.uint8)
    cv2.line(d, (10, 10), (210, 210), 255, 1)
    g = build_graph(skeletonize(d))
    assert g.seg_length_px[0] == pytest.approx(200 * np.sqrt(2), rel=0.02)


def test_skeleton_is_single_pixel_so_path_pixels_have_two_neighbours():
    s = skeletonize(y_shape()).image
    count, _, _ = neighbour_tables()
    n = count[neighbour_code(s)][s > 0]
    assert set(np.unique(n)) <= {1, 2, 3, 4}
    assert (n == 2).mean() > 0.9


def test_crossing_lines_give_one_junction_of_degree_four():
    m = np.zeros((200, 200), np.uint8)
    cv2.line(m, (20, 100), (180, 100), 255, 5)
    cv2.line(m, (100, 20), (100, 180), 255, 5)
    g = build_graph(skeletonize(m))
    assert (g.node_kind == JUNCTION).sum() == 1
    assert g.node_degree[g.node_kind == JUNCTION][0] == 4
    assert (g.node_kind == ENDPOINT).sum() == 4
